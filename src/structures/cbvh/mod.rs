//! The Compact BVH (Fabianowski and Dingliana 2009), as the dual-split
//! paper compares it: the BVH's own tree, with each inner node stored in 32
//! bytes by leaving out the planes its two children share with it.
//!
//! When a parent box `P` is the exact union of its children's boxes, on each
//! axis one child's minimum is `P`'s minimum and one child's maximum is
//! `P`'s maximum. So a node stores, per axis, only the *other* child's
//! minimum and the *other* child's maximum (six planes), plus which child
//! owns `P`'s planes; a traversal that knows `P` rebuilds both children's
//! boxes bit for bit.
//!
//! Node layout (32 bytes, [`CbvhNode`]):
//! - `lo[a]`: on axis `a`, the minimum of the child that does not own
//!   `P.min[a]`; `hi[a]` the maximum of the child that does not own
//!   `P.max[a]`;
//! - `refs[0]`: child 0's reference, with bits 28–30 saying, for x, y and z,
//!   which child owns `P.min` (0 = child 0); `refs[1]`: child 1's
//!   reference, with bits 28–30 saying which owns `P.max`;
//! - a reference: bit 31 set for a leaf, bits 0–27 the child's node index
//!   or, for a leaf, the position of its first triangle in the index list
//!   (whose last entry per leaf has [`LAST`] set).
//!
//! Choices where the paper is open (baselines.md §6): child 0 owns a plane
//! both children share; leaves take no node of their own (a reference holds
//! them), which gives the paper's 32/56 ≈ 57% of the uncompressed BVH; the
//! root box is kept beside the nodes, as every structure here does. A
//! traversal carries the six plane distances of the current node's box, so
//! it computes only the six stored planes per node; the distances are the
//! same expressions on the same floats as the uncompressed BVH's, so the
//! traversal visits exactly the nodes STACK visits
//! (`traverse.rs`).

mod saved;
mod traverse;

use super::shared::MAX_STACK_DEPTH;
use super::Accel;
use crate::bvh::{Bvh, NodeKind, ROOT};
use crate::error::{Error, Result};
use crate::geometry::{Aabb, Hit, Ray, Triangle};
use crate::stats::Stats;
use crate::structures::shared::tri_block::LeafBlocks;
use std::sync::Arc;

use super::shared::leaf::LAST;

/// Reference bit: a leaf.
const LEAF: u32 = 1 << 31;
/// Reference bits holding the index.
const INDEX_MASK: u32 = (1 << 28) - 1;
/// Reference bits holding the three owner flags.
const OWNER_SHIFT: u32 = 28;

/// One inner node: six planes and two child references (32 bytes).
#[derive(Clone, Copy, Debug, Default, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
#[repr(C, align(32))]
pub struct CbvhNode {
    /// Per axis xyz, the minimum of the child that does not own the parent's
    /// minimum.
    pub lo: [f32; 3],
    /// Per axis xyz, the maximum of the child that does not own the parent's
    /// maximum.
    pub hi: [f32; 3],
    /// Child 0's and child 1's references (bit 31 leaf, bits 0–27 index),
    /// with the owners of the parent's minima (`refs[0]`) and maxima
    /// (`refs[1]`) in bits 28–30, for x, y, z.
    pub refs: [u32; 2],
}

impl CbvhNode {
    /// Planes a node stores (`lo` and `hi`: six, shared by its two
    /// children), each tested once per visit.
    pub const PLANES: u32 = 6;

    /// Encodes the children `c` of the parent box `p` (which must be their
    /// exact union) with references `refs` (owner bits clear).
    pub fn encode(p: &Aabb, c: [&Aabb; 2], refs: [u32; 2]) -> CbvhNode {
        let mut n = CbvhNode {
            refs,
            ..CbvhNode::default()
        };
        for a in 0..3 {
            let min_owner = (c[0].min[a] != p.min[a]) as usize;
            let max_owner = (c[0].max[a] != p.max[a]) as usize;
            n.lo[a] = c[1 - min_owner].min[a];
            n.hi[a] = c[1 - max_owner].max[a];
            n.refs[0] |= (min_owner as u32) << (OWNER_SHIFT + a as u32);
            n.refs[1] |= (max_owner as u32) << (OWNER_SHIFT + a as u32);
        }
        n
    }

    /// Which child owns the parent's minimum (`[0]`) and maximum (`[1]`) on
    /// `axis`.
    #[inline(always)]
    pub fn owners(&self, axis: usize) -> [usize; 2] {
        [
            (self.refs[0] >> (OWNER_SHIFT + axis as u32) & 1) as usize,
            (self.refs[1] >> (OWNER_SHIFT + axis as u32) & 1) as usize,
        ]
    }

    /// Child `j`'s reference (leaf bit and index, owner bits removed).
    #[inline(always)]
    pub fn child(&self, j: usize) -> u32 {
        self.refs[j] & (LEAF | INDEX_MASK)
    }

    /// Both children's boxes, rebuilt from the parent box `p`.
    pub fn decode(&self, p: &Aabb) -> [Aabb; 2] {
        let mut c = [*p; 2];
        for a in 0..3 {
            let [mn, mx] = self.owners(a);
            c[1 - mn].min[a] = self.lo[a];
            c[1 - mx].max[a] = self.hi[a];
        }
        c
    }
}

/// A Compact BVH: nodes, the triangle index list and the scene box.
#[derive(Clone, Debug)]
pub struct CompactBvh {
    pub(crate) nodes: Vec<CbvhNode>,
    pub(crate) index: Vec<u32>,
    /// The leaf list's triangles in blocks, as the traversal tests them.
    pub(crate) blocks: LeafBlocks,
    /// The root's reference: node 0, or a leaf when the BVH is one leaf.
    pub(crate) root: u32,
    pub(crate) root_bounds: Aabb,
    pub(crate) triangles: Arc<[Triangle]>,
    pub(crate) depth: u32,
    /// Canonical ids of the nodes, and of the leaves by index-list
    /// position: only read by visit logs and tests.
    node_ids: Vec<u32>,
    leaf_ids: Vec<(u32, u32)>,
}

impl CompactBvh {
    /// Converts `bvh`. [`Error::Invalid`] for a BVH whose parent boxes are
    /// not the exact unions of their children's (the encoding needs them);
    /// [`Error::Limit`] for one deeper than the traversal stack, or with more
    /// than 2²⁸ nodes or triangle references.
    pub fn from_bvh(bvh: &Bvh, triangles: Arc<[Triangle]>) -> Result<Self> {
        if bvh.stats.depth as usize >= MAX_STACK_DEPTH {
            return Err(Error::Limit(format!(
                "BVH depth {} exceeds the compact BVH traversal's limit of {} levels; use the hybrid builder",
                bvh.stats.depth,
                MAX_STACK_DEPTH - 1
            )));
        }
        let limit = INDEX_MASK as usize + 1;
        if bvh.stats.inner_nodes > limit || bvh.prims.len() > limit {
            return Err(Error::Limit(format!(
                "{} inner nodes and {} triangle references: the compact BVH's 28-bit references address at most {limit} of each",
                bvh.stats.inner_nodes,
                bvh.prims.len()
            )));
        }
        for (i, n) in bvh.nodes.iter().enumerate() {
            if let NodeKind::Inner { left, right, .. } = n.kind {
                let u = bvh.nodes[left as usize]
                    .bounds
                    .union(bvh.nodes[right as usize].bounds);
                if u != n.bounds {
                    return Err(Error::Invalid(format!(
                        "BVH node {i}'s box is not the exact union of its children's; the compact BVH cannot encode it"
                    )));
                }
            }
        }
        let mut c = CompactBvh {
            nodes: crate::pages::vec_with_capacity(bvh.stats.inner_nodes),
            index: Vec::with_capacity(bvh.prims.len()),
            blocks: LeafBlocks::default(),
            root: 0,
            root_bounds: bvh.bounds(),
            triangles,
            depth: bvh.stats.depth,
            node_ids: Vec::with_capacity(bvh.stats.inner_nodes),
            leaf_ids: Vec::with_capacity(bvh.stats.leaves),
        };
        if !bvh.prims.is_empty() {
            c.root = c.place(bvh, ROOT);
        }
        c.blocks = LeafBlocks::new(&c.index, &c.triangles);
        crate::pages::advise(&c.nodes);
        Ok(c)
    }

    /// Places node `id` and its subtree, depth-first; returns its reference.
    fn place(&mut self, bvh: &Bvh, id: u32) -> u32 {
        let node = &bvh.nodes[id as usize];
        match node.kind {
            NodeKind::Leaf { .. } => {
                let first = self.index.len() as u32;
                self.index.extend_from_slice(bvh.leaf_prims(node));
                if let Some(last) = self.index.last_mut() {
                    *last |= LAST;
                }
                self.leaf_ids.push((first, id));
                first | LEAF
            }
            NodeKind::Inner { left, right, .. } => {
                let at = self.nodes.len();
                self.nodes.push(CbvhNode::default());
                self.node_ids.push(id);
                let l = self.place(bvh, left);
                let r = self.place(bvh, right);
                self.nodes[at] = CbvhNode::encode(
                    &node.bounds,
                    [
                        &bvh.nodes[left as usize].bounds,
                        &bvh.nodes[right as usize].bounds,
                    ],
                    [l, r],
                );
                at as u32
            }
        }
    }

    /// The inner nodes, depth-first; the root is node 0.
    pub fn nodes(&self) -> &[CbvhNode] {
        &self.nodes
    }

    /// Mesh triangle indices of the leaves, each leaf's last one with
    /// [`LAST`] set.
    pub fn index_list(&self) -> &[u32] {
        &self.index
    }

    /// The root's reference (bit 31 set when the tree is a single leaf).
    pub fn root(&self) -> u32 {
        self.root
    }

    /// The scene box, from which the root's children are rebuilt.
    pub fn root_bounds(&self) -> Aabb {
        self.root_bounds
    }

    /// Whether the tree holds no triangles.
    pub fn is_empty(&self) -> bool {
        self.index.is_empty()
    }

    /// 32 bytes per inner node.
    pub fn node_bytes(&self) -> usize {
        self.nodes.len() * std::mem::size_of::<CbvhNode>()
    }

    /// 4 bytes per triangle reference.
    pub fn index_bytes(&self) -> usize {
        self.index.len() * 4
    }

    /// Leaves, which take no node of their own (a reference holds each).
    pub fn leaves(&self) -> usize {
        self.leaf_ids.len()
    }

    /// Where the leaf that reference `r` points to starts in
    /// [`Self::index_list`], or `None` if `r` is an inner node (an index
    /// into [`Self::nodes`]).
    pub fn leaf_start(&self, r: u32) -> Option<u32> {
        (r & LEAF != 0).then_some(r & INDEX_MASK)
    }

    /// The canonical BVH id of reference `r` (for visit logs).
    pub fn canonical_id(&self, r: u32) -> u32 {
        if r & LEAF == 0 {
            return self.node_ids[r as usize];
        }
        let first = r & INDEX_MASK;
        let k = self
            .leaf_ids
            .binary_search_by_key(&first, |p| p.0)
            .expect("a placed leaf");
        self.leaf_ids[k].1
    }
}

impl Accel for CompactBvh {
    fn name(&self) -> &'static str {
        "cbvh"
    }

    fn bytes(&self) -> usize {
        self.node_bytes() + self.index_bytes()
    }

    fn closest_hit<S: Stats>(&self, ray: &Ray, stats: &mut S) -> Option<Hit> {
        traverse::trace::<S, false>(self, ray, stats)
    }

    fn any_hit<S: Stats>(&self, ray: &Ray, stats: &mut S) -> Option<Hit> {
        traverse::trace::<S, true>(self, ray, stats)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;

    #[test]
    fn node_is_32_bytes() {
        assert_eq!(std::mem::size_of::<CbvhNode>(), 32);
    }

    #[test]
    fn every_ownership_pattern_round_trips() {
        // Per axis: child 0 owns min and max, child 1 owns both, one each,
        // and both share both planes.
        let p = Aabb::new(Vec3::splat(0.0), Vec3::splat(10.0));
        let cases: [([f32; 2], [f32; 2]); 5] = [
            ([0.0, 10.0], [2.0, 8.0]),
            ([2.0, 8.0], [0.0, 10.0]),
            ([0.0, 6.0], [3.0, 10.0]),
            ([4.0, 10.0], [0.0, 5.0]),
            ([0.0, 10.0], [0.0, 10.0]),
        ];
        for (i, x) in cases.iter().enumerate() {
            let y = cases[(i + 1) % 5];
            let z = cases[(i + 3) % 5];
            let c0 = Aabb::new(
                Vec3::new(x.0[0], y.0[0], z.0[0]),
                Vec3::new(x.0[1], y.0[1], z.0[1]),
            );
            let c1 = Aabb::new(
                Vec3::new(x.1[0], y.1[0], z.1[0]),
                Vec3::new(x.1[1], y.1[1], z.1[1]),
            );
            assert_eq!(c0.union(c1), p);
            let refs = [INDEX_MASK, LEAF | 7];
            let n = CbvhNode::encode(&p, [&c0, &c1], refs);
            assert_eq!(n.decode(&p), [c0, c1]);
            assert_eq!([n.child(0), n.child(1)], refs);
        }
    }
}
