//! The least storage any identical conversion of a BVH into a two-plane
//! tree can have: a yardstick for `dst` and the BIH.
//!
//! An identical conversion carves every face of a child's box that differs
//! from its parent's box, except the one its splitting node's plane gives
//! (the first child's maximum or the second child's minimum on the split
//! axis). A carving node removes at most two faces (one axis's two, or one
//! face on each of two axes), so a child with `f` such faces needs at least
//! `ceil(f / 2)` 12-byte carving nodes; a leaf child with none is a 4-byte
//! plain leaf; every inner node is a 12-byte splitting node; the triangle
//! index list is the BVH's. The bound takes the best split axis and child
//! order at every node.

use crate::bvh::{Bvh, NodeKind};
use crate::geometry::Aabb;

/// Faces of `child` that differ from `parent`'s, per axis `[min, max]`.
fn differing_faces(child: &Aabb, parent: &Aabb) -> [[bool; 2]; 3] {
    std::array::from_fn(|a| [child.min[a] != parent.min[a], child.max[a] != parent.max[a]])
}

/// Least words under a splitting node on `axis` for a child whose face
/// `side` (0 min, 1 max) on that axis the split's plane gives.
fn child_words(faces: [[bool; 2]; 3], axis: usize, side: usize, leaf: bool) -> usize {
    let mut to_carve = 0;
    for (a, f) in faces.iter().enumerate() {
        for (s, &differs) in f.iter().enumerate() {
            to_carve += usize::from(differs && !(a == axis && s == side));
        }
    }
    match to_carve.div_ceil(2) {
        0 if leaf => 1,
        nodes => 3 * nodes,
    }
}

/// The least bytes (nodes and triangle index list) of any identical
/// two-plane conversion of `bvh`.
pub fn least_identical_bytes(bvh: &Bvh) -> usize {
    if bvh.prims.is_empty() {
        return 0;
    }
    let mut words = usize::from(bvh.nodes[0].is_leaf());
    for node in &bvh.nodes {
        let NodeKind::Inner { left, right, .. } = node.kind else {
            continue;
        };
        let (l, r) = (&bvh.nodes[left as usize], &bvh.nodes[right as usize]);
        let fl = differing_faces(&l.bounds, &node.bounds);
        let fr = differing_faces(&r.bounds, &node.bounds);
        let best = (0..3)
            .map(|a| {
                let left_first =
                    child_words(fl, a, 1, l.is_leaf()) + child_words(fr, a, 0, r.is_leaf());
                let right_first =
                    child_words(fr, a, 1, r.is_leaf()) + child_words(fl, a, 0, l.is_leaf());
                left_first.min(right_first)
            })
            .min()
            .unwrap_or(0);
        words += 3 + best;
    }
    4 * (words + bvh.prims.len())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_carving_node_removes_two_faces() {
        let none = [[false; 2]; 3];
        assert_eq!(child_words(none, 0, 1, true), 1);
        assert_eq!(child_words(none, 0, 1, false), 0);
        // The split's own face is free; any other two share a node.
        let split_face = [[false, true], [false; 2], [false; 2]];
        assert_eq!(child_words(split_face, 0, 1, false), 0);
        assert_eq!(child_words(split_face, 1, 1, false), 3);
        let two_axes = [[true, false], [false, true], [false; 2]];
        assert_eq!(child_words(two_axes, 2, 0, true), 3);
        let all = [[true; 2]; 3];
        assert_eq!(child_words(all, 0, 0, true), 9);
    }
}
