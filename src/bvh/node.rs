use crate::geometry::Aabb;

/// A node of the canonical [`super::Bvh`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Node {
    /// The box of the node's triangles, in scene units.
    pub bounds: Aabb,
    /// The parent's id, or [`super::NO_PARENT`] for the root.
    pub parent: u32,
    /// Distance from the root (root = 0).
    pub depth: u32,
    /// Inner node or leaf, with its children or triangles.
    pub kind: NodeKind,
}

/// What a [`Node`] holds.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum NodeKind {
    /// Two children, `left` = this node's id + 1; `axis` is the axis the
    /// builder split (0, 1, 2).
    Inner {
        /// Id of the left child: always this node's id + 1 (preorder).
        left: u32,
        /// Id of the right child, after the left child's whole subtree.
        right: u32,
        /// The axis the builder split on: 0 = x, 1 = y, 2 = z.
        axis: u8,
    },
    /// Triangles `prims[first .. first + count]`.
    Leaf {
        /// Start of the leaf's range in [`super::Bvh::prims`].
        first: u32,
        /// Number of triangles: 1..=`max_leaf_size`, 0 only for the root of
        /// a tree over no triangles.
        count: u32,
    },
}

impl Node {
    /// The one node of a tree over no triangles: an empty leaf.
    pub const EMPTY_ROOT: Node = Node {
        bounds: Aabb::EMPTY,
        parent: super::NO_PARENT,
        depth: 0,
        kind: NodeKind::Leaf { first: 0, count: 0 },
    };

    /// Whether the node is a [`NodeKind::Leaf`].
    pub fn is_leaf(&self) -> bool {
        matches!(self.kind, NodeKind::Leaf { .. })
    }

    /// `[left, right]` for an inner node.
    pub fn children(&self) -> Option<[u32; 2]> {
        match self.kind {
            NodeKind::Inner { left, right, .. } => Some([left, right]),
            NodeKind::Leaf { .. } => None,
        }
    }
}
