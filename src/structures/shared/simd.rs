//! The vector instruction set the wide kernels run on, chosen at run time:
//! one binary, built without `target-cpu=native`, runs the widest path the
//! processor offers.
//!
//! | path | x86-64 features | used by |
//! |---|---|---|
//! | `portable` | the target's baseline (SSE2 on x86-64, NEON on aarch64) | every kernel |
//! | `sse4.1` | SSE4.1 | `bvh4`, `bvh8`, `cwbvh` |
//! | `avx2` | AVX2 and FMA | `bvh4`, `bvh8`, `cwbvh` |
//! | `avx512` | AVX-512 F, VL, DQ and BW | `bvh4`, `bvh8`, `cwbvh` |
//!
//! Every path computes the same f32 operations in the same order (no fused
//! multiply-add in a box or triangle test), so answers, distances and
//! statistics are bit for bit the same on every path; the paths differ only
//! in how many lanes one instruction covers and in how hit lanes are
//! gathered. The environment variable `RAYTREE_SIMD` (one of the names
//! above) or [`set_active`] forces a path, so that tests and benchmarks can
//! run each one the processor has.

use crate::error::{Error, Result};
use std::sync::atomic::{AtomicBool, AtomicU8, Ordering};

/// A vector instruction set a kernel may run on (see the module docs).
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum SimdPath {
    /// What the compilation target guarantees: SSE2 on x86-64, NEON on
    /// aarch64, scalar code elsewhere.
    Portable,
    /// x86-64 with SSE4.1.
    Sse41,
    /// x86-64 with AVX2 and FMA (256-bit lanes).
    Avx2,
    /// x86-64 with AVX-512 F, VL, DQ and BW (mask registers, compress).
    Avx512,
}

impl SimdPath {
    /// Every path, narrowest first.
    pub const ALL: [SimdPath; 4] = [
        SimdPath::Portable,
        SimdPath::Sse41,
        SimdPath::Avx2,
        SimdPath::Avx512,
    ];

    /// The name `RAYTREE_SIMD` and reports use.
    pub fn name(self) -> &'static str {
        match self {
            SimdPath::Portable => "portable",
            SimdPath::Sse41 => "sse4.1",
            SimdPath::Avx2 => "avx2",
            SimdPath::Avx512 => "avx512",
        }
    }

    /// The path named `s` (see [`SimdPath::name`]).
    ///
    /// # Errors
    /// [`Error::Invalid`] naming the known paths.
    pub fn parse(s: &str) -> Result<Self> {
        Self::ALL
            .into_iter()
            .find(|p| p.name() == s.trim())
            .ok_or_else(|| {
                // A long value is cut, so that the error stays one line.
                let shown: String = s.chars().take(40).collect();
                let more = if s.chars().count() > 40 { "…" } else { "" };
                Error::Invalid(format!(
                    "unknown SIMD path '{shown}{more}' (known: {})",
                    Self::ALL.map(|p| p.name()).join(", ")
                ))
            })
    }

    /// Whether this processor can run the path.
    pub fn supported(self) -> bool {
        match self {
            SimdPath::Portable => true,
            #[cfg(target_arch = "x86_64")]
            SimdPath::Sse41 => std::arch::is_x86_feature_detected!("sse4.1"),
            #[cfg(target_arch = "x86_64")]
            SimdPath::Avx2 => {
                std::arch::is_x86_feature_detected!("avx2")
                    && std::arch::is_x86_feature_detected!("fma")
                    && bit_manipulation()
            }
            #[cfg(target_arch = "x86_64")]
            SimdPath::Avx512 => {
                bit_manipulation()
                    && std::arch::is_x86_feature_detected!("avx2")
                    && std::arch::is_x86_feature_detected!("fma")
                    && std::arch::is_x86_feature_detected!("avx512f")
                    && std::arch::is_x86_feature_detected!("avx512vl")
                    && std::arch::is_x86_feature_detected!("avx512dq")
                    && std::arch::is_x86_feature_detected!("avx512bw")
            }
            #[cfg(not(target_arch = "x86_64"))]
            _ => false,
        }
    }

    /// What the portable path is on this target, for reports.
    pub fn describe(self) -> &'static str {
        match self {
            SimdPath::Portable if cfg!(target_arch = "x86_64") => "portable (SSE2)",
            SimdPath::Portable if cfg!(target_arch = "aarch64") => "portable (NEON)",
            SimdPath::Portable => "portable (scalar)",
            p => p.name(),
        }
    }
}

impl std::fmt::Display for SimdPath {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

/// The paths this processor can run, narrowest first.
pub fn supported() -> Vec<SimdPath> {
    SimdPath::ALL
        .into_iter()
        .filter(|p| p.supported())
        .collect()
}

/// The widest path this processor can run.
pub fn best() -> SimdPath {
    *supported().last().expect("the portable path always runs")
}

/// Not yet chosen.
const UNSET: u8 = u8::MAX;
static ACTIVE: AtomicU8 = AtomicU8::new(UNSET);
/// Whether the active path was forced (`set_active` or `RAYTREE_SIMD`).
static FORCED: AtomicBool = AtomicBool::new(false);

/// The path `RAYTREE_SIMD` asks for, if set.
///
/// # Errors
/// [`Error::Invalid`] for an unknown name, or a path this processor cannot
/// run.
pub fn from_env() -> Result<Option<SimdPath>> {
    let Some(v) = std::env::var_os("RAYTREE_SIMD") else {
        return Ok(None);
    };
    let Some(v) = v.to_str() else {
        return Err(Error::Invalid(format!(
            "RAYTREE_SIMD is not UTF-8 text (known paths: {})",
            SimdPath::ALL.map(|p| p.name()).join(", ")
        )));
    };
    // Set but empty: as if unset.
    if v.trim().is_empty() {
        return Ok(None);
    }
    let p = SimdPath::parse(v).map_err(|e| Error::Invalid(format!("RAYTREE_SIMD: {e}")))?;
    if !p.supported() {
        return Err(Error::Invalid(format!(
            "RAYTREE_SIMD={v}: this processor cannot run it (it can run: {})",
            supported()
                .iter()
                .map(|p| p.name())
                .collect::<Vec<_>>()
                .join(", ")
        )));
    }
    Ok(Some(p))
}

/// The path the kernels run on: the one [`set_active`] chose, else the one
/// `RAYTREE_SIMD` names, else [`best`]. An unusable `RAYTREE_SIMD` is
/// ignored here (programs check it up front with [`from_env`]).
#[inline]
pub fn active() -> SimdPath {
    match ACTIVE.load(Ordering::Relaxed) {
        UNSET => {
            let forced = from_env().ok().flatten();
            FORCED.store(forced.is_some(), Ordering::Relaxed);
            let p = forced.unwrap_or_else(best);
            ACTIVE.store(p as u8, Ordering::Relaxed);
            p
        }
        v => SimdPath::ALL[v as usize],
    }
}

/// Makes `path` the one every later trace runs on (for every thread).
///
/// # Errors
/// [`Error::Invalid`] if this processor cannot run it; the active path is
/// then unchanged.
pub fn set_active(path: SimdPath) -> Result<()> {
    if !path.supported() {
        return Err(Error::Invalid(format!(
            "SIMD path {path}: this processor cannot run it"
        )));
    }
    ACTIVE.store(path as u8, Ordering::Relaxed);
    FORCED.store(true, Ordering::Relaxed);
    Ok(())
}

/// How the active path was chosen, for reports: "chosen at run time" or
/// "forced".
pub fn how_chosen() -> &'static str {
    active();
    if FORCED.load(Ordering::Relaxed) {
        "forced (RAYTREE_SIMD or set_active)"
    } else {
        "chosen at run time"
    }
}

/// POPCNT, LZCNT, BMI1 and BMI2, which every processor with AVX2 has
/// (Intel from Haswell, AMD from Excavator) and which the AVX2 and AVX-512
/// paths are compiled with: a mask's population count in one instruction
/// rather than a multiply sequence on the kernel's critical path.
#[cfg(target_arch = "x86_64")]
fn bit_manipulation() -> bool {
    std::arch::is_x86_feature_detected!("popcnt")
        && std::arch::is_x86_feature_detected!("lzcnt")
        && std::arch::is_x86_feature_detected!("bmi1")
        && std::arch::is_x86_feature_detected!("bmi2")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_round_trip_and_unknown_names_are_refused() {
        for p in SimdPath::ALL {
            assert_eq!(SimdPath::parse(p.name()).unwrap(), p);
        }
        let e = SimdPath::parse("avx1024").unwrap_err().to_string();
        assert!(e.contains("avx1024") && e.contains("avx512"), "{e}");
        let long = "x".repeat(5000);
        let e = SimdPath::parse(&long).unwrap_err().to_string();
        assert!(e.len() < 200 && e.contains("…"), "{e}");
    }

    #[test]
    fn the_portable_path_always_runs_and_best_is_supported() {
        assert!(SimdPath::Portable.supported());
        assert_eq!(supported()[0], SimdPath::Portable);
        assert!(best().supported());
        assert!(supported().windows(2).all(|w| w[0] < w[1]));
    }
}
