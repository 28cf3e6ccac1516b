//! Diffuse path tracing, the dual-split paper's workload: up to 5 bounces,
//! no Russian roulette, a constant sky and one albedo everywhere; every ray
//! is a closest-hit query.

use super::sampling::{cosine_hemisphere, eye_ray, facing_normal, offset_origin};
use super::{Ctx, RaySink};
use crate::geometry::Ray;
use crate::rng::Pcg32;
use crate::structures::Accel;

/// What a path-traced render traces; a pixel's value is the mean radiance
/// of its samples.
#[derive(Clone, Debug, serde::Serialize)]
pub struct PathSettings {
    /// Paths per pixel, each starting with a jittered eye ray.
    pub samples: u32,
    /// Diffuse bounces after the eye ray.
    pub bounces: u32,
    /// Reflectance of every surface, in [0, 1]: each bounce multiplies the
    /// path's throughput by it.
    pub albedo: f32,
    /// Radiance of the constant sky, reached by a ray that misses.
    pub sky: f32,
}

impl Default for PathSettings {
    /// The dual-split paper's: 1 sample per pixel, 5 bounces.
    fn default() -> Self {
        PathSettings {
            samples: 1,
            bounces: 5,
            albedo: 0.7,
            sky: 1.0,
        }
    }
}

pub(super) fn pixel<A: Accel, S: RaySink>(
    accel: &A,
    ctx: &Ctx,
    s: &PathSettings,
    x: usize,
    y: usize,
    stats: &mut S,
) -> f32 {
    let pixel = (y * ctx.width + x) as u64;
    let mut sum = 0.0;
    for sample in 0..s.samples {
        let mut rng = Pcg32::new(pixel, sample as u64);
        let mut ray = eye_ray(&ctx.camera, x, y, ctx.width, ctx.height, &mut rng);
        let mut throughput = 1.0;
        for _ in 0..=s.bounces {
            stats.ray();
            let Some(hit) = accel.closest_hit(&ray, stats) else {
                sum += throughput * s.sky;
                break;
            };
            // Cosine-weighted sampling of a Lambertian surface: the weight
            // is the albedo alone.
            throughput *= s.albedo;
            let n = facing_normal(ctx.scene, &ray, &hit);
            let origin = offset_origin(ray.at(hit.t), n);
            ray = Ray::infinite(origin, cosine_hemisphere(n, &mut rng));
        }
    }
    sum / s.samples.max(1) as f32
}
