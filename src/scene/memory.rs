//! A check before a scene is built that the machine can hold it: better a
//! clear error naming the limit than an out-of-memory kill an hour later.

use crate::error::{Error, Result};

/// Peak bytes per triangle of loading a scene, building its BVH and
/// derived structures and tracing them, measured on a 12M-triangle
/// hairball: 124 for `raytree info` or `render` (one structure at a time),
/// 173 for `bench dst` (all six held at once); the rest is margin.
pub const PEAK_BYTES_PER_TRIANGLE: u64 = 180;

/// An environment variable that caps the memory raytree assumes it may use,
/// in bytes (for shared machines, and for testing the check).
pub const LIMIT_VARIABLE: &str = "RAYTREE_MEMORY_LIMIT";

/// Memory the system can give without swapping (`MemAvailable` of
/// `/proc/meminfo`), where the system says, capped by [`LIMIT_VARIABLE`].
pub fn available_bytes() -> Option<u64> {
    let system = (|| {
        let info = std::fs::read_to_string("/proc/meminfo").ok()?;
        let line = info.lines().find(|l| l.starts_with("MemAvailable:"))?;
        let kib: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
        Some(kib * 1024)
    })();
    let cap = std::env::var(LIMIT_VARIABLE)
        .ok()
        .and_then(|v| v.trim().parse::<u64>().ok());
    match (system, cap) {
        (Some(s), Some(c)) => Some(s.min(c)),
        (s, c) => s.or(c),
    }
}

/// Refuses `triangles` triangles of `what` when their estimated peak
/// exceeds `available` bytes (unknown: no check).
pub fn check_fits(what: &str, triangles: u64, available: Option<u64>) -> Result<()> {
    let need = triangles.saturating_mul(PEAK_BYTES_PER_TRIANGLE);
    match available {
        Some(have) if need > have => Err(Error::Limit(format!(
            "{what}: {triangles} triangles need about {:.1} GiB ({PEAK_BYTES_PER_TRIANGLE} bytes per triangle at the peak), but only {:.1} GiB of memory is available; use a smaller scene (at most about {} triangles here)",
            need as f64 / (1u64 << 30) as f64,
            have as f64 / (1u64 << 30) as f64,
            have / PEAK_BYTES_PER_TRIANGLE
        ))),
        _ => Ok(()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn refuses_what_does_not_fit_and_says_the_limit() {
        let gib = 1u64 << 30;
        assert!(check_fits("s", 1_000_000, Some(gib)).is_ok());
        let e = check_fits("hairball:200M", 200_000_000, Some(24 * gib)).unwrap_err();
        let m = e.to_string();
        assert!(
            m.contains("hairball:200M") && m.contains("33.5 GiB") && m.contains("24.0 GiB"),
            "{m}"
        );
        assert!(check_fits("s", u64::MAX, None).is_ok());
        assert!(available_bytes().is_none_or(|b| b > 0));
    }
}
