//! Directions for the integrators.

use crate::geometry::{Hit, Ray};
use crate::rng::Pcg32;
use crate::scene::Scene;
use glam::Vec3;

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
    #[inline]
    pub fn cosine_paper(&self, u: f32, v: f32) -> Vec3 {
        let phi = std::f32::consts::TAU * u;
        let r = v.sqrt();
        (self.t * (phi.cos() * r) + self.b * (phi.sin() * r) + self.n * (1.0 - v).max(0.0).sqrt())
            .normalize()
    }
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
        let k = n.isqrt();
        (k * k == n && k > 0).then_some(k)
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

/// The eye ray through pixel (`x`, `y`) jittered by `rng`.
pub fn eye_ray(scene: &Scene, x: usize, y: usize, w: usize, h: usize, rng: &mut Pcg32) -> Ray {
    let sx = (x as f32 + rng.next_f32()) / w as f32;
    let sy = (y as f32 + rng.next_f32()) / h as f32;
    scene.camera.ray(sx, sy, w as f32 / h as f32)
}

/// Eye ray `sample` of `n` through pixel (`x`, `y`), placed by `sampling`
/// (for [`Sampling::Independent`] the same ray as [`eye_ray`]).
pub fn eye_ray_sampled(
    scene: &Scene,
    (x, y): (usize, usize),
    (w, h): (usize, usize),
    (sample, n): (u32, u32),
    sampling: Sampling,
    rng: &mut Pcg32,
) -> Ray {
    let (u, v) = sampling.sample(sample, n, rng);
    let sx = (x as f32 + u) / w as f32;
    let sy = (y as f32 + v) / h as f32;
    scene.camera.ray(sx, sy, w as f32 / h as f32)
}

#[cfg(test)]
mod tests {
    use super::*;

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
