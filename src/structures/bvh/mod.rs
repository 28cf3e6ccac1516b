//! The uncompressed binary BVH of the dual-split paper's comparison (Lin et
//! al. 2019, §5): each inner node stores both children's boxes, so that a
//! node is 52 bytes and a leaf only 4.
//!
//! Layout, in 32-bit words:
//! - inner node (13 words): both children's boxes, per axis
//!   `[lo_left, lo_right, hi_left, hi_right]` for x, y, then z (so that one
//!   4-wide vector op tests an axis of both boxes), then a link word:
//!   bits 0–29 the word offset of the
//!   left child, bit 31 set if the left child is a leaf, bit 30 if the right
//!   one is. The right child follows the left directly (siblings adjacent),
//!   at `offset + 1` or `offset + 13`.
//! - leaf (1 word): the position of its first triangle in the index list.
//!
//! Nodes are placed depth-first, each sibling pair together. The triangle
//! index list holds mesh triangle indices; the last one of each leaf has its
//! sign bit set, so leaves store no count. The root's own box (the scene box)
//! is kept beside the nodes and not counted in [`Accel::bytes`]: every
//! structure has it.
//!
//! STACK runs over a copy derived from these words (`lines.rs`: each inner
//! node on one 64-byte cache line, leaves referenced by their first triangle
//! block), as it runs over the leaves' triangle blocks rather than the list.

mod lines;
mod saved;
mod stack;

use super::shared::leaf::LAST;
use super::shared::tri_block::LeafBlocks;
use super::shared::MAX_STACK_DEPTH;
use super::Accel;
use crate::bvh::{Bvh, NodeKind, ROOT};
use crate::error::{Error, Result};
use crate::geometry::{Aabb, Hit, Ray, Triangle};
use crate::stats::Stats;
use std::sync::Arc;

/// Words in an inner node.
const INNER_WORDS: usize = 13;
/// Ray-plane tests at an inner node: all its words but the link are the
/// planes of its two children's boxes.
const PAIR_PLANES: u32 = INNER_WORDS as u32 - 1;
/// Link bit: the left child is a leaf.
const LEFT_LEAF: u32 = 1 << 31;
/// Link bit: the right child is a leaf.
const RIGHT_LEAF: u32 = 1 << 30;
/// Link bits holding the left child's word offset.
const OFFSET_MASK: u32 = (1 << 30) - 1;

/// A node reference as traversals hold it: the word offset, with bit 31 set
/// for a leaf.
pub type NodeRef = u32;

/// The references of an inner node's two children, from its link word:
/// the left child at the link's offset, the right one after it (1 word on
/// from a leaf, 13 from an inner node), each with [`LAST`] set for a leaf.
fn children_of(link: u32) -> [NodeRef; 2] {
    let l = link & OFFSET_MASK;
    let flag = |leaf: bool| if leaf { LAST } else { 0 };
    let left_leaf = link & LEFT_LEAF != 0;
    let right = l + if left_leaf { 1 } else { INNER_WORDS as u32 };
    [l | flag(left_leaf), right | flag(link & RIGHT_LEAF != 0)]
}

/// The uncompressed binary BVH (52-byte inner nodes, 4-byte leaves; see the
/// module docs), traversed by STACK.
#[derive(Clone, Debug)]
pub struct BinaryBvh {
    pub(crate) words: Vec<u32>,
    pub(crate) index: Vec<u32>,
    /// The leaf list's triangles in blocks, as the traversal tests them.
    pub(crate) blocks: LeafBlocks,
    pub(crate) root: NodeRef,
    pub(crate) root_bounds: Aabb,
    pub(crate) triangles: Arc<[Triangle]>,
    /// Word offsets of the nodes in placement (increasing) order, and their
    /// canonical ids: only read by visit logs.
    offsets: Vec<u32>,
    ids: Vec<u32>,
    inner_nodes: usize,
    leaves: usize,
    pub(crate) depth: u32,
    /// The traversal's copy of the inner nodes (`lines.rs`), derived from
    /// `words` and `blocks`.
    pub(crate) lines: lines::Lines,
}

impl BinaryBvh {
    /// Lays out `bvh` over `triangles` (the ones it was built from).
    ///
    /// [`Error::Limit`] for a tree deeper than the traversal stack
    /// ([`MAX_STACK_DEPTH`]) or one whose nodes pass 2³⁰ words.
    pub fn from_bvh(bvh: &Bvh, triangles: Arc<[Triangle]>) -> Result<Self> {
        if bvh.stats.depth as usize >= MAX_STACK_DEPTH {
            return Err(Error::Limit(format!(
                "BVH depth {} exceeds the binary BVH layout's limit of {} levels; use a smaller scene or the hybrid builder",
                bvh.stats.depth,
                MAX_STACK_DEPTH - 1
            )));
        }
        let words_needed = bvh.stats.inner_nodes * INNER_WORDS + bvh.stats.leaves;
        if words_needed > OFFSET_MASK as usize {
            return Err(Error::Limit(format!(
                "{words_needed} node words exceed the binary BVH layout's 30-bit offsets ({} words)",
                OFFSET_MASK
            )));
        }
        let mut b = BinaryBvh {
            words: crate::pages::vec_with_capacity(words_needed),
            index: Vec::with_capacity(bvh.prims.len()),
            blocks: LeafBlocks::default(),
            root: 0,
            root_bounds: bvh.bounds(),
            triangles,
            offsets: Vec::with_capacity(bvh.nodes.len()),
            ids: Vec::with_capacity(bvh.nodes.len()),
            inner_nodes: bvh.stats.inner_nodes,
            leaves: bvh.stats.leaves,
            depth: bvh.stats.depth,
            lines: lines::Lines::default(),
        };
        b.root = b.place(bvh, ROOT);
        b.fill(bvh, ROOT, b.root);
        debug_assert_eq!(b.words.len(), words_needed);
        b.blocks = LeafBlocks::new(&b.index, &b.triangles);
        b.lines = lines::Lines::new(&b);
        crate::pages::advise(&b.words);
        Ok(b)
    }

    /// Appends node `id`'s own words (zeroed link / leaf word) and returns
    /// its reference.
    fn place(&mut self, bvh: &Bvh, id: u32) -> NodeRef {
        let at = self.words.len() as u32;
        self.offsets.push(at);
        self.ids.push(id);
        match bvh.nodes[id as usize].kind {
            NodeKind::Inner { .. } => {
                self.words.resize(self.words.len() + INNER_WORDS, 0);
                at
            }
            NodeKind::Leaf { .. } => {
                self.words.push(0);
                at | LAST
            }
        }
    }

    /// Writes the contents of node `id`, already placed at `r`, and places
    /// its subtree.
    fn fill(&mut self, bvh: &Bvh, id: u32, r: NodeRef) {
        let node = &bvh.nodes[id as usize];
        let at = (r & !LAST) as usize;
        match node.kind {
            NodeKind::Leaf { .. } => {
                self.words[at] = self.index.len() as u32;
                let prims = bvh.leaf_prims(node);
                self.index.extend_from_slice(prims);
                if let Some(last) = self.index.last_mut() {
                    *last |= LAST;
                }
            }
            NodeKind::Inner { left, right, .. } => {
                let l = self.place(bvh, left);
                let r = self.place(bvh, right);
                let boxes = pair_boxes(
                    &bvh.nodes[left as usize].bounds,
                    &bvh.nodes[right as usize].bounds,
                );
                for (j, v) in boxes.into_iter().enumerate() {
                    self.words[at + j] = v.to_bits();
                }
                let mut link = l & !LAST;
                if l & LAST != 0 {
                    link |= LEFT_LEAF;
                }
                if r & LAST != 0 {
                    link |= RIGHT_LEAF;
                }
                self.words[at + 12] = link;
                self.fill(bvh, left, l);
                self.fill(bvh, right, r);
            }
        }
    }

    /// The canonical node id of reference `r` (for visit logs).
    pub(crate) fn canonical_id(&self, r: NodeRef) -> u32 {
        let at = r & !LAST;
        let k = self.offsets.binary_search(&at).expect("a placed node");
        self.ids[k]
    }

    /// Nodes with two children (13 words each).
    pub fn inner_nodes(&self) -> usize {
        self.inner_nodes
    }

    /// Leaf nodes (1 word each).
    pub fn leaves(&self) -> usize {
        self.leaves
    }

    /// Bytes of the nodes: 52 per inner node, 4 per leaf.
    pub fn node_bytes(&self) -> usize {
        self.words.len() * 4
    }

    /// Bytes of the traversal's copy of the inner nodes, derived from the
    /// words and not counted in [`Accel::bytes`]: 64 per inner node (each on
    /// its own cache line, children referenced directly).
    pub fn line_bytes(&self) -> usize {
        self.lines.bytes()
    }

    /// Bytes of the triangle index list: 4 per triangle reference.
    pub fn index_bytes(&self) -> usize {
        self.index.len() * 4
    }

    /// Whether the tree holds no triangles.
    pub fn is_empty(&self) -> bool {
        self.index.is_empty()
    }
    /// The encoded nodes, word for word as the traversal reads them (see
    /// the module docs), for back ends that upload them as they are.
    pub fn words(&self) -> &[u32] {
        &self.words
    }

    /// The sign-terminated triangle index list ([`LAST`]).
    pub fn index(&self) -> &[u32] {
        &self.index
    }

    /// The root's reference: its word offset, bit 31 set for a leaf.
    pub fn root(&self) -> NodeRef {
        self.root
    }

    /// The root's own box (the scene box).
    pub fn root_bounds(&self) -> Aabb {
        self.root_bounds
    }

    /// The tree's depth (the canonical BVH's).
    pub fn depth(&self) -> u32 {
        self.depth
    }

    /// The mesh's triangles, in mesh order.
    pub fn triangles(&self) -> &[Triangle] {
        &self.triangles
    }
}

/// Two boxes in the per-axis order of an inner node and of
/// [`crate::geometry::BoxRay::test_pair`].
pub fn pair_boxes(l: &Aabb, r: &Aabb) -> [f32; 12] {
    let (l, r) = (l.to_array(), r.to_array());
    std::array::from_fn(|j| {
        let (axis, k) = (j / 4, j % 4);
        [l[axis], r[axis], l[axis + 3], r[axis + 3]][k]
    })
}

impl Accel for BinaryBvh {
    fn name(&self) -> &'static str {
        "bvh"
    }

    fn bytes(&self) -> usize {
        self.node_bytes() + self.index_bytes()
    }

    fn closest_hit<S: Stats>(&self, ray: &Ray, stats: &mut S) -> Option<Hit> {
        stack::trace::<S, false>(self, ray, stats)
    }

    fn any_hit<S: Stats>(&self, ray: &Ray, stats: &mut S) -> Option<Hit> {
        stack::trace::<S, true>(self, ray, stats)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bvh::BuildOptions;
    use crate::scene::Scene;

    /// The inverse of [`pair_boxes`].
    fn unpair_boxes(b: &[f32; 12]) -> [Aabb; 2] {
        [0, 1].map(|c| Aabb::from_array(&[b[c], b[4 + c], b[8 + c], b[2 + c], b[6 + c], b[10 + c]]))
    }

    #[test]
    fn storage_is_exact_and_nodes_decode_to_the_bvh() {
        let scene = Scene::builtin("chess:3000").unwrap();
        let bvh = Bvh::build(&scene.triangles, &BuildOptions::sah());
        let b = BinaryBvh::from_bvh(&bvh, scene.triangles.clone()).unwrap();
        let s = &bvh.stats;
        assert_eq!(b.node_bytes(), 52 * s.inner_nodes + 4 * s.leaves);
        assert_eq!(b.index_bytes(), 4 * bvh.prims.len());
        assert_eq!(
            b.bytes(),
            52 * s.inner_nodes + 4 * s.leaves + 4 * bvh.prims.len()
        );

        // Walk the layout and compare every decoded node with the canonical one.
        let mut todo = vec![(b.root, ROOT)];
        let mut seen = 0;
        while let Some((r, id)) = todo.pop() {
            seen += 1;
            assert_eq!(b.canonical_id(r), id);
            let node = &bvh.nodes[id as usize];
            let at = (r & !LAST) as usize;
            match node.kind {
                NodeKind::Leaf { .. } => {
                    assert!(r & LAST != 0);
                    let mut i = b.words[at] as usize;
                    let mut prims = vec![];
                    loop {
                        prims.push(b.index[i] & !LAST);
                        if b.index[i] & LAST != 0 {
                            break;
                        }
                        i += 1;
                    }
                    assert_eq!(prims, bvh.leaf_prims(node));
                }
                NodeKind::Inner { left, right, .. } => {
                    let kids = children_of(b.words[at + 12]);
                    let bits: [f32; 12] = std::array::from_fn(|j| f32::from_bits(b.words[at + j]));
                    let boxes = unpair_boxes(&bits);
                    for (k, (c, kr)) in [left, right].into_iter().zip(kids).enumerate() {
                        assert_eq!(boxes[k], bvh.nodes[c as usize].bounds);
                        todo.push((kr, c));
                    }
                }
            }
        }
        assert_eq!(seen, bvh.nodes.len());
    }

    /// The traversal's lines hold the words' boxes, one cache line per
    /// inner node, and reference each leaf's own blocks: walked from the
    /// root, they give the canonical tree.
    #[test]
    fn lines_hold_the_tree_one_cache_line_per_inner_node() {
        for (spec, opts) in [
            ("chess:3000", BuildOptions::sah()),
            ("hairball:2000", BuildOptions::hybrid()),
        ] {
            let scene = Scene::builtin(spec).unwrap();
            let bvh = Bvh::build(&scene.triangles, &opts);
            let b = BinaryBvh::from_bvh(&bvh, scene.triangles.clone()).unwrap();
            let lines = &b.lines;
            assert_eq!(lines.nodes.len(), bvh.stats.inner_nodes);
            assert_eq!(b.line_bytes(), 64 * bvh.stats.inner_nodes);
            assert_eq!(lines.nodes.as_ptr() as usize % 64, 0);
            let blocks = b.blocks.blocks();
            let mut todo = vec![(lines.root, ROOT)];
            let mut seen = 0;
            while let Some((r, id)) = todo.pop() {
                seen += 1;
                assert_eq!(lines.canonical_id(r), id);
                let node = &bvh.nodes[id as usize];
                match node.kind {
                    NodeKind::Leaf { .. } => {
                        assert!(r & LAST != 0);
                        let mut prims = vec![];
                        'blocks: for blk in &blocks[(r & !LAST) as usize..] {
                            for &p in &blk.prims[..blk.count()] {
                                prims.push(p & !LAST);
                                if p & LAST != 0 {
                                    break 'blocks;
                                }
                            }
                        }
                        assert_eq!(prims, bvh.leaf_prims(node));
                    }
                    NodeKind::Inner { left, right, .. } => {
                        assert!(r & LAST == 0);
                        let n = &lines.nodes[r as usize];
                        let boxes = unpair_boxes(&n.planes);
                        for (k, c) in [left, right].into_iter().enumerate() {
                            assert_eq!(boxes[k], bvh.nodes[c as usize].bounds);
                            todo.push((n.child[k], c));
                        }
                    }
                }
            }
            assert_eq!(seen, bvh.nodes.len());
        }
    }
}
