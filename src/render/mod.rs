//! Integrators (ambient occlusion, diffuse path tracing), rendered in tiles
//! over rayon, and the images they produce.
//!
//! Every pixel draws its random numbers from its own stream, seeded by the
//! pixel and sample index, so an image is bit-identical for any thread count.

mod ao;
mod ao_phased;
mod built;
pub mod heatmap;
mod image;
mod path;
pub mod rayset;
mod sampling;

pub use self::image::{is_stdout, remove_unfinished_files, write_atomically, Image, ImageFormat};
pub use ao::{AoQuery, AoSettings, Sampling, PAPER_EYE_TMAX, PAPER_TMIN};
pub use ao_phased::{render_ao_phased, render_ao_phased_uncounted, Phase, PhasedAo};
pub use path::PathSettings;

use crate::scene::Scene;
use crate::stats::{Counters, Stats, Tally};
use crate::structures::Accel;
use std::time::Instant;

/// Which integrator, with its settings.
#[derive(Clone, Debug)]
pub enum Integrator {
    /// Ambient occlusion, the stackless paper's workload.
    Ao(AoSettings),
    /// Diffuse path tracing, the dual-split paper's workload.
    Path(PathSettings),
}

/// What a render produced and measured.
#[derive(Clone, Debug)]
pub struct Rendered {
    /// The rendered values, `width × height`.
    pub image: Image,
    /// The work of each pixel's rays, for heat maps.
    pub work: heatmap::WorkImage,
    /// Rays traced (eye, AO and bounce rays) and, when counted, the work.
    pub counters: Counters,
    /// Wall-clock time of the render (its threads in parallel), in seconds.
    pub seconds: f64,
}

/// Image tiles are this many pixels square.
const TILE: usize = 16;

/// Renders `scene` through `accel`, counting rays and traversal work.
/// `progress` is called once per finished tile.
pub fn render<A: Accel>(
    accel: &A,
    scene: &Scene,
    integrator: &Integrator,
    width: usize,
    height: usize,
    progress: &(dyn Fn(usize) + Sync),
) -> Rendered {
    render_with::<A, Counters>(accel, scene, integrator, width, height, progress)
}

/// [`render`] counting rays only: the traversals run with their counters
/// compiled out, as a frame that is timed should. `work` is all zero and
/// `counters` holds only the rays.
pub fn render_uncounted<A: Accel>(
    accel: &A,
    scene: &Scene,
    integrator: &Integrator,
    width: usize,
    height: usize,
    progress: &(dyn Fn(usize) + Sync),
) -> Rendered {
    render_with::<A, RaysOnly>(accel, scene, integrator, width, height, progress)
}

fn render_with<A: Accel, S: RaySink + Default>(
    accel: &A,
    scene: &Scene,
    integrator: &Integrator,
    width: usize,
    height: usize,
    progress: &(dyn Fn(usize) + Sync),
) -> Rendered {
    let start = Instant::now();
    let tiles_x = width.div_ceil(TILE);
    let tiles: Vec<(usize, usize)> = (0..height.div_ceil(TILE))
        .flat_map(|ty| (0..tiles_x).map(move |tx| (tx, ty)))
        .collect();
    let ctx = Ctx {
        scene,
        width,
        height,
        camera: sampling::image_projection(scene, width, height),
    };
    let results: Vec<(Vec<(f32, Tally)>, Counters)> = crate::par::map(&tiles, &|&(tx, ty)| {
        let mut sink = S::default();
        let px = render_tile(accel, &ctx, integrator, tx, ty, &mut sink);
        progress(1);
        (px, sink.counters())
    });
    let mut image = Image::new(width, height);
    let mut work = heatmap::WorkImage {
        width,
        height,
        pixels: vec![Tally::default(); width * height],
    };
    let mut counters = Counters::default();
    for (&(tx, ty), (px, c)) in tiles.iter().zip(results) {
        counters += c;
        let mut k = 0;
        for y in ty * TILE..((ty + 1) * TILE).min(height) {
            for x in tx * TILE..((tx + 1) * TILE).min(width) {
                image.set(x, y, px[k].0);
                work.pixels[y * width + x] = px[k].1;
                k += 1;
            }
        }
    }
    Rendered {
        image,
        work,
        counters,
        seconds: start.elapsed().as_secs_f64(),
    }
}

/// The number of tiles `render` reports progress over.
pub fn tile_count(width: usize, height: usize) -> usize {
    width.div_ceil(TILE) * height.div_ceil(TILE)
}

struct Ctx<'a> {
    scene: &'a Scene,
    width: usize,
    height: usize,
    /// The scene camera's projection for the image, made once.
    camera: crate::scene::Projection,
}

/// Sinks that know how many rays were traced.
trait RaySink: Stats {
    fn ray(&mut self);
    /// What was counted so far.
    fn counters(&self) -> Counters;
}

impl RaySink for Counters {
    #[inline(always)]
    fn ray(&mut self) {
        self.rays += 1;
    }
    fn counters(&self) -> Counters {
        *self
    }
}

/// Counts rays; the traversal work vanishes as with [`crate::stats::NoStats`].
#[derive(Clone, Copy, Debug, Default)]
struct RaysOnly {
    rays: u64,
}

impl Stats for RaysOnly {
    #[inline(always)]
    fn add(&mut self, _: Tally) {}
}

impl RaySink for RaysOnly {
    #[inline(always)]
    fn ray(&mut self) {
        self.rays += 1;
    }
    fn counters(&self) -> Counters {
        Counters {
            rays: self.rays,
            ..Counters::default()
        }
    }
}

/// A tile's pixel values, each with the work of its rays.
fn render_tile<A: Accel, S: RaySink>(
    accel: &A,
    ctx: &Ctx,
    integrator: &Integrator,
    tx: usize,
    ty: usize,
    stats: &mut S,
) -> Vec<(f32, Tally)> {
    let mut out = Vec::with_capacity(TILE * TILE);
    for y in ty * TILE..((ty + 1) * TILE).min(ctx.height) {
        for x in tx * TILE..((tx + 1) * TILE).min(ctx.width) {
            let before = stats.counters();
            let v = match integrator {
                Integrator::Ao(s) => ao::pixel(accel, ctx, s, x, y, stats),
                Integrator::Path(s) => path::pixel(accel, ctx, s, x, y, stats),
            };
            let after = stats.counters();
            let work = Tally {
                nodes: (after.nodes - before.nodes) as u32,
                planes: (after.planes - before.planes) as u32,
                triangles: (after.triangles - before.triangles) as u32,
            };
            out.push((v, work));
        }
    }
    out
}
