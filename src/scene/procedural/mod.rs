//! Built-in procedural scenes: deterministic (fixed seeds) and scalable by an
//! approximate triangle count, so tests and benchmarks need no download.

mod atrium;
mod chess;
mod forest;
mod hairball;
mod plant;
pub mod shapes;

use super::Scene;
use crate::error::{Error, Result};

/// A built-in scene: its name, default size and what it is like.
pub struct Builtin {
    /// The name a spec starts with (`chess`).
    pub name: &'static str,
    /// The approximate triangle count built when the spec gives none.
    pub default_triangles: usize,
    /// One line on what the scene is like (and the paper scene it stands in
    /// for, if any).
    pub about: &'static str,
    make: fn(usize) -> Scene,
}

/// Every built-in scene.
pub const BUILTIN: &[Builtin] = &[
    Builtin {
        name: "chess",
        default_triangles: 64_000,
        about: "regular: a board and 32 lathe-turned pieces, like the stackless paper's CHESS",
        make: chess::scene,
    },
    Builtin {
        name: "hairball",
        default_triangles: 100_000,
        about: "irregular: thin curved tubes tangled inside a sphere, like HAIRBALL",
        make: hairball::scene,
    },
    Builtin {
        name: "atrium",
        default_triangles: 260_000,
        about: "architectural interior: a two-storey arcaded court with columns, arches and drapes, like Crytek Sponza",
        make: atrium::scene,
    },
    Builtin {
        name: "forest",
        default_triangles: 1_000_000,
        about: "vegetation: grass blades and leafy branching trees on rolling ground, irregular",
        make: forest::scene,
    },
    Builtin {
        name: "plant",
        default_triangles: 1_000_000,
        about: "industrial: a grid of works with stacks, tanks, pipes and trusses, like Powerplant (plant:12M)",
        make: plant::scene,
    },
];

/// Smallest and largest sizes accepted, in triangles.
pub const SIZE_RANGE: (usize, usize) = (500, 200_000_000);

/// Whether `spec` (`chess`, `hairball:300000`) names a built-in scene.
pub fn is_builtin(spec: &str) -> bool {
    let base = spec.split(':').next().unwrap_or(spec);
    BUILTIN.iter().any(|b| b.name == base)
}

/// Builds `name` or `name:size`; size is an approximate triangle count and
/// may end in `k` or `M` (`hairball:3M`). [`Error::Invalid`] for an unknown
/// name, a size that is malformed or outside [`SIZE_RANGE`], or a malformed
/// [`super::memory::LIMIT_VARIABLE`]; [`Error::Limit`] when the scene would
/// not fit in the memory available.
pub fn build(spec: &str) -> Result<Scene> {
    let (name, size) = match spec.split_once(':') {
        Some((n, s)) => (n, Some(parse_size(s)?)),
        None => (spec, None),
    };
    let b = BUILTIN
        .iter()
        .find(|b| b.name == name)
        .ok_or_else(|| Error::Invalid(format!("unknown built-in scene '{name}'")))?;
    let size = size.unwrap_or(b.default_triangles);
    if !(SIZE_RANGE.0..=SIZE_RANGE.1).contains(&size) {
        return Err(Error::Invalid(format!(
            "scene size {size} is outside {}..={} triangles",
            SIZE_RANGE.0, SIZE_RANGE.1
        )));
    }
    super::memory::check_fits(spec, size as u64, super::memory::available_bytes()?)?;
    let mut scene = (b.make)(size);
    scene.name = format!("{name}:{size}");
    for g in &mut scene.mesh.geometries {
        g.name.clone_from(&scene.name);
    }
    Ok(scene)
}

fn parse_size(s: &str) -> Result<usize> {
    let (digits, mul) = match s.as_bytes().last() {
        Some(b'k' | b'K') => (&s[..s.len() - 1], 1_000.0),
        Some(b'm' | b'M') => (&s[..s.len() - 1], 1_000_000.0),
        _ => (s, 1.0),
    };
    digits
        .parse::<f64>()
        .ok()
        .filter(|v| v.is_finite() && *v > 0.0)
        .map(|v| (v * mul).round() as usize)
        .ok_or_else(|| {
            Error::Invalid(format!(
                "bad scene size '{s}': expected a triangle count like 64000, 250k or 3M"
            ))
        })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sizes_parse() {
        assert_eq!(parse_size("64000").unwrap(), 64000);
        assert_eq!(parse_size("2.5k").unwrap(), 2500);
        assert_eq!(parse_size("3M").unwrap(), 3_000_000);
        assert!(parse_size("x").is_err());
        assert!(parse_size("-5").is_err());
        assert!(build("chess:10").is_err());
        assert!(build("nope").is_err());
    }

    #[test]
    fn default_sizes_are_near_their_targets_and_deterministic() {
        for b in BUILTIN {
            let s = build(b.name).unwrap();
            let n = s.mesh.triangle_count() as f64;
            let target = b.default_triangles as f64;
            assert!((n / target - 1.0).abs() < 0.1, "{}: {n} triangles", b.name);
            s.mesh.validate().unwrap();
            let again = build(b.name).unwrap();
            assert_eq!(s.mesh, again.mesh);
        }
    }

    #[test]
    fn sizes_scale() {
        for b in BUILTIN {
            for target in [5_000usize, 300_000] {
                let n = build(&format!("{}:{target}", b.name))
                    .unwrap()
                    .mesh
                    .triangle_count() as f64;
                assert!(
                    (n / target as f64 - 1.0).abs() < 0.15,
                    "{}:{target} gave {n}",
                    b.name
                );
            }
        }
    }
}
