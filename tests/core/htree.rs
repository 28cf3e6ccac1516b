//! The H-tree: its cells are the BVH's boxes bit for bit, its nodes decode
//! to what was encoded and its storage adds up.

use crate::common;

use raytree::prelude::*;
use raytree::structures::htree::node::HNode;
use raytree::structures::HTree;
use raytree::structures::LAST;
use std::collections::{HashMap, HashSet};

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

/// Walks the tree from the scene box: `node(at, decoded, cell on entry)` at
/// every node, `leaf(cell, triangles)` at every leaf. Returns the words
/// visited.
fn walk(
    h: &HTree,
    leaf: &mut dyn FnMut(Aabb, Vec<u32>),
    node: &mut dyn FnMut(usize, HNode, Aabb),
) -> usize {
    let mut todo = vec![(0usize, h.root_bounds())];
    let mut words = 0;
    while let Some((at, mut cell)) = todo.pop() {
        let n = h.node(at);
        node(at, n, cell);
        words += n.words();
        match n {
            HNode::Split {
                axis,
                planes,
                second,
            } => {
                let a = axis as usize;
                let mut c0 = cell;
                c0.max[a] = planes[0];
                let mut c1 = cell;
                c1.min[a] = planes[1];
                todo.push((at + 3, c0));
                todo.push((at + second as usize, c1));
            }
            HNode::Bound { mask, planes } => {
                let mut b = cell.to_array();
                let mut j = 0;
                for (k, v) in b.iter_mut().enumerate() {
                    if mask >> k & 1 == 1 {
                        *v = planes[j];
                        j += 1;
                    }
                }
                cell = Aabb::from_array(&b);
                todo.push((at + n.words(), cell));
            }
            HNode::Leaf { offset } => {
                let mut prims = vec![];
                let mut i = offset as usize;
                loop {
                    let e = h.index_list()[i];
                    prims.push(e & !LAST);
                    if e & LAST != 0 {
                        break;
                    }
                    i += 1;
                }
                leaf(cell, prims);
            }
        }
    }
    words
}

#[test]
fn cells_equal_the_bvh_boxes_bit_for_bit() {
    let bits = |b: &Aabb| b.to_array().map(f32::to_bits);
    for scene in scenes() {
        for builder in Builder::ALL {
            for max_leaf in [1, 4, 8] {
                let bvh = Bvh::build(
                    &scene.triangles,
                    &BuildOptions::new(builder).with_max_leaf_size(max_leaf),
                );
                let h = HTree::from_bvh(&bvh, scene.triangles.clone()).unwrap();
                // A leaf by its triangles and box (spatial splits list a
                // triangle in several leaves, each with its own box).
                let leaf_of: HashMap<(Vec<u32>, [u32; 6]), usize> = bvh
                    .nodes
                    .iter()
                    .enumerate()
                    .filter(|(_, n)| n.is_leaf())
                    .map(|(i, n)| ((bvh.leaf_prims(n).to_vec(), bits(&n.bounds)), i))
                    .collect();
                let inner: HashSet<[u32; 6]> = bvh
                    .nodes
                    .iter()
                    .filter(|n| !n.is_leaf())
                    .map(|n| bits(&n.bounds))
                    .collect();
                let mut seen = vec![0; bvh.nodes.len()];
                let (mut splits, mut bounds) = (0, 0);
                let words = walk(
                    &h,
                    &mut |cell, prims| {
                        let id = leaf_of[&(prims.to_vec(), bits(&cell))];
                        seen[id] += 1;
                        let n = &bvh.nodes[id];
                        assert_eq!(prims, bvh.leaf_prims(n));
                        assert_eq!(bits(&cell), bits(&n.bounds), "{} leaf {id}", scene.name);
                    },
                    &mut |at, n, cell| {
                        // Re-encoding gives the stored words.
                        let mut w = vec![];
                        n.encode(&mut w).unwrap();
                        assert_eq!(&w[..], &h.words()[at..at + n.words()]);
                        match n {
                            HNode::Split { .. } => {
                                splits += 1;
                                assert!(inner.contains(&bits(&cell)), "{}", scene.name);
                            }
                            HNode::Bound { mask, .. } => {
                                bounds += 1;
                                assert!(mask != 0);
                            }
                            HNode::Leaf { .. } => {}
                        }
                    },
                );
                for (i, n) in bvh.nodes.iter().enumerate() {
                    assert_eq!(seen[i], n.is_leaf() as i32, "BVH node {i}");
                }
                let s = &h.stats;
                assert_eq!(splits, bvh.stats.inner_nodes);
                assert_eq!((s.split_nodes, s.bound_nodes), (splits, bounds));
                assert_eq!(s.leaves, bvh.stats.leaves);
                // Storage: 12 per split, 4 + 4·faces per bounding node, 4 per
                // leaf, 4 per triangle reference; every word in one node.
                let faces: usize = (1..=6).map(|m| m * s.bound_faces[m]).sum();
                assert_eq!(
                    s.node_bytes,
                    12 * s.split_nodes + 4 * s.bound_nodes + 4 * faces + 4 * s.leaves
                );
                assert_eq!(words * 4, s.node_bytes);
                assert_eq!(h.bytes(), s.node_bytes + 4 * bvh.prims.len());
            }
        }
    }
}

#[test]
fn plane_tests_are_two_per_split_and_one_per_face() {
    let scene = Scene::builtin("chess:4000").unwrap();
    let bvh = Bvh::build(&scene.triangles, &BuildOptions::sah());
    let h = HTree::from_bvh(&bvh, scene.triangles.clone()).unwrap();
    let rays = common::mixed_rays(&scene, 2000, 5);
    for r in &rays {
        let mut log = VisitLog::default();
        h.closest_hit(r, &mut log);
        let planes: u32 = log
            .visits
            .iter()
            .map(|&at| match h.node(at as usize) {
                HNode::Split { .. } => 2,
                HNode::Bound { mask, .. } => mask.count_ones(),
                HNode::Leaf { .. } => 0,
            })
            .sum();
        assert_eq!(log.counters.planes as u32, 6 + planes);
        assert_eq!(log.counters.nodes as usize, log.visits.len());
    }
}

#[test]
fn single_leaf_and_empty_scenes() {
    let tris: std::sync::Arc<[Triangle]> = vec![Triangle::new(Vec3::ZERO, Vec3::X, Vec3::Y)].into();
    let bvh = Bvh::build(&tris, &BuildOptions::sah());
    let h = HTree::from_bvh(&bvh, tris.clone()).unwrap();
    assert_eq!(h.bytes(), 8);
    let r = Ray::infinite(Vec3::new(0.2, 0.2, 1.0), -Vec3::Z);
    assert_eq!(h.closest_hit(&r, &mut NoStats).map(|h| h.prim), Some(0));
    let empty: std::sync::Arc<[Triangle]> = Vec::new().into();
    let bvh = Bvh::build(&empty, &BuildOptions::sah());
    let h = HTree::from_bvh(&bvh, empty).unwrap();
    assert_eq!(h.closest_hit(&r, &mut NoStats), None);
}
