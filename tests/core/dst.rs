//! Dual-split trees: the encoding, the partitioning against the BVH's, and
//! the traversal against the oracle.

use crate::common;

use raytree::prelude::*;
use raytree::structures::dst::node::DstNode;
use raytree::structures::dst::plan::Rules;
use raytree::structures::Bih;
use raytree::structures::DualSplitTree;
use raytree::structures::LAST;
use std::collections::HashMap;

/// Walks the encoded tree from the scene box, narrowing each node's region
/// by its planes; calls `leaf(region, prims)` at every leaf and `node(at,
/// decoded, region on entry)` at every node. Returns the number of words
/// visited.
fn walk(
    t: &DualSplitTree,
    root: Aabb,
    leaf: &mut dyn FnMut(Aabb, Vec<u32>),
    node: &mut dyn FnMut(usize, DstNode, Aabb),
) -> usize {
    let mut todo = vec![(0usize, root)];
    let mut words = 0;
    while let Some((at, mut cell)) = todo.pop() {
        let n = t.node(at);
        node(at, n, cell);
        words += n.words();
        let leaf_at = |offset: u32| {
            let mut prims = vec![];
            let mut i = offset as usize;
            loop {
                let e = t_index(t)[i];
                prims.push(e & !LAST);
                if e & LAST != 0 {
                    break prims;
                }
                i += 1;
            }
        };
        match n {
            DstNode::Split {
                axis,
                planes,
                first_words,
                offset,
            } => {
                let a = axis as usize;
                let first = at + offset as usize;
                let mut c0 = cell;
                c0.max[a] = planes[0];
                let mut c1 = cell;
                c1.min[a] = planes[1];
                todo.push((first, c0));
                todo.push((first + first_words as usize, c1));
            }
            DstNode::CarveSingle {
                axis,
                planes,
                leaf: is_leaf,
                offset,
            } => {
                cell.min[axis as usize] = planes[0];
                cell.max[axis as usize] = planes[1];
                if is_leaf {
                    leaf(cell, leaf_at(offset));
                } else {
                    todo.push((at + offset as usize, cell));
                }
            }
            DstNode::CarveDual {
                axes,
                max_side,
                planes,
                leaf: is_leaf,
                offset,
            } => {
                for k in 0..2 {
                    if max_side[k] {
                        cell.max[axes[k] as usize] = planes[k];
                    } else {
                        cell.min[axes[k] as usize] = planes[k];
                    }
                }
                if is_leaf {
                    leaf(cell, leaf_at(offset));
                } else {
                    todo.push((at + offset as usize, cell));
                }
            }
            DstNode::Leaf { offset } => leaf(cell, leaf_at(offset)),
        }
    }
    words
}

fn t_index(t: &DualSplitTree) -> &[u32] {
    t.index_list()
}

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

#[test]
fn identical_conversion_reproduces_every_bvh_leaf_box_exactly() {
    for scene in scenes() {
        for builder in Builder::ALL {
            let bvh = Bvh::build(&scene.triangles, &BuildOptions::new(builder));
            // The leaves listing each set of triangles: spatial splits
            // list a triangle in several leaves, told apart by their boxes.
            let mut leaf_of: HashMap<Vec<u32>, Vec<u32>> = HashMap::new();
            for (i, n) in bvh.nodes.iter().enumerate().filter(|(_, n)| n.is_leaf()) {
                leaf_of
                    .entry(bvh.leaf_prims(n).to_vec())
                    .or_default()
                    .push(i as u32);
            }
            let inner_boxes: std::collections::HashSet<[u32; 6]> = bvh
                .nodes
                .iter()
                .filter(|n| !n.is_leaf())
                .map(|n| n.bounds.to_array().map(f32::to_bits))
                .collect();
            // The BIH is a dual-split tree without dual-axis nodes: the same
            // walk checks it.
            for rules in [Rules::IDENTICAL, Rules::SIMILAR, Rules::BIH] {
                let similar = !rules.complete;
                let t = DualSplitTree::with_rules(&bvh, scene.triangles.clone(), rules).unwrap();
                if !rules.dual {
                    assert_eq!(t.stats.carve_dual, 0);
                    let bih = Bih::from_bvh(&bvh, scene.triangles.clone()).unwrap();
                    assert_eq!(bih.tree().words(), t.words());
                }
                let mut seen = vec![0; bvh.nodes.len()];
                let mut split_regions = Vec::new();
                let words = walk(
                    &t,
                    bvh.bounds(),
                    &mut |cell, prims| {
                        let ids = &leaf_of[&prims.to_vec()];
                        let id = *ids
                            .iter()
                            .find(|&&c| {
                                let b = &bvh.nodes[c as usize].bounds;
                                seen[c as usize] == 0
                                    && if similar {
                                        cell.contains(b)
                                    } else {
                                        cell == *b
                                    }
                            })
                            .unwrap_or(&ids[0]);
                        seen[id as usize] += 1;
                        let n = &bvh.nodes[id as usize];
                        assert_eq!(prims, bvh.leaf_prims(n), "{}: leaf triangles", scene.name);
                        if similar {
                            assert!(
                                cell.contains(&n.bounds),
                                "{}: similar region must hold the leaf",
                                scene.name
                            );
                        } else {
                            assert_eq!(
                                cell, n.bounds,
                                "{}: identical region differs from the BVH leaf box",
                                scene.name
                            );
                        }
                    },
                    &mut |_, n, cell| {
                        if let DstNode::Split { .. } = n {
                            split_regions.push(cell.to_array());
                        }
                    },
                );
                assert_eq!(
                    words * 4,
                    t.stats.node_bytes,
                    "every word belongs to one node"
                );
                for (i, n) in bvh.nodes.iter().enumerate() {
                    assert_eq!(
                        seen[i],
                        n.is_leaf() as i32,
                        "BVH node {i} seen {} times",
                        seen[i]
                    );
                }
                // One splitting node per BVH inner node; with identical
                // partitioning its region is that node's box.
                assert_eq!(split_regions.len(), bvh.stats.inner_nodes);
                if !similar {
                    for r in &split_regions {
                        assert!(
                            inner_boxes.contains(&r.map(f32::to_bits)),
                            "{}: a split region {r:?} is no BVH box",
                            scene.name
                        );
                    }
                }
            }
        }
    }
}

#[test]
fn nodes_decode_to_what_was_encoded_and_sizes_add_up() {
    let scene = Scene::builtin("hairball:5000").unwrap();
    let bvh = Bvh::build(&scene.triangles, &BuildOptions::sah());
    for similar in [false, true] {
        let t = DualSplitTree::from_bvh(&bvh, scene.triangles.clone(), similar).unwrap();
        let mut kinds = [0usize; 4];
        walk(&t, bvh.bounds(), &mut |_, _| {}, &mut |at, n, _| {
            let mut w = Vec::new();
            n.encode(&mut w).unwrap();
            assert_eq!(
                &w[..],
                &t.words()[at..at + n.words()],
                "re-encoding node at {at}"
            );
            kinds[match n {
                DstNode::Split { .. } => 0,
                DstNode::CarveSingle { .. } => 1,
                DstNode::CarveDual { .. } => 2,
                DstNode::Leaf { .. } => 3,
            }] += 1;
        });
        let s = &t.stats;
        assert_eq!(
            kinds,
            [s.split_nodes, s.carve_single, s.carve_dual, s.plain_leaves]
        );
        assert_eq!(
            s.node_bytes,
            12 * (s.split_nodes + s.carve_single + s.carve_dual) + 4 * s.plain_leaves
        );
        assert_eq!(s.index_bytes, 4 * bvh.prims.len());
        // One splitting node per BVH inner node; every splitting-node child
        // has 0 to 3 carving levels.
        assert_eq!(s.split_nodes, bvh.stats.inner_nodes);
        assert_eq!(s.carving_levels.iter().sum::<usize>(), 2 * s.split_nodes);
        if !similar {
            // The similar conversion never needs more carving nodes.
            let sim = DualSplitTree::from_bvh(&bvh, scene.triangles.clone(), true).unwrap();
            assert!(sim.stats.carve_single + sim.stats.carve_dual <= s.carve_single + s.carve_dual);
            assert!(sim.stats.node_bytes <= s.node_bytes);
        }
    }
}

/// No identical conversion is smaller than the bound, and `dst` comes
/// within a few percent of it (it picks configurations by SAH, not size).
#[test]
fn identical_trees_are_no_smaller_than_the_least_identical_storage() {
    for spec in ["chess:4000", "hairball:4000", "forest:5000", "plant:5000"] {
        let scene = Scene::builtin(spec).unwrap();
        for builder in Builder::ALL {
            for leaf in [1, 4, 8] {
                let bvh = Bvh::build(
                    &scene.triangles,
                    &BuildOptions::new(builder).with_max_leaf_size(leaf),
                );
                let least = raytree::structures::dst::bound::least_identical_bytes(&bvh);
                let dst = DualSplitTree::from_bvh(&bvh, scene.triangles.clone(), false).unwrap();
                let bih = Bih::from_bvh(&bvh, scene.triangles.clone()).unwrap();
                let what = format!("{spec} {} leaf {leaf}", builder.name());
                assert_eq!(dst.stats.least_identical_bytes, least, "{what}");
                assert!(
                    dst.bytes() >= least,
                    "{what}: dst {} < {least}",
                    dst.bytes()
                );
                assert!(
                    bih.bytes() >= least,
                    "{what}: bih {} < {least}",
                    bih.bytes()
                );
                assert!(
                    (dst.bytes() as f64) < 1.1 * least as f64,
                    "{what}: dst {} far above {least}",
                    dst.bytes()
                );
            }
        }
    }
}
