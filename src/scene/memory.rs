//! A check before a scene is built that the machine can hold it: better a
//! clear error naming the limit than an out-of-memory kill an hour later.

use crate::error::{Error, Result};

/// Peak bytes per triangle of loading a scene, building its BVH and
/// derived structures and tracing them, measured on a 12M-triangle
/// hairball: 124 for `raytree info` or `render` (one structure at a time),
/// 173 for `bench dst` (all six held at once); the rest is margin.
pub const PEAK_BYTES_PER_TRIANGLE: u64 = 180;

/// An environment variable that caps the memory raytree assumes it may use
/// (for shared machines, and for testing the check): bytes, or a number
/// with a unit `K`, `M`, `G`, `T` (or `KiB` ... `TiB`, binary either way).
/// A value that is not such a size is an error; an empty one is no cap.
pub const LIMIT_VARIABLE: &str = "RAYTREE_MEMORY_LIMIT";

/// Memory the system can give without swapping (`MemAvailable` of
/// `/proc/meminfo`), where the system says, capped by [`LIMIT_VARIABLE`].
/// [`Error::Invalid`] when the variable is set to something that is not a size.
pub fn available_bytes() -> Result<Option<u64>> {
    let system = (|| {
        let info = std::fs::read_to_string("/proc/meminfo").ok()?;
        let line = info.lines().find(|l| l.starts_with("MemAvailable:"))?;
        let kib: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
        Some(kib * 1024)
    })();
    let cap = match std::env::var_os(LIMIT_VARIABLE) {
        None => None,
        Some(v) => parse_limit(&v.to_string_lossy())?,
    };
    Ok(match (system, cap) {
        (Some(s), Some(c)) => Some(s.min(c)),
        (s, c) => s.or(c),
    })
}

/// The value of [`LIMIT_VARIABLE`] in bytes: `None` when empty,
/// [`Error::Invalid`] when not a positive size.
pub fn parse_limit(value: &str) -> Result<Option<u64>> {
    let v = value.trim();
    if v.is_empty() {
        return Ok(None);
    }
    let digits = v.find(|c: char| !c.is_ascii_digit()).unwrap_or(v.len());
    let (number, unit) = v.split_at(digits);
    let shift = match unit.trim().to_ascii_lowercase().as_str() {
        "" | "b" => Some(0),
        "k" | "kib" => Some(10),
        "m" | "mib" => Some(20),
        "g" | "gib" => Some(30),
        "t" | "tib" => Some(40),
        _ => None,
    };
    let bytes = number
        .parse::<u64>()
        .ok()
        .zip(shift)
        .and_then(|(n, s)| n.checked_mul(1u64 << s))
        .filter(|&b| b > 0);
    match bytes {
        Some(b) => Ok(Some(b)),
        None => Err(Error::Invalid(format!(
            "{LIMIT_VARIABLE}='{value}' is not a memory size: give a positive number of bytes, optionally with a unit K, M, G or T (e.g. 4G)"
        ))),
    }
}

/// `bytes` in the unit that shows it: B, KiB, MiB or GiB, by magnitude.
pub fn human_bytes(bytes: u64) -> String {
    const UNITS: [&str; 3] = ["KiB", "MiB", "GiB"];
    if bytes < 1024 {
        return format!("{bytes} B");
    }
    let mut value = bytes as f64 / 1024.0;
    let mut unit = 0;
    while value >= 1024.0 && unit < UNITS.len() - 1 {
        value /= 1024.0;
        unit += 1;
    }
    format!("{value:.1} {}", UNITS[unit])
}

/// Peak bytes of `triangles` triangles.
pub fn peak_bytes(triangles: u64) -> u64 {
    triangles.saturating_mul(PEAK_BYTES_PER_TRIANGLE)
}

/// Refuses `triangles` triangles of `what` with an [`Error::Limit`] when
/// their estimated peak exceeds `available` bytes (unknown: no check).
pub fn check_fits(what: &str, triangles: u64, available: Option<u64>) -> Result<()> {
    let need = peak_bytes(triangles);
    match available {
        Some(have) if need > have => Err(Error::Limit(format!(
            "{what}: {triangles} triangles need about {} ({PEAK_BYTES_PER_TRIANGLE} bytes per triangle at the peak), but only {} of memory is available; use a smaller scene (at most about {} triangles here)",
            human_bytes(need),
            human_bytes(have),
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
        assert!(available_bytes().unwrap().is_none_or(|b| b > 0));
        // Small sizes are shown in a unit that shows them.
        let m = check_fits("chess:64000", 64_000, Some(1_000_000))
            .unwrap_err()
            .to_string();
        assert!(
            m.contains("need about 11.0 MiB") && m.contains("only 976.6 KiB"),
            "{m}"
        );
    }

    #[test]
    fn sizes_in_the_unit_that_shows_them() {
        assert_eq!(human_bytes(0), "0 B");
        assert_eq!(human_bytes(1023), "1023 B");
        assert_eq!(human_bytes(1024), "1.0 KiB");
        assert_eq!(human_bytes(1_000_000), "976.6 KiB");
        assert_eq!(human_bytes(3 << 20), "3.0 MiB");
        assert_eq!(human_bytes(5 << 30), "5.0 GiB");
        assert_eq!(human_bytes(2048 << 30), "2048.0 GiB");
    }

    #[test]
    fn the_limit_variable_is_a_size_or_an_error() {
        assert_eq!(parse_limit("1000000").unwrap(), Some(1_000_000));
        assert_eq!(parse_limit(" 4G ").unwrap(), Some(4 << 30));
        assert_eq!(parse_limit("512MiB").unwrap(), Some(512 << 20));
        assert_eq!(parse_limit("2 k").unwrap(), Some(2048));
        assert_eq!(parse_limit("").unwrap(), None);
        for bad in ["abc", "-5", "0", "1.5G", "4X", "G", "99999999999999999999"] {
            let m = parse_limit(bad).unwrap_err().to_string();
            assert!(
                m.contains(LIMIT_VARIABLE) && m.contains(&format!("'{bad}'")),
                "{bad}: {m}"
            );
        }
    }
}
