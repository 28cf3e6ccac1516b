//! Directions for the integrators.

use crate::geometry::{Hit, Ray};
use crate::rng::Pcg32;
use crate::scene::Scene;
use glam::Vec3;

/// A cosine-weighted direction about the unit normal `n` (Malley's method:
/// a uniform disk point lifted to the hemisphere).
pub fn cosine_hemisphere(n: Vec3, rng: &mut Pcg32) -> Vec3 {
    let r = rng.next_f32().sqrt();
    let phi = std::f32::consts::TAU * rng.next_f32();
    let (x, y) = (r * phi.cos(), r * phi.sin());
    let z = (1.0 - r * r).max(0.0).sqrt();
    let (t, b) = n.any_orthonormal_pair();
    (t * x + b * y + n * z).normalize()
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

#[cfg(test)]
mod tests {
    use super::*;

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
