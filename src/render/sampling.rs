//! Directions for the integrators.

use crate::geometry::{Hit, Ray};
use crate::rng::Pcg32;
use crate::scene::{Projection, Scene};
use glam::{Vec3, Vec4};

/// A cosine-weighted direction about the unit normal `n` (Malley's method:
/// a uniform disk point lifted to the hemisphere).
pub fn cosine_hemisphere(n: Vec3, rng: &mut Pcg32) -> Vec3 {
    Frame::any(n).cosine(rng)
}

/// An orthonormal basis `(t, b, n)` about a unit normal `n`, made once per
/// hit and shared by its occlusion rays (the directions are those of
/// [`cosine_hemisphere`] and of the stackless paper's tracer, bit for bit).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Frame {
    t: Vec3,
    b: Vec3,
    n: Vec3,
}

impl Frame {
    /// The basis of [`cosine_hemisphere`]: glam's `any_orthonormal_pair`.
    pub fn any(n: Vec3) -> Frame {
        let (t, b) = n.any_orthonormal_pair();
        Frame { t, b, n }
    }

    /// The stackless paper tracer's basis (Barringer & Akenine-Möller 2013,
    /// supplemental `Tracer::sampleAO`): `t = normalize(a × n)`,
    /// `b = n × t`, `a` = +Y when `|n.x| > 0.1` and +X otherwise.
    pub fn paper(n: Vec3) -> Frame {
        let a = if n.x.abs() > 0.1 { Vec3::Y } else { Vec3::X };
        let t = a.cross(n).normalize();
        let b = n.cross(t);
        Frame { t, b, n }
    }

    /// [`cosine_hemisphere`] in this basis, drawing two numbers.
    #[inline]
    pub fn cosine(&self, rng: &mut Pcg32) -> Vec3 {
        let r = rng.next_f32().sqrt();
        let phi = std::f32::consts::TAU * rng.next_f32();
        let (x, y) = (r * phi.cos(), r * phi.sin());
        let z = (1.0 - r * r).max(0.0).sqrt();
        (self.t * x + self.b * y + self.n * z).normalize()
    }

    /// A cosine-weighted direction from the sample (`u`, `v`) in `[0,1)²`
    /// as the stackless paper's tracer maps it: `r² = v`, `φ = 2π·u`,
    /// `d = t·r·cos φ + b·r·sin φ + n·√(1−r²)`, normalized.
    /// The one-sample form, kept as the reference the four-lane form is
    /// tested against.
    #[cfg(test)]
    pub fn cosine_paper(&self, u: f32, v: f32) -> Vec3 {
        let phi = std::f32::consts::TAU * u;
        let (sin, cos) = sin_cos4(Vec4::splat(phi));
        let r = v.sqrt();
        (self.t * (cos.x * r) + self.b * (sin.x * r) + self.n * (1.0 - v).max(0.0).sqrt())
            .normalize()
    }

    /// Four cosine-weighted directions from the samples (`u[l]`, `v[l]`)
    /// in `[0,1)²`, as the stackless paper's tracer maps a sample: `r² = v`,
    /// `φ = 2π·u`, `d = t·r·cos φ + b·r·sin φ + n·√(1−r²)`, normalized. Each
    /// lane computes the f32 operations of that formula in the order the
    /// one-sample form did (and a test checks it still does), so every
    /// direction is the one-sample form's bit for bit. Everything runs in
    /// four-lane vectors, the sines and cosines too ([`sin_cos4`]: within
    /// 2⁻²³ of the exact values, where the original called `sinf`/`cosf`).
    /// Returned by axis: the directions' x, y and z lanes, as
    /// [`crate::geometry::Ray::new4_lanes`] takes them.
    #[inline]
    pub fn cosine_paper4_lanes(&self, u: Vec4, v: Vec4) -> [Vec4; 3] {
        let (sin, cos) = sin_cos4(Vec4::splat(std::f32::consts::TAU) * u);
        let r = v.sqrt();
        let (cr, sr) = (cos * r, sin * r);
        let z = (Vec4::ONE - v).max(Vec4::ZERO).sqrt();
        let axis = |a: usize| {
            Vec4::splat(self.t[a]) * cr + Vec4::splat(self.b[a]) * sr + Vec4::splat(self.n[a]) * z
        };
        let (x, y, z) = (axis(0), axis(1), axis(2));
        // glam's `normalize`: times 1 / sqrt(x·x + y·y + z·z), in that order.
        let recip = Vec4::ONE / (x * x + y * y + z * z).sqrt();
        [x * recip, y * recip, z * recip]
    }
}

/// The sines and cosines of four angles in `[0, 2π]` (radians), each within
/// 2⁻²³ of the exact value (tested against f64).
///
/// The method of Cephes' `sinf`/`cosf` (Moshier), in the form of Agner Fog's
/// vector class library: the nearest multiple `q` of π/2 is taken off in
/// three parts (Cody and Waite), so that `|x| ≤ π/4` is exact to f32
/// precision, and minimax polynomials of degree 7 (sine) and 8 (cosine) in
/// `x` give both functions; `q`'s last two bits choose which is which and
/// their signs. Written out here rather than taken from a SIMD crate
/// because every operation is a separate f32 multiply or add: the
/// directions are the same bit for bit on every platform and with any
/// compile flags (a crate that fuses multiply-adds where the target has
/// FMA would change them under `target-cpu=native`). Against libm's
/// `sinf`/`cosf` one lane at a time, this took the paper render's time on
/// battlefield.obj from 5.77 to 5.52 s (one thread).
// The constants as published; each rounds to the intended f32.
#[allow(clippy::excessive_precision)]
#[inline(always)]
pub fn sin_cos4(x: Vec4) -> (Vec4, Vec4) {
    debug_assert!(x.cmpge(Vec4::ZERO).all() && x.cmple(Vec4::splat(std::f32::consts::TAU)).all());
    // π/2 in three parts; the first two have few enough bits that their
    // products with q (at most 4 here) are exact.
    const DP1: f32 = 0.785_156_25 * 2.0;
    const DP2: f32 = 2.418_756_484_985_351_562_5e-4 * 2.0;
    const DP3: f32 = 3.774_894_977_445_941_08e-8 * 2.0;
    let q = (x * std::f32::consts::FRAC_2_PI).round();
    let r = ((x - q * DP1) - q * DP2) - q * DP3;
    let r2 = r * r;
    let s = ((Vec4::splat(-1.951_529_589_1e-4) * r2 + Vec4::splat(8.332_160_873_6e-3)) * r2
        + Vec4::splat(-1.666_665_461_1e-1))
        * (r2 * r)
        + r;
    let c = ((Vec4::splat(2.443_315_711_809_948e-5) * r2 + Vec4::splat(-1.388_731_625_493_765e-3))
        * r2
        + Vec4::splat(4.166_664_568_298_827e-2))
        * (r2 * r2)
        + (Vec4::ONE - Vec4::splat(0.5) * r2);
    // q is 0 to 4 (4 is 0 again). Odd quadrants swap the two; sin is
    // negative in quadrants 2 and 3, cos in 1 and 2.
    let (q1, q2, q3) = (
        q.cmpeq(Vec4::ONE),
        q.cmpeq(Vec4::splat(2.0)),
        q.cmpeq(Vec4::splat(3.0)),
    );
    let swap = q1 | q3;
    let sin = Vec4::select(swap, c, s);
    let cos = Vec4::select(swap, s, c);
    let (neg_sin, neg_cos) = (q2 | q3, q1 | q2);
    (
        Vec4::select(neg_sin, -sin, sin),
        Vec4::select(neg_cos, -cos, cos),
    )
}

/// How a pixel's eye rays are placed in it, and a hit's AO directions
/// spread over the hemisphere.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Sampling {
    /// Each sample drawn uniformly on its own (the default render's).
    #[default]
    Independent,
    /// The stackless paper's tracer (Section 4; supplemental `main.cpp` and
    /// `Tracer::sampleAO`): `n = k²` samples on a k×k grid, one jittered
    /// sample per cell, sample `s` in column `s mod k` and row `s / k`. For
    /// AO directions the grid is over (φ/2π, r²). A count that is not a
    /// square falls back to independent samples.
    Stratified,
}

impl crate::names::Named for Sampling {
    const WHAT: &'static str = "sampling";
    const TABLE: &'static [(Self, &'static str, &'static str)] = &[
        (
            Sampling::Independent,
            "independent",
            "each sample drawn uniformly on its own",
        ),
        (
            Sampling::Stratified,
            "stratified",
            "one jittered sample per cell of a k×k grid, as the stackless paper's tracer",
        ),
    ];
}

crate::named_from_str!(Sampling);

impl Sampling {
    /// The side `k` of the grid `n` samples are stratified on, or `None`
    /// for independent samples (independent sampling, or `n` not a square).
    pub fn grid(self, n: u32) -> Option<u32> {
        if self == Sampling::Independent {
            return None;
        }
        // The root in f64 (exact for every u32 square, and faster than
        // `isqrt`, which this runs once per sample).
        let k = (n as f64).sqrt() as u32;
        (k.checked_mul(k) == Some(n) && k > 0).then_some(k)
    }

    /// Sample `s` of `n` in `[0,1)²`, drawing two numbers from `rng` (the
    /// first for `u`, the second for `v`).
    pub fn sample(self, s: u32, n: u32, rng: &mut Pcg32) -> (f32, f32) {
        let (a, b) = (rng.next_f32(), rng.next_f32());
        match self.grid(n) {
            None => (a, b),
            Some(k) => (stratum(s % k, k, a), stratum((s / k) % k, k, b)),
        }
    }

    /// Samples `first` to `first + 3` of `n` as four calls of
    /// [`Self::sample`] give them, bit for bit, drawing from `rng` in the
    /// same order; lanes at `n` or beyond are not drawn and hold zeros.
    #[inline]
    pub fn sample4(self, first: u32, n: u32, rng: &mut Pcg32) -> (Vec4, Vec4) {
        let (mut a, mut b) = ([0.0; 4], [0.0; 4]);
        for l in 0..(n.saturating_sub(first).min(4) as usize) {
            a[l] = rng.next_f32();
            b[l] = rng.next_f32();
        }
        let (a, b) = (Vec4::from_array(a), Vec4::from_array(b));
        match self.grid(n) {
            None => (a, b),
            Some(k) => {
                let s: [u32; 4] = std::array::from_fn(|l| first + l as u32);
                (
                    stratum4(s.map(|s| s % k), k, a),
                    stratum4(s.map(|s| (s / k) % k), k, b),
                )
            }
        }
    }
}

/// [`stratum`] of four lanes, the same operations lane by lane.
#[inline(always)]
fn stratum4(cell: [u32; 4], k: u32, xi: Vec4) -> Vec4 {
    // The f32 just below each lane's value (all positive here).
    let below = |x: Vec4| Vec4::from_array(x.to_array().map(|x| f32::from_bits(x.to_bits() - 1)));
    let top = Vec4::from_array(cell.map(|c| (c + 1) as f32));
    let v = Vec4::from_array(cell.map(|c| c as f32)) + xi;
    let v = Vec4::select(v.cmpge(top), below(top), v);
    let (u, edge) = if k.is_power_of_two() {
        // Dividing by a power of two is multiplying by its exact
        // reciprocal: the same bits, without the divisions.
        let r = Vec4::splat(1.0 / k as f32);
        (v * r, top * r)
    } else {
        let kf = Vec4::splat(k as f32);
        (v / kf, top / kf)
    };
    Vec4::select(u.cmpge(edge), below(edge), u)
}

/// `(cell + xi) / k`, kept below the cell's upper edge where rounding would
/// reach it, so that a sample always lies in its own cell.
fn stratum(cell: u32, k: u32, xi: f32) -> f32 {
    let top = (cell + 1) as f32;
    let mut v = cell as f32 + xi;
    if v >= top {
        v = f32::from_bits(top.to_bits() - 1);
    }
    let u = v / k as f32;
    let edge = top / k as f32;
    if u >= edge {
        f32::from_bits(edge.to_bits() - 1)
    } else {
        u
    }
}

/// The unit geometric normal at a hit, facing the incoming ray.
pub fn facing_normal(scene: &Scene, ray: &Ray, hit: &Hit) -> Vec3 {
    let n = scene.triangles[hit.prim as usize]
        .normal()
        .normalize_or_zero();
    if n.dot(ray.direction()) > 0.0 {
        -n
    } else {
        n
    }
}

/// A point just off the surface on the normal's side, so that rays leaving
/// it do not hit the surface they start on. The offset grows with the
/// coordinates' magnitude, which bounds the hit point's rounding.
pub fn offset_origin(p: Vec3, n: Vec3) -> Vec3 {
    let eps = 1e-4 + 4e-6 * p.abs().max_element();
    p + n * eps
}

/// The eye ray through pixel (`x`, `y`) of a `w`×`h` image jittered by
/// `rng`, through `camera` (the scene camera's [`Projection`] for the
/// image, [`image_projection`]).
pub fn eye_ray(
    camera: &Projection,
    x: usize,
    y: usize,
    w: usize,
    h: usize,
    rng: &mut Pcg32,
) -> Ray {
    let sx = (x as f32 + rng.next_f32()) / w as f32;
    let sy = (y as f32 + rng.next_f32()) / h as f32;
    camera.ray(sx, sy)
}

/// The scene camera's [`Projection`] for a `w`×`h` image.
pub fn image_projection(scene: &Scene, w: usize, h: usize) -> Projection {
    scene.camera.projection(w as f32 / h as f32)
}

/// Eye ray `sample` of `n` through pixel (`x`, `y`), placed by `sampling`,
/// over `[tmin, tmax]` (for [`Sampling::Independent`] over `[0, +inf)` the
/// same ray as [`eye_ray`]).
pub fn eye_ray_sampled(
    camera: &Projection,
    (x, y): (usize, usize),
    (w, h): (usize, usize),
    (sample, n): (u32, u32),
    sampling: Sampling,
    (tmin, tmax): (f32, f32),
    rng: &mut Pcg32,
) -> Ray {
    let (u, v) = sampling.sample(sample, n, rng);
    let sx = (x as f32 + u) / w as f32;
    let sy = (y as f32 + v) / h as f32;
    camera.ray_over(sx, sy, tmin, tmax)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn four_lane_sines_and_cosines_are_within_2_to_the_minus_23() {
        // Every 64th f32 in [0, 2π], and the ends and quadrant edges.
        let tau = std::f32::consts::TAU;
        let mut xs: Vec<f32> = (0..=(tau.to_bits() >> 6))
            .map(|k| f32::from_bits(k << 6))
            .collect();
        for k in 0..=4 {
            let e = k as f32 * std::f32::consts::FRAC_PI_2;
            xs.extend([
                e,
                f32::from_bits(e.to_bits() + 1),
                f32::from_bits(e.to_bits().max(1) - 1),
            ]);
        }
        xs.retain(|x| (0.0..=tau).contains(x));
        let mut worst = 0.0f64;
        for c in xs.chunks(4) {
            let mut lanes = [0.0; 4];
            lanes[..c.len()].copy_from_slice(c);
            let (s, co) = sin_cos4(Vec4::from_array(lanes));
            for (l, &x) in c.iter().enumerate() {
                let x64 = f64::from(x);
                worst = worst
                    .max((f64::from(s[l]) - x64.sin()).abs())
                    .max((f64::from(co[l]) - x64.cos()).abs());
            }
        }
        assert!(worst <= 2f64.powi(-23), "{worst:e}");
    }

    #[test]
    fn stratified_samples_fill_every_cell_once() {
        for n in [1u32, 4, 9, 16, 64] {
            let k = n.isqrt();
            for pixel in 0..200u64 {
                let mut seen = vec![0u32; n as usize];
                for s in 0..n {
                    let mut rng = Pcg32::new(pixel, s as u64);
                    let (u, v) = Sampling::Stratified.sample(s, n, &mut rng);
                    assert!((0.0..1.0).contains(&u) && (0.0..1.0).contains(&v));
                    let (cx, cy) = ((u * k as f32) as u32, (v * k as f32) as u32);
                    assert_eq!((cx, cy), (s % k, s / k), "n {n} sample {s}: {u} {v}");
                    seen[(cy * k + cx) as usize] += 1;
                }
                assert!(seen.iter().all(|&c| c == 1), "n {n}: {seen:?}");
            }
        }
        // Rounding never lifts a sample onto the next cell's edge.
        assert!(stratum(3, 4, 1.0 - 1.0 / (1 << 24) as f32) < 1.0);
        // Not a square: independent samples, the same numbers as unstratified.
        assert_eq!(Sampling::Stratified.grid(8), None);
        let mut a = Pcg32::new(1, 2);
        let mut b = Pcg32::new(1, 2);
        assert_eq!(
            Sampling::Stratified.sample(5, 8, &mut a),
            Sampling::Independent.sample(5, 8, &mut b)
        );
    }

    /// Four samples and four directions at once equal one at a time, bit
    /// for bit, drawing the same numbers: stratified grids of every size
    /// (and counts that are not squares), groups cut short at `n`, normals
    /// of every orientation.
    #[test]
    fn four_lane_samples_and_directions_equal_one_at_a_time() {
        let mut pick = Pcg32::new(8, 8);
        for case in 0..3000u64 {
            let n = [1u32, 3, 4, 9, 16, 25, 8, 64][case as usize % 8];
            let sampling = if case % 5 == 0 {
                Sampling::Independent
            } else {
                Sampling::Stratified
            };
            let normal = Vec3::new(
                pick.next_f32() - 0.5,
                pick.next_f32() - 0.5,
                pick.next_f32() - 0.5,
            )
            .normalize();
            let frame = Frame::paper(normal);
            let (mut four, mut one) = (Pcg32::new(case, 1), Pcg32::new(case, 1));
            for first in (0..n).step_by(4) {
                let (u, v) = sampling.sample4(first, n, &mut four);
                let d = frame.cosine_paper4_lanes(u, v).map(|a| a.to_array());
                for l in 0..(n - first).min(4) as usize {
                    let (u1, v1) = sampling.sample(first + l as u32, n, &mut one);
                    assert_eq!(
                        (u[l].to_bits(), v[l].to_bits()),
                        (u1.to_bits(), v1.to_bits())
                    );
                    let d1 = frame.cosine_paper(u1, v1);
                    assert_eq!(d.map(|a| a[l].to_bits()), d1.to_array().map(f32::to_bits));
                }
            }
            assert_eq!(four.next_u32(), one.next_u32(), "the same numbers drawn");
        }
        // The largest draw in every cell: the clamps below the cell's edge
        // lane by lane as in the scalar form.
        let xi = 1.0 - 1.0 / (1 << 24) as f32;
        for k in [3u32, 4, 7, 16] {
            let cells = [0, 1, k - 2, k - 1];
            let u = stratum4(cells, k, Vec4::splat(xi)).to_array();
            for l in 0..4 {
                assert_eq!(u[l].to_bits(), stratum(cells[l], k, xi).to_bits());
                assert!(u[l] < (cells[l] + 1) as f32 / k as f32);
            }
        }
    }

    #[test]
    fn paper_cosine_directions_are_in_the_hemisphere_with_cosine_mean() {
        let mut rng = Pcg32::new(5, 1);
        for n in [
            Vec3::X,
            Vec3::Y,
            -Vec3::Z,
            Vec3::new(0.05, -0.3, 0.9).normalize(),
        ] {
            let mut mean_cos = 0.0;
            for _ in 0..20000 {
                let d = Frame::paper(n).cosine_paper(rng.next_f32(), rng.next_f32());
                assert!((d.length() - 1.0).abs() < 1e-5);
                assert!(d.dot(n) >= -1e-6);
                mean_cos += d.dot(n) as f64;
            }
            assert!((mean_cos / 20000.0 - 2.0 / 3.0).abs() < 0.01, "{n}");
        }
    }

    #[test]
    fn cosine_directions_are_in_the_hemisphere_with_cosine_mean() {
        let mut rng = Pcg32::new(3, 3);
        let n = Vec3::new(0.3, -0.5, 0.8).normalize();
        let mut mean_cos = 0.0;
        for _ in 0..20000 {
            let d = cosine_hemisphere(n, &mut rng);
            assert!((d.length() - 1.0).abs() < 1e-5);
            assert!(d.dot(n) >= -1e-6);
            mean_cos += d.dot(n) as f64;
        }
        // E[cos] under a cosine-weighted density is 2/3.
        assert!((mean_cos / 20000.0 - 2.0 / 3.0).abs() < 0.01);
    }
}
