//! Conversion of the canonical BVH into a dual-split tree (§4.2).
//!
//! Each BVH inner node becomes a splitting node on the axis (and child
//! order) of least SAH cost, each child followed by up to three carving
//! nodes chosen by [`super::plan::best_plan`]. The identical conversion
//! carves every excess plane, so each child's region equals its BVH box bit
//! for bit; the similar conversion tracks the actual regions and lets SAH
//! leave planes for deeper levels. Subtrees convert in parallel.

use super::plan::{best_plan, CarveOp, Plan, Rules};
use crate::bvh::{Bvh, NodeKind};
use crate::geometry::Aabb;

/// A dual-split subtree before encoding.
#[derive(Clone, Debug, PartialEq)]
pub enum Tree {
    Split {
        axis: u8,
        /// The first child's maximum and the second child's minimum on `axis`.
        planes: [f32; 2],
        kids: Box<[Tree; 2]>,
    },
    /// A carving node over `child`, or a carving leaf when `child` is a
    /// [`Tree::Leaf`] that it absorbs (see [`Tree::chain`]).
    Carve { op: CarveOp, child: Box<Tree> },
    /// BVH leaf `node`'s triangles.
    Leaf { node: u32 },
}

/// Subtrees with more triangles than this convert on another thread.
const PARALLEL: u32 = 4096;

/// Converts BVH node `id`, whose region is `cell` (it contains the node's
/// box), under `rules`.
pub fn convert(bvh: &Bvh, id: u32, cell: Aabb, rules: Rules, counts: &[u32]) -> Tree {
    let node = &bvh.nodes[id as usize];
    let [l, r] = match node.kind {
        NodeKind::Leaf { .. } => {
            // A root leaf: its region is its box already.
            return Tree::Leaf { node: id };
        }
        NodeKind::Inner { left, right, .. } => [left, right],
    };
    let area = cell.area();
    // Candidates: axis × which child comes first (lower on the axis).
    let mut best: Option<(f32, u8, [u32; 2], [Plan; 2])> = None;
    for axis in 0..3u8 {
        for order in [[l, r], [r, l]] {
            let (f, s) = (
                &bvh.nodes[order[0] as usize].bounds,
                &bvh.nodes[order[1] as usize].bounds,
            );
            let a = axis as usize;
            let mut fcell = cell;
            fcell.max[a] = f.max[a];
            let mut scell = cell;
            scell.min[a] = s.min[a];
            let pf = best_plan(&fcell, f, counts[order[0] as usize], area, rules);
            let ps = best_plan(&scell, s, counts[order[1] as usize], area, rules);
            let cost = pf.cost + ps.cost;
            if best.as_ref().is_none_or(|b| cost < b.0) {
                best = Some((cost, axis, order, [pf, ps]));
            }
        }
    }
    let (_, axis, order, [pf, ps]) = best.expect("three axes tried");
    let a = axis as usize;
    let planes = [
        bvh.nodes[order[0] as usize].bounds.max[a],
        bvh.nodes[order[1] as usize].bounds.min[a],
    ];
    let sub = |child: u32, plan: Plan| -> Tree {
        let inner = if bvh.nodes[child as usize].is_leaf() {
            Tree::Leaf { node: child }
        } else {
            convert(bvh, child, plan.cell, rules, counts)
        };
        Tree::chain(plan.ops, inner)
    };
    let kids = if counts[id as usize] > PARALLEL {
        rayon::join(|| sub(order[0], pf), || sub(order[1], ps))
    } else {
        (sub(order[0], pf), sub(order[1], ps))
    };
    Tree::Split {
        axis,
        planes,
        kids: Box::new([kids.0, kids.1]),
    }
}

impl Tree {
    /// `ops` as nested carving nodes above `inner`.
    pub fn chain(ops: Vec<CarveOp>, inner: Tree) -> Tree {
        ops.into_iter().rev().fold(inner, |child, op| Tree::Carve {
            op,
            child: Box::new(child),
        })
    }
}

/// Triangles under every BVH node.
pub fn triangle_counts(bvh: &Bvh) -> Vec<u32> {
    let mut counts = vec![0u32; bvh.nodes.len()];
    for i in (0..bvh.nodes.len()).rev() {
        counts[i] = match bvh.nodes[i].kind {
            NodeKind::Leaf { count, .. } => count,
            NodeKind::Inner { left, right, .. } => counts[left as usize] + counts[right as usize],
        };
    }
    counts
}
