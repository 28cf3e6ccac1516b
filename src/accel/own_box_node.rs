//! The 32-byte node of the stackless paper's layouts: a node holds its own
//! box, so that an inner node's children are tested by reading the two
//! adjacent sibling nodes.

use bytemuck::{Pod, Zeroable};

/// `bounds` is `[min xyz, max xyz]`. `link`: bit 31 set for a leaf; bits
/// 0–30 the left child's index (the right child follows it) or the leaf's
/// first position in the triangle index list (sign-bit terminated). `extra`
/// belongs to the layout: parent link and split axis in the sparse layout,
/// the canonical node id in the implicit one.
#[repr(C, align(32))]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct OwnBoxNode {
    pub bounds: [f32; 6],
    pub link: u32,
    pub extra: u32,
}

/// `link` bit of a leaf.
pub const LEAF: u32 = 1 << 31;

impl OwnBoxNode {
    #[inline(always)]
    pub fn is_leaf(&self) -> bool {
        self.link & LEAF != 0
    }

    /// Left child (inner) or first index-list position (leaf).
    #[inline(always)]
    pub fn target(&self) -> u32 {
        self.link & !LEAF
    }
}

#[cfg(test)]
mod tests {
    #[test]
    fn is_32_bytes() {
        assert_eq!(std::mem::size_of::<super::OwnBoxNode>(), 32);
        assert_eq!(std::mem::align_of::<super::OwnBoxNode>(), 32);
    }
}
