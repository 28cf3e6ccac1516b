//! Wide BVHs: 4- and 8-wide nodes (`bvh4`, `bvh8`) collapsed from the
//! canonical binary [`Bvh`] by SAH, their child boxes stored per plane side
//! by side so that one pass of vector instructions tests every child.
//!
//! - Collapse (`collapse.rs`): which binary descendants become a wide node's
//!   children is chosen by dynamic programming over the binary tree to
//!   minimise the SAH cost of the wide tree (the optimal collapse of Ylitie,
//!   Karras and Laine 2017, §3.1: a node costs 1 and a block of four
//!   triangles 1.2, their 0.3 per triangle, since leaves are tested a block
//!   at a time), not by a fixed two-level merge. A leaf is a binary leaf, or
//!   a binary subtree of at most 8 triangle references merged into one leaf
//!   where that costs less.
//! - Node ([`WideNode`]): the children's boxes as six rows of `W` floats
//!   (`min x`, `min y`, `min z`, `max x`, `max y`, `max z`; empty lanes hold
//!   an inverted box that no ray enters) and `W` child references: a wide
//!   node's index, or with bit 31 set a leaf's first triangle block, or
//!   `u32::MAX` for an empty lane.
//! - Leaves: the leaf's triangles copied side by side in blocks of four
//!   ([`super::shared::tri_block`]), tested in one pass of vector arithmetic
//!   with the scalar watertight test's exact answers.
//!   4 + 6·4·4 = 112 bytes padded to 128 for `bvh4`; 256 bytes for `bvh8`.
//! - Traversal (`traverse.rs`): every child's box in one pass, the hit
//!   children visited nearest first (sorted by entry distance), a stack of
//!   node references with their entry distances, so that popped entries
//!   farther than the closest hit are skipped.

pub(crate) mod collapse;
pub(crate) mod saved;
pub(crate) mod traverse;

use super::shared::simd::SimdPath;
use super::shared::tri_block::{self, TriBlock};
use super::shared::MAX_STACK_DEPTH;
use super::Accel;
use crate::bvh::Bvh;
use crate::error::{Error, Result};
use crate::geometry::{Aabb, Hit, Ray, Triangle};
use crate::stats::Stats;
use std::sync::Arc;

/// Reference bit: the child is a leaf (the rest: its first triangle block).
pub(crate) const LEAF: u32 = 1 << 31;
/// Bit of a leaf's reference in a node: the leaf's first block is followed
/// by another of the same leaf, so that the leaf test loads both blocks at
/// once without first reading the first one's entries
/// ([`tri_block::pair_hint`]; `bvh8` 1.02–1.06× as fast on hairball's and
/// forest's rays: `ARCHITECTURE.md`, "Wide kernels"). A layout's own: saved
/// files and [`WideBvh::root`] hold references without it ([`plain`]).
pub(crate) const PAIR: u32 = 1 << 30;
/// Leaf references hold block indices below this.
pub(crate) const MAX_BLOCKS: usize = PAIR as usize;

/// Reference `r` without the [`PAIR`] bit (an empty lane's stays
/// `u32::MAX`).
#[inline(always)]
pub(crate) fn plain(r: u32) -> u32 {
    if r != EMPTY && r & LEAF != 0 {
        r & !PAIR
    } else {
        r
    }
}

/// Leaf reference `r` with the [`PAIR`] bit of its leaf in `blocks`.
#[inline(always)]
pub(crate) fn with_pair(r: u32, blocks: &[TriBlock]) -> u32 {
    if r != EMPTY && r & LEAF != 0 && tri_block::pair_hint(blocks, r & !(LEAF | PAIR)) {
        r | PAIR
    } else {
        r
    }
}
/// The reference of an empty lane.
const EMPTY: u32 = u32::MAX;

/// A node of `W` children (`W` = 4 or 8): `planes[r][k]` is plane row `r`
/// (`min x, min y, min z, max x, max y, max z`) of child `k`.
#[derive(Clone, Copy, Debug, PartialEq)]
#[repr(C, align(64))]
pub struct WideNode<const W: usize> {
    /// Child boxes, one row per plane, one lane per child.
    pub planes: [[f32; W]; 6],
    /// Child references: a node index, a leaf (bit 31 set: its first
    /// block; bit 30 set when a second block follows, [`PAIR`]), or
    /// `u32::MAX` for an empty lane.
    pub children: [u32; W],
}

impl<const W: usize> WideNode<W> {
    /// A node with every lane empty: boxes inverted (`+inf` minima, `-inf`
    /// maxima) so that no ray enters them.
    fn empty() -> Self {
        let mut planes = [[f32::INFINITY; W]; 6];
        for row in &mut planes[3..] {
            *row = [f32::NEG_INFINITY; W];
        }
        WideNode {
            planes,
            children: [EMPTY; W],
        }
    }

    /// Children in use.
    pub fn child_count(&self) -> usize {
        self.children.iter().filter(|&&c| c != EMPTY).count()
    }

    /// The box of child `k`.
    pub fn child_bounds(&self, k: usize) -> Aabb {
        Aabb::from_array(&std::array::from_fn(|r| self.planes[r][k]))
    }

    /// The child references as saved files and other back ends take them:
    /// a node index, bit 31 and a leaf's first block, or `u32::MAX`, without
    /// the in-memory [`PAIR`] bit.
    pub fn plain_children(&self) -> [u32; W] {
        self.children.map(plain)
    }
}

/// A `W`-wide BVH (`W` = 4: `bvh4`, 8: `bvh8`) over a mesh's triangles.
#[derive(Clone, Debug)]
pub struct WideBvh<const W: usize> {
    nodes: Vec<WideNode<W>>,
    blocks: Vec<TriBlock>,
    triangles: Arc<[Triangle]>,
    root_bounds: Aabb,
    /// The root's reference: node 0, or a leaf for a one-leaf tree.
    root: u32,
    /// Canonical BVH id of each wide node, and of each leaf by its first
    /// block (visit logs only).
    node_ids: Vec<u32>,
    leaf_ids: Vec<(u32, u32)>,
    /// Wide levels below the root.
    depth: u32,
    leaves: usize,
    sah_cost: f64,
}

/// A 4-wide BVH.
pub type Bvh4 = WideBvh<4>;
/// An 8-wide BVH.
pub type Bvh8 = WideBvh<8>;

impl<const W: usize> WideBvh<W> {
    /// Puts the nodes and leaf blocks on huge pages ([`crate::pages`]).
    pub(crate) fn advise_pages(&self) {
        crate::pages::advise(&self.nodes);
        crate::pages::advise(&self.blocks);
    }

    /// Collapses `bvh` (built over `triangles`) into a `W`-wide tree by SAH.
    ///
    /// # Errors
    /// [`Error::Limit`] for a tree deeper than the traversal stack holds
    /// ([`MAX_STACK_DEPTH`] levels) or with 2³¹ or more nodes.
    pub fn from_bvh(bvh: &Bvh, triangles: Arc<[Triangle]>) -> Result<Self> {
        const { assert!(W == 4 || W == 8, "wide BVHs are 4 or 8 wide") };
        if bvh.stats.depth as usize >= MAX_STACK_DEPTH {
            return Err(Error::Limit(format!(
                "BVH depth {} exceeds the {W}-wide BVH's limit of {} levels; use the hybrid builder",
                bvh.stats.depth,
                MAX_STACK_DEPTH - 1
            )));
        }
        if bvh.nodes.len() >= LEAF as usize {
            return Err(Error::Limit(format!(
                "{} BVH nodes exceed the {W}-wide BVH's 31-bit references",
                bvh.nodes.len()
            )));
        }
        if bvh.prims.len() >= MAX_BLOCKS {
            return Err(Error::Limit(format!(
                "{} triangle references exceed the {W}-wide BVH's 30-bit block indices",
                bvh.prims.len()
            )));
        }
        let plan = collapse::plan::<W>(bvh);
        let mut w = WideBvh {
            nodes: Vec::new(),
            blocks: crate::pages::vec_with_capacity(bvh.prims.len() / 2),
            triangles,
            root_bounds: bvh.bounds(),
            root: 0,
            node_ids: Vec::new(),
            leaf_ids: Vec::new(),
            depth: 0,
            leaves: 0,
            sah_cost: plan.cost,
        };
        w.root = plain(w.place(bvh, &plan, crate::bvh::ROOT, 0));
        w.advise_pages();
        Ok(w)
    }

    /// Places binary node `id` (a leaf, or an inner node that becomes a wide
    /// node) at wide depth `depth`; returns its reference.
    fn place(&mut self, bvh: &Bvh, plan: &collapse::Plan, id: u32, depth: u32) -> u32 {
        self.depth = self.depth.max(depth);
        if let Some(prims) = plan.leaf(bvh, id) {
            if prims.is_empty() {
                return EMPTY;
            }
            let at = tri_block::push_leaf(&mut self.blocks, &prims, &self.triangles);
            self.leaf_ids.push((at, id));
            self.leaves += 1;
            return with_pair(at | LEAF, &self.blocks);
        }
        let at = self.nodes.len();
        self.nodes.push(WideNode::empty());
        self.node_ids.push(id);
        let children = plan.children(bvh, id);
        debug_assert!(children.len() <= W);
        let mut k = 0;
        for &c in &children {
            let r = self.place(bvh, plan, c, depth + 1);
            if r == EMPTY {
                continue;
            }
            let b = bvh.nodes[c as usize].bounds.to_array();
            let n = &mut self.nodes[at];
            for (row, v) in b.into_iter().enumerate() {
                n.planes[row][k] = v;
            }
            n.children[k] = r;
            k += 1;
        }
        at as u32
    }

    /// The wide nodes; node 0 is the root unless the tree is one leaf.
    pub fn nodes(&self) -> &[WideNode<W>] {
        &self.nodes
    }

    /// The leaves' triangle blocks.
    pub fn blocks(&self) -> &[TriBlock] {
        &self.blocks
    }

    /// Bytes of the nodes.
    pub fn node_bytes(&self) -> usize {
        std::mem::size_of_val(&self.nodes[..])
    }

    /// Bytes of the leaves' triangle blocks (160 per four triangles: the
    /// vertices copied beside their indices).
    pub fn index_bytes(&self) -> usize {
        std::mem::size_of_val(&self.blocks[..])
    }

    /// Wide (inner) nodes.
    pub fn inner_nodes(&self) -> usize {
        self.nodes.len()
    }

    /// Leaves (the binary BVH's).
    pub fn leaves(&self) -> usize {
        self.leaves
    }

    /// Wide levels below the root.
    pub fn depth(&self) -> u32 {
        self.depth
    }

    /// The root's reference: node 0, or (bit 31 set) the first block of a
    /// tree that is one leaf.
    pub fn root(&self) -> u32 {
        self.root
    }

    /// SAH cost of the wide tree (node cost 1, 1.2 per block of four
    /// triangles, areas relative to the root's), as the collapse minimised
    /// it.
    pub fn sah_cost(&self) -> f64 {
        self.sah_cost
    }

    /// Whether the tree holds no triangle.
    pub fn is_empty(&self) -> bool {
        self.blocks.is_empty()
    }
}

impl<const W: usize> Accel for WideBvh<W> {
    fn name(&self) -> &'static str {
        if W == 4 {
            "bvh4"
        } else {
            "bvh8"
        }
    }

    fn bytes(&self) -> usize {
        self.node_bytes() + self.index_bytes()
    }

    fn closest_hit<S: Stats>(&self, ray: &Ray, stats: &mut S) -> Option<Hit> {
        traverse::trace::<W, Self, S, false>(self, ray, stats)
    }

    fn any_hit<S: Stats>(&self, ray: &Ray, stats: &mut S) -> Option<Hit> {
        traverse::trace::<W, Self, S, true>(self, ray, stats)
    }

    fn closest_hit_triangle<S: Stats>(
        &self,
        ray: &Ray,
        stats: &mut S,
    ) -> Option<(Hit, Option<Triangle>)> {
        traverse::closest_with_triangle::<W, Self, S>(self, ray, stats).map(|(h, t)| (h, Some(t)))
    }
}

impl<const W: usize> WideBvh<W> {
    /// [`Accel::closest_hit`] (`any = false`) or [`Accel::any_hit`] on SIMD
    /// path `path` rather than the active one, so that a test can run every
    /// path the processor has.
    ///
    /// # Errors
    /// [`Error::Invalid`] if this processor cannot run `path`.
    pub fn trace_on<S: Stats>(
        &self,
        path: SimdPath,
        ray: &Ray,
        any: bool,
        stats: &mut S,
    ) -> Result<Option<Hit>> {
        traverse::trace_checked::<W, Self, S>(path, self, ray, any, stats)
    }

    /// [`Accel::closest_hit_triangle`] on SIMD path `path` rather than the
    /// active one: the closest hit and the hit triangle read from its leaf.
    ///
    /// # Errors
    /// [`Error::Invalid`] if this processor cannot run `path`.
    pub fn closest_hit_triangle_on<S: Stats>(
        &self,
        path: SimdPath,
        ray: &Ray,
        stats: &mut S,
    ) -> Result<Option<(Hit, Triangle)>> {
        traverse::closest_with_triangle_checked::<W, Self, S>(path, self, ray, stats)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bvh::BuildOptions;
    use crate::scene::Scene;

    fn check<const W: usize>(spec: &str) {
        let scene = Scene::builtin(spec).unwrap();
        let bvh = Bvh::build(&scene.triangles, &BuildOptions::sah());
        let w = WideBvh::<W>::from_bvh(&bvh, scene.triangles.clone()).unwrap();
        // Fewer leaves than the binary tree's (small subtrees merge into
        // one), and every triangle listed once.
        assert!(w.leaves() <= bvh.stats.leaves);
        assert!(w.leaves() * 10 < bvh.stats.leaves * 9, "few leaves merged");
        let mut listed: Vec<u32> = w
            .blocks
            .iter()
            .flat_map(|b| b.prims)
            .filter(|&p| p != EMPTY)
            .map(|e| e & !crate::structures::LAST)
            .collect();
        listed.sort_unstable();
        let mut want = bvh.prims.clone();
        want.sort_unstable();
        assert_eq!(listed, want);
        // Each node's children lie inside the box its parent gave it, and
        // every node but a lone root has 2..=W children.
        let mut todo = vec![(0u32, bvh.bounds())];
        let mut seen = 0;
        while let Some((r, b)) = todo.pop() {
            let n = &w.nodes[r as usize];
            seen += 1;
            let count = n.child_count();
            assert!((2..=W).contains(&count), "{count} children");
            for k in 0..count {
                let c = n.child_bounds(k);
                assert!(b.contains(&c), "child box outside its parent");
                if n.children[k] & LEAF == 0 {
                    todo.push((n.children[k], c));
                }
            }
            assert!(n.children[count..].iter().all(|&c| c == EMPTY));
        }
        assert_eq!(seen, w.nodes.len());
        // Fewer nodes than the binary tree's inner nodes, and no costlier.
        assert!(w.inner_nodes() < bvh.stats.inner_nodes);
        assert!(w.sah_cost() <= collapse::binary_cost(&bvh) + 1e-9);
    }

    #[test]
    fn bvh4_and_bvh8_hold_every_leaf_inside_their_parents() {
        for spec in ["chess:3000", "hairball:3000", "atrium:3000"] {
            check::<4>(spec);
            check::<8>(spec);
        }
    }

    #[test]
    fn node_sizes() {
        assert_eq!(std::mem::size_of::<WideNode<4>>(), 128);
        assert_eq!(std::mem::size_of::<WideNode<8>>(), 256);
    }
}
