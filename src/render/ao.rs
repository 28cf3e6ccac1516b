//! Ambient occlusion, as the stackless paper's ray tracer renders it: N
//! jittered eye rays per pixel and, at each eye-ray hit, M cosine-weighted
//! occlusion rays of a fixed length. The paper's "16 eye and 256 AO rays per
//! pixel" is N = 16 and M = 16 (its tracer shoots 4×4 AO rays at each of
//! 4×4 eye-ray hits).
//!
//! Two forms of the occlusion rays ([`AoQuery`]): the paper's tracer's
//! closest-hit queries from the hit point itself, and the any-hit queries
//! from an offset origin that the default render uses. Both give the same
//! occlusion for the same rays up to the few rays that start differently;
//! they differ in the traversal work, which is what the paper measured.

pub use super::sampling::Sampling;
use super::sampling::{eye_ray_sampled, facing_normal, offset_origin, Frame};
use super::{Ctx, RaySink};
use crate::geometry::Ray;
use crate::rng::Pcg32;
use crate::structures::Accel;
use glam::Vec3;

/// How occlusion rays are traced.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum AoQuery {
    /// Any-hit queries (the first hit found ends the ray) over `[0, radius]`
    /// from the hit point moved off the surface by `sampling::offset_origin`: the
    /// default render's form.
    #[default]
    Any,
    /// The stackless paper's tracer (Barringer & Akenine-Möller 2013,
    /// Section 4; supplemental `Tracer::sampleAO` and `Camera::generateRay`):
    /// closest-hit queries (the traversal narrows the interval to each hit
    /// it finds and goes on) over `[`[`PAPER_TMIN`]`, radius]` from the eye
    /// ray's hit point itself, `origin + t·direction` with a unit direction;
    /// eye rays likewise over `[`[`PAPER_TMIN`]`, `[`PAPER_EYE_TMAX`]`]`.
    Closest,
}

impl crate::names::Named for AoQuery {
    const WHAT: &'static str = "AO query";
    const TABLE: &'static [(Self, &'static str, &'static str)] = &[
        (
            AoQuery::Any,
            "any",
            "any-hit occlusion rays from the offset hit point",
        ),
        (
            AoQuery::Closest,
            "closest",
            "closest-hit rays limited to the radius, as the stackless paper's tracer",
        ),
    ];
}

crate::named_from_str!(AoQuery);

impl AoQuery {
    /// The form's name in reports.
    pub fn name(self) -> &'static str {
        match self {
            AoQuery::Any => "any-hit",
            AoQuery::Closest => "closest-hit",
        }
    }
}

/// The start of every ray's interval in the stackless paper's tracer, in
/// scene units (its rays have unit directions): `minT = 1e-3`.
pub const PAPER_TMIN: f32 = 1e-3;

/// The end of an eye ray's interval in the stackless paper's tracer, in
/// scene units: `maxT = 1e6`.
pub const PAPER_EYE_TMAX: f32 = 1e6;

/// What an AO render traces; a pixel's value is the mean over its eye rays
/// of the unoccluded fraction of their AO rays, or [`Self::background`] for
/// an eye ray that misses (see [`AoSettings::paper`]).
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
    /// How the occlusion rays are traced (and where they start).
    pub query: AoQuery,
    /// How the eye rays are placed in their pixel and the AO directions
    /// spread over the hemisphere.
    pub sampling: Sampling,
}

impl AoSettings {
    /// The stackless paper's settings (Section 4): 16 eye rays per pixel,
    /// 16 AO rays per eye-ray hit (256 AO rays per pixel), traced as its
    /// tracer did: closest-hit AO rays from the hit point
    /// ([`AoQuery::Closest`]), eye rays and AO directions on 4×4 grids
    /// ([`Sampling::Stratified`]).
    pub fn paper(radius: f32) -> Self {
        AoSettings {
            eye_rays: 16,
            ao_rays: 16,
            radius,
            background: 1.0,
            facing: false,
            query: AoQuery::Closest,
            sampling: Sampling::Stratified,
        }
    }

    /// The settings of the default render (before the paper's form existed):
    /// `eye_rays` and `ao_rays`, any-hit AO rays, independent samples.
    pub fn plain(eye_rays: u32, ao_rays: u32, radius: f32) -> Self {
        AoSettings {
            eye_rays,
            ao_rays,
            radius,
            background: 1.0,
            facing: false,
            query: AoQuery::Any,
            sampling: Sampling::Independent,
        }
    }

    /// The form of the rays in words, for reports: the query and the
    /// sampling actually used (a count that is not a square is sampled
    /// independently).
    pub fn form(&self) -> String {
        let grid = |n: u32| match self.sampling.grid(n) {
            Some(k) => format!("{k}×{k} stratified"),
            None => "independent".to_owned(),
        };
        format!(
            "{} AO rays, {} eye jitter, {} AO directions",
            self.query.name(),
            grid(self.eye_rays),
            grid(self.ao_rays)
        )
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
            query: AoQuery::Any,
            sampling: Sampling::Independent,
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
    /// `|cos θ|` between the eye ray and the normal at the hit (0 unless
    /// the settings shade by it, [`AoSettings::facing`]).
    pub facing: f32,
    pub rng: Pcg32,
}

/// Eye ray `sample` of pixel (`x`, `y`) of a `w`×`h` image in the form of
/// `s`, and the sample's random stream after drawing it.
pub(crate) fn eye_ray_of(
    camera: &crate::scene::Projection,
    s: &AoSettings,
    (x, y): (usize, usize),
    (w, h): (usize, usize),
    sample: u32,
) -> (Ray, Pcg32) {
    let mut rng = Pcg32::new((y * w + x) as u64, sample as u64);
    let interval = match s.query {
        AoQuery::Any => (0.0, f32::INFINITY),
        AoQuery::Closest => (PAPER_TMIN, PAPER_EYE_TMAX),
    };
    let ray = eye_ray_sampled(
        camera,
        (x, y),
        (w, h),
        (sample, s.eye_rays),
        s.sampling,
        interval,
        &mut rng,
    );
    (ray, rng)
}

/// Where the occlusion rays of an eye ray's `hit` start, and the unit
/// normal facing the eye they spread about, in the form of `s`.
pub(crate) fn ao_start(
    scene: &crate::scene::Scene,
    s: &AoSettings,
    ray: &Ray,
    hit: &crate::geometry::Hit,
) -> (Vec3, Vec3) {
    let n = facing_normal(scene, ray, hit);
    let p = ray.at(hit.t);
    match s.query {
        AoQuery::Any => (offset_origin(p, n), n),
        AoQuery::Closest => (p, n),
    }
}

/// Traces eye ray `sample` of pixel (`x`, `y`).
#[inline]
pub(super) fn eye_sample<A: Accel, S: RaySink>(
    accel: &A,
    ctx: &Ctx,
    s: &AoSettings,
    x: usize,
    y: usize,
    sample: u32,
    stats: &mut S,
) -> EyeSample {
    let (ray, rng) = eye_ray_of(&ctx.camera, s, (x, y), (ctx.width, ctx.height), sample);
    stats.ray();
    let mut facing = 0.0;
    let hit = accel.closest_hit(&ray, stats).map(|hit| {
        let (origin, n) = ao_start(ctx.scene, s, &ray, &hit);
        if s.facing {
            facing = n.dot(ray.direction().normalize()).abs();
        }
        (origin, n)
    });
    EyeSample { hit, facing, rng }
}

/// The `s.ao_rays` occlusion rays of a hit at `origin`, spread in the hit's
/// `frame` ([`ao_frame`]), in the form `s` asks for, drawing from `rng`:
/// `each` is called with every ray, in order. The
/// paper's forms make their directions four at a time
/// ([`Sampling::sample4`], [`Frame::cosine_paper4_lanes`], [`Ray::new4_lanes`]), the
/// same rays bit for bit as one at a time.
#[inline]
pub(crate) fn ao_rays(
    s: &AoSettings,
    origin: Vec3,
    frame: &Frame,
    rng: &mut Pcg32,
    mut each: impl FnMut(Ray),
) {
    match (s.query, s.sampling) {
        // The default render's draws, bit for bit.
        (AoQuery::Any, Sampling::Independent) => {
            for _ in 0..s.ao_rays {
                each(Ray::new(origin, frame.cosine(rng), 0.0, s.radius));
            }
        }
        (query, sampling) => {
            let tmin = if query == AoQuery::Closest {
                PAPER_TMIN
            } else {
                0.0
            };
            for first in (0..s.ao_rays).step_by(4) {
                let (u, v) = sampling.sample4(first, s.ao_rays, rng);
                let rays = Ray::new4_lanes(origin, frame.cosine_paper4_lanes(u, v), tmin, s.radius);
                for ray in &rays[..(s.ao_rays - first).min(4) as usize] {
                    each(*ray);
                }
            }
        }
    }
}

/// The basis the occlusion rays of a hit with unit normal `n` spread in,
/// in the form of `s`: made once per hit, read by [`ao_rays`].
#[inline]
pub(crate) fn ao_frame(s: &AoSettings, n: Vec3) -> Frame {
    match (s.query, s.sampling) {
        (AoQuery::Any, Sampling::Independent) => Frame::any(n),
        _ => Frame::paper(n),
    }
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
    let frame = ao_frame(s, n);
    ao_rays(s, origin, &frame, &mut e.rng, |ray| {
        stats.ray();
        let blocked = match s.query {
            AoQuery::Any => accel.any_hit(&ray, stats).is_some(),
            AoQuery::Closest => accel.closest_hit(&ray, stats).is_some(),
        };
        if !blocked {
            open += 1;
        }
    });
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
        let mut e = eye_sample(accel, ctx, s, x, y, sample, stats);
        sum += ao_value(accel, s, &mut e, stats);
    }
    sum / s.eye_rays.max(1) as f32
}
