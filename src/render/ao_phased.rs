//! AO in two phases, as the stackless paper's tracer measures it: every eye
//! ray first (closest hit), then every AO ray (in the form of
//! [`AoSettings::query`]), each phase timed and
//! counted on its own. The image equals [`super::render`]'s AO image bit for
//! bit: the same samples, random streams and sums.
//!
//! [`render_ao_phased_uncounted`] is the same render with the traversal
//! counters compiled out, for phases that are timed.

use super::ao::{ao_value, eye_sample, EyeSample};
use super::{AoSettings, Ctx, Image, RaySink, RaysOnly};
use crate::par;
use crate::scene::Scene;
use crate::stats::Counters;
use crate::structures::Accel;
use serde::Serialize;
use std::time::Instant;

/// One phase's time and work.
#[derive(Clone, Copy, Debug, Default, Serialize)]
pub struct Phase {
    /// Wall-clock time of the phase (its threads in parallel), in seconds.
    pub seconds: f64,
    /// Rays traced in the phase and, when counted, their work.
    pub counters: Counters,
}

/// What [`render_ao_phased`] produced and measured.
#[derive(Clone, Debug)]
pub struct PhasedAo {
    /// The AO image, equal to [`super::render`]'s bit for bit.
    pub image: Image,
    /// The eye rays' phase (closest hit).
    pub eye: Phase,
    /// The AO rays' phase.
    pub ao: Phase,
}

impl PhasedAo {
    /// Both phases' time.
    pub fn seconds(&self) -> f64 {
        self.eye.seconds + self.ao.seconds
    }
}

/// Rows are handed out in chunks of this many pixels.
const CHUNK: usize = 256;

/// AO of `scene` through `accel`, eye rays then AO rays, each phase timed
/// and counted.
pub fn render_ao_phased<A: Accel>(
    accel: &A,
    scene: &Scene,
    s: &AoSettings,
    width: usize,
    height: usize,
) -> PhasedAo {
    phased_with::<A, Counters>(accel, scene, s, width, height)
}

/// [`render_ao_phased`] counting rays only: the same image and rays, the
/// traversals' counters compiled out.
pub fn render_ao_phased_uncounted<A: Accel>(
    accel: &A,
    scene: &Scene,
    s: &AoSettings,
    width: usize,
    height: usize,
) -> PhasedAo {
    phased_with::<A, RaysOnly>(accel, scene, s, width, height)
}

fn phased_with<A: Accel, S: RaySink + Default>(
    accel: &A,
    scene: &Scene,
    s: &AoSettings,
    width: usize,
    height: usize,
) -> PhasedAo {
    let ctx = Ctx {
        scene,
        width,
        height,
        camera: super::sampling::image_projection(scene, width, height),
    };
    let n = s.eye_rays as usize;
    let pixels: Vec<usize> = (0..width * height).collect();

    let start = Instant::now();
    let eye: Vec<(Vec<EyeSample>, Counters)> = par::map_chunks(&pixels, CHUNK, &|chunk| {
        let mut c = S::default();
        let mut samples = Vec::with_capacity(chunk.len() * n);
        for &p in chunk {
            for sample in 0..s.eye_rays {
                samples.push(eye_sample(
                    accel,
                    &ctx,
                    s,
                    p % width,
                    p / width,
                    sample,
                    &mut c,
                ));
            }
        }
        (samples, c.counters())
    });
    let eye_phase = Phase {
        seconds: start.elapsed().as_secs_f64(),
        counters: sum(eye.iter().map(|e| e.1)),
    };

    let start = Instant::now();
    let ao: Vec<(Vec<f32>, Counters)> = par::map_owned(eye, &|(mut samples, _)| {
        let mut c = S::default();
        let values = samples
            .chunks_mut(n.max(1))
            .map(|pixel| {
                let mut v = 0.0;
                for e in pixel {
                    v += ao_value(accel, s, e, &mut c);
                }
                v / s.eye_rays.max(1) as f32
            })
            .collect();
        (values, c.counters())
    });
    let ao_phase = Phase {
        seconds: start.elapsed().as_secs_f64(),
        counters: sum(ao.iter().map(|a| a.1)),
    };
    let mut image = Image::new(width, height);
    image.pixels = ao.into_iter().flat_map(|a| a.0).collect();
    PhasedAo {
        image,
        eye: eye_phase,
        ao: ao_phase,
    }
}

fn sum(it: impl Iterator<Item = Counters>) -> Counters {
    it.fold(Counters::default(), |mut a, b| {
        a += b;
        a
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bvh::{BuildOptions, Bvh};
    use crate::render::{render, Integrator};
    use crate::structures::BinaryBvh;

    /// A small chess scene, its BVH and AO with `eye_rays` and `ao_rays`.
    fn chess(eye_rays: u32, ao_rays: u32) -> (Scene, BinaryBvh, AoSettings) {
        let scene = Scene::builtin("chess:3000").unwrap();
        let bvh = Bvh::build(&scene.triangles, &BuildOptions::sah());
        let b = BinaryBvh::from_bvh(&bvh, scene.triangles.clone()).unwrap();
        let s = AoSettings::plain(eye_rays, ao_rays, 30.0);
        (scene, b, s)
    }

    #[test]
    fn phased_image_equals_the_interleaved_render() {
        let (scene, b, s) = chess(3, 5);
        let phased = render_ao_phased(&b, &scene, &s, 41, 17);
        let plain = render(&b, &scene, &Integrator::Ao(s.clone()), 41, 17, &|_| {});
        assert_eq!(phased.image, plain.image);
        let mut total = phased.eye.counters;
        total += phased.ao.counters;
        assert_eq!(total, plain.counters);
        assert_eq!(phased.eye.counters.rays, 41 * 17 * 3);
    }

    #[test]
    fn uncounted_phases_trace_the_same_rays_and_count_only_them() {
        let (scene, b, s) = chess(2, 4);
        let counted = render_ao_phased(&b, &scene, &s, 23, 19);
        let timed = render_ao_phased_uncounted(&b, &scene, &s, 23, 19);
        assert_eq!(timed.image, counted.image);
        for (t, c) in [(timed.eye, counted.eye), (timed.ao, counted.ao)] {
            assert_eq!(t.counters.rays, c.counters.rays);
            assert!(c.counters.nodes > 0 && c.counters.triangles > 0);
            let only_rays = Counters {
                rays: c.counters.rays,
                ..Counters::default()
            };
            assert_eq!(t.counters, only_rays);
        }
        // Enough eye rays hit for the AO phase to be tested too.
        assert!(
            counted.ao.counters.rays > 500,
            "{}",
            counted.ao.counters.rays
        );
    }
}
