//! Numeric extremes over the whole f32 range: tiny and huge triangles, ray
//! origins far from what they aim at, subnormal direction components. The
//! oracle is checked against exact rational arithmetic, and every structure
//! and traversal against the oracle.

use crate::common;

use num_bigint::BigInt;
use num_rational::BigRational;
use num_traits::{Signed, ToPrimitive, Zero};
use raytree::prelude::*;
use raytree::rng::Pcg32;
use raytree::structures::Built;
use std::sync::Arc;

/// The exact value of an f32.
fn exact(x: f32) -> BigRational {
    if x == 0.0 {
        return BigRational::zero();
    }
    let bits = x.to_bits();
    let exp = ((bits >> 23) & 0xff) as i32;
    let frac = (bits & 0x7f_ffff) as i64;
    let (m, e) = if exp == 0 {
        (frac, -149)
    } else {
        (frac | 1 << 23, exp - 150)
    };
    let m = BigInt::from(if x < 0.0 { -m } else { m });
    let two = BigInt::from(2);
    if e >= 0 {
        BigRational::from_integer(m * two.pow(e as u32))
    } else {
        BigRational::new(m, two.pow((-e) as u32))
    }
}

type V = [BigRational; 3];

fn ev(v: Vec3) -> V {
    [exact(v.x), exact(v.y), exact(v.z)]
}

fn sub(a: &V, b: &V) -> V {
    [&a[0] - &b[0], &a[1] - &b[1], &a[2] - &b[2]]
}

fn cross(a: &V, b: &V) -> V {
    [
        &a[1] * &b[2] - &a[2] * &b[1],
        &a[2] * &b[0] - &a[0] * &b[2],
        &a[0] * &b[1] - &a[1] * &b[0],
    ]
}

fn dot(a: &V, b: &V) -> BigRational {
    &a[0] * &b[0] + &a[1] * &b[1] + &a[2] * &b[2]
}

/// The exact answer of the (edge-inclusive, two-sided) ray-triangle test,
/// or `None` when the ray passes so close to an edge, or meets the plane so
/// close to `tmin` or `tmax`, that f32 arithmetic may decide either way.
fn exact_hit(tri: &Triangle, ray: &Ray) -> Option<Option<(f64, f64, f64)>> {
    let (o, d) = (ray.origin(), ray.direction());
    let (a, b, c, eo, ed) = (ev(tri.a), ev(tri.b), ev(tri.c), ev(o), ev(d));
    let edge = |p: &V, q: &V| dot(&sub(q, p), &cross(&ed, &sub(p, &eo)));
    let w = [edge(&b, &c), edge(&c, &a), edge(&a, &b)];
    // Relative margins: each edge function against the rounding of the
    // path that decides it: f32 (about 2⁻²³ of the terms) for triangles
    // large against their distance, double-double (about 2⁻¹⁰⁰) for
    // triangles smaller than 2⁻²⁰ of it (see `Triangle::intersect`).
    let norm = |p: Vec3, q: Vec3| (q.as_dvec3() - p.as_dvec3()).abs().element_sum();
    let size = norm(tri.a, tri.b).max(norm(tri.a, tri.c));
    let far = norm(o, tri.a);
    let relative = if size < far * 2f64.powi(-24) {
        1e-29
    } else {
        4e-6
    };
    let scale = |p: Vec3, q: Vec3| {
        relative * norm(p, q).max(1e-300) * norm(Vec3::ZERO, d) * norm(o, p).max(1e-300)
    };
    let scales = [
        scale(tri.b, tri.c),
        scale(tri.c, tri.a),
        scale(tri.a, tri.b),
    ];
    let ambiguous_edge = w
        .iter()
        .zip(scales)
        .any(|(e, s)| e.abs().to_f64().unwrap() < s);
    let pos = w.iter().any(|e| e.is_positive());
    let neg = w.iter().any(|e| e.is_negative());
    let sum = &w[0] + &w[1] + &w[2];
    if ambiguous_edge {
        return None;
    }
    if (pos && neg) || sum.is_zero() {
        return Some(None);
    }
    let n = cross(&sub(&b, &a), &sub(&c, &a));
    let t = dot(&n, &sub(&a, &eo)) / dot(&n, &ed);
    let tf = t.to_f64().unwrap();
    let near = |bound: f32| {
        bound.is_finite() && (tf - bound as f64).abs() <= 1e-5 * tf.abs().max(bound.abs() as f64)
    };
    if near(ray.tmin) || near(ray.tmax) {
        return None;
    }
    if t < exact(ray.tmin) || t > exact(ray.tmax) || tf.abs() > f32::MAX as f64 {
        return Some(None);
    }
    let u = (&w[1] / &sum).to_f64().unwrap();
    let v = (&w[2] / &sum).to_f64().unwrap();
    Some(Some((tf, u, v)))
}

/// A random triangle of size `size` around `center`.
fn triangle(rng: &mut Pcg32, center: Vec3, size: f32) -> Triangle {
    loop {
        let mut p = || {
            center
                + Vec3::new(
                    rng.range(-1.0, 1.0),
                    rng.range(-1.0, 1.0),
                    rng.range(-1.0, 1.0),
                ) * size
        };
        let t = Triangle::new(p(), p(), p());
        if !t.is_degenerate() {
            return t;
        }
    }
}

/// Rays at a triangle from `distance` away: aimed at a point of it
/// (rounded by f32), axis-parallel through a point of it (exact), and in
/// random directions.
fn rays_at(rng: &mut Pcg32, tri: &Triangle, distance: f32) -> Vec<Ray> {
    let mut out = Vec::new();
    for i in 0..24 {
        let p = common::point_on(tri, rng);
        let ray = match i % 3 {
            0 => {
                let o = p + common::unit(rng) * distance;
                Ray::infinite(o, p - o)
            }
            1 => {
                let axis = rng.below(3) as usize;
                let mut o = p;
                o[axis] += distance;
                let mut d = Vec3::ZERO;
                d[axis] = -rng.range(0.5, 2.0);
                Ray::infinite(o, d)
            }
            _ => Ray::infinite(p + common::unit(rng) * distance, common::unit(rng)),
        };
        if ray.is_valid() {
            out.push(ray);
        }
    }
    out
}

/// Triangle sizes and origin distances from subnormal to near overflow,
/// with distances up to 1e24 times the size (the double-double path
/// decides edge functions to about 2⁻¹⁰⁰ of their terms; a triangle
/// smaller than about 1e-29 of its distance is beyond it).
fn magnitudes() -> Vec<(f32, f32)> {
    let mut v = Vec::new();
    for size in [
        1e-44f32, 1e-40, 1e-38, 1e-30, 1e-20, 1e-5, 1.0, 1e5, 1e20, 1e30, 1e36,
    ] {
        for factor in [2.0f64, 1e3, 1e9, 1e12, 1e20, 1e24] {
            let distance = size as f64 * factor;
            if distance < 2e37 {
                v.push((size, distance as f32));
            }
        }
    }
    v
}

#[test]
fn the_triangle_test_agrees_with_exact_arithmetic_at_every_magnitude() {
    let mut rng = Pcg32::new(20, 1);
    let (mut checked, mut hits, mut skipped) = (0, 0, 0);
    for (size, distance) in magnitudes() {
        for _ in 0..8 {
            let center = Vec3::new(
                rng.range(-1.0, 1.0),
                rng.range(-1.0, 1.0),
                rng.range(-1.0, 1.0),
            ) * size
                * 4.0;
            let tri = triangle(&mut rng, center, size);
            for ray in rays_at(&mut rng, &tri, distance) {
                let got = tri.intersect(&ray, ray.tmin, ray.tmax);
                if let Some((t, u, v)) = got {
                    assert!(
                        t.is_finite() && u.is_finite() && v.is_finite(),
                        "{tri:?} {ray:?}: {got:?}"
                    );
                }
                let Some(want) = exact_hit(&tri, &ray) else {
                    skipped += 1;
                    continue;
                };
                checked += 1;
                match (got, want) {
                    (None, None) => {}
                    (Some((t, u, v)), Some((et, eu, ev))) => {
                        hits += 1;
                        assert!(
                            // f32's own resolution: a relative 1e-5, or one subnormal step.
                            (t as f64 - et).abs() <= 1e-5 * et.abs() + 1.5e-45,
                            "size {size:e} distance {distance:e}: t {t} exact {et}"
                        );
                        // f32 shearing rounds by about 2⁻²³ of the distance.
                        let tol = 1e-4 + 2f64.powi(-20) * distance as f64 / size as f64;
                        assert!(
                            (u as f64 - eu).abs() <= tol && (v as f64 - ev).abs() <= tol,
                            "size {size:e} distance {distance:e}: u, v {u} {v} exact {eu} {ev}"
                        );
                    }
                    _ => panic!(
                        "size {size:e} distance {distance:e}: {tri:?} {ray:?}: got {got:?}, exact {want:?}"
                    ),
                }
            }
        }
    }
    // The sweep really tests hits and decides nearly every ray.
    assert!(hits > 1000, "{hits} hits of {checked}");
    assert!(skipped * 10 < checked, "{skipped} skipped of {checked}");
}

/// Item 1: a right triangle with legs of 1e-20 at the origin, hit from
/// above, and the same at every smaller size down to subnormal legs.
#[test]
fn tiny_triangles_are_hit_with_finite_exact_values() {
    for leg in [1e-20f32, 1e-25, 1e-30, 1e-36, 1e-40, 1e-43] {
        let tri = Triangle::new(
            Vec3::ZERO,
            Vec3::new(leg, 0.0, 0.0),
            Vec3::new(0.0, leg, 0.0),
        );
        assert!(!tri.is_degenerate(), "{leg:e}");
        let (x, y) = (leg / 4.0, leg / 4.0);
        let ray = Ray::infinite(Vec3::new(x, y, 1.0), Vec3::new(0.0, 0.0, -2.0));
        let (t, u, v) = tri.intersect(&ray, 0.0, f32::INFINITY).expect("a hit");
        assert_eq!(t, 0.5, "{leg:e}");
        // Barycentrics of the f32 values actually stored.
        let (eu, ev) = (x as f64 / leg as f64, y as f64 / leg as f64);
        assert!(
            (u as f64 - eu).abs() < 1e-6 && (v as f64 - ev).abs() < 1e-6,
            "{leg:e}: {u} {v}"
        );
        // Through the structures too.
        let tris: Arc<[Triangle]> = vec![tri].into();
        let oracle = BruteForce::new(tris.clone());
        let hit = oracle
            .closest_hit(&ray, &mut NoStats)
            .expect("the oracle hits");
        assert_eq!((hit.t, hit.prim), (0.5, 0));
        let bvh = Bvh::build(&tris, &BuildOptions::new(Builder::Sah));
        let rays = [ray];
        common::every_configuration_agrees(&bvh, &tris, &oracle, &rays)
            .unwrap_or_else(|e| panic!("{leg:e} {e}"));
    }
    // The case: the ray crosses at (1/4, 1/4) of the legs.
    let tri = Triangle::new(
        Vec3::ZERO,
        Vec3::new(1e-20, 0.0, 0.0),
        Vec3::new(0.0, 1e-20, 0.0),
    );
    let ray = Ray::infinite(Vec3::new(2.5e-21, 2.5e-21, 1.0), Vec3::new(0.0, 0.0, -2.0));
    let (t, u, v) = tri.intersect(&ray, 0.0, f32::INFINITY).unwrap();
    assert_eq!(t, 0.5);
    assert!(
        (u - 0.25).abs() < 1e-6 && (v - 0.25).abs() < 1e-6,
        "{u} {v}"
    );
}

/// Item 2: a triangle about 1.2e4 across near the origin and 2000 rays from
/// 1e20 to 1e22 away passing at about 0.6 of their distance from it: the
/// oracle and every structure report no hit.
#[test]
fn far_origins_make_no_false_hits() {
    let tris: Arc<[Triangle]> = vec![Triangle::new(
        Vec3::new(-6000.0, -3000.0, 100.0),
        Vec3::new(6000.0, -2500.0, -200.0),
        Vec3::new(500.0, 6000.0, 50.0),
    )]
    .into();
    let oracle = BruteForce::new(tris.clone());
    let mut rng = Pcg32::new(2, 2);
    let mut rays = Vec::new();
    for _ in 0..2000 {
        let distance = 10f32.powf(rng.range(20.0, 22.0));
        let o = common::unit(&mut rng) * distance;
        // Aimed at a point about 0.6 · distance off the triangle.
        let off = common::unit(&mut rng) * distance * 0.6;
        let ray = Ray::infinite(o, off - o);
        assert!(ray.is_valid());
        assert_eq!(exact_hit(&tris[0], &ray), Some(None));
        assert_eq!(oracle.closest_hit(&ray, &mut NoStats), None, "{ray:?}");
        rays.push(ray);
    }
    // And rays from as far that do cross it (axis-parallel, exact) hit it.
    let mut crossing = Vec::new();
    for _ in 0..200 {
        let p = common::point_on(&tris[0], &mut rng);
        let z = 10f32.powf(rng.range(20.0, 22.0));
        let ray = Ray::infinite(Vec3::new(p.x, p.y, z), -Vec3::Z);
        if let Some(Some((t, ..))) = exact_hit(&tris[0], &ray) {
            let hit = oracle
                .closest_hit(&ray, &mut NoStats)
                .expect("a crossing is a hit");
            assert!((hit.t as f64 - t).abs() <= 1e-6 * t);
            crossing.push(ray);
        }
    }
    assert!(crossing.len() > 150);
    rays.extend(crossing);
    let bvh = Bvh::build(&tris, &BuildOptions::new(Builder::Sah));
    common::every_configuration_agrees(&bvh, &tris, &oracle, &rays).unwrap();
}

/// A closed mesh (an octahedron split into a fan per face, so that edges
/// are shared) scaled to `size` around `center`.
fn closed_mesh(center: Vec3, size: f32) -> Vec<Triangle> {
    let p = [Vec3::X, -Vec3::X, Vec3::Y, -Vec3::Y, Vec3::Z, -Vec3::Z].map(|v| center + v * size);
    let mut tris = Vec::new();
    for &(i, j, k) in &[
        (0, 2, 4),
        (2, 1, 4),
        (1, 3, 4),
        (3, 0, 4),
        (2, 0, 5),
        (1, 2, 5),
        (3, 1, 5),
        (0, 3, 5),
    ] {
        let (a, b, c) = (p[i], p[j], p[k]);
        let m = (a + b + c) / 3.0;
        tris.extend([
            Triangle::new(a, b, m),
            Triangle::new(b, c, m),
            Triangle::new(c, a, m),
        ]);
    }
    tris
}

/// The kind: every structure and traversal agrees with the oracle on
/// scenes from subnormal to near-overflow sizes, seen from near and far,
/// and rays from outside aimed into the closed mesh never pass through it.
#[test]
fn every_structure_agrees_with_the_oracle_at_every_magnitude() {
    let mut rng = Pcg32::new(26, 3);
    for (size, distance) in magnitudes() {
        if distance > size * 1e12 {
            continue; // Such rays never reach the mesh: covered above.
        }
        let center = Vec3::new(0.3, -0.2, 0.1) * size;
        let mut tris = closed_mesh(center, size);
        for _ in 0..8 {
            let c = center + common::unit(&mut rng) * size * 2.0;
            tris.push(triangle(&mut rng, c, size * 0.5));
        }
        let tris: Arc<[Triangle]> = tris.into();
        let oracle = BruteForce::new(tris.clone());
        let mut rays = Vec::new();
        for k in 0..24 {
            let pick = rng.below(tris.len() as u32) as usize;
            rays.extend(rays_at(&mut rng, &tris[pick], distance));
            // Into the closed mesh: axis-parallel through its center's
            // neighbourhood, which it must stop.
            let axis = k % 3;
            let mut o = center + common::unit(&mut rng) * size * 0.3;
            o[axis] = center[axis] + distance.max(size * 2.0);
            let mut d = Vec3::ZERO;
            d[axis] = -1.0;
            let ray = Ray::infinite(o, d);
            assert!(
                oracle.any_hit(&ray, &mut NoStats).is_some(),
                "size {size:e}: a ray slipped through the closed mesh: {ray:?}"
            );
            rays.push(ray);
        }
        for builder in Builder::ALL {
            let bvh = Bvh::build(&tris, &BuildOptions::new(builder).with_max_leaf_size(4));
            assert!(bvh.validate(&tris).is_ok());
            common::every_configuration_agrees(&bvh, &tris, &oracle, &rays).unwrap_or_else(|e| {
                panic!(
                    "size {size:e} distance {distance:e} {}: {e}",
                    builder.name()
                )
            });
        }
    }
}

/// A plane just behind the origin, met at a distance so small against a
/// long direction that the f32 products of `T = t·det` underflow to zero
/// (the sign that says "behind" lost): a miss, for the scalar test, the
/// four-lane leaf blocks and every structure; and a triangle as far in
/// front is still hit there, at a `t` of positive sign.
#[test]
fn planes_behind_the_origin_are_missed_where_t_underflows() {
    let p2 = |e: i32| 2f32.powi(e);
    for e in [28, 30] {
        // Relative to the origin: a = (x, 0, 0), b = (x, s, 0), c = (x, 0, s),
        // with x = -s behind the origin and x = +s in front of it.
        let s = p2(-e);
        let o = Vec3::new(s, 0.0, 2.0 * s);
        let at = |x: f32| {
            Triangle::new(
                o + Vec3::new(x, 0.0, 0.0),
                o + Vec3::new(x, s, 0.0),
                o + Vec3::new(x, 0.0, s),
            )
        };
        let (behind, front) = (at(-s), at(s));
        for k in [64, 80, 100, 120] {
            let ray = Ray::infinite(o + Vec3::new(0.0, 0.25 * s, 0.25 * s), Vec3::X * p2(k));
            assert_eq!(exact_hit(&behind, &ray), Some(None), "2^-{e}, 2^{k}");
            assert_eq!(
                behind.intersect(&ray, ray.tmin, ray.tmax),
                None,
                "2^-{e}, 2^{k}"
            );
            let (t, _, _) = front.intersect(&ray, ray.tmin, ray.tmax).expect("in front");
            // (Where the exact t is below half the least subnormal, +0.)
            assert!(t >= 0.0 && t.is_sign_positive(), "2^-{e}, 2^{k}: t = {t:e}");
            for tris in [vec![behind], vec![behind, front, behind, at(-2.0 * s)]] {
                let tris: Arc<[Triangle]> = tris.into();
                let oracle = BruteForce::new(tris.clone());
                let want = oracle.closest_hit(&ray, &mut NoStats);
                assert_eq!(want.is_some(), tris.len() > 1, "2^-{e}, 2^{k}: {want:?}");
                let bvh = Bvh::build(&tris, &BuildOptions::new(Builder::Sah));
                common::every_configuration_agrees(&bvh, &tris, &oracle, &[ray])
                    .unwrap_or_else(|err| panic!("2^-{e}, 2^{k}: {err}"));
            }
        }
    }
}

/// Rays that are not valid (NaN, infinite, zero or out-of-range parts, a
/// negative `tmin`, also one set after `Ray::new`) are answered with a miss
/// by every structure after visiting at most the root, on a scene and on a
/// one-triangle tree whose root is a leaf (the wide layouts then test no
/// box before the triangle).
#[test]
fn invalid_rays_are_misses_in_constant_time() {
    let scene = Scene::from_spec("chess:2000").unwrap();
    let one: Arc<[Triangle]> = Arc::from(vec![Triangle::new(
        Vec3::new(-1.0, 0.0, 0.0),
        Vec3::new(-1.0, 1.0, 0.0),
        Vec3::new(-1.0, 0.0, 1.0),
    )]);
    // Nodes and triangles tested by both queries together: at most the
    // root, or on the one-triangle tree the root leaf and its triangle
    // (the wide layouts test no box before a root leaf).
    for (tris, c, most) in [
        (scene.triangles.clone(), scene.mesh.bounds().center(), 2),
        (one, Vec3::new(0.0, 0.25, 0.25), 4),
    ] {
        check_invalid_rays(tris, c, most);
    }
}

fn check_invalid_rays(tris: Arc<[Triangle]>, c: Vec3, most: u64) {
    let bvh = Bvh::build(&tris, &BuildOptions::new(Builder::Sah));
    let made_negative = |tmin: f32| {
        // The triangle lies behind the origin: a negative tmin would reach it.
        let mut r = Ray::infinite(c, Vec3::X);
        r.tmin = tmin;
        r
    };
    let bad = [
        Ray::infinite(Vec3::NAN, Vec3::X),
        Ray::infinite(c, Vec3::new(f32::NAN, 1.0, 0.0)),
        Ray::infinite(c, Vec3::new(0.0, f32::INFINITY, 0.0)),
        Ray::infinite(c, Vec3::ZERO),
        Ray::infinite(c, Vec3::splat(1e-31)),
        Ray::infinite(Vec3::new(1e38, c.y, c.z), -Vec3::X),
        Ray::new(c, Vec3::X, f32::NAN, 1.0),
        Ray::new(c, -Vec3::X, -1.0, 10.0),
        made_negative(-2.0),
        made_negative(f32::NAN),
    ];
    for (s, t) in common::configurations() {
        let (built, _) = Built::new(s, t, &bvh, tris.clone()).unwrap();
        for ray in &bad {
            assert!(!ray.is_valid(), "{ray:?}");
            let (closest, any, nodes) = built.with(Probe(*ray));
            assert_eq!(
                (closest, any),
                (None, None),
                "{}/{}: {ray:?}",
                s.name(),
                t.name()
            );
            assert!(
                nodes <= most,
                "{}/{}: {nodes} nodes for {ray:?}",
                s.name(),
                t.name()
            );
        }
    }
}

struct Probe(Ray);

impl raytree::structures::WithAccel for Probe {
    type Output = (Option<Hit>, Option<Hit>, u64);
    fn run<A: Accel>(self, a: &A) -> Self::Output {
        let mut c = Counters::default();
        let closest = a.closest_hit(&self.0, &mut c);
        let any = a.any_hit(&self.0, &mut c);
        (closest, any, c.nodes + c.triangles)
    }
}
