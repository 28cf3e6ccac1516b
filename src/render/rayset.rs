//! Fixed ray sets for tests and benchmarks: the eye rays and AO rays the AO
//! integrator would trace and the bounce rays of the path integrator,
//! generated with the same sampling.

use super::sampling::{cosine_hemisphere, eye_ray, facing_normal, image_projection, offset_origin};
use crate::geometry::Ray;
use crate::rng::Pcg32;
use crate::scene::Scene;
use crate::stats::NoStats;
use crate::structures::Accel;

/// `spp` jittered eye rays per pixel of a `w`×`h` image (coherent rays).
pub fn eye_rays(scene: &Scene, w: usize, h: usize, spp: u32) -> Vec<Ray> {
    let camera = image_projection(scene, w, h);
    let mut rays = Vec::with_capacity(w * h * spp as usize);
    for y in 0..h {
        for x in 0..w {
            for s in 0..spp {
                let mut rng = Pcg32::new((y * w + x) as u64, s as u64);
                rays.push(eye_ray(&camera, x, y, w, h, &mut rng));
            }
        }
    }
    rays
}

/// `per_hit` cosine-weighted occlusion rays of length `radius` at each hit
/// of `eye` (incoherent rays), the hits found through `accel`.
pub fn ao_rays<A: Accel>(
    scene: &Scene,
    accel: &A,
    eye: &[Ray],
    per_hit: u32,
    radius: f32,
) -> Vec<Ray> {
    let mut rays = Vec::new();
    for (i, r) in eye.iter().enumerate() {
        let Some(hit) = accel.closest_hit(r, &mut NoStats) else {
            continue;
        };
        let n = facing_normal(scene, r, &hit);
        let origin = offset_origin(r.at(hit.t), n);
        let mut rng = Pcg32::new(i as u64, 0xA0);
        for _ in 0..per_hit {
            rays.push(Ray::new(
                origin,
                cosine_hemisphere(n, &mut rng),
                0.0,
                radius,
            ));
        }
    }
    rays
}

/// The rays the AO integrator traces for a `w`×`h` image with settings `s`,
/// in their form (intervals, origins, sampling: see
/// [`super::AoQuery`] and [`super::Sampling`]): per pixel, row by row, its
/// `s.eye_rays` eye rays, and for each eye ray with a hit (found through
/// `accel`) its `s.ao_rays` occlusion rays. Returns the eye rays and the
/// occlusion rays apart, each eye ray with the index range of its own.
#[allow(clippy::type_complexity)]
pub fn ao_workload<A: Accel>(
    scene: &Scene,
    accel: &A,
    s: &super::AoSettings,
    w: usize,
    h: usize,
) -> (Vec<(Ray, std::ops::Range<usize>)>, Vec<Ray>) {
    let camera = image_projection(scene, w, h);
    let (mut eye, mut ao) = (Vec::new(), Vec::new());
    for y in 0..h {
        for x in 0..w {
            for sample in 0..s.eye_rays {
                let (ray, mut rng) = super::ao::eye_ray_of(&camera, s, (x, y), (w, h), sample);
                let first = ao.len();
                if let Some(hit) = accel.closest_hit(&ray, &mut NoStats) {
                    let (origin, n) = super::ao::ao_start(scene, s, &ray, &hit);
                    let frame = super::ao::ao_frame(s, n);
                    super::ao::ao_rays(s, origin, &frame, &mut rng, |r| ao.push(r));
                }
                eye.push((ray, first..ao.len()));
            }
        }
    }
    (eye, ao)
}

/// The bounce rays of one path-traced frame of `w`×`h` pixels at 1 sample
/// per pixel, up to `bounces` after each eye ray: the rays the path
/// integrator traces after the eye rays, with its sampling, the hits found
/// through `accel`.
pub fn path_rays<A: Accel + Sync>(
    scene: &Scene,
    accel: &A,
    w: usize,
    h: usize,
    bounces: u32,
) -> Vec<Ray> {
    let rows: Vec<Vec<Ray>> =
        crate::par::map_range(h, &|y| path_rays_of_row(scene, accel, y, w, h, bounces));
    rows.concat()
}

fn path_rays_of_row<A: Accel>(
    scene: &Scene,
    accel: &A,
    y: usize,
    w: usize,
    h: usize,
    bounces: u32,
) -> Vec<Ray> {
    let camera = image_projection(scene, w, h);
    let mut rays = Vec::new();
    {
        for x in 0..w {
            let mut rng = Pcg32::new((y * w + x) as u64, 0);
            let mut ray = eye_ray(&camera, x, y, w, h, &mut rng);
            for _ in 0..bounces {
                let Some(hit) = accel.closest_hit(&ray, &mut NoStats) else {
                    break;
                };
                let n = facing_normal(scene, &ray, &hit);
                ray = Ray::infinite(
                    offset_origin(ray.at(hit.t), n),
                    cosine_hemisphere(n, &mut rng),
                );
                rays.push(ray);
            }
        }
    }
    rays
}
