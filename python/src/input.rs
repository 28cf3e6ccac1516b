//! numpy inputs in Python terms: any array-like is accepted where numpy can
//! make it a real array; float32 and float64 C-contiguous arrays are used
//! in place (no copy); anything else is converted once by numpy. Wrong kinds
//! are `TypeError`s, wrong shapes `ValueError`s, each naming the argument.

use crate::trace::{Bound as End, Coords};
use numpy::{
    PyArrayDescrMethods, PyArrayDyn, PyArrayMethods, PyReadonlyArrayDyn, PyUntypedArray,
    PyUntypedArrayMethods,
};
use pyo3::exceptions::{PyTypeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::PyTuple;

/// A float array of the caller's, float32 or float64, C-contiguous.
pub enum FloatArray<'py> {
    /// float32, as given or converted.
    F32(PyReadonlyArrayDyn<'py, f32>),
    /// float64, as given or converted.
    F64(PyReadonlyArrayDyn<'py, f64>),
}

impl FloatArray<'_> {
    /// The array's shape.
    pub fn shape(&self) -> &[usize] {
        match self {
            FloatArray::F32(a) => a.shape(),
            FloatArray::F64(a) => a.shape(),
        }
    }

    /// The values in C order.
    pub fn coords(&self) -> PyResult<Coords<'_>> {
        let contiguous = |e| PyValueError::new_err(format!("array is not contiguous: {e}"));
        Ok(match self {
            FloatArray::F32(a) => Coords::F32(a.as_slice().map_err(contiguous)?),
            FloatArray::F64(a) => Coords::F64(a.as_slice().map_err(contiguous)?),
        })
    }
}

/// `numpy.<name>(args...)`.
fn numpy_call<'py>(
    py: Python<'py>,
    name: &str,
    args: impl pyo3::call::PyCallArgs<'py>,
) -> PyResult<Bound<'py, PyAny>> {
    py.import("numpy")?.getattr(name)?.call1(args)
}

/// `obj` as a numpy array (`numpy.asarray` for anything else), with a
/// `TypeError` naming `what` when numpy cannot make one of numbers.
fn as_ndarray<'py>(obj: &Bound<'py, PyAny>, what: &str) -> PyResult<Bound<'py, PyUntypedArray>> {
    let arr = if obj.is_instance_of::<PyUntypedArray>() {
        obj.clone()
    } else {
        numpy_call(obj.py(), "asarray", (obj,)).map_err(|e| {
            PyTypeError::new_err(format!(
                "{what} must be a numpy array or convertible to one: {e}"
            ))
        })?
    };
    Ok(arr.cast_into::<PyUntypedArray>()?)
}

/// The dtype's name for messages (`float16`, `<U1`).
fn dtype_name(arr: &Bound<'_, PyUntypedArray>) -> String {
    arr.dtype().to_string()
}

/// `obj` as a C-contiguous float32 or float64 array. A float32 or float64
/// C-contiguous array is borrowed as it is; other real arrays (integers,
/// float16, other byte orders, strided views, lists) are converted by
/// numpy: to float32 from float32 and float16, to float64 otherwise.
/// `TypeError` for booleans, complex numbers, strings and objects.
pub fn float_array<'py>(obj: &Bound<'py, PyAny>, what: &str) -> PyResult<FloatArray<'py>> {
    let py = obj.py();
    if let Ok(a) = obj.cast::<PyArrayDyn<f32>>() {
        if a.is_c_contiguous() {
            return Ok(FloatArray::F32(a.try_readonly()?));
        }
    }
    if let Ok(a) = obj.cast::<PyArrayDyn<f64>>() {
        if a.is_c_contiguous() {
            return Ok(FloatArray::F64(a.try_readonly()?));
        }
    }
    let arr = as_ndarray(obj, what)?;
    let dtype = arr.dtype();
    let target = match (dtype.kind(), dtype.itemsize()) {
        (b'f', 2 | 4) => "float32",
        (b'f' | b'i' | b'u', _) => "float64",
        _ => {
            return Err(PyTypeError::new_err(format!(
                "{what} must be an array of real numbers (float32 or float64; integers are converted), not of dtype {}",
                dtype_name(&arr)
            )))
        }
    };
    let np = py.import("numpy")?;
    let kwargs = pyo3::types::PyDict::new(py);
    kwargs.set_item("dtype", np.getattr(target)?)?;
    kwargs.set_item("order", "C")?;
    let c = np.getattr("asarray")?.call((&arr,), Some(&kwargs))?;
    if target == "float32" {
        Ok(FloatArray::F32(
            c.cast_into::<PyArrayDyn<f32>>()?.try_readonly()?,
        ))
    } else {
        Ok(FloatArray::F64(
            c.cast_into::<PyArrayDyn<f64>>()?.try_readonly()?,
        ))
    }
}

/// An integer array of the caller's, C-contiguous, signed or unsigned.
pub enum IndexArray<'py> {
    /// Signed integers, as int64.
    I64(PyReadonlyArrayDyn<'py, i64>),
    /// Unsigned integers, as uint64.
    U64(PyReadonlyArrayDyn<'py, u64>),
}

impl IndexArray<'_> {
    /// The array's shape.
    pub fn shape(&self) -> &[usize] {
        match self {
            IndexArray::I64(a) => a.shape(),
            IndexArray::U64(a) => a.shape(),
        }
    }
}

/// `obj` as an integer array (any integer dtype, converted to int64 or
/// uint64 by numpy); `TypeError` for anything else (floats included: a
/// float index is a mistake worth hearing about).
pub fn index_array<'py>(obj: &Bound<'py, PyAny>, what: &str) -> PyResult<IndexArray<'py>> {
    let py = obj.py();
    let arr = as_ndarray(obj, what)?;
    let target = match arr.dtype().kind() {
        b'i' => "int64",
        b'u' => "uint64",
        _ => {
            return Err(PyTypeError::new_err(format!(
                "{what} must be an array of integers (vertex indices), not of dtype {}",
                dtype_name(&arr)
            )))
        }
    };
    let np = py.import("numpy")?;
    let kwargs = pyo3::types::PyDict::new(py);
    kwargs.set_item("dtype", np.getattr(target)?)?;
    kwargs.set_item("order", "C")?;
    let c = np.getattr("asarray")?.call((&arr,), Some(&kwargs))?;
    Ok(if target == "int64" {
        IndexArray::I64(c.cast_into::<PyArrayDyn<i64>>()?.try_readonly()?)
    } else {
        IndexArray::U64(c.cast_into::<PyArrayDyn<u64>>()?.try_readonly()?)
    })
}

/// One end of the rays' intervals as given: a number, or an array that
/// broadcasts to the rays' leading shape (converted to float32).
pub enum EndArg<'py> {
    /// The same value for every ray.
    All(f32),
    /// One value per ray, broadcast to the leading shape, C order.
    PerRay(PyReadonlyArrayDyn<'py, f32>),
}

impl EndArg<'_> {
    /// The end as the tracing loops read it.
    pub fn end(&self) -> PyResult<End<'_>> {
        Ok(match self {
            EndArg::All(v) => End::All(*v),
            EndArg::PerRay(a) => End::PerRay(
                a.as_slice()
                    .map_err(|e| PyValueError::new_err(e.to_string()))?,
            ),
        })
    }
}

/// `obj` (`None` for `default`) as an interval end for rays of leading
/// shape `lead`.
pub fn end_arg<'py>(
    obj: Option<&Bound<'py, PyAny>>,
    default: f32,
    lead: &[usize],
    what: &str,
) -> PyResult<EndArg<'py>> {
    let Some(obj) = obj.filter(|o| !o.is_none()) else {
        return Ok(EndArg::All(default));
    };
    let py = obj.py();
    if !obj.is_instance_of::<PyUntypedArray>() {
        if let Ok(v) = obj.extract::<f64>() {
            return Ok(EndArg::All(v as f32));
        }
    }
    let arr = float_array(obj, what)?;
    if arr.shape().is_empty() {
        let v = match &arr {
            FloatArray::F32(a) => a.as_array().first().copied().unwrap_or(default),
            FloatArray::F64(a) => a.as_array().first().map_or(default, |&v| v as f32),
        };
        return Ok(EndArg::All(v));
    }
    let source = match &arr {
        FloatArray::F32(a) => a.as_any().clone(),
        FloatArray::F64(a) => a.as_any().clone(),
    };
    let shape = arr.shape().to_vec();
    let lead_tuple = PyTuple::new(py, lead)?;
    let broadcast = numpy_call(py, "broadcast_to", (source, lead_tuple)).map_err(|_| {
        PyValueError::new_err(format!(
            "{what} of shape {} does not broadcast to the rays' leading shape {}",
            shape_str(&shape),
            shape_str(lead)
        ))
    })?;
    let np = py.import("numpy")?;
    let kwargs = pyo3::types::PyDict::new(py);
    kwargs.set_item("dtype", np.getattr("float32")?)?;
    kwargs.set_item("order", "C")?;
    let c = np.getattr("asarray")?.call((broadcast,), Some(&kwargs))?;
    Ok(EndArg::PerRay(
        c.cast_into::<PyArrayDyn<f32>>()?.try_readonly()?,
    ))
}

/// A shape as Python prints it: `(5, 3)`, `(6,)`, `()`.
pub fn shape_str(shape: &[usize]) -> String {
    match shape {
        [n] => format!("({n},)"),
        _ => format!(
            "({})",
            shape
                .iter()
                .map(|d| d.to_string())
                .collect::<Vec<_>>()
                .join(", ")
        ),
    }
}

/// Flat index `i` over `shape` as a numpy index: `rays[2, 5]`, `rays[7]`.
pub fn index_str(what: &str, mut i: usize, shape: &[usize]) -> String {
    let mut idx = vec![0; shape.len()];
    for (k, &d) in shape.iter().enumerate().rev() {
        if d > 0 {
            idx[k] = i % d;
            i /= d;
        }
    }
    format!(
        "{what}[{}]",
        idx.iter()
            .map(|d| d.to_string())
            .collect::<Vec<_>>()
            .join(", ")
    )
}
