//! Times the binary traversals on the stackless paper's CHESS workload as
//! fixed ray sets (eye rays, then closest-hit AO rays of radius 32 from the
//! hit points, 4×4 stratified), one thread, no counting:
//! `cargo run --release --example paper_speed -- [scene] [traversal] [scale]`.
//! `scene` defaults to `../shared/scenes/battlefield.obj`; `scale` divides
//! the image's width and height (default 2: a quarter of the paper's rays).
//! Prints each traversal's eye and AO seconds, the fastest of 3 rounds.

use raytree::prelude::*;
use raytree::render::{rayset, AoQuery, AoSettings, Sampling};
use raytree::structures::{Built, SparseBvh, StructureKind, TraversalKind, WithAccel};
use std::sync::Arc;
use std::time::Instant;

struct Time<'a>(&'a [Ray]);
impl WithAccel for Time<'_> {
    type Output = (f64, usize);
    #[inline(never)]
    fn run<A: Accel>(self, a: &A) -> (f64, usize) {
        let t = Instant::now();
        let mut n = 0;
        for r in self.0 {
            n += a.closest_hit(r, &mut NoStats).is_some() as usize;
        }
        (t.elapsed().as_secs_f64(), n)
    }
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let spec = args
        .get(1)
        .cloned()
        .unwrap_or("../shared/scenes/battlefield.obj".into());
    let only = args.get(2).filter(|s| *s != "all").cloned();
    let scale: usize = args.get(3).map_or(2, |s| s.parse().unwrap());
    let mut scene = Scene::from_spec(&spec).unwrap();
    scene.use_stackless_view();
    let bvh = Bvh::build(&scene.triangles, &BuildOptions::hybrid());
    let b = BinaryBvh::from_bvh(&bvh, scene.triangles.clone()).unwrap();
    let ao = AoSettings {
        query: AoQuery::Closest,
        sampling: Sampling::Stratified,
        ..AoSettings::plain(16, 16, Scene::STACKLESS_CHESS_AO_RADIUS)
    };
    let (eye, aorays) = rayset::ao_workload(&scene, &b, &ao, 800 / scale, 300 / scale);
    let eye: Vec<Ray> = eye.into_iter().map(|(r, _)| r).collect();
    eprintln!("{} eye rays, {} AO rays", eye.len(), aorays.len());
    let sp = Arc::new(SparseBvh::from_bvh(&bvh, scene.triangles.clone()).unwrap());
    let rows: Vec<_> = raytree_rows()
        .into_iter()
        .filter(|(n, _, _)| only.as_deref().is_none_or(|o| o == *n))
        .map(|(name, t, s)| {
            let built = match s {
                1 => Built::sparse(t, sp.clone()).unwrap(),
                2 => Built::paired(t, sp.clone()).unwrap(),
                _ => {
                    Built::new(StructureKind::Bvh, t, &bvh, scene.triangles.clone())
                        .unwrap()
                        .0
                }
            };
            (name, built)
        })
        .collect();
    let mut best = vec![(f64::MAX, f64::MAX); rows.len()];
    for _ in 0..3 {
        for ((_, built), best) in rows.iter().zip(&mut best) {
            let (te, _) = built.with(Time(&eye));
            let (ta, _) = built.with(Time(&aorays));
            best.0 = best.0.min(te);
            best.1 = best.1.min(ta);
        }
    }
    for ((name, _), (te, ta)) in rows.iter().zip(best) {
        println!("{name:14} eye {te:.3} ao {ta:.3} total {:.3}", te + ta);
    }
}

/// Rows: name, traversal, nodes (0 its own layout, 1 the sparse layout's
/// own-box nodes, 2 the paper tracer's 64-byte nodes).
fn raytree_rows() -> Vec<(&'static str, TraversalKind, u8)> {
    use TraversalKind::*;
    vec![
        ("stack", Stack, 0),
        ("stack-sparse", Stack, 1),
        ("sparse", Sparse, 1),
        ("implicit-a", ImplicitA, 0),
        ("implicit-b", ImplicitB, 0),
        ("hapala", Hapala, 1),
        ("laine-0", Laine0, 1),
        ("laine-1", Laine1, 1),
        ("laine-2", Laine2, 1),
        ("laine-8", Laine8, 1),
        ("stack-paired", Stack, 2),
        ("sparse-paired", Sparse, 2),
        ("laine-0-paired", Laine0, 2),
        ("laine-1-paired", Laine1, 2),
        ("laine-2-paired", Laine2, 2),
        ("laine-8-paired", Laine8, 2),
    ]
}
