use crate::geometry::Aabb;

/// A node of the canonical [`super::Bvh`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Node {
    pub bounds: Aabb,
    /// The parent's id, or [`super::NO_PARENT`] for the root.
    pub parent: u32,
    /// Distance from the root (root = 0).
    pub depth: u32,
    pub kind: NodeKind,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum NodeKind {
    /// Two children, `left` = this node's id + 1; `axis` is the axis the
    /// builder split (0, 1, 2).
    Inner { left: u32, right: u32, axis: u8 },
    /// Triangles `prims[first .. first + count]`.
    Leaf { first: u32, count: u32 },
}

impl Node {
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
