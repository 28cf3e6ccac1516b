//! Conversion of the canonical BVH into an H-tree with the BVH's
//! partitioning (baselines.md §5).
//!
//! For every BVH inner node with cell `V` (its box; the scene box at the
//! root), each of the three axes and both child orders give a candidate
//! split: the first child's cell is `V` with `max[axis]` lowered to the
//! first child's maximum, the second's is `V` with `min[axis]` raised to
//! the second child's minimum. A child whose cell is larger than its box
//! gets one bounding node storing exactly the `m` faces that differ. The
//! cost of a child is
//!
//! `C = (S_cell/S)·C_B(m) + (S_box/S)·C_I·T`, with `C_B(m) = 0.15·m·C_I`
//!
//! (`C_B = 0` when nothing differs), and the candidate of least total cost
//! wins; ties keep the BVH's order and the lowest axis. Two faces cost
//! `0.3·C_I`, the dual-split paper's σ for a two-plane node. Havran et
//! al.'s own rule, which inserts a bounding node only when it pays, would
//! change the partitioning; Lin et al. compare an identical H-tree, and so
//! does raytree.

use crate::bvh::{Bvh, NodeKind};
use crate::geometry::Aabb;
use crate::structures::dst::convert::triangle_counts;

/// Cost of one face of a bounding node, relative to a triangle test.
pub const FACE_COST: f32 = 0.15;

/// An H-tree subtree before encoding.
#[derive(Clone, Debug, PartialEq)]
pub enum Tree {
    Split {
        axis: u8,
        planes: [f32; 2],
        kids: Box<[Tree; 2]>,
    },
    /// A bounding node storing the faces in `mask` (their positions in
    /// `planes`, in mask order).
    Bound {
        mask: u8,
        planes: [f32; 6],
        child: Box<Tree>,
    },
    /// BVH leaf `node`'s triangles.
    Leaf { node: u32 },
}

/// Subtrees with more triangles than this convert on another thread.
const PARALLEL: u32 = 4096;

/// The faces by which `cell` is larger than `target`: the mask and the
/// target's planes in mask order.
pub fn excess_faces(cell: &Aabb, target: &Aabb) -> (u8, [f32; 6]) {
    let (c, t) = (cell.to_array(), target.to_array());
    let mut mask = 0u8;
    let mut planes = [0.0; 6];
    let mut n = 0;
    for k in 0..6 {
        if c[k] != t[k] {
            mask |= 1 << k;
            planes[n] = t[k];
            n += 1;
        }
    }
    (mask, planes)
}

/// Converts the whole BVH.
pub fn convert_bvh(bvh: &Bvh) -> Tree {
    let counts = triangle_counts(bvh);
    convert(bvh, crate::bvh::ROOT, &counts)
}

/// Converts BVH node `id`, whose cell is its own box.
fn convert(bvh: &Bvh, id: u32, counts: &[u32]) -> Tree {
    let node = &bvh.nodes[id as usize];
    let [l, r] = match node.kind {
        NodeKind::Leaf { .. } => return Tree::Leaf { node: id },
        NodeKind::Inner { left, right, .. } => [left, right],
    };
    let cell = node.bounds;
    let inv = 1.0 / cell.area().max(f32::MIN_POSITIVE);
    let child_cost = |child_cell: &Aabb, child: u32| {
        let b = &bvh.nodes[child as usize].bounds;
        let m = excess_faces(child_cell, b).0.count_ones() as f32;
        (child_cell.area() * FACE_COST * m + b.area() * counts[child as usize] as f32) * inv
    };
    let mut best: Option<(f32, u8, [u32; 2])> = None;
    for axis in 0..3u8 {
        for order in [[l, r], [r, l]] {
            let [fc, sc] = split_cells(bvh, &cell, axis, order);
            let cost = child_cost(&fc, order[0]) + child_cost(&sc, order[1]);
            if best.is_none_or(|b| cost < b.0) {
                best = Some((cost, axis, order));
            }
        }
    }
    let (_, axis, order) = best.expect("three axes tried");
    let cells = split_cells(bvh, &cell, axis, order);
    let sub = |k: usize| -> Tree {
        let child = order[k];
        let inner = convert(bvh, child, counts);
        let (mask, planes) = excess_faces(&cells[k], &bvh.nodes[child as usize].bounds);
        if mask == 0 {
            inner
        } else {
            Tree::Bound {
                mask,
                planes,
                child: Box::new(inner),
            }
        }
    };
    let kids = if counts[id as usize] > PARALLEL {
        rayon::join(|| sub(0), || sub(1))
    } else {
        (sub(0), sub(1))
    };
    let a = axis as usize;
    Tree::Split {
        axis,
        planes: [cells[0].max[a], cells[1].min[a]],
        kids: Box::new([kids.0, kids.1]),
    }
}

/// The two children's cells of a split of `cell` on `axis` with children
/// `order` (first, second).
fn split_cells(bvh: &Bvh, cell: &Aabb, axis: u8, order: [u32; 2]) -> [Aabb; 2] {
    let a = axis as usize;
    let mut f = *cell;
    f.max[a] = bvh.nodes[order[0] as usize].bounds.max[a];
    let mut s = *cell;
    s.min[a] = bvh.nodes[order[1] as usize].bounds.min[a];
    [f, s]
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;

    #[test]
    fn excess_faces_are_the_differing_ones_in_mask_order() {
        let cell = Aabb::new(Vec3::ZERO, Vec3::splat(10.0));
        let t = Aabb::new(Vec3::new(0.0, 1.0, 0.0), Vec3::new(10.0, 10.0, 7.0));
        let (mask, planes) = excess_faces(&cell, &t);
        assert_eq!(mask, 0b100_010);
        assert_eq!(&planes[..2], &[1.0, 7.0]);
        assert_eq!(excess_faces(&cell, &cell).0, 0);
    }
}
