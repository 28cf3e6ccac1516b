//! The traversal's copy of the binary BVH: each inner node on one 64-byte
//! cache line, and each child referenced directly, so that a step reads one
//! line and a leaf goes straight to its triangle blocks.
//!
//! The 52-byte words of the module docs stay the structure's encoding (the
//! dual-split paper's storage model, the saved file, the GPU upload); this
//! copy is derived from them when the structure is built or loaded, like
//! the leaves' triangle blocks
//! ([`crate::structures::shared::tri_block::LeafBlocks`]), and is not counted in
//! [`crate::structures::Accel::bytes`]: 64 bytes per inner node
//! ([`BinaryBvh::line_bytes`]).
//!
//! Measured against STACK over the words (`examples/paper_speed` on
//! battlefield.obj, one thread, alternated): 0.93× the kernel time. A 52-byte
//! node at a 4-byte offset spans two cache lines four times in five, and a
//! leaf reached through the words costs two dependent loads (its word, then
//! the map from list positions to blocks) before its first block.

use super::{children_of, BinaryBvh, NodeRef, INNER_WORDS, LAST};

/// An inner node on one cache line: its children's boxes in the words'
/// per-axis order (`[lo_left, lo_right, hi_left, hi_right]` for x, y, z, as
/// [`crate::geometry::BoxRay::test_pair`] reads them) and their references:
/// a line index for an inner child, [`LAST`] | its first block for a leaf.
#[repr(C, align(64))]
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub(crate) struct LineNode {
    /// Both children's boxes per axis, in scene units.
    pub(crate) planes: [f32; 12],
    /// The children's references, left then right.
    pub(crate) child: [u32; 2],
    /// Up to the cache line.
    pad: [u32; 2],
}

/// The lines of a [`BinaryBvh`], its root's reference in them, and each
/// reference's canonical BVH id (visit logs only).
#[derive(Clone, Debug, Default)]
pub(crate) struct Lines {
    pub(crate) nodes: Vec<LineNode>,
    pub(crate) root: u32,
    /// Canonical id of line `k`.
    node_ids: Vec<u32>,
    /// `(first block, canonical id)` of every leaf, ascending.
    leaf_ids: Vec<(u32, u32)>,
}

impl Lines {
    /// The lines of `b`'s words (and of its leaf blocks, already made),
    /// depth-first in the words' order.
    pub(crate) fn new(b: &BinaryBvh) -> Self {
        let mut lines = Lines {
            nodes: crate::pages::vec_with_capacity(b.inner_nodes),
            root: 0,
            node_ids: Vec::with_capacity(b.inner_nodes),
            leaf_ids: Vec::with_capacity(b.leaves),
        };
        if !b.is_empty() {
            lines.root = lines.place(b, b.root);
        }
        lines.leaf_ids.sort_unstable();
        crate::pages::advise(&lines.nodes);
        lines
    }

    /// Copies the node at word reference `r` and its subtree; returns its
    /// reference in the lines.
    fn place(&mut self, b: &BinaryBvh, r: NodeRef) -> u32 {
        let at = (r & !LAST) as usize;
        let id = b.canonical_id(r);
        if r & LAST != 0 {
            let first = b.blocks.start_of(b.words[at]);
            self.leaf_ids.push((first, id));
            return LAST | first;
        }
        let k = self.nodes.len();
        let w: &[u32; INNER_WORDS] = b.words[at..at + INNER_WORDS].try_into().unwrap();
        self.nodes.push(LineNode {
            planes: std::array::from_fn(|j| f32::from_bits(w[j])),
            ..LineNode::default()
        });
        self.node_ids.push(id);
        let [left, right] = children_of(w[12]);
        let child = [self.place(b, left), self.place(b, right)];
        self.nodes[k].child = child;
        k as u32
    }

    /// The canonical BVH id of line reference `r`.
    pub(crate) fn canonical_id(&self, r: u32) -> u32 {
        crate::structures::shared::leaf::canonical_id(&self.node_ids, &self.leaf_ids, r)
    }

    /// Bytes of the lines: 64 per inner node.
    pub(crate) fn bytes(&self) -> usize {
        std::mem::size_of_val(&self.nodes[..])
    }
}
