//! Python bindings of raytree: the extension module `raytree._raytree`,
//! re-exported by the pure-Python package `raytree` (`python/raytree/`),
//! which adds the trimesh interop.
//!
//! Two classes: [`PyScene`] (`raytree.Scene`: a triangle mesh from numpy
//! arrays, a file or a built-in name) and [`PyAccelerator`]
//! (`raytree.Accelerator`: one structure and traversal built over a scene,
//! answering closest-hit, any-hit, hit-count and hit-list queries over numpy
//! arrays of rays). Queries release the GIL and run on a rayon pool of the
//! requested size; rays are read from the caller's buffer and answers
//! written straight into the returned arrays ([`trace`]).
//!
//! Nothing here panics on the caller's input: every array, name and number
//! is checked first, and faults are `TypeError` (wrong kind of argument) or
//! `ValueError` (wrong shape or value), `OSError` for files.

mod input;
mod trace;

use input::{end_arg, float_array, index_array, index_str, shape_str, FloatArray, IndexArray};
use numpy::ndarray::IxDyn;
use numpy::{PyArray, PyArrayDyn, PyArrayMethods};
use pyo3::exceptions::{
    PyFileNotFoundError, PyMemoryError, PyOSError, PyRuntimeError, PyTypeError, PyValueError,
};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyTuple};
use raytree::bvh::{BuildOptions, BuildStats, Builder, Bvh};
use raytree::error::Error;
use raytree::geometry::{Triangle, COORDINATE_LIMIT};
use raytree::prelude::Vec3;
use raytree::scene::{memory, Camera, LoadOptions, Mesh, Scene};
use raytree::structures::{Built, StructureInfo, StructureKind, TraversalKind};
use std::collections::HashMap;
use std::sync::{Arc, Mutex, OnceLock};
use trace::{
    Closest, ClosestOut, CountHits, FirstInvalid, Geometries, ListHits, ListOut, Occluded,
    PerRayOut, Rays, RustBatch, Slots, Work, INVALID_ID,
};

/// A core error as a Python exception: a missing file is
/// `FileNotFoundError`, other I/O `OSError`, a scene too large for memory
/// `MemoryError` (when `limit_is_memory`), the rest `ValueError`.
fn py_err(e: Error, limit_is_memory: bool) -> PyErr {
    match &e {
        Error::Io { source, .. } if source.kind() == std::io::ErrorKind::NotFound => {
            PyFileNotFoundError::new_err(e.to_string())
        }
        Error::Io { .. } => PyOSError::new_err(e.to_string()),
        Error::Limit(_) if limit_is_memory => PyMemoryError::new_err(e.to_string()),
        _ => PyValueError::new_err(e.to_string()),
    }
}

/// Most worker threads a call may ask for.
const MAX_THREADS: i64 = 1024;

/// The rayon pool of `threads` workers (`None` or 0: one per logical core),
/// built once and kept for later calls.
fn pool(threads: Option<i64>) -> PyResult<Arc<rayon::ThreadPool>> {
    let n = match threads {
        None | Some(0) => std::thread::available_parallelism().map_or(1, |n| n.get()),
        Some(t) if (1..=MAX_THREADS).contains(&t) => t as usize,
        Some(t) => {
            return Err(PyValueError::new_err(format!(
                "threads must be None, 0 (all logical cores) or 1..={MAX_THREADS}, not {t}"
            )))
        }
    };
    static POOLS: OnceLock<Mutex<HashMap<usize, Arc<rayon::ThreadPool>>>> = OnceLock::new();
    let mut pools = POOLS
        .get_or_init(Default::default)
        .lock()
        .unwrap_or_else(|p| p.into_inner());
    if let Some(p) = pools.get(&n) {
        return Ok(p.clone());
    }
    let p = rayon::ThreadPoolBuilder::new()
        .num_threads(n)
        .thread_name(|i| format!("raytree-{i}"))
        .build()
        .map_err(|e| PyRuntimeError::new_err(format!("cannot start {n} threads: {e}")))?;
    let p = Arc::new(p);
    pools.insert(n, p.clone());
    Ok(p)
}

/// A triangle mesh to trace rays against.
///
/// Make one with `Scene.from_arrays(vertices, triangles)`,
/// `Scene.load(path)` (OBJ or PLY: every format the core reads) or
/// `Scene.builtin("chess:20000")`. Coordinates are kept as float32 (the
/// precision raytree traces in). Triangle `i` is row `i` of `triangles`;
/// degenerate (zero-area) triangles are kept in the numbering but can never
/// be hit.
#[pyclass(frozen, module = "raytree", name = "Scene")]
pub struct PyScene {
    scene: Scene,
}

impl PyScene {
    fn checked(mesh: Mesh, name: String) -> PyResult<PyScene> {
        mesh.validate().map_err(PyValueError::new_err)?;
        memory::check_fits(
            &name,
            mesh.triangle_count() as u64,
            memory::available_bytes().map_err(|e| py_err(e, false))?,
        )
        .map_err(|e| py_err(e, true))?;
        let camera = Camera::framing(&mesh.bounds());
        Ok(PyScene {
            scene: Scene::new(name, mesh, camera),
        })
    }
}

/// Vertex positions from a float array of shape (N, 3), checked with
/// 0-based indices in the messages.
fn positions(v: &FloatArray) -> PyResult<Vec<Vec3>> {
    let shape = v.shape();
    if shape.len() != 2 || shape[1] != 3 {
        return Err(PyValueError::new_err(format!(
            "vertices must have shape (N, 3), got shape {}",
            shape_str(shape)
        )));
    }
    let check = |i: usize, p: [f64; 3]| -> PyResult<Vec3> {
        if p.iter().any(|c| !c.is_finite()) {
            return Err(PyValueError::new_err(format!(
                "vertices[{i}] has a non-finite coordinate: {p:?}"
            )));
        }
        if p.iter().any(|c| c.abs() > COORDINATE_LIMIT as f64) {
            return Err(PyValueError::new_err(format!(
                "vertices[{i}] has a coordinate beyond ±{COORDINATE_LIMIT:e} (2^126): {p:?}"
            )));
        }
        Ok(Vec3::new(p[0] as f32, p[1] as f32, p[2] as f32))
    };
    match v.coords()? {
        trace::Coords::F32(s) => s
            .chunks_exact(3)
            .enumerate()
            .map(|(i, p)| check(i, [p[0] as f64, p[1] as f64, p[2] as f64]))
            .collect(),
        trace::Coords::F64(s) => s
            .chunks_exact(3)
            .enumerate()
            .map(|(i, p)| check(i, [p[0], p[1], p[2]]))
            .collect(),
    }
}

/// Triangle indices from an integer array of shape (M, 3), each in
/// `0..vertices`.
fn indices(t: &IndexArray, vertices: usize) -> PyResult<Vec<[u32; 3]>> {
    let shape = t.shape();
    if shape.len() != 2 || shape[1] != 3 {
        return Err(PyValueError::new_err(format!(
            "triangles must have shape (M, 3), got shape {}",
            shape_str(shape)
        )));
    }
    let bad = |i: usize, k: usize, v: String| {
        PyValueError::new_err(format!(
            "triangles[{i}, {k}] = {v} is not a vertex index: there are {vertices} vertices (0..{vertices})"
        ))
    };
    let read = |s: &[i128]| -> PyResult<Vec<[u32; 3]>> {
        s.chunks_exact(3)
            .enumerate()
            .map(|(i, tri)| {
                let mut out = [0u32; 3];
                for k in 0..3 {
                    let v = tri[k];
                    if v < 0 || v >= vertices as i128 {
                        return Err(bad(i, k, v.to_string()));
                    }
                    out[k] = v as u32;
                }
                Ok(out)
            })
            .collect()
    };
    // Meshes are small next to what is traced: widening costs nothing.
    let wide: Vec<i128> = match t {
        IndexArray::I64(a) => a.as_array().iter().map(|&v| v as i128).collect(),
        IndexArray::U64(a) => a.as_array().iter().map(|&v| v as i128).collect(),
    };
    if vertices > u32::MAX as usize {
        return Err(PyValueError::new_err(format!(
            "{vertices} vertices: more than 2^32 - 1"
        )));
    }
    read(&wide)
}

#[pymethods]
impl PyScene {
    /// A scene from numpy arrays.
    ///
    /// Args:
    ///     vertices: (N, 3) float32 or float64 (or anything numpy converts
    ///         to a real array) vertex positions, in scene units. Rounded to
    ///         float32; every coordinate must be finite and within ±2^126.
    ///     triangles: (M, 3) integer array (any integer dtype): the vertex
    ///         indices a, b, c of each triangle, each in 0..N. Hit
    ///         barycentrics (u, v) weigh b and c.
    ///     name: a name for reports and repr (None: ``"arrays"``).
    ///
    /// Raises:
    ///     TypeError: a non-real `vertices` or non-integer `triangles` dtype.
    ///     ValueError: a wrong shape, a NaN/infinite/out-of-range vertex, an
    ///         index out of range, no triangles or only degenerate ones.
    ///     MemoryError: more triangles than the memory available can build
    ///         (``RAYTREE_MEMORY_LIMIT`` lowers the limit).
    #[staticmethod]
    #[pyo3(signature = (vertices, triangles, name = None))]
    fn from_arrays(
        vertices: &Bound<'_, PyAny>,
        triangles: &Bound<'_, PyAny>,
        name: Option<String>,
    ) -> PyResult<PyScene> {
        let name = name.unwrap_or_else(|| "arrays".into());
        let v = float_array(vertices, "vertices")?;
        let t = index_array(triangles, "triangles")?;
        let positions = positions(&v)?;
        let indices = indices(&t, positions.len())?;
        let mesh = Mesh {
            positions,
            indices,
            geometries: Vec::new(),
        };
        PyScene::checked(mesh, name)
    }

    /// A scene from mesh files: every format the core reads (OBJ, PLY,
    /// STL, glTF 2.0 and GLB; polygons fan-triangulated in file order).
    ///
    /// Args:
    ///     path: str or os.PathLike, or a list of them: one scene of all
    ///         the files, file k's triangles numbered after those of the
    ///         files before it.
    ///     gltf_scene: the glTF scene to load by index (None: the file's
    ///         default scene, or its first).
    ///
    /// Each file is a geometry (each triangle primitive instance of a glTF
    /// scene, each solid of an ASCII STL file): see `geometries`.
    ///
    /// Raises:
    ///     FileNotFoundError / OSError: a file cannot be read.
    ///     ValueError: a malformed file (the message names the file and the
    ///         line or element) or an unknown format.
    ///     MemoryError: more triangles than the memory available can build.
    #[staticmethod]
    #[pyo3(signature = (path, gltf_scene = None))]
    fn load(path: &Bound<'_, PyAny>, gltf_scene: Option<usize>) -> PyResult<PyScene> {
        let paths: Vec<std::path::PathBuf> = match path.extract::<std::path::PathBuf>() {
            Ok(p) => vec![p],
            Err(_) => path.extract().map_err(|_| {
                PyTypeError::new_err(format!(
                    "path must be a str or os.PathLike, or a list of them, not {}",
                    path.get_type().name().map_or("?".into(), |n| n.to_string())
                ))
            })?,
        };
        if paths.is_empty() {
            return Err(PyValueError::new_err("no mesh files given"));
        }
        let options = LoadOptions { gltf_scene };
        let scene = Scene::load_many(&paths, &options).map_err(|e| py_err(e, true))?;
        Ok(PyScene { scene })
    }

    /// One of raytree's procedural scenes by name, optionally with a size in
    /// triangles: ``"chess"``, ``"chess:20000"``, ``"hairball:1M"``,
    /// ``"atrium"``, ``"forest"``, ``"plant"``. Deterministic.
    ///
    /// Raises:
    ///     ValueError: an unknown name or a malformed size.
    #[staticmethod]
    fn builtin(spec: &str) -> PyResult<PyScene> {
        let scene = Scene::builtin(spec).map_err(|e| py_err(e, true))?;
        Ok(PyScene { scene })
    }

    /// The built-in name with its size, the file path, or the name given to
    /// `from_arrays`.
    #[getter]
    fn name(&self) -> &str {
        &self.scene.name
    }

    /// Number of triangles M.
    #[getter]
    fn triangle_count(&self) -> usize {
        self.scene.mesh.triangle_count()
    }

    /// Number of vertices N.
    #[getter]
    fn vertex_count(&self) -> usize {
        self.scene.mesh.positions.len()
    }

    /// (N, 3) float32: vertex positions (a copy).
    #[getter]
    fn vertices<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArrayDyn<f32>>> {
        let flat: Vec<f32> = self
            .scene
            .mesh
            .positions
            .iter()
            .flat_map(|p| p.to_array())
            .collect();
        PyArray::from_vec(py, flat)
            .reshape(vec![self.scene.mesh.positions.len(), 3])
            .map(|a| a.to_dyn().clone())
    }

    /// (M, 3) uint32: the vertex indices of each triangle (a copy).
    #[getter]
    fn triangles<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArrayDyn<u32>>> {
        let flat: Vec<u32> = self.scene.mesh.indices.iter().flatten().copied().collect();
        PyArray::from_vec(py, flat)
            .reshape(vec![self.scene.mesh.indices.len(), 3])
            .map(|a| a.to_dyn().clone())
    }

    /// (2, 3) float32: the box of every vertex, min row then max row.
    #[getter]
    fn bounds<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArrayDyn<f32>>> {
        let b = self.scene.mesh.bounds();
        let flat: Vec<f32> = [b.min.to_array(), b.max.to_array()].concat();
        PyArray::from_vec(py, flat)
            .reshape(vec![2, 3])
            .map(|a| a.to_dyn().clone())
    }

    /// The geometries, in order: one dict per geometry with ``name`` (the
    /// file, or the glTF node, mesh and primitive), ``first_triangle`` and
    /// ``triangle_count``: geometry g's triangles are rows
    /// ``first_triangle:first_triangle + triangle_count`` of `triangles`.
    #[getter]
    fn geometries<'py>(&self, py: Python<'py>) -> PyResult<Vec<Bound<'py, PyDict>>> {
        self.scene
            .mesh
            .geometries
            .iter()
            .map(|g| {
                let d = PyDict::new(py);
                d.set_item("name", &g.name)?;
                d.set_item("first_triangle", g.first_triangle)?;
                d.set_item("triangle_count", g.triangle_count)?;
                Ok(d)
            })
            .collect()
    }

    /// geometry_of(primitive_ids) -> (geometry_ids, local_ids)
    ///
    /// The geometry of each triangle index (as `cast_rays` returns them)
    /// and its index within that geometry: two uint32 arrays of the input's
    /// shape, ``INVALID_ID`` for ``INVALID_ID`` and any index past the last
    /// triangle.
    fn geometry_of<'py>(
        &self,
        py: Python<'py>,
        primitive_ids: &Bound<'py, PyAny>,
    ) -> PyResult<(U32Array<'py>, U32Array<'py>)> {
        let ids = index_array(primitive_ids, "primitive_ids")?;
        let wide: Vec<i128> = match &ids {
            IndexArray::I64(a) => a.as_array().iter().map(|&v| v as i128).collect(),
            IndexArray::U64(a) => a.as_array().iter().map(|&v| v as i128).collect(),
        };
        let mesh = &self.scene.mesh;
        let (geometry, local): (Vec<u32>, Vec<u32>) = wide
            .iter()
            .map(|&id| {
                u32::try_from(id)
                    .ok()
                    .and_then(|id| mesh.geometry_of(id))
                    .unwrap_or((INVALID_ID, INVALID_ID))
            })
            .unzip();
        let shape = ids.shape().to_vec();
        Ok((
            PyArray::from_vec(py, geometry).reshape(shape.clone())?,
            PyArray::from_vec(py, local).reshape(shape)?,
        ))
    }

    fn __len__(&self) -> usize {
        self.scene.mesh.triangle_count()
    }

    fn __repr__(&self) -> String {
        let geometries = self.scene.mesh.geometry_count();
        format!(
            "Scene({:?}, {} triangles, {} vertices{})",
            self.scene.name,
            self.scene.mesh.triangle_count(),
            self.scene.mesh.positions.len(),
            if geometries > 1 {
                format!(", {geometries} geometries")
            } else {
                String::new()
            }
        )
    }
}

/// A numpy uint32 array of any shape.
type U32Array<'py> = Bound<'py, PyArrayDyn<u32>>;

/// `"sah"`, `"hybrid"`, `"sbvh"` or `"lbvh"`.
fn parse_builder(name: &str) -> PyResult<Builder> {
    Builder::ALL
        .into_iter()
        .find(|b| b.name() == name)
        .ok_or_else(|| {
            let known: Vec<&str> = Builder::ALL.iter().map(|b| b.name()).collect();
            PyValueError::new_err(format!(
                "unknown builder '{name}' (known: {})",
                known.join(", ")
            ))
        })
}

/// A structure and traversal built over a scene, answering ray queries:
/// ``cast_rays`` (closest hit), ``test_occlusions`` (any hit),
/// ``count_intersections`` and ``list_intersections`` (every hit).
///
/// ``Accelerator(scene, structure="bvh", traversal=None, builder="sah",
/// max_leaf_size=8, threads=None, sah_block=None)`` builds the canonical BVH over `scene` and derives `structure` from it.
///
/// Args:
///     scene: a `Scene`.
///     structure: ``"bvh"`` (52-byte binary nodes), ``"dst"``,
///         ``"dst-similar"`` (dual-split trees), ``"bih"``, ``"htree"``,
///         ``"cbvh"``, ``"bvh4"``, ``"bvh8"`` (4- and 8-wide BVHs),
///         ``"cwbvh"`` (compressed 8-wide BVH, 80-byte nodes) or
///         ``"brute"`` (every triangle: the oracle); or
///         ``"bvh/<traversal>"``. See `raytree.STRUCTURES`.
///     traversal: for ``"bvh"`` only: ``"stack"`` (the default),
///         ``"implicit-a"``, ``"implicit-b"``, ``"sparse"``,
///         ``"hapala"``, ``"laine-0"``, ``"laine-1"``, ``"laine-2"``,
///         ``"laine-4"``, ``"laine-8"``. See `raytree.TRAVERSALS`.
///     builder: ``"sah"`` (binned SAH), ``"hybrid"`` (SAH for the top
///         8 levels, then median splits: the stackless paper's tree) or
///         ``"sbvh"`` (binned SAH with spatial splits: a triangle may sit
///         in several leaves) or ``"lbvh"`` (a linear BVH: Morton order,
///         leaves by SAH; the fastest build, trees of higher SAH cost).
///     max_leaf_size: most triangles per BVH leaf, 1..=255.
///     threads: worker threads for the build (None or 0: all cores).
///     sah_block: 1, 2, 4, 8 or 16: the SAH counts a leaf of n triangles
///         as ceil(n / sah_block) tests and splits no node of at most
///         sah_block triangles (Embree's sahBlockSize). Builders ``"sah"``,
///         ``"sbvh"`` and ``"lbvh"`` (its leaves), and ``"hybrid"``'s SAH
///         levels. None (the
///         default): 4 for ``"bvh4"``, ``"bvh8"`` and ``"cwbvh"``, whose
///         leaves test four triangles at a time (the fastest trees on one
///         core), 1 for the others (the trees the papers' tables use; the
///         command line's default).
///
/// Raises:
///     TypeError: `scene` is not a Scene.
///     ValueError: an unknown name (the message lists the known ones), a
///         traversal on a structure that has its own, a leaf size or
///         SAH block out of range, or a tree the layout cannot encode.
#[pyclass(frozen, module = "raytree", name = "Accelerator")]
pub struct PyAccelerator {
    built: Built,
    info: StructureInfo,
    bvh: BuildStats,
    triangles: Arc<[Triangle]>,
    normals: Vec<[f32; 3]>,
    geometries: Geometries,
    scene: Py<PyScene>,
    builder: Builder,
}

/// The queries' common arguments, checked: the rays' array, their leading
/// shape, interval ends and what to do with rays that cannot be traced.
struct Query<'py> {
    rays: FloatArray<'py>,
    lead: Vec<usize>,
    tmin: input::EndArg<'py>,
    tmax: input::EndArg<'py>,
    raise_invalid: bool,
    pool: Arc<rayon::ThreadPool>,
}

impl<'py> Query<'py> {
    fn new(
        rays: &Bound<'py, PyAny>,
        tmin: Option<&Bound<'py, PyAny>>,
        tmax: Option<&Bound<'py, PyAny>>,
        threads: Option<i64>,
        invalid_rays: &str,
    ) -> PyResult<Query<'py>> {
        let raise_invalid = match invalid_rays {
            "raise" => true,
            "miss" => false,
            other => {
                return Err(PyValueError::new_err(format!(
                    "invalid_rays must be 'raise' or 'miss', not {other:?}"
                )))
            }
        };
        let pool = pool(threads)?;
        let rays = float_array(rays, "rays")?;
        let shape = rays.shape();
        if shape.last() != Some(&6) {
            return Err(PyValueError::new_err(format!(
                "rays must have shape (..., 6): origin x, y, z then direction x, y, z; got shape {}",
                shape_str(shape)
            )));
        }
        let lead = shape[..shape.len() - 1].to_vec();
        let tmin = end_arg(tmin, 0.0, &lead, "tmin")?;
        let tmax = end_arg(tmax, f32::INFINITY, &lead, "tmax")?;
        Ok(Query {
            rays,
            lead,
            tmin,
            tmax,
            raise_invalid,
            pool,
        })
    }

    fn rays(&self) -> PyResult<Rays<'_>> {
        Ok(Rays {
            coords: self.rays.coords()?,
            tmin: self.tmin.end()?,
            tmax: self.tmax.end()?,
        })
    }

    fn count(&self) -> usize {
        self.lead.iter().product()
    }

    /// `ValueError` naming the first ray that could not be traced, when the
    /// caller asked for that.
    fn check(&self, invalid: &FirstInvalid) -> PyResult<()> {
        let Some(i) = invalid.get().filter(|_| self.raise_invalid) else {
            return Ok(());
        };
        let (o, d, tmin, tmax) = self.rays()?.parts(i);
        let why = raytree::geometry::Ray::invalid_reason(o, d, tmin, tmax)
            .unwrap_or_else(|| "out of range".into());
        Err(PyValueError::new_err(format!(
            "{} cannot be traced: {why} (origin {:?}, direction {:?}, tmin {tmin}, tmax {tmax}, in float32); pass invalid_rays='miss' to answer such rays with misses",
            index_str("rays", i, &self.lead),
            o.to_array(),
            d.to_array()
        )))
    }

    /// A new output array of the leading shape followed by `tail`, its
    /// elements not yet written ([`uninit_array`]).
    fn array<T: numpy::Element>(
        &self,
        py: Python<'py>,
        tail: &[usize],
    ) -> Bound<'py, PyArrayDyn<T>> {
        let dims: Vec<usize> = self.lead.iter().chain(tail).copied().collect();
        uninit_array(py, &dims)
    }
}

/// Per-ray counter arrays, filled by a query and put into its dict.
struct WorkArrays<'py> {
    nodes: Bound<'py, PyArrayDyn<u32>>,
    planes: Bound<'py, PyArrayDyn<u32>>,
    triangles: Bound<'py, PyArrayDyn<u32>>,
}

impl<'py> WorkArrays<'py> {
    fn new(q: &Query<'py>, py: Python<'py>, on: bool) -> Option<Self> {
        on.then(|| WorkArrays {
            nodes: q.array(py, &[]),
            planes: q.array(py, &[]),
            triangles: q.array(py, &[]),
        })
    }

    fn insert(&self, d: &Bound<'py, PyDict>) -> PyResult<()> {
        d.set_item("nodes", &self.nodes)?;
        d.set_item("plane_tests", &self.planes)?;
        d.set_item("triangle_tests", &self.triangles)
    }
}

/// Mutable views of [`WorkArrays`] while a query fills them.
struct WorkViews<'py>([numpy::PyReadwriteArray<'py, u32, IxDyn>; 3]);

impl<'py> WorkViews<'py> {
    fn new(w: &Option<WorkArrays<'py>>) -> Option<Self> {
        w.as_ref().map(|w| {
            WorkViews([
                w.nodes.readwrite(),
                w.planes.readwrite(),
                w.triangles.readwrite(),
            ])
        })
    }

    fn work(&mut self) -> PyResult<Work<'_>> {
        let [n, p, t] = &mut self.0;
        Ok(Work {
            nodes: slots(n)?,
            planes: slots(p)?,
            triangles: slots(t)?,
        })
    }
}

/// A new C-ordered array of shape `dims` whose elements are not written:
/// a query's output, every element of which the query writes through
/// [`slots`] before the array reaches Python (`trace::Slots`). Without
/// numpy's zero fill, a serial memset before the parallel loop.
fn uninit_array<'py, T: numpy::Element>(
    py: Python<'py>,
    dims: &[usize],
) -> Bound<'py, PyArrayDyn<T>> {
    // SAFETY: `PyArray::new` leaves the elements uninitialized, which is
    // sound as long as nothing reads them first: Rust reaches them only as
    // `MaybeUninit` slots (`slots`), written once each by the query, and
    // the array is handed to Python only after the query has returned
    // without error (on an error or a panic it is dropped unseen). The
    // element types used (f32, u32, i64, bool) hold no references.
    unsafe { PyArray::new(py, IxDyn(dims), false) }
}

/// The elements of an output array made by [`uninit_array`], as slots to
/// write, for as long as the read-write borrow `a` lasts.
fn slots<'a, T: numpy::Element>(
    a: &'a mut numpy::PyReadwriteArray<'_, T, IxDyn>,
) -> PyResult<Slots<'a, T>> {
    if !numpy::PyUntypedArrayMethods::is_c_contiguous(&***a) {
        return Err(PyRuntimeError::new_err("an output array is not contiguous"));
    }
    let len = numpy::PyUntypedArrayMethods::len(&***a);
    if len == 0 {
        return Ok(&mut []);
    }
    let data = a.data().cast::<std::mem::MaybeUninit<T>>();
    // SAFETY: `data` points at the array's `len` contiguous, aligned
    // elements (checked C-contiguous, non-empty); the read-write borrow
    // `a` gives this slice the only access to them for `'a`; a
    // `MaybeUninit<T>` has `T`'s layout and may hold any bytes.
    Ok(unsafe { std::slice::from_raw_parts_mut(data, len) })
}

#[pymethods]
impl PyAccelerator {
    #[new]
    #[pyo3(signature = (scene, structure = "bvh", traversal = None, builder = "sah", max_leaf_size = 8, threads = None, sah_block = None))]
    // The Python constructor's keyword arguments, one per parameter.
    #[allow(clippy::too_many_arguments)]
    fn new(
        py: Python<'_>,
        scene: &Bound<'_, PyAny>,
        structure: &str,
        traversal: Option<&str>,
        builder: &str,
        max_leaf_size: i64,
        threads: Option<i64>,
        sah_block: Option<i64>,
    ) -> PyResult<Self> {
        let scene = scene.cast::<PyScene>().map_err(|_| {
            PyTypeError::new_err(format!(
                "scene must be a raytree.Scene (Scene.from_arrays, Scene.load, Scene.builtin), not {}",
                scene.get_type().name().map_or("?".into(), |n| n.to_string())
            ))
        })?;
        let (s, t) = match (structure.split_once('/'), traversal) {
            (Some(_), Some(t)) => {
                return Err(PyValueError::new_err(format!(
                    "the traversal is given twice: structure={structure:?} and traversal={t:?}"
                )))
            }
            (Some((s, t)), None) => (s, t),
            (None, t) => (structure, t.unwrap_or("stack")),
        };
        let invalid = |e: raytree::names::UnknownName| PyValueError::new_err(e.to_string());
        let structure: StructureKind = s.parse().map_err(invalid)?;
        let traversal: TraversalKind = t.parse().map_err(invalid)?;
        raytree::structures::check(structure, traversal).map_err(|e| py_err(e, false))?;
        let builder = parse_builder(builder)?;
        if !(1..=255).contains(&max_leaf_size) {
            return Err(PyValueError::new_err(format!(
                "max_leaf_size must be in 1..=255, not {max_leaf_size}"
            )));
        }
        let sah_block = sah_block.unwrap_or(match structure {
            StructureKind::Bvh4 | StructureKind::Bvh8 | StructureKind::Cwbvh => 4,
            _ => 1,
        });
        if !usize::try_from(sah_block).is_ok_and(|b| BuildOptions::SAH_BLOCKS.contains(&b)) {
            return Err(PyValueError::new_err(format!(
                "sah_block must be 1, 2, 4, 8 or 16, not {sah_block}"
            )));
        }
        let pool = pool(threads)?;
        let triangles = scene.get().scene.triangles.clone();
        let geometries = Geometries::of(&scene.get().scene.mesh);
        let options = BuildOptions::new(builder)
            .with_max_leaf_size(max_leaf_size as usize)
            .with_sah_block(sah_block as usize);
        let tris = triangles.clone();
        let (bvh, built, normals) = py.detach(move || {
            pool.install(|| {
                let bvh = Bvh::build(&tris, &options);
                let normals = trace::unit_normals(&tris);
                let built = Built::new(structure, traversal, &bvh, tris);
                (bvh.stats, built, normals)
            })
        });
        let (built, info) = built.map_err(|e| py_err(e, false))?;
        Ok(PyAccelerator {
            built,
            info,
            bvh,
            triangles,
            normals,
            geometries,
            scene: scene.clone().unbind(),
            builder,
        })
    }

    /// The structure's name (``"bvh"``, ``"dst"``, ...).
    #[getter]
    fn structure(&self) -> &'static str {
        self.info.structure.name()
    }

    /// The traversal's name for ``"bvh"`` (``"stack"``, ``"laine-4"``, ...);
    /// None for structures with their own.
    #[getter]
    fn traversal(&self) -> Option<&'static str> {
        self.info.traversal.map(|t| t.name())
    }

    /// ``"sah"`` or ``"hybrid"``.
    #[getter]
    fn builder(&self) -> &'static str {
        self.builder.name()
    }

    /// Bytes of the structure: nodes and triangle index lists (not the
    /// triangles themselves, which every structure shares).
    #[getter]
    fn bytes(&self) -> usize {
        self.info.bytes
    }

    /// The Scene it was built over.
    #[getter]
    fn scene(&self, py: Python<'_>) -> Py<PyScene> {
        self.scene.clone_ref(py)
    }

    /// What the structure reports about itself, as plain Python values:
    /// ``structure``, ``traversal`` (None but for bvh), ``layout``,
    /// ``bytes`` (= ``node_bytes`` + ``index_bytes``), ``reserved_bytes``
    /// (implicit layout only), ``inner_nodes``, ``leaves``, ``state_bytes``
    /// (per-ray traversal state, bvh only), ``conversion_seconds``, ``dst``
    /// and ``htree`` (node kinds, or None); ``bvh``: the canonical BVH's
    /// build report (``builder``, ``max_leaf_size``, ``sah_block``, ``build_seconds``,
    /// ``nodes``, ``inner_nodes``, ``leaves``, ``references``, ``depth``,
    /// ``sah_cost``, ``degenerate_triangles``, ``optimized``, and
    /// ``peak_heap_bytes``, None here: only the ``raytree`` command meters
    /// its heap); ``triangles``: the scene's triangle count.
    /// Byte counts in bytes, times in seconds.
    fn info<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let mut v =
            serde_json::to_value(&self.info).map_err(|e| PyRuntimeError::new_err(e.to_string()))?;
        v["bvh"] =
            serde_json::to_value(&self.bvh).map_err(|e| PyRuntimeError::new_err(e.to_string()))?;
        v["triangles"] = self.triangles.len().into();
        let text = v.to_string();
        py.import("json")?.getattr("loads")?.call1((text,))
    }

    fn __repr__(&self) -> String {
        let name = match self.info.traversal {
            Some(t) => format!("{}/{}", self.info.structure.name(), t.name()),
            None => self.info.structure.name().to_string(),
        };
        format!(
            "Accelerator({name:?}, builder={:?}, {} triangles, {} bytes)",
            self.builder.name(),
            self.triangles.len(),
            self.info.bytes
        )
    }

    /// The closest hit of every ray, like Open3D's
    /// ``RaycastingScene.cast_rays``.
    ///
    /// Args:
    ///     rays: (..., 6) float32 or float64 array, any leading shape:
    ///         origin x, y, z then direction x, y, z. The direction need not
    ///         be unit length: distances are in units of it. float32
    ///         C-contiguous and float64 C-contiguous arrays are read in
    ///         place (float64 rounded to float32 ray by ray); anything else
    ///         is converted first.
    ///     tmin, tmax: the interval [tmin, tmax] searched along each ray
    ///         (both inclusive, in units of the direction): a number, or an
    ///         array that broadcasts to the leading shape; None for 0 and
    ///         inf. Rounded to float32.
    ///     threads: worker threads (None or 0: all logical cores). The GIL
    ///         is released while tracing; answers do not depend on it.
    ///     counters: also return per-ray work counters.
    ///     invalid_rays: ``"raise"``: a ray that cannot be traced (a NaN or
    ///         infinite component, a zero direction, a NaN bound, a
    ///         coordinate beyond ±2^126 once in float32) raises ValueError
    ///         naming it; ``"miss"``: such rays are misses.
    ///
    /// Returns:
    ///     dict of arrays with the rays' leading shape (...):
    ///     ``t_hit`` (..., float32): distance to the hit, in units of the
    ///     direction; inf on a miss. ``primitive_ids`` (..., uint32): the
    ///     triangle's row in the scene's triangles (numbered over all its
    ///     geometries), ``raytree.INVALID_ID`` (0xFFFFFFFF) on a miss.
    ///     ``geometry_ids`` (..., uint32): the geometry of the triangle hit
    ///     (0 for a scene of one geometry; see `Scene.geometries` and
    ///     `Scene.geometry_of`), INVALID_ID on a miss. ``primitive_uvs``
    ///     (..., 2) float32: barycentrics (u, v) of the hit point
    ///     (1-u-v)·a + u·b + v·c; zeros on a miss. ``primitive_normals``
    ///     (..., 3) float32: the unit geometric normal (b-a)×(c-a)/|...|
    ///     of the triangle hit (not flipped towards the ray); zeros on a
    ///     miss. With ``counters=True`` also ``nodes``, ``plane_tests``
    ///     (a box test counts 6) and ``triangle_tests`` (..., uint32).
    ///     On equal distances the smaller triangle index wins.
    #[pyo3(signature = (rays, tmin = None, tmax = None, threads = None, counters = false, invalid_rays = "raise"))]
    #[allow(clippy::too_many_arguments)]
    fn cast_rays<'py>(
        &self,
        py: Python<'py>,
        rays: &Bound<'py, PyAny>,
        tmin: Option<&Bound<'py, PyAny>>,
        tmax: Option<&Bound<'py, PyAny>>,
        threads: Option<i64>,
        counters: bool,
        invalid_rays: &str,
    ) -> PyResult<Bound<'py, PyDict>> {
        let q = Query::new(rays, tmin, tmax, threads, invalid_rays)?;
        let t = q.array::<f32>(py, &[]);
        let prim = q.array::<u32>(py, &[]);
        let geom = q.array::<u32>(py, &[]);
        let uv = q.array::<f32>(py, &[2]);
        let normal = q.array::<f32>(py, &[3]);
        let work = WorkArrays::new(&q, py, counters);
        {
            let (mut tw, mut pw, mut gw, mut uw, mut nw) = (
                t.readwrite(),
                prim.readwrite(),
                geom.readwrite(),
                uv.readwrite(),
                normal.readwrite(),
            );
            let mut views = WorkViews::new(&work);
            let out = ClosestOut {
                t: slots(&mut tw)?,
                prim: slots(&mut pw)?,
                geom: slots(&mut gw)?,
                uv: slots(&mut uw)?,
                normal: slots(&mut nw)?,
                work: views.as_mut().map(|v| v.work()).transpose()?,
            };
            let invalid = FirstInvalid::default();
            let job = Closest {
                rays: q.rays()?,
                out,
                normals: &self.normals,
                geometries: &self.geometries,
                invalid: &invalid,
            };
            let (built, pool) = (&self.built, &q.pool);
            py.detach(|| pool.install(|| built.with(job)));
            q.check(&invalid)?;
        }
        let d = PyDict::new(py);
        d.set_item("t_hit", t)?;
        d.set_item("primitive_ids", prim)?;
        d.set_item("geometry_ids", geom)?;
        d.set_item("primitive_uvs", uv)?;
        d.set_item("primitive_normals", normal)?;
        if let Some(w) = &work {
            w.insert(&d)?;
        }
        Ok(d)
    }

    /// Whether each ray hits anything within [tmin, tmax] (an any-hit
    /// query: the first hit found ends the ray's search), like Open3D's
    /// ``RaycastingScene.test_occlusions``. Arguments as `cast_rays`.
    ///
    /// Returns:
    ///     (...) bool array; with ``counters=True`` a dict: ``occluded``
    ///     and the per-ray ``nodes``, ``plane_tests``, ``triangle_tests``.
    #[pyo3(signature = (rays, tmin = None, tmax = None, threads = None, counters = false, invalid_rays = "raise"))]
    #[allow(clippy::too_many_arguments)]
    fn test_occlusions<'py>(
        &self,
        py: Python<'py>,
        rays: &Bound<'py, PyAny>,
        tmin: Option<&Bound<'py, PyAny>>,
        tmax: Option<&Bound<'py, PyAny>>,
        threads: Option<i64>,
        counters: bool,
        invalid_rays: &str,
    ) -> PyResult<Bound<'py, PyAny>> {
        let q = Query::new(rays, tmin, tmax, threads, invalid_rays)?;
        let values = q.array::<bool>(py, &[]);
        let work = WorkArrays::new(&q, py, counters);
        {
            let mut vw = values.readwrite();
            let mut views = WorkViews::new(&work);
            let out = PerRayOut {
                values: slots(&mut vw)?,
                work: views.as_mut().map(|v| v.work()).transpose()?,
            };
            let invalid = FirstInvalid::default();
            let job = Occluded {
                rays: q.rays()?,
                out,
                invalid: &invalid,
            };
            let (built, pool) = (&self.built, &q.pool);
            py.detach(|| pool.install(|| built.with(job)));
            q.check(&invalid)?;
        }
        match work {
            None => Ok(values.into_any()),
            Some(w) => {
                let d = PyDict::new(py);
                d.set_item("occluded", values)?;
                w.insert(&d)?;
                Ok(d.into_any())
            }
        }
    }

    /// The number of triangles each ray meets within [tmin, tmax] (every
    /// hit, each triangle once; a ray through a shared edge meets both
    /// triangles), like Open3D's ``RaycastingScene.count_intersections``.
    /// Arguments as `cast_rays`.
    ///
    /// Returns:
    ///     (...) uint32 array; with ``counters=True`` a dict: ``count`` and
    ///     the per-ray ``nodes``, ``plane_tests``, ``triangle_tests``.
    #[pyo3(signature = (rays, tmin = None, tmax = None, threads = None, counters = false, invalid_rays = "raise"))]
    #[allow(clippy::too_many_arguments)]
    fn count_intersections<'py>(
        &self,
        py: Python<'py>,
        rays: &Bound<'py, PyAny>,
        tmin: Option<&Bound<'py, PyAny>>,
        tmax: Option<&Bound<'py, PyAny>>,
        threads: Option<i64>,
        counters: bool,
        invalid_rays: &str,
    ) -> PyResult<Bound<'py, PyAny>> {
        let q = Query::new(rays, tmin, tmax, threads, invalid_rays)?;
        let values = q.array::<u32>(py, &[]);
        let work = WorkArrays::new(&q, py, counters);
        {
            let mut vw = values.readwrite();
            let mut views = WorkViews::new(&work);
            let out = PerRayOut {
                values: slots(&mut vw)?,
                work: views.as_mut().map(|v| v.work()).transpose()?,
            };
            let invalid = FirstInvalid::default();
            let job = CountHits {
                rays: q.rays()?,
                out,
                invalid: &invalid,
            };
            let (built, pool) = (&self.built, &q.pool);
            py.detach(|| pool.install(|| built.with(job)));
            q.check(&invalid)?;
        }
        match work {
            None => Ok(values.into_any()),
            Some(w) => {
                let d = PyDict::new(py);
                d.set_item("count", values)?;
                w.insert(&d)?;
                Ok(d.into_any())
            }
        }
    }

    /// Every hit along every ray within [tmin, tmax], nearest first (equal
    /// distances by the smaller triangle index), in flat arrays, like
    /// Open3D's ``RaycastingScene.list_intersections``. Arguments as
    /// `cast_rays`; ``max_hits`` keeps at most that many (the nearest) per
    /// ray.
    ///
    /// Returns:
    ///     dict. With R rays (the leading shape flattened, C order) and K
    ///     hits in all: ``ray_splits`` (R+1,) int64: the hits of flat ray
    ///     ``r`` are entries ``ray_splits[r]:ray_splits[r+1]`` of the flat
    ///     arrays; ``ray_ids`` (K,) int64: the flat ray of each hit;
    ///     ``t_hit`` (K,) float32; ``primitive_ids`` (K,) uint32;
    ///     ``geometry_ids`` (K,) uint32; ``primitive_uvs`` (K, 2)
    ///     float32; ``primitive_normals`` (K, 3) float32: as in
    ///     `cast_rays`. With ``counters=True`` also ``nodes``,
    ///     ``plane_tests``, ``triangle_tests`` with the leading shape (...),
    ///     uint32, counting the whole search whatever ``max_hits`` keeps.
    #[pyo3(signature = (rays, tmin = None, tmax = None, threads = None, counters = false, invalid_rays = "raise", max_hits = None))]
    #[allow(clippy::too_many_arguments)]
    fn list_intersections<'py>(
        &self,
        py: Python<'py>,
        rays: &Bound<'py, PyAny>,
        tmin: Option<&Bound<'py, PyAny>>,
        tmax: Option<&Bound<'py, PyAny>>,
        threads: Option<i64>,
        counters: bool,
        invalid_rays: &str,
        max_hits: Option<i64>,
    ) -> PyResult<Bound<'py, PyDict>> {
        let max_hits = match max_hits {
            None => usize::MAX,
            Some(m) if m >= 0 => m as usize,
            Some(m) => {
                return Err(PyValueError::new_err(format!(
                    "max_hits must be None or at least 0, not {m}"
                )))
            }
        };
        let q = Query::new(rays, tmin, tmax, threads, invalid_rays)?;
        let work = WorkArrays::new(&q, py, counters);
        let chunks = {
            let mut views = WorkViews::new(&work);
            let invalid = FirstInvalid::default();
            let job = ListHits {
                rays: q.rays()?,
                work: views.as_mut().map(|v| v.work()).transpose()?,
                max_hits,
                invalid: &invalid,
            };
            let (built, pool) = (&self.built, &q.pool);
            let chunks = py.detach(|| pool.install(|| built.with(job)));
            q.check(&invalid)?;
            chunks
        };
        let k: usize = chunks.iter().map(|c| c.hits.len()).sum();
        let flat = |tail: &[usize]| [&[k][..], tail].concat();
        let t = uninit_array::<f32>(py, &flat(&[]));
        let prim = uninit_array::<u32>(py, &flat(&[]));
        let geom = uninit_array::<u32>(py, &flat(&[]));
        let uv = uninit_array::<f32>(py, &flat(&[2]));
        let normal = uninit_array::<f32>(py, &flat(&[3]));
        let ray_ids = uninit_array::<i64>(py, &flat(&[]));
        let splits = uninit_array::<i64>(py, &[q.count() + 1]);
        {
            let (mut tw, mut pw, mut gw, mut uw, mut nw, mut rw, mut sw) = (
                t.readwrite(),
                prim.readwrite(),
                geom.readwrite(),
                uv.readwrite(),
                normal.readwrite(),
                ray_ids.readwrite(),
                splits.readwrite(),
            );
            let out = ListOut {
                t: slots(&mut tw)?,
                prim: slots(&mut pw)?,
                geom: slots(&mut gw)?,
                uv: slots(&mut uw)?,
                normal: slots(&mut nw)?,
                ray_ids: slots(&mut rw)?,
            };
            let splits = slots(&mut sw)?;
            let (pool, normals, geometries) = (&q.pool, &self.normals, &self.geometries);
            py.detach(|| {
                pool.install(|| trace::fill_lists(&chunks, out, splits, normals, geometries))
            });
        }
        let d = PyDict::new(py);
        d.set_item("ray_splits", splits)?;
        d.set_item("ray_ids", ray_ids)?;
        d.set_item("t_hit", t)?;
        d.set_item("primitive_ids", prim)?;
        d.set_item("geometry_ids", geom)?;
        d.set_item("primitive_uvs", uv)?;
        d.set_item("primitive_normals", normal)?;
        if let Some(w) = &work {
            w.insert(&d)?;
        }
        Ok(d)
    }

    /// For benchmarks: the core's own batch call (``Tracer::intersect``,
    /// closest hits) over the same rays on the same pool, with the GIL
    /// released, as a Rust program given the same arrays runs it: the rays
    /// built from the arrays (``Ray::new``: reciprocal, shear, checks),
    /// then traced. Returns the wall-clock and CPU seconds (this process,
    /// all threads; what ``time.process_time()`` counts) of both steps
    /// together and of the trace alone, and the number of rays that hit:
    /// the baselines `cast_rays`'s overhead is measured against.
    #[pyo3(signature = (rays, tmin = None, tmax = None, threads = None))]
    fn _rust_batch<'py>(
        &self,
        py: Python<'py>,
        rays: &Bound<'py, PyAny>,
        tmin: Option<&Bound<'py, PyAny>>,
        tmax: Option<&Bound<'py, PyAny>>,
        threads: Option<i64>,
    ) -> PyResult<(f64, f64, f64, f64, usize)> {
        let q = Query::new(rays, tmin, tmax, threads, "miss")?;
        let r = q.rays()?;
        let (built, pool) = (&self.built, &q.pool);
        py.detach(|| {
            pool.install(|| {
                let mut hits = vec![None; r.len()];
                let (start, cpu) = (std::time::Instant::now(), process_cpu_seconds());
                let rays = trace::build_rays(&r);
                let (traced, traced_cpu) = (std::time::Instant::now(), process_cpu_seconds());
                built
                    .with(RustBatch {
                        rays: &rays,
                        hits: &mut hits,
                    })
                    .map_err(|e| py_err(e, false))?;
                let end_cpu = process_cpu_seconds();
                let (wall, trace_wall) = (
                    start.elapsed().as_secs_f64(),
                    traced.elapsed().as_secs_f64(),
                );
                Ok((
                    wall,
                    end_cpu - cpu,
                    trace_wall,
                    end_cpu - traced_cpu,
                    hits.iter().flatten().count(),
                ))
            })
        })
    }
}

/// CPU time of the whole process, all threads, in seconds (the clock of
/// Python's `time.process_time`); NaN where unknown.
#[cfg(unix)]
fn process_cpu_seconds() -> f64 {
    let mut ts = libc::timespec {
        tv_sec: 0,
        tv_nsec: 0,
    };
    // SAFETY: `ts` is a valid, writable timespec; the clock id is a constant.
    let rc = unsafe { libc::clock_gettime(libc::CLOCK_PROCESS_CPUTIME_ID, &mut ts) };
    if rc == 0 {
        ts.tv_sec as f64 + ts.tv_nsec as f64 * 1e-9
    } else {
        f64::NAN
    }
}

#[cfg(not(unix))]
fn process_cpu_seconds() -> f64 {
    f64::NAN
}

/// The extension module; `raytree/__init__.py` re-exports it.
#[pymodule]
#[pyo3(name = "_raytree")]
fn raytree_module(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<PyScene>()?;
    m.add_class::<PyAccelerator>()?;
    m.add("INVALID_ID", INVALID_ID)?;
    let py = m.py();
    let names = |n: Vec<&'static str>| PyTuple::new(py, n);
    m.add(
        "STRUCTURES",
        names(StructureKind::all().iter().map(|s| s.name()).collect())?,
    )?;
    m.add(
        "TRAVERSALS",
        names(TraversalKind::all().iter().map(|t| t.name()).collect())?,
    )?;
    m.add(
        "BUILDERS",
        names(Builder::ALL.iter().map(|b| b.name()).collect())?,
    )?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    Ok(())
}
