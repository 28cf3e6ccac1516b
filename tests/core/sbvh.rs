//! Spatial splits (`--builder sbvh`) and the reinsertion optimizer
//! (`--optimize`) on scenes where spatial splits duplicate many references:
//! every structure and traversal against the oracle (closest, any, all hits),
//! the reference cap, saved files, and trees that only ever improve.

use crate::common;
use rayon::prelude::*;
use raytree::bvh::{NodeKind, OptimizeOptions};
use raytree::prelude::*;
use raytree::rng::Pcg32;
use raytree::structures::{Built, WithAccel};
use std::sync::Arc;

/// Thin triangles in a 20-unit cube, one in ten 20 units long and the rest
/// 0.6, in random directions: the long ones' boxes cover much of the scene
/// and overlap everything, the case spatial splits are for.
fn long_triangles(n: usize, seed: u64) -> Vec<Triangle> {
    let mut rng = Pcg32::new(seed, 1);
    (0..n)
        .map(|i| {
            let p = Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) * 20.0;
            let len = if i % 10 == 0 { 10.0 } else { 0.3 };
            let d = common::unit(&mut rng) * len;
            let w = common::unit(&mut rng) * 0.05;
            Triangle::new(p - d, p + d, p + w)
        })
        .collect()
}

fn scene_of(tris: &[Triangle]) -> Scene {
    let mut mesh = Mesh::default();
    for (i, t) in tris.iter().enumerate() {
        mesh.positions.extend([t.a, t.b, t.c]);
        let i = 3 * i as u32;
        mesh.indices.push([i, i + 1, i + 2]);
    }
    let camera = Camera::framing(&mesh.bounds());
    Scene::new("long triangles", mesh, camera)
}

/// Triangles listed in more than one leaf.
fn duplicates(bvh: &Bvh, triangles: usize) -> usize {
    let mut seen = vec![0u32; triangles];
    for &p in &bvh.prims {
        seen[p as usize] += 1;
    }
    seen.iter().filter(|&&s| s > 1).count()
}

/// A scene's rays with the oracle's answers, computed once.
struct Case {
    name: String,
    tris: Arc<[Triangle]>,
    rays: Vec<Ray>,
    oracle: BruteForce,
    closest: Vec<Option<Hit>>,
    /// Every hit of the first [`ALL_HITS`] rays.
    lists: Vec<Vec<Hit>>,
}

const ALL_HITS: usize = 1000;

/// Checks a structure against the oracle: closest hits confirmed, any hit
/// agreeing on hit or miss, and every hit listed (and counted) once.
struct Agrees<'a>(&'a Case);
impl WithAccel for Agrees<'_> {
    type Output = Result<(), String>;
    fn run<A: Accel>(self, a: &A) -> Result<(), String> {
        let c = self.0;
        raytree::par::try_for_each_index(c.rays.len(), &|i| {
            let r = &c.rays[i];
            let want = c.closest[i];
            let got = a.closest_hit(r, &mut NoStats);
            if !common::same_closest(got, want, &c.oracle, r) {
                return Err(format!("ray {i} {r:?}: closest {got:?}, oracle {want:?}"));
            }
            let any = a.any_hit(r, &mut NoStats);
            if any.is_some() != want.is_some() {
                return Err(format!("ray {i}: any {any:?}, oracle {want:?}"));
            }
            if let Some(list) = c.lists.get(i) {
                let got = a.list_hits(r);
                if &got != list {
                    return Err(format!("ray {i}: hits {got:?}, oracle {list:?}"));
                }
                if a.count_hits(r) as usize != list.len() {
                    return Err(format!("ray {i}: count differs from {}", list.len()));
                }
            }
            Ok(())
        })
    }
}

/// Every configuration built from `bvh` agrees with the oracle.
fn check(what: &str, bvh: &Bvh, c: &Case) {
    bvh.validate(&c.tris).unwrap();
    for (s, t) in common::configurations() {
        let (built, _) = Built::new(s, t, bvh, c.tris.clone()).unwrap();
        built
            .with(Agrees(c))
            .unwrap_or_else(|e| panic!("{what} {}/{}: {e}", s.name(), t.name()));
    }
}

impl Case {
    fn new(name: &str, scene: &Scene, rays: usize, seed: u64) -> Case {
        let rays = common::mixed_rays(scene, rays, seed);
        let oracle = BruteForce::new(scene.triangles.clone());
        let closest = rays
            .par_iter()
            .map(|r| oracle.closest_hit(r, &mut NoStats))
            .collect();
        let lists = rays[..ALL_HITS]
            .par_iter()
            .map(|r| oracle.list_hits(r))
            .collect();
        Case {
            name: name.into(),
            tris: scene.triangles.clone(),
            rays,
            oracle,
            closest,
            lists,
        }
    }
}

fn cases() -> Vec<Case> {
    let atrium = Scene::builtin("atrium:20000").unwrap();
    let long = scene_of(&long_triangles(3000, 5));
    vec![
        Case::new("atrium:20000", &atrium, 10_000, 3),
        Case::new("long triangles", &long, 10_000, 4),
    ]
}

#[test]
fn spatial_splits_duplicate_references_and_agree_with_the_oracle() {
    for c in cases() {
        let (name, tris) = (&c.name, &c.tris);
        let sah = Bvh::build(tris, &BuildOptions::sah());
        for leaf in [1, 8] {
            let bvh = Bvh::build(tris, &BuildOptions::sbvh().with_max_leaf_size(leaf));
            let dup = duplicates(&bvh, tris.len());
            // Spatial splits happened, many of them, within the cap.
            assert!(
                dup > tris.len() / 20,
                "{name}: only {dup} of {} triangles in several leaves",
                tris.len()
            );
            assert_eq!(bvh.stats.references, bvh.prims.len());
            assert!(bvh.prims.len() as f64 <= 1.5 * tris.len() as f64);
            if leaf == 8 {
                assert!(
                    bvh.stats.sah_cost < sah.stats.sah_cost,
                    "{name}: sbvh {} vs sah {}",
                    bvh.stats.sah_cost,
                    sah.stats.sah_cost
                );
            }
            check(&format!("{name} sbvh leaf {leaf}"), &bvh, &c);
        }
    }
}

#[test]
fn optimized_trees_keep_their_leaves_and_agree_with_the_oracle() {
    for c in cases() {
        let (name, tris) = (&c.name, &c.tris);
        for builder in Builder::ALL {
            let bvh = Bvh::build(tris, &BuildOptions::new(builder));
            let opt = bvh.optimize(&OptimizeOptions::default());
            let o = opt.stats.optimized.clone().unwrap();
            assert!(o.sah_cost_after <= o.sah_cost_before, "{name} {builder:?}");
            assert!(opt.sah_cost() <= bvh.sah_cost() * (1.0 + 1e-9));
            assert_eq!(o.sah_cost_before, bvh.sah_cost());
            let mut a = bvh.prims.clone();
            let mut b = opt.prims.clone();
            a.sort_unstable();
            b.sort_unstable();
            assert_eq!(a, b, "{name} {builder:?}: references changed");
            assert_eq!(opt.stats.leaves, bvh.stats.leaves);
            check(&format!("{name} {builder:?}+optimize"), &opt, &c);
        }
    }
}

#[test]
fn the_reference_cap_bounds_growth() {
    let tris: Vec<Triangle> = long_triangles(2000, 9);
    for growth in [1.0f32, 1.1, 1.3, 2.0] {
        let mut opts = BuildOptions::sbvh();
        opts.max_reference_growth = growth;
        let bvh = Bvh::build(&tris, &opts);
        bvh.validate(&tris).unwrap();
        assert!(
            bvh.prims.len() as f64 <= growth as f64 * tris.len() as f64,
            "growth {growth}: {} references",
            bvh.prims.len()
        );
        if growth == 1.0 {
            assert_eq!(bvh.prims.len(), tris.len());
        } else {
            assert!(bvh.prims.len() > tris.len());
        }
    }
    // α large: no node's overlap qualifies, no spatial split.
    let mut opts = BuildOptions::sbvh();
    opts.alpha = 2.0;
    let bvh = Bvh::build(&tris, &opts);
    assert_eq!(bvh.prims.len(), tris.len());
}

/// The triangles listed in the leaves under node `id`, with repeats.
fn subtree_refs(bvh: &Bvh, id: u32, out: &mut Vec<u32>) {
    match bvh.nodes[id as usize].kind {
        NodeKind::Leaf { first, count } => {
            out.extend_from_slice(&bvh.prims[first as usize..(first + count) as usize])
        }
        NodeKind::Inner { left, right, .. } => {
            subtree_refs(bvh, left, out);
            subtree_refs(bvh, right, out);
        }
    }
}

#[test]
fn spatial_splits_only_where_the_options_allow() {
    let tris = long_triangles(3000, 5);
    // A node of at most `min` references is split by objects only, so no
    // triangle is listed under both of its children; larger nodes do list
    // some under both (the test can fail).
    let min = 40;
    let mut opts = BuildOptions::sbvh();
    opts.spatial_min_refs = min;
    let bvh = Bvh::build(&tris, &opts);
    bvh.validate(&tris).unwrap();
    let (mut small, mut shared_above) = (0, 0);
    for n in &bvh.nodes {
        if let NodeKind::Inner { left, right, .. } = n.kind {
            let (mut l, mut r) = (Vec::new(), Vec::new());
            subtree_refs(&bvh, left, &mut l);
            subtree_refs(&bvh, right, &mut r);
            l.sort_unstable();
            let shared = r.iter().filter(|t| l.binary_search(t).is_ok()).count();
            if l.len() + r.len() <= min {
                small += 1;
                assert_eq!(shared, 0, "a node of {} references", l.len() + r.len());
            } else if shared > 0 {
                shared_above += 1;
            }
        }
    }
    assert!(small > 100 && shared_above > 10, "{small} {shared_above}");
    // No node large enough, or no overlap large enough against the node's
    // own surface: no spatial split.
    for (min, node_overlap) in [(tris.len(), 0.0), (0, 1e9)] {
        let mut opts = BuildOptions::sbvh();
        opts.spatial_min_refs = min;
        opts.spatial_min_node_overlap = node_overlap;
        let bvh = Bvh::build(&tris, &opts);
        assert_eq!(bvh.prims.len(), tris.len(), "{min} {node_overlap}");
    }
    // A node-relative threshold between the two keeps some spatial splits
    // and rules out others.
    let all = duplicates(&Bvh::build(&tris, &BuildOptions::sbvh()), tris.len());
    let mut opts = BuildOptions::sbvh();
    opts.spatial_min_node_overlap = 0.5;
    let some = duplicates(&Bvh::build(&tris, &opts), tris.len());
    assert!(some > 0 && some < all, "{some} of {all}");
}

#[test]
fn spatial_split_trees_are_deterministic_across_thread_counts() {
    let scene = Scene::builtin("atrium:60000").unwrap();
    let one = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .unwrap();
    let a = one.install(|| Bvh::build(&scene.triangles, &BuildOptions::sbvh()));
    let b = Bvh::build(&scene.triangles, &BuildOptions::sbvh());
    assert_eq!(a.nodes, b.nodes);
    assert_eq!(a.prims, b.prims);
    assert!(duplicates(&a, scene.triangles.len()) > 0);
    let oa = a.optimize(&OptimizeOptions::default());
    let ob = b.optimize(&OptimizeOptions::default());
    assert_eq!(oa.nodes, ob.nodes);
}

#[test]
fn inner_boxes_are_the_unions_of_their_children() {
    let tris = long_triangles(2000, 11);
    let bvh = Bvh::build(&tris, &BuildOptions::sbvh());
    for n in &bvh.nodes {
        if let NodeKind::Inner { left, right, .. } = n.kind {
            let u = bvh.nodes[left as usize]
                .bounds
                .union(bvh.nodes[right as usize].bounds);
            assert_eq!(n.bounds, u);
        }
    }
    // A leaf's box may be smaller than a triangle it lists (its part only).
    let clipped = bvh.nodes.iter().filter(|n| n.is_leaf()).any(|n| {
        bvh.leaf_prims(n)
            .iter()
            .any(|&p| !n.bounds.contains(&tris[p as usize].bounds()))
    });
    assert!(clipped);
}
