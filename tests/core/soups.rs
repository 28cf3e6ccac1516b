//! Property tests over random triangle soups: every structure and every
//! traversal agrees with the brute-force oracle on closest and any hits.
//!
//! Soups are empty or up to 40 triangles, at scales from 1e-30 to 1e30, in
//! four kinds: random, coplanar, with degenerate triangles (a repeated
//! vertex, collinear vertices) and with overlapping copies. Rays are aimed
//! at points on triangles, exactly at vertices, along the axes, and at
//! random.

use crate::common;

use proptest::prelude::*;
use raytree::prelude::*;
use raytree::rng::Pcg32;
use raytree::structures::Built;
use std::sync::Arc;

#[derive(Clone, Copy, Debug)]
enum Kind {
    Random,
    Coplanar,
    Degenerate,
    Overlapping,
}

fn soup(n: usize, scale: f32, kind: Kind, seed: u64) -> Vec<Triangle> {
    let mut rng = Pcg32::new(seed, 1);
    let p = |rng: &mut Pcg32| {
        let v = Vec3::new(
            rng.range(-1.0, 1.0),
            rng.range(-1.0, 1.0),
            rng.range(-1.0, 1.0),
        ) * scale;
        if let Kind::Coplanar = kind {
            Vec3::new(v.x, v.y, 0.5 * scale)
        } else {
            v
        }
    };
    let mut tris: Vec<Triangle> = Vec::with_capacity(n);
    for i in 0..n {
        let (a, b, c) = (p(&mut rng), p(&mut rng), p(&mut rng));
        tris.push(match kind {
            Kind::Degenerate if i % 3 == 1 => Triangle::new(a, a, b),
            Kind::Degenerate if i % 3 == 2 => Triangle::new(a, (a + b) * 0.5, b),
            Kind::Overlapping if i % 2 == 1 => {
                let t = tris[i - 1];
                if i % 4 == 1 {
                    t
                } else {
                    // The same triangle nudged along its own plane.
                    let d = (t.b - t.a) * 0.25;
                    Triangle::new(t.a + d, t.b + d, t.c + d)
                }
            }
            _ => Triangle::new(a, b, c),
        });
    }
    tris
}

fn rays(tris: &[Triangle], scale: f32, seed: u64) -> Vec<Ray> {
    let mut rng = Pcg32::new(seed, 2);
    let mut out = Vec::new();
    for i in 0..120 {
        let origin = Vec3::new(
            rng.range(-3.0, 3.0),
            rng.range(-3.0, 3.0),
            rng.range(-3.0, 3.0),
        ) * scale;
        let target = if tris.is_empty() || i % 4 == 3 {
            Vec3::new(
                rng.range(-1.0, 1.0),
                rng.range(-1.0, 1.0),
                rng.range(-1.0, 1.0),
            ) * scale
        } else {
            let t = &tris[rng.below(tris.len() as u32) as usize];
            match i % 4 {
                0 => common::point_on(t, &mut rng),
                1 => [t.a, t.b, t.c][i % 3],
                _ => (t.a + t.b + t.c) / 3.0,
            }
        };
        let mut d = target - origin;
        if i % 10 == 5 {
            // Axis-parallel: keep one component.
            let k = i % 3;
            let mut axis = Vec3::ZERO;
            axis[k] = if d[k] == 0.0 { 1.0 } else { d[k] };
            d = axis;
        }
        if !(d.length_squared() > 0.0 && d.is_finite()) {
            continue;
        }
        out.push(Ray::new(origin, d, 0.0, f32::INFINITY));
    }
    out
}

fn check(tris: Vec<Triangle>, scale: f32, seed: u64) -> Result<(), TestCaseError> {
    let rays = rays(&tris, scale, seed);
    let tris: Arc<[Triangle]> = tris.into();
    let oracle = BruteForce::new(tris.clone());
    for (builder, opts) in common::build_variants() {
        for leaf in [1, 4] {
            let bvh = Bvh::build(&tris, &opts.clone().with_max_leaf_size(leaf));
            prop_assert!(bvh.validate(&tris).is_ok(), "{:?}", bvh.validate(&tris));
            for (s, t) in common::configurations() {
                let (built, _) = Built::new(s, t, &bvh, tris.clone())
                    .map_err(|e| TestCaseError::fail(format!("{} {}: {e}", s.name(), t.name())))?;
                let r = built.with(common::Agrees {
                    oracle: &oracle,
                    rays: &rays,
                });
                prop_assert!(
                    r.is_ok(),
                    "{} / {} / {} leaf {leaf}: {}",
                    s.name(),
                    t.name(),
                    builder,
                    r.unwrap_err()
                );
            }
        }
    }
    Ok(())
}

fn kind() -> impl Strategy<Value = Kind> {
    prop_oneof![
        Just(Kind::Random),
        Just(Kind::Coplanar),
        Just(Kind::Degenerate),
        Just(Kind::Overlapping)
    ]
}

fn scale() -> impl Strategy<Value = f32> {
    prop_oneof![Just(1e-30f32), Just(1e-3), Just(1.0), Just(1e3), Just(1e30)]
}

proptest! {
    #![proptest_config(ProptestConfig {
        cases: 256,
        failure_persistence: Some(Box::new(
            proptest::test_runner::FileFailurePersistence::Direct("tests/soups.proptest-regressions"),
        )),
        ..ProptestConfig::default()
    })]

    #[test]
    fn every_structure_agrees_with_the_oracle_on_soups(
        n in 0usize..40,
        scale in scale(),
        kind in kind(),
        seed in any::<u64>(),
    ) {
        check(soup(n, scale, kind, seed), scale, seed)?;
    }

    #[test]
    fn a_single_triangle_is_found_by_every_structure(
        scale in scale(),
        seed in any::<u64>(),
    ) {
        check(soup(1, scale, Kind::Random, seed), scale, seed)?;
    }
}
