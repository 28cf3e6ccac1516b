//! Ambient occlusion, as the stackless paper's ray tracer renders it: N
//! jittered eye rays per pixel and, at each eye-ray hit, M cosine-weighted
//! occlusion rays of a fixed length, traced as any-hit queries. The paper's
//! "16 eye and 256 AO rays per pixel" is N = 16 and M = 16 (its tracer
//! shoots 4×4 AO rays at each of 4×4 eye-ray hits).

use super::sampling::{cosine_hemisphere, eye_ray, facing_normal, offset_origin};
use super::{Ctx, RaySink};
use crate::accel::Accel;
use crate::geometry::Ray;
use crate::rng::Pcg32;
use glam::Vec3;

#[derive(Clone, Debug, serde::Serialize)]
pub struct AoSettings {
    /// Eye rays per pixel.
    pub eye_rays: u32,
    /// Occlusion rays per eye-ray hit.
    pub ao_rays: u32,
    /// Length of the occlusion rays, in scene units.
    pub radius: f32,
    /// Value of a pixel sample whose eye ray misses the scene.
    pub background: f32,
    /// Whether each sample's AO is weighted by how squarely the surface
    /// faces the eye (`0.25 + 0.75·|cos θ|`, θ between the eye ray and the
    /// normal), so that a single convex object, which AO alone leaves flat,
    /// shows its shape. Off in the paper's settings.
    #[serde(default)]
    pub facing: bool,
}

impl AoSettings {
    /// The stackless paper's settings: 16 eye rays per pixel, 16 AO rays
    /// per eye-ray hit (256 AO rays per pixel).
    pub fn paper(radius: f32) -> Self {
        AoSettings {
            eye_rays: 16,
            ao_rays: 16,
            radius,
            background: 1.0,
            facing: false,
        }
    }

    /// Settings for a first look at a user's mesh: `radius`, 4 eye rays and
    /// 8 AO rays, a dark grey background (0.2) against which the silhouette
    /// stands out, and facing-ratio shading that shows the shape of convex
    /// parts.
    pub fn preview(radius: f32) -> Self {
        AoSettings {
            eye_rays: 4,
            ao_rays: 8,
            radius,
            background: 0.2,
            facing: true,
        }
    }

    /// The default radius: this fraction of the scene's diagonal (32 units
    /// on the paper's 500-unit chess board).
    pub const RADIUS_FRACTION: f32 = 0.045;
}

/// An eye ray's outcome: where occlusion rays start (the offset hit point
/// and the normal facing the eye), and the sample's random stream, which the
/// occlusion rays go on drawing from.
pub(super) struct EyeSample {
    pub hit: Option<(Vec3, Vec3)>,
    /// `|cos θ|` between the eye ray and the normal at the hit.
    pub facing: f32,
    pub rng: Pcg32,
}

/// Traces eye ray `sample` of pixel (`x`, `y`).
#[inline]
pub(super) fn eye_sample<A: Accel, S: RaySink>(
    accel: &A,
    ctx: &Ctx,
    x: usize,
    y: usize,
    sample: u32,
    stats: &mut S,
) -> EyeSample {
    let pixel = (y * ctx.width + x) as u64;
    let mut rng = Pcg32::new(pixel, sample as u64);
    let ray = eye_ray(ctx.scene, x, y, ctx.width, ctx.height, &mut rng);
    stats.ray();
    let mut facing = 0.0;
    let hit = accel.closest_hit(&ray, stats).map(|hit| {
        let n = facing_normal(ctx.scene, &ray, &hit);
        facing = n.dot(ray.direction().normalize()).abs();
        (offset_origin(ray.at(hit.t), n), n)
    });
    EyeSample { hit, facing, rng }
}

/// The sample's value: the unoccluded fraction of its AO rays, or the
/// background for a missed eye ray.
#[inline]
pub(super) fn ao_value<A: Accel, S: RaySink>(
    accel: &A,
    s: &AoSettings,
    e: &mut EyeSample,
    stats: &mut S,
) -> f32 {
    let Some((origin, n)) = e.hit else {
        return s.background;
    };
    let mut open = 0u32;
    for _ in 0..s.ao_rays {
        let d = cosine_hemisphere(n, &mut e.rng);
        stats.ray();
        if accel
            .any_hit(&Ray::new(origin, d, 0.0, s.radius), stats)
            .is_none()
        {
            open += 1;
        }
    }
    let ao = open as f32 / s.ao_rays.max(1) as f32;
    if s.facing {
        ao * (0.25 + 0.75 * e.facing)
    } else {
        ao
    }
}

pub(super) fn pixel<A: Accel, S: RaySink>(
    accel: &A,
    ctx: &Ctx,
    s: &AoSettings,
    x: usize,
    y: usize,
    stats: &mut S,
) -> f32 {
    let mut sum = 0.0;
    for sample in 0..s.eye_rays {
        let mut e = eye_sample(accel, ctx, x, y, sample, stats);
        sum += ao_value(accel, s, &mut e, stats);
    }
    sum / s.eye_rays.max(1) as f32
}
