//! Times the binary traversals on the stackless paper's CHESS workload as
//! fixed ray sets (eye rays, then closest-hit AO rays of radius 32 from the
//! hit points, 4×4 stratified), one thread, no counting:
//! `cargo run --release --example paper_speed -- [scene] [traversals] [scale]`.
//! `scene` defaults to `../shared/scenes/battlefield.obj` (a scene other than
//! the paper's CHESS is traced at 512×512 with an AO radius of 0.045 of its
//! diagonal, as `bench stackless --preset paper` does); `traversals` is
//! `all` or comma-separated row names (`stack-paired,sparse-paired`); `scale` divides
//! the image's width and height (default 2: a quarter of the paper's rays).
//! Prints each traversal's eye and AO seconds, the fastest of 3 rounds.
//! With `RAYTREE_PHASED=1`, times instead the whole phased render at the
//! paper's 800×300 as `bench stackless --preset paper` does (ray making,
//! shading and the counters-off traversal), fastest of 3; with
//! `RAYTREE_PHASED=gen`, that render with every AO ray answered a miss
//! untraced (what the render costs besides the AO traces). The phased
//! modes run on rayon's pool: `RAYON_NUM_THREADS=1` for one thread. With
//! `RAYTREE_COUNT=1` it prints each traversal's nodes visited per ray
//! instead of its times.

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

/// Nodes visited per ray (the counters on), for `RAYTREE_COUNT=1`.
struct Count<'a>(&'a [Ray]);
impl WithAccel for Count<'_> {
    type Output = f64;
    fn run<A: Accel>(self, a: &A) -> f64 {
        let mut c = Counters::default();
        for r in self.0 {
            a.closest_hit(r, &mut c);
        }
        c.nodes as f64 / self.0.len().max(1) as f64
    }
}

/// The binary BVH for eye rays only: every AO ray (`tmax` below 1000) a
/// miss without a trace, so that a phased render times everything but the
/// AO traces (`RAYTREE_PHASED=gen`).
struct EyeOnly<'a>(&'a BinaryBvh);
impl Accel for EyeOnly<'_> {
    fn name(&self) -> &'static str {
        "eye-only"
    }
    fn bytes(&self) -> usize {
        0
    }
    fn closest_hit<S: Stats>(&self, ray: &Ray, stats: &mut S) -> Option<Hit> {
        if ray.tmax < 1000.0 {
            return None;
        }
        self.0.closest_hit(ray, stats)
    }
    fn any_hit<S: Stats>(&self, ray: &Ray, stats: &mut S) -> Option<Hit> {
        self.closest_hit(ray, stats)
    }
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let spec = args
        .get(1)
        .cloned()
        .unwrap_or("../shared/scenes/battlefield.obj".into());
    let only: Option<Vec<String>> = args
        .get(2)
        .filter(|s| *s != "all")
        .map(|s| s.split(',').map(str::to_owned).collect());
    let scale: usize = args.get(3).map_or(2, |s| s.parse().unwrap());
    let mut scene = Scene::from_spec(&spec).unwrap();
    // The paper's CHESS view and radius 32; any other scene at 512×512 with
    // the preset's radius (0.045 of the diagonal), as `bench stackless
    // --preset paper` traces it.
    let chess = scene.use_stackless_view();
    let (width, height, radius) = if chess {
        (800, 300, Scene::STACKLESS_CHESS_AO_RADIUS)
    } else {
        (
            512,
            512,
            AoSettings::RADIUS_FRACTION * scene.mesh.bounds().extent().length(),
        )
    };
    let bvh = Bvh::build(&scene.triangles, &BuildOptions::hybrid());
    let b = BinaryBvh::from_bvh(&bvh, scene.triangles.clone()).unwrap();
    let ao = AoSettings {
        query: AoQuery::Closest,
        sampling: Sampling::Stratified,
        ..AoSettings::plain(16, 16, radius)
    };
    let mode = std::env::var("RAYTREE_PHASED").unwrap_or_default();
    let phased = mode == "1";
    if mode == "gen" {
        let e = EyeOnly(&b);
        for _ in 0..3 {
            let r = raytree::render::render_ao_phased_uncounted(&e, &scene, &ao, width, height);
            println!(
                "eye-only       phased eye {:.3} ao {:.3}",
                r.eye.seconds, r.ao.seconds
            );
        }
        return;
    }
    let (eye, aorays) = if phased {
        (Vec::new(), Vec::new())
    } else {
        rayset::ao_workload(&scene, &b, &ao, width / scale, height / scale)
    };
    let eye: Vec<Ray> = eye.into_iter().map(|(r, _)| r).collect();
    eprintln!("{} eye rays, {} AO rays", eye.len(), aorays.len());
    let sp = Arc::new(SparseBvh::from_bvh(&bvh, scene.triangles.clone()).unwrap());
    let rows: Vec<_> = raytree_rows()
        .into_iter()
        .filter(|(n, _, _)| only.as_ref().is_none_or(|o| o.iter().any(|o| o == n)))
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
    if phased {
        for (name, built) in &rows {
            let mut best = (f64::MAX, f64::MAX);
            for _ in 0..3 {
                let r = built.render_ao_phased(&scene, &ao, width, height, false);
                if r.eye.seconds + r.ao.seconds < best.0 + best.1 {
                    best = (r.eye.seconds, r.ao.seconds);
                }
            }
            let (te, ta) = best;
            println!(
                "{name:14} phased eye {te:.3} ao {ta:.3} total {:.3}",
                te + ta
            );
        }
        return;
    }
    if std::env::var("RAYTREE_COUNT").is_ok_and(|v| v == "1") {
        for (name, built) in &rows {
            let (ne, na) = (built.with(Count(&eye)), built.with(Count(&aorays)));
            println!("{name:14} nodes per eye ray {ne:.2} per AO ray {na:.2}");
        }
        return;
    }
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
