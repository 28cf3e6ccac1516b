//! The Compact BVH: its boxes are the BVH's bit for bit, its storage is
//! exact, and its traversal visits exactly STACK's nodes.

use crate::common;

use rayon::prelude::*;
use raytree::prelude::*;
use raytree::structures::leaf_triangles;
use raytree::structures::CompactBvh;

fn scenes() -> Vec<Scene> {
    let mut v = vec![
        Scene::builtin("chess:4000").unwrap(),
        Scene::builtin("hairball:4000").unwrap(),
    ];
    if let Some(p) = common::shared_scene("teapot.obj") {
        v.push(Scene::load(p).unwrap());
    }
    v
}

/// Walks the compact tree from the scene box, rebuilding every child box;
/// returns (canonical id, rebuilt box, triangles of a leaf) for every node.
fn walk(c: &CompactBvh) -> Vec<(u32, Aabb, Vec<u32>)> {
    let mut out = vec![];
    let mut todo = vec![(c.root(), c.root_bounds())];
    while let Some((r, b)) = todo.pop() {
        let mut prims = vec![];
        if let Some(first) = c.leaf_start(r) {
            prims.extend(leaf_triangles(c.index_list(), first));
        } else {
            let n = &c.nodes()[r as usize];
            let kids = n.decode(&b);
            todo.push((n.child(0), kids[0]));
            todo.push((n.child(1), kids[1]));
        }
        out.push((c.canonical_id(r), b, prims));
    }
    out
}

#[test]
fn rebuilt_boxes_equal_the_bvh_boxes_bit_for_bit() {
    for scene in scenes() {
        for builder in Builder::ALL {
            for leaf in [1, 4, 8] {
                let bvh = Bvh::build(
                    &scene.triangles,
                    &BuildOptions::new(builder).with_max_leaf_size(leaf),
                );
                let c = CompactBvh::from_bvh(&bvh, scene.triangles.clone()).unwrap();
                let nodes = walk(&c);
                // Every BVH node exactly once.
                assert_eq!(nodes.len(), bvh.nodes.len(), "{}", scene.name);
                let mut seen = vec![false; bvh.nodes.len()];
                for (id, b, prims) in nodes {
                    let n = &bvh.nodes[id as usize];
                    assert!(!seen[id as usize]);
                    seen[id as usize] = true;
                    let bits = |b: &Aabb| b.to_array().map(f32::to_bits);
                    assert_eq!(bits(&b), bits(&n.bounds), "{} node {id}", scene.name);
                    assert_eq!(
                        prims,
                        if n.is_leaf() {
                            bvh.leaf_prims(n).to_vec()
                        } else {
                            vec![]
                        }
                    );
                }
                // 32 bytes per inner node, 4 per triangle reference.
                assert_eq!(
                    c.bytes(),
                    32 * bvh.stats.inner_nodes + 4 * bvh.prims.len(),
                    "{}",
                    scene.name
                );
                let b = BinaryBvh::from_bvh(&bvh, scene.triangles.clone()).unwrap();
                // Nodes: 32 per inner node against 52 per inner node and 4
                // per leaf, i.e. 32/56 (the paper's 57%).
                let i = bvh.stats.inner_nodes;
                assert_eq!(b.node_bytes(), 52 * i + 4 * (i + 1));
                assert_eq!(c.node_bytes(), 32 * i);
            }
        }
    }
}

#[test]
fn traversal_visits_exactly_stacks_nodes() {
    for scene in scenes() {
        let rays = common::mixed_rays(&scene, 30_000, 11);
        for builder in Builder::ALL {
            let bvh = Bvh::build(&scene.triangles, &BuildOptions::new(builder));
            let b = BinaryBvh::from_bvh(&bvh, scene.triangles.clone()).unwrap();
            let c = CompactBvh::from_bvh(&bvh, scene.triangles.clone()).unwrap();
            rays.par_iter().enumerate().for_each(|(i, r)| {
                for any in [false, true] {
                    let (mut lb, mut lc) = (VisitLog::default(), VisitLog::default());
                    let (hb, hc) = if any {
                        (b.any_hit(r, &mut lb), c.any_hit(r, &mut lc))
                    } else {
                        (b.closest_hit(r, &mut lb), c.closest_hit(r, &mut lc))
                    };
                    assert_eq!(hb, hc, "{} ray {i} any={any}", scene.name);
                    assert_eq!(lb.visits, lc.visits, "{} ray {i} any={any}", scene.name);
                    assert_eq!(lb.counters.nodes, lc.counters.nodes);
                    assert_eq!(lb.counters.triangles, lc.counters.triangles);
                    // Half the plane tests at inner nodes: 6 for the root box,
                    // then 6 per inner node against 12.
                    let inner = (lb.counters.planes - 6) / 12;
                    if lb.counters.planes > 0 {
                        assert_eq!(lc.counters.planes, 6 + 6 * inner);
                    }
                }
            });
        }
    }
}

#[test]
fn single_leaf_and_empty_scenes() {
    let tri = Triangle::new(Vec3::ZERO, Vec3::X, Vec3::Y);
    let tris: std::sync::Arc<[Triangle]> = vec![tri].into();
    let bvh = Bvh::build(&tris, &BuildOptions::sah());
    let c = CompactBvh::from_bvh(&bvh, tris.clone()).unwrap();
    assert_eq!(c.nodes().len(), 0);
    assert_eq!(c.bytes(), 4);
    let r = Ray::infinite(Vec3::new(0.2, 0.2, 1.0), -Vec3::Z);
    assert_eq!(c.closest_hit(&r, &mut NoStats).map(|h| h.prim), Some(0));
    let miss = Ray::infinite(Vec3::new(2.0, 0.2, 1.0), -Vec3::Z);
    assert_eq!(c.any_hit(&miss, &mut NoStats), None);
}
