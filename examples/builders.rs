//! Build time, SAH cost, node and reference counts of every builder (with
//! and without `--optimize`), on one thread and on all, and the one-thread
//! trace speed of the binary BVH (STACK) each builder makes on primary, AO
//! (any hit) and path rays; the rays are made once per scene with the SAH
//! tree, and the fastest of the interleaved rounds is kept.
//!
//! ```text
//! cargo run --release --example builders -- atrium ../shared/scenes/bunny.obj
//! ```
//!
//! `RAYTREE_BUILD_ONLY=1` skips the traces; `RAYTREE_ROUNDS` sets the
//! rounds (default 5); `RAYTREE_BUILDERS=sah,sbvh+opt` picks the variants
//! (default: all); `RAYTREE_SBVH_MIN_REFS` and `RAYTREE_SBVH_NODE_OVERLAP`
//! set `BuildOptions::spatial_min_refs` and `spatial_min_node_overlap` for
//! the `sbvh` variants. The peak heap is the most a one-thread build held at
//! once, beyond what was live before it. Each line ends with a fingerprint
//! of the tree (its nodes and reference list), so that a change to a
//! builder that must not change its trees can be checked.

use raytree::bvh::OptimizeOptions;
use raytree::meter::{peak_during, Metered};
use raytree::prelude::*;
use raytree::render::rayset;
use std::hash::{Hash, Hasher};
use std::time::Instant;

#[global_allocator]
static HEAP: Metered = Metered;

/// A hash of the tree's nodes (boxes by their bits, links, depths) and its
/// reference list.
fn fingerprint(bvh: &Bvh) -> u64 {
    let mut h = std::collections::hash_map::DefaultHasher::new();
    for n in &bvh.nodes {
        for v in [n.bounds.min, n.bounds.max] {
            v.to_array().map(f32::to_bits).hash(&mut h);
        }
        n.parent.hash(&mut h);
        n.depth.hash(&mut h);
        n.kind.hash(&mut h);
    }
    bvh.prims.hash(&mut h);
    h.finish()
}

struct Variant {
    name: &'static str,
    builder: Builder,
    optimize: bool,
}

const VARIANTS: [Variant; 7] = [
    Variant {
        name: "sah",
        builder: Builder::Sah,
        optimize: false,
    },
    Variant {
        name: "hybrid",
        builder: Builder::Hybrid,
        optimize: false,
    },
    Variant {
        name: "sbvh",
        builder: Builder::Sbvh,
        optimize: false,
    },
    Variant {
        name: "lbvh",
        builder: Builder::Lbvh,
        optimize: false,
    },
    Variant {
        name: "sah+opt",
        builder: Builder::Sah,
        optimize: true,
    },
    Variant {
        name: "lbvh+opt",
        builder: Builder::Lbvh,
        optimize: true,
    },
    Variant {
        name: "sbvh+opt",
        builder: Builder::Sbvh,
        optimize: true,
    },
];

/// `RAYTREE_SBVH_*`'s value, if set; exits naming the variable if it does
/// not parse.
fn env_option<T: std::str::FromStr>(name: &str) -> Option<T> {
    let v = std::env::var(name).ok()?;
    Some(v.parse().unwrap_or_else(|_| {
        eprintln!("{name}: cannot read {v:?} as a number");
        std::process::exit(2);
    }))
}

fn build(v: &Variant, tris: &[Triangle]) -> (Bvh, f64) {
    let mut opts = BuildOptions::new(v.builder);
    if let Some(f) = env_option("RAYTREE_SBVH_NODE_OVERLAP") {
        opts.spatial_min_node_overlap = f;
    }
    if let Some(n) = env_option("RAYTREE_SBVH_MIN_REFS") {
        opts.spatial_min_refs = n;
    }
    let t = Instant::now();
    let mut bvh = Bvh::build(tris, &opts);
    if v.optimize {
        bvh = bvh.optimize(&OptimizeOptions::default());
    }
    (bvh, t.elapsed().as_secs_f64())
}

fn trace(a: &BinaryBvh, rays: &[Ray], any: bool) -> (f64, usize) {
    let t = Instant::now();
    let hits = if any {
        rays.iter()
            .filter(|r| a.any_hit(r, &mut NoStats).is_some())
            .count()
    } else {
        rays.iter()
            .filter(|r| a.closest_hit(r, &mut NoStats).is_some())
            .count()
    };
    (t.elapsed().as_secs_f64(), hits)
}

fn main() {
    let specs: Vec<String> = std::env::args().skip(1).collect();
    let rounds: usize = std::env::var("RAYTREE_ROUNDS")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(5);
    let build_only = std::env::var_os("RAYTREE_BUILD_ONLY").is_some();
    let one = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .unwrap();
    let threads = rayon::current_num_threads();
    let picked: Option<Vec<String>> = std::env::var("RAYTREE_BUILDERS")
        .ok()
        .map(|s| s.split(',').map(str::to_owned).collect());
    if let Some(p) = &picked {
        if let Some(bad) = p
            .iter()
            .find(|n| VARIANTS.iter().all(|v| v.name != n.as_str()))
        {
            let names: Vec<&str> = VARIANTS.iter().map(|v| v.name).collect();
            eprintln!(
                "RAYTREE_BUILDERS: unknown variant {bad:?} (known: {})",
                names.join(", ")
            );
            std::process::exit(2);
        }
    }
    let variants: Vec<&Variant> = VARIANTS
        .iter()
        .filter(|v| {
            picked
                .as_ref()
                .is_none_or(|p| p.iter().any(|n| n == v.name))
        })
        .collect();
    for spec in &specs {
        let scene = Scene::from_spec(spec).unwrap();
        let tris = &scene.triangles;
        println!("{spec}: {} triangles", tris.len());
        let mut bvhs = Vec::new();
        for v in &variants {
            let (mut t1, mut tn) = (f64::INFINITY, f64::INFINITY);
            let mut bvh = None;
            let mut peak = 0;
            for _ in 0..rounds.min(3) {
                let ((b, t), p) = peak_during(|| one.install(|| build(v, tris)));
                peak = p.unwrap_or(0);
                t1 = t1.min(t);
                let (_, t) = build(v, tris);
                tn = tn.min(t);
                bvh = Some(b);
            }
            let bvh = bvh.unwrap();
            let s = &bvh.stats;
            println!(
                "  {:<9} build {:>8.1} ms (1 thread) {:>8.1} ms ({threads} threads)  SAH {:>8.3}  nodes {:>8}  refs {:>8} ({:.3}x)  depth {}  peak heap {:.1} MiB ({:.0} B/ref)  tree {:016x}",
                v.name,
                t1 * 1e3,
                tn * 1e3,
                s.sah_cost,
                s.nodes,
                s.references,
                s.references as f64 / tris.len() as f64,
                s.depth,
                peak as f64 / (1 << 20) as f64,
                peak as f64 / s.references.max(1) as f64,
                fingerprint(&bvh)
            );
            bvhs.push(bvh);
        }
        if build_only {
            continue;
        }
        let accels: Vec<BinaryBvh> = bvhs
            .iter()
            .map(|b| BinaryBvh::from_bvh(b, tris.clone()).unwrap())
            .collect();
        let eye = rayset::eye_rays(&scene, 512, 512, 1);
        let radius = 0.1 * scene.mesh.bounds().extent().length();
        let ao = rayset::ao_rays(&scene, &accels[0], &eye, 4, radius);
        let path = one.install(|| rayset::path_rays(&scene, &accels[0], 256, 256, 5));
        for (kind, rays, any) in [
            ("primary", &eye, false),
            ("ao", &ao, true),
            ("path", &path, false),
        ] {
            let mut best = vec![f64::INFINITY; accels.len()];
            let mut hits = vec![0; accels.len()];
            for _ in 0..rounds {
                for (k, a) in accels.iter().enumerate() {
                    let (t, h) = trace(a, rays, any);
                    best[k] = best[k].min(t);
                    hits[k] = h;
                }
            }
            assert!(
                hits.iter().all(|&h| h == hits[0]),
                "{kind}: hits differ {hits:?}"
            );
            print!("  {kind:<8} {:>8} rays, Mrays/s:", rays.len());
            for (k, v) in variants.iter().enumerate() {
                print!(
                    " {} {:.2} ({:.3})",
                    v.name,
                    rays.len() as f64 / best[k] / 1e6,
                    best[0] / best[k]
                );
            }
            println!();
        }
    }
}
