//! Every structure agrees with the brute-force oracle on mixed ray sets.

use crate::common;

use rayon::prelude::*;
use raytree::prelude::*;
use raytree::structures::{Built, StructureKind, TraversalKind, WithAccel};

/// Closest hits must be identical (same t, triangle and barycentrics: the
/// same triangle test and tie rule run in both); any-hit answers must agree
/// on hit or miss, and a reported hit must lie within the ray's interval.
fn check<A: Accel>(accel: &A, oracle: &Oracle, rays: &[Ray], what: &str) {
    let bad: Vec<String> = rays
        .par_iter()
        .enumerate()
        .filter_map(|(i, r)| {
            let want = oracle.closest[i];
            let triangles = &oracle.triangles;
            let oracle = &oracle.brute;
            let got = accel.closest_hit(r, &mut NoStats);
            if !common::same_closest(got, want, oracle, r) {
                return Some(format!("ray {i} {r:?}: closest {got:?}, oracle {want:?}"));
            }
            // The same hit with the triangle's vertices, from the leaf where
            // the structure keeps copies (the wide trees always do).
            let located = accel.closest_hit_triangle(r, &mut NoStats);
            if located.map(|(h, _)| h) != got {
                return Some(format!(
                    "ray {i}: closest_hit_triangle {located:?}, closest {got:?}"
                ));
            }
            if let Some((h, t)) = located {
                let wide = matches!(accel.name(), "bvh4" | "bvh8" | "cwbvh");
                if t.is_none() && wide {
                    return Some(format!("ray {i}: {} gave no triangle", accel.name()));
                }
                if t.is_some_and(|t| t != triangles[h.prim as usize]) {
                    return Some(format!("ray {i}: triangle {t:?} is not {}'s", h.prim));
                }
            }
            let any = accel.any_hit(r, &mut NoStats);
            if any.is_some() != want.is_some() {
                return Some(format!("ray {i}: any-hit {any:?}, oracle {want:?}"));
            }
            if let Some(h) = any {
                if !(h.t >= r.tmin && h.t <= r.tmax) {
                    return Some(format!("ray {i}: any-hit t {} outside interval", h.t));
                }
            }
            None
        })
        .collect();
    assert!(
        bad.is_empty(),
        "{what}: {} of {} rays disagree; first: {}",
        bad.len(),
        rays.len(),
        bad[0]
    );
}

/// The brute-force closest hits of a ray set, computed once per scene.
struct Oracle {
    brute: BruteForce,
    triangles: Vec<Triangle>,
    closest: Vec<Option<Hit>>,
}

impl Oracle {
    fn new(scene: &Scene, rays: &[Ray]) -> Self {
        let brute = BruteForce::new(scene.triangles.clone());
        let closest = rays
            .par_iter()
            .map(|r| brute.closest_hit(r, &mut NoStats))
            .collect();
        Oracle {
            brute,
            triangles: scene.triangles.to_vec(),
            closest,
        }
    }
}

/// [`check`] through [`Built::with`].
struct Check<'a>(&'a Oracle, &'a [Ray], String);

impl WithAccel for Check<'_> {
    type Output = ();
    fn run<A: Accel>(self, a: &A) {
        check(a, self.0, self.1, &self.2)
    }
}

fn check_scene(scene: &Scene, rays: usize) {
    let rays = common::mixed_rays(scene, rays, 7);
    let oracle = Oracle::new(scene, &rays);
    let hits = oracle.closest.iter().filter(|h| h.is_some()).count();
    assert!(
        hits > rays.len() / 5 && hits < rays.len(),
        "{}: a poor ray set ({hits} hits)",
        scene.name
    );
    for (builder, opts) in common::build_variants() {
        let bvh = Bvh::build(&scene.triangles, &opts);
        bvh.validate(&scene.triangles).unwrap();
        // Every structure derived from the BVH.
        for &kind in StructureKind::all() {
            if kind == StructureKind::Brute {
                continue;
            }
            let (built, _) =
                Built::new(kind, TraversalKind::Stack, &bvh, scene.triangles.clone()).unwrap();
            let what = format!("{} {}/{builder}", scene.name, kind.name());
            built.with(Check(&oracle, &rays, what));
        }
    }
}

#[test]
fn chess_agrees_with_oracle() {
    check_scene(&Scene::builtin("chess:2000").unwrap(), 100_000);
}

#[test]
fn hairball_agrees_with_oracle() {
    check_scene(&Scene::builtin("hairball:3000").unwrap(), 100_000);
}

#[test]
fn paper_analogue_scenes_agree_with_oracle() {
    for spec in ["atrium:6000", "forest:4000", "plant:4000"] {
        check_scene(&Scene::builtin(spec).unwrap(), 100_000);
    }
}

#[test]
fn shared_meshes_agree_with_oracle() {
    // The brute-force answers dominate the test's time (rays × triangles):
    // 30,000 rays on the 65,000- and 70,000-triangle meshes.
    for (name, rays) in [
        ("teapot.obj", 100_000),
        ("bunny.obj", 30_000),
        ("battlefield.obj", 30_000),
    ] {
        match common::shared_scene(name) {
            Some(p) => check_scene(&Scene::load(p).unwrap(), rays),
            None => eprintln!("skipping {name}: ../shared/scenes is not present"),
        }
    }
}

#[test]
fn every_leaf_size_agrees_with_oracle() {
    let scene = Scene::builtin("hairball:2000").unwrap();
    let rays = common::mixed_rays(&scene, 10_000, 3);
    let oracle = Oracle::new(&scene, &rays);
    for leaf in 1..=8 {
        for (builder, opts) in common::build_variants() {
            let bvh = Bvh::build(&scene.triangles, &opts.with_max_leaf_size(leaf));
            for &kind in StructureKind::all() {
                if kind == StructureKind::Brute {
                    continue;
                }
                let (built, _) =
                    Built::new(kind, TraversalKind::Stack, &bvh, scene.triangles.clone()).unwrap();
                let what = format!("leaf {leaf} {} {builder}", kind.name());
                built.with(Check(&oracle, &rays, what));
            }
        }
    }
}

/// References under each node of `bvh`, by node id.
fn subtree_refs(bvh: &Bvh) -> Vec<u32> {
    let mut refs = vec![0u32; bvh.nodes.len()];
    // Preorder: every child's id is above its parent's.
    for i in (0..bvh.nodes.len()).rev() {
        refs[i] = match bvh.nodes[i].kind {
            raytree::bvh::NodeKind::Leaf { count, .. } => count,
            raytree::bvh::NodeKind::Inner { left, right, .. } => {
                refs[left as usize] + refs[right as usize]
            }
        };
    }
    refs
}

/// With SAH leaf costs in blocks of `b` triangles, no node of at most `b`
/// references is split (when the leaf size allows), leaves keep to the
/// leaf size, the tree is valid, and where leaves may hold a block it has
/// fewer leaves than the per-triangle build; per-triangle cost is 1 block, so `sah_block = 1`
/// builds the same tree as the default options.
#[test]
fn sah_blocks_make_fuller_leaves() {
    let scene = Scene::builtin("hairball:4000").unwrap();
    let tris = &scene.triangles;
    for base in [BuildOptions::sah(), BuildOptions::sbvh()] {
        let plain = Bvh::build(tris, &base);
        let one = Bvh::build(tris, &base.clone().with_sah_block(1));
        assert_eq!(plain.nodes, one.nodes, "{}", base.builder.name());
        assert_eq!(plain.prims, one.prims, "{}", base.builder.name());
        for (block, leaf) in [(2, 8), (4, 8), (8, 8), (16, 8), (4, 2), (16, 16)] {
            let opts = base.clone().with_sah_block(block).with_max_leaf_size(leaf);
            let bvh = Bvh::build(tris, &opts);
            let what = format!("{} block {block} leaf {leaf}", base.builder.name());
            bvh.validate(tris).unwrap_or_else(|e| panic!("{what}: {e}"));
            assert_eq!(bvh.stats.sah_block, block, "{what}");
            let refs = subtree_refs(&bvh);
            for (i, n) in bvh.nodes.iter().enumerate() {
                if n.is_leaf() {
                    assert!(refs[i] as usize <= leaf, "{what}: leaf {i} of {}", refs[i]);
                } else {
                    assert!(
                        refs[i] as usize > block.min(leaf),
                        "{what}: inner node {i} over {} references",
                        refs[i]
                    );
                }
            }
            if leaf < block {
                continue;
            }
            // Fuller leaves: fewer of them than per-triangle costs give.
            let base_leaf = Bvh::build(tris, &base.clone().with_max_leaf_size(leaf));
            assert!(
                bvh.stats.leaves < base_leaf.stats.leaves,
                "{what}: {} leaves, {} per triangle",
                bvh.stats.leaves,
                base_leaf.stats.leaves
            );
        }
    }
}
