//! The sparse layout of the stackless paper (its §3): 32-byte nodes with
//! their own boxes and parent links, siblings adjacent, depth-first. The
//! root is node 0; each sibling pair is placed together, the left child at
//! an odd index, so `sibling(n) = n + 1` for odd `n` and `n - 1` for even.
//!
//! SPARSE, HAPALA, LAINE-k and (for fair timing ratios) STACK all run over
//! this one layout: the paper gave every algorithm exactly the same BVH.

mod hapala;
mod laine;
mod paired;
mod saved;
#[allow(clippy::module_inception)]
mod sparse;
mod stack;

use super::shared::own_box::{BinaryNode, OwnBoxNode, Walk, LEAF};
use super::{Accel, TraversalKind};
use crate::bvh::{Bvh, NodeKind, ROOT};
use crate::error::{Error, Result};
use crate::geometry::{Aabb, Triangle};
use crate::geometry::{Hit, Ray};
use crate::stats::Stats;
use crate::structures::shared::tri_block::LeafBlocks;
use std::marker::PhantomData;
use std::sync::Arc;

/// `extra` bits 0–29: the parent's index.
const PARENT_MASK: u32 = (1 << 30) - 1;
/// The root's parent field.
const NO_PARENT: u32 = PARENT_MASK;

/// The canonical BVH in [`OwnBoxNode`]s (32 bytes each) with parent links:
/// see the module docs. `extra` holds the parent's slot (bits 0–29) and the
/// split axis (bits 30–31).
#[derive(Clone, Debug)]
pub struct SparseBvh {
    pub(crate) nodes: Vec<OwnBoxNode>,
    pub(crate) index: Vec<u32>,
    /// The leaf list's triangles in blocks, as the traversals test them.
    pub(crate) blocks: LeafBlocks,
    pub(crate) triangles: Arc<[Triangle]>,
    /// Canonical id of each node (read by visit logs only).
    pub(crate) ids: Vec<u32>,
    pub(crate) depth: u32,
    inner_nodes: usize,
}

impl SparseBvh {
    /// Lays out `bvh`. [`Error::Limit`] for 2³⁰ − 1 nodes or more (the parent
    /// field).
    pub fn from_bvh(bvh: &Bvh, triangles: Arc<[Triangle]>) -> Result<Self> {
        if bvh.nodes.len() >= PARENT_MASK as usize {
            return Err(Error::Limit(format!(
                "{} BVH nodes exceed the sparse layout's 30-bit node indices ({} nodes)",
                bvh.nodes.len(),
                PARENT_MASK - 1
            )));
        }
        let mut s = SparseBvh {
            nodes: crate::pages::vec_with_capacity(bvh.nodes.len()),
            index: Vec::with_capacity(bvh.prims.len()),
            blocks: LeafBlocks::default(),
            triangles,
            ids: Vec::with_capacity(bvh.nodes.len()),
            depth: bvh.stats.depth,
            inner_nodes: bvh.stats.inner_nodes,
        };
        s.push(bvh, ROOT, NO_PARENT);
        s.fill(bvh, 0);
        s.blocks = LeafBlocks::new(&s.index, &s.triangles);
        crate::pages::advise(&s.nodes);
        Ok(s)
    }

    fn push(&mut self, bvh: &Bvh, id: u32, parent: u32) -> u32 {
        let n = &bvh.nodes[id as usize];
        let axis = match n.kind {
            NodeKind::Inner { axis, .. } => axis as u32,
            NodeKind::Leaf { .. } => 0,
        };
        self.nodes.push(OwnBoxNode {
            bounds: n.bounds.to_array(),
            link: if n.is_leaf() { LEAF } else { 0 },
            extra: parent | axis << 30,
        });
        self.ids.push(id);
        self.nodes.len() as u32 - 1
    }

    /// Fills in node `at` (already pushed) and places its subtree.
    fn fill(&mut self, bvh: &Bvh, at: u32) {
        let id = self.ids[at as usize];
        let node = &bvh.nodes[id as usize];
        match node.kind {
            NodeKind::Leaf { .. } => {
                self.nodes[at as usize].link = LEAF | self.index.len() as u32;
                self.index.extend_from_slice(bvh.leaf_prims(node));
                if let Some(last) = self.index.last_mut() {
                    *last |= LEAF;
                }
            }
            NodeKind::Inner { left, right, .. } => {
                let l = self.push(bvh, left, at);
                let r = self.push(bvh, right, at);
                debug_assert_eq!((l % 2, r), (1, l + 1));
                self.nodes[at as usize].link = l;
                self.fill(bvh, l);
                self.fill(bvh, r);
            }
        }
    }

    /// The root's box, in scene units ([`Aabb::EMPTY`] for a tree over no
    /// triangles).
    pub fn bounds(&self) -> Aabb {
        Aabb::from_array(&self.nodes[0].bounds)
    }

    /// Whether the tree holds no triangles.
    pub fn is_empty(&self) -> bool {
        self.index.is_empty()
    }

    /// The nodes, as the traversals read them (root at slot 0).
    pub fn nodes(&self) -> &[OwnBoxNode] {
        &self.nodes
    }

    /// The sign-terminated triangle index list.
    pub fn index(&self) -> &[u32] {
        &self.index
    }

    /// The tree's depth (the canonical BVH's).
    pub fn depth(&self) -> u32 {
        self.depth
    }

    /// The mesh's triangles, in mesh order.
    pub fn triangles(&self) -> &[Triangle] {
        &self.triangles
    }

    /// Nodes of the tree: the canonical BVH's count.
    pub fn node_count(&self) -> usize {
        self.nodes.len()
    }

    /// Nodes with two children.
    pub fn inner_nodes(&self) -> usize {
        self.inner_nodes
    }

    /// 32 bytes per node.
    pub fn node_bytes(&self) -> usize {
        self.nodes.len() * std::mem::size_of::<OwnBoxNode>()
    }

    /// Bytes of the sign-terminated triangle index list: 4 per triangle reference.
    pub fn index_bytes(&self) -> usize {
        self.index.len() * 4
    }

    #[inline(always)]
    pub(crate) fn parent(&self, n: u32) -> u32 {
        self.nodes[n as usize].extra & PARENT_MASK
    }

    /// The axis the builder split node `n` on.
    #[inline(always)]
    pub(crate) fn axis(&self, n: u32) -> usize {
        (self.nodes[n as usize].extra >> 30) as usize
    }
}

/// The other child of `n`'s parent (`n` is not the root).
#[inline(always)]
pub fn sibling(n: u32) -> u32 {
    // Odd n (a left child): n + 1; even n: n - 1. No branch.
    ((n - 1) ^ 1) + 1
}

pub use paired::PairedBvh;

/// A sparse layout: the canonical tree's nodes in slots, the root at slot
/// 0, each sibling pair adjacent with the left child at an odd slot, and
/// parent links. STACK, SPARSE and LAINE-k run over any of them: the
/// own-box nodes ([`SparseBvh`]) or the stackless paper's own tracer's
/// 64-byte nodes with both children's boxes ([`PairedBvh`]).
pub trait SparseLayout: Send + Sync + 'static {
    /// The node record.
    type Node: BinaryNode;
    /// The own-box layout (its leaf blocks, triangles, depth and ids).
    fn sparse(&self) -> &SparseBvh;
    /// Enters the walk at the root (its box tested); `None` on a miss.
    fn walk<'a, const ANY: bool, S: Stats>(
        &'a self,
        ray: &'a Ray,
        stats: &mut S,
    ) -> Option<Walk<'a, ANY, Self::Node>>;
    /// The parent of slot `n` (not the root).
    fn parent(&self, n: u32) -> u32;
    /// The ancestor `up` levels above slot `n` (`up` at most `n`'s depth).
    #[inline(always)]
    fn ancestor(&self, mut n: u32, up: u32) -> u32 {
        for _ in 0..up {
            n = self.parent(n);
        }
        n
    }
    /// Bytes of the node records (the index list is the own-box layout's).
    fn node_bytes(&self) -> usize;
    /// The canonical id of slot `n` (for visit logs).
    #[inline(always)]
    fn id(&self, n: u32) -> u32 {
        self.sparse().ids[n as usize]
    }
    /// Whether the tree holds no triangles.
    #[inline(always)]
    fn is_empty(&self) -> bool {
        self.sparse().index.is_empty()
    }
}

impl SparseLayout for SparseBvh {
    type Node = OwnBoxNode;
    #[inline(always)]
    fn sparse(&self) -> &SparseBvh {
        self
    }
    #[inline(always)]
    fn walk<'a, const ANY: bool, S: Stats>(
        &'a self,
        ray: &'a Ray,
        stats: &mut S,
    ) -> Option<Walk<'a, ANY, OwnBoxNode>> {
        Walk::enter(
            ray,
            &self.nodes,
            &self.nodes[0].bounds,
            &self.blocks,
            &self.triangles,
            stats,
        )
    }
    #[inline(always)]
    fn parent(&self, n: u32) -> u32 {
        SparseBvh::parent(self, n)
    }
    fn node_bytes(&self) -> usize {
        SparseBvh::node_bytes(self)
    }
}

/// An algorithm over a sparse layout `L`.
pub trait SparseAlgorithm<L = SparseBvh>: Send + Sync + 'static {
    /// The traversal's registry entry.
    const KIND: TraversalKind;
    /// Deepest tree the algorithm's integers address.
    const MAX_DEPTH: u32;
    /// Traces `ray` over `layout`: the closest hit, or with `ANY` the first
    /// hit found.
    fn trace<S: Stats, const ANY: bool>(layout: &L, ray: &Ray, stats: &mut S) -> Option<Hit>;
}

/// STACK over the sparse layout (for ratios on the same nodes).
pub struct StackOnSparse;
/// SPARSE (Algorithm 4).
pub struct Sparse;
/// HAPALA.
pub struct Hapala;
/// LAINE-k with a short stack of `K` (0, 1, 2, 4 or 8) entries.
pub struct Laine<const K: usize>;

impl<L: SparseLayout> SparseAlgorithm<L> for StackOnSparse {
    const KIND: TraversalKind = TraversalKind::Stack;
    const MAX_DEPTH: u32 = crate::structures::shared::MAX_STACK_DEPTH as u32 - 1;
    #[inline(always)]
    fn trace<S: Stats, const ANY: bool>(l: &L, r: &Ray, s: &mut S) -> Option<Hit> {
        stack::trace::<L, S, ANY>(l, r, s)
    }
}

impl<L: SparseLayout> SparseAlgorithm<L> for Sparse {
    const KIND: TraversalKind = TraversalKind::Sparse;
    const MAX_DEPTH: u32 = 63;
    #[inline(always)]
    fn trace<S: Stats, const ANY: bool>(l: &L, r: &Ray, s: &mut S) -> Option<Hit> {
        sparse::trace::<L, S, ANY>(l, r, s)
    }
}

/// HAPALA tests one box at a time (the sibling's on the way back), so it
/// runs over the own-box nodes only.
impl SparseAlgorithm for Hapala {
    const KIND: TraversalKind = TraversalKind::Hapala;
    const MAX_DEPTH: u32 = u32::MAX;
    #[inline(always)]
    fn trace<S: Stats, const ANY: bool>(l: &SparseBvh, r: &Ray, s: &mut S) -> Option<Hit> {
        hapala::trace::<S, ANY>(l, r, s)
    }
}

impl<L: SparseLayout, const K: usize> SparseAlgorithm<L> for Laine<K> {
    const KIND: TraversalKind = match K {
        0 => TraversalKind::Laine0,
        1 => TraversalKind::Laine1,
        2 => TraversalKind::Laine2,
        4 => TraversalKind::Laine4,
        8 => TraversalKind::Laine8,
        _ => panic!("LAINE-k exists for k = 0, 1, 2, 4, 8"),
    };
    const MAX_DEPTH: u32 = 63;
    #[inline(always)]
    fn trace<S: Stats, const ANY: bool>(l: &L, r: &Ray, s: &mut S) -> Option<Hit> {
        laine::trace::<L, S, ANY, K>(l, r, s)
    }
}

/// A sparse-layout algorithm with its layout (shared between algorithms).
pub struct OnSparse<A: SparseAlgorithm<L>, L: SparseLayout = SparseBvh> {
    /// The layout, shared with other algorithms over it.
    pub layout: Arc<L>,
    _a: PhantomData<A>,
}

impl<A: SparseAlgorithm<L>, L: SparseLayout> OnSparse<A, L> {
    /// `A` over `layout`; [`Error::Limit`] for a tree deeper than
    /// [`SparseAlgorithm::MAX_DEPTH`].
    pub fn new(layout: Arc<L>) -> crate::error::Result<Self> {
        let depth = layout.sparse().depth;
        if depth > A::MAX_DEPTH {
            return Err(crate::error::Error::Limit(format!(
                "BVH depth {} exceeds {}'s limit of {} levels; use the hybrid builder (--builder hybrid)",
                depth,
                A::KIND.name(),
                A::MAX_DEPTH
            )));
        }
        Ok(OnSparse {
            layout,
            _a: PhantomData,
        })
    }
}

impl<A: SparseAlgorithm<L>, L: SparseLayout> Accel for OnSparse<A, L> {
    fn name(&self) -> &'static str {
        "bvh"
    }
    fn bytes(&self) -> usize {
        self.layout.node_bytes() + self.layout.sparse().index_bytes()
    }
    fn closest_hit<S: Stats>(&self, ray: &Ray, stats: &mut S) -> Option<Hit> {
        A::trace::<S, false>(&self.layout, ray, stats)
    }
    fn any_hit<S: Stats>(&self, ray: &Ray, stats: &mut S) -> Option<Hit> {
        A::trace::<S, true>(&self.layout, ray, stats)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bvh::BuildOptions;
    use crate::scene::Scene;

    #[test]
    fn nodes_match_the_canonical_tree() {
        let scene = Scene::builtin("hairball:3000").unwrap();
        let bvh = Bvh::build(&scene.triangles, &BuildOptions::sah());
        let s = SparseBvh::from_bvh(&bvh, scene.triangles.clone()).unwrap();
        assert_eq!(s.node_count(), bvh.nodes.len());
        assert_eq!(s.node_bytes(), 32 * bvh.nodes.len());
        for (i, n) in s.nodes.iter().enumerate() {
            let c = &bvh.nodes[s.ids[i] as usize];
            assert_eq!(Aabb::from_array(&n.bounds), c.bounds);
            if i > 0 {
                assert_eq!(s.ids[s.parent(i as u32) as usize], c.parent);
                assert_eq!(sibling(sibling(i as u32)), i as u32);
            }
            match c.kind {
                NodeKind::Inner { left, right, axis } => {
                    assert!(!n.is_leaf());
                    assert_eq!(s.ids[n.target() as usize], left);
                    assert_eq!(s.ids[n.target() as usize + 1], right);
                    assert_eq!(s.axis(i as u32), axis as usize);
                }
                NodeKind::Leaf { .. } => {
                    assert!(n.is_leaf());
                    let mut k = n.target() as usize;
                    let mut prims = vec![];
                    loop {
                        prims.push(s.index[k] & !LEAF);
                        if s.index[k] & LEAF != 0 {
                            break;
                        }
                        k += 1;
                    }
                    assert_eq!(prims, bvh.leaf_prims(c));
                }
            }
        }
    }
}
