//! Traversal time of every structure of the dual-split paper on one fixed
//! set of path-tracing bounce rays (512×512 pixels, 1 spp, 5 diffuse
//! bounces, traced through the BVH), one thread, closest hit, no counting.
//! Rounds are interleaved and each structure's best round is kept, so the
//! ratios to the BVH vary by about ±1% between runs (frame times of
//! `raytree bench dst` by about ±4%).
//!
//! ```text
//! cargo run --release --example dst_speed -- atrium ../shared/scenes/bunny.obj
//! ```
//!
//! With `RAYTREE_ONLY=dst` (any structure name) it traces the rays once
//! through that structure alone and prints its per-ray work, for
//! instruction counts under `valgrind --tool=callgrind` or profiles under
//! `perf record`. Under callgrind, `--toggle-collect='*Time*run*'`
//! counts the traced rays' instructions alone.

use raytree::prelude::*;
use raytree::render::rayset;
use raytree::structures::{Built, StructureKind, TraversalKind, WithAccel};
use std::time::Instant;

/// Seconds to trace the rays and how many hit.
struct Time<'a>(&'a [Ray]);

impl WithAccel for Time<'_> {
    type Output = (f64, usize);
    // Not inlined: callgrind's `--toggle-collect` names it.
    #[inline(never)]
    fn run<A: Accel>(self, a: &A) -> (f64, usize) {
        let t = Instant::now();
        let hits = self
            .0
            .iter()
            .filter(|r| a.closest_hit(r, &mut NoStats).is_some())
            .count();
        (t.elapsed().as_secs_f64(), hits)
    }
}

/// The rays' total nodes, plane tests and triangle tests.
struct Count<'a>(&'a [Ray]);

impl WithAccel for Count<'_> {
    type Output = Counters;
    fn run<A: Accel>(self, a: &A) -> Counters {
        let mut c = Counters::default();
        for r in self.0 {
            a.closest_hit(r, &mut c);
        }
        c
    }
}

const ROUNDS: usize = 7;

fn main() {
    let specs: Vec<String> = std::env::args().skip(1).collect();
    let only = std::env::var("RAYTREE_ONLY").ok();
    let kinds: Vec<StructureKind> = StructureKind::all()
        .iter()
        .copied()
        .filter(|k| *k != StructureKind::Brute)
        .collect();
    assert_eq!(
        kinds[0],
        StructureKind::Bvh,
        "ratios are to the first structure"
    );
    let mut sums = vec![0.0; kinds.len()];
    for spec in &specs {
        let scene = Scene::from_spec(spec).unwrap();
        let bvh = Bvh::build(&scene.triangles, &BuildOptions::sah());
        let built: Vec<Built> = kinds
            .iter()
            .map(|&k| {
                Built::new(k, TraversalKind::Stack, &bvh, scene.triangles.clone())
                    .unwrap()
                    .0
            })
            .collect();
        let reference = BinaryBvh::from_bvh(&bvh, scene.triangles.clone()).unwrap();
        let rays = rayset::path_rays(&scene, &reference, 512, 512, 5);
        if let Some(only) = only.as_deref() {
            if let Some(k) = kinds.iter().position(|k| k.name() == only) {
                let (t, _) = built[k].with(Time(&rays));
                let c = built[k].with(Count(&rays));
                let n = rays.len() as f64;
                println!(
                    "{spec}: {only}, {} rays in {t:.3} s: {:.2} nodes, {:.2} plane tests, {:.2} triangle tests per ray",
                    rays.len(),
                    c.nodes as f64 / n,
                    c.planes as f64 / n,
                    c.triangles as f64 / n
                );
            }
            continue;
        }
        let mut best = vec![f64::INFINITY; kinds.len()];
        let mut hits = vec![0; kinds.len()];
        for _ in 0..ROUNDS {
            for (k, b) in built.iter().enumerate() {
                let (t, h) = b.with(Time(&rays));
                best[k] = best[k].min(t);
                hits[k] = h;
            }
        }
        assert!(
            hits.iter().all(|&h| h == hits[0]),
            "hit counts differ: {hits:?}"
        );
        print!("{spec:<28} {:>8} rays  bvh {:.3} s ", rays.len(), best[0]);
        for (k, kind) in kinds.iter().enumerate().skip(1) {
            let r = best[k] / best[0];
            sums[k] += r;
            print!(" {} {r:.3}", kind.name());
        }
        println!();
    }
    if only.is_none() && specs.len() > 1 {
        print!("mean of the ratios to bvh:");
        for (k, kind) in kinds.iter().enumerate().skip(1) {
            print!(" {} {:.3}", kind.name(), sums[k] / specs.len() as f64);
        }
        println!();
    }
}
