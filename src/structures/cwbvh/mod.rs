//! `cwbvh`: the compressed 8-wide BVH of Ylitie, Karras and Laine 2017
//! ("Efficient Incoherent Ray Traversal on GPUs Through Compressed Wide
//! BVHs", §3.2–3.3), the storage-lean wide layout: 80 bytes per node of up
//! to eight children, against 256 for `bvh8`.
//!
//! - Collapse: the SAH-optimal one of `bvh8` (`super::wide::collapse`,
//!   Ylitie et al. §3.1), so that `cwbvh` and `bvh8` have the same nodes and
//!   differ only in how the child boxes are stored.
//! - Node ([`CwNode`]): the node's box corner `p` (3 floats), a
//!   power-of-two scale per axis as an 8-bit exponent, the mask of children
//!   that are nodes (`imask`), the index of the first child node and of the
//!   first triangle block (children of a node are stored side by side, so
//!   one base addresses all of them), a meta byte per child and the child
//!   boxes quantized to 8 bits per plane: `lo = p + q_lo·2^e`,
//!   `hi = p + q_hi·2^e`.
//! - Meta byte as in the paper: `0` for an empty slot; `0b001_xxxxx` with
//!   `xxxxx = 24 + slot` for a child node; for a leaf, its block count in
//!   unary in the top three bits (`001`, `011`, `111`: one to three blocks
//!   of four triangles, so leaves of at most 12 triangles) and the offset of
//!   its first block from the node's block base in the low five.
//! - Conservative rounding: minima are rounded down and maxima up, and each
//!   quantized plane is checked against the f32 arithmetic the traversal
//!   decodes it with, so every decoded child box contains the exact one and
//!   the answers are exact: every hit equals the oracle's.
//! - Traversal: the wide kernel (`super::wide::traverse`) on boxes decoded
//!   per node, every SIMD path of [`super::simd`].

mod saved;

use super::shared::simd::SimdPath;
use super::shared::tri_block::{self, TriBlock};
use super::shared::MAX_STACK_DEPTH;
use super::wide::collapse;
use super::wide::traverse::{self, gather, Entered, Isa, NodeRay, Portable, WideTree};
use super::Accel;
use crate::bvh::Bvh;
use crate::error::{Error, Result};
use crate::geometry::{Aabb, Hit, Ray, Triangle};
use crate::stats::Stats;
use std::sync::Arc;

/// Children per node.
pub const WIDTH: usize = 8;
// Reference bit: a leaf (the rest: its first triangle block), as in
// `bvh8`'s references.
use super::wide::LEAF;
/// Meta byte of a child node: `0b001` then `24 + slot`.
const INNER_META: u8 = 0b0010_0000;
/// Most blocks a leaf may have (the meta byte's unary count).
pub const MAX_LEAF_BLOCKS: usize = 3;
/// Most blocks a node's leaves may have together (5-bit offsets).
const MAX_NODE_BLOCKS: usize = 32;

/// A compressed 8-wide node, 80 bytes (Ylitie et al. 2017, Fig. 2).
#[derive(Clone, Copy, Debug, PartialEq, Eq, bytemuck::Pod, bytemuck::Zeroable)]
#[repr(C, align(16))]
pub struct CwNode {
    /// The quantization frame's origin: the node's box minimum, bit patterns
    /// of three floats.
    pub origin: [u32; 3],
    /// Per axis the scale `2^(e − 127)`, as the biased exponent `e` of an
    /// f32 (1..=254).
    pub exponent: [u8; 3],
    /// Bit `k`: slot `k` is a child node.
    pub imask: u8,
    /// Index of the first child node; the others follow in slot order.
    pub child_base: u32,
    /// Index of the first triangle block of the node's leaves.
    pub block_base: u32,
    /// Per slot: empty (0), a node, or a leaf (see the module docs).
    pub meta: [u8; WIDTH],
    /// Quantized minima, one row per axis, one byte per slot.
    pub q_lo: [[u8; WIDTH]; 3],
    /// Quantized maxima.
    pub q_hi: [[u8; WIDTH]; 3],
}

impl CwNode {
    /// The frame's origin.
    pub fn origin(&self) -> [f32; 3] {
        self.origin.map(f32::from_bits)
    }

    /// The per-axis scales `2^(e − 127)`.
    pub fn scale(&self) -> [f32; 3] {
        self.exponent.map(|e| f32::from_bits((e as u32) << 23))
    }

    /// The decoded child boxes as six plane rows (`min x, min y, min z,
    /// max x, max y, max z`) of eight lanes: `p + q·scale` in f32, exactly
    /// as the traversal computes them. Empty slots decode to whatever their
    /// bytes say; [`CwNode::valid`] masks them.
    pub fn planes(&self) -> [[f32; WIDTH]; 6] {
        self.planes_on::<Portable>()
    }

    /// [`CwNode::planes`] on a SIMD path.
    #[inline(always)]
    fn planes_on<I: Isa>(&self) -> [[f32; WIDTH]; 6] {
        let p = self.origin();
        let s = self.scale();
        std::array::from_fn(|r| {
            let (a, q) = if r < 3 {
                (r, &self.q_lo[r])
            } else {
                (r - 3, &self.q_hi[r - 3])
            };
            I::dequantize8(p[a], s[a], q)
        })
    }

    /// Bit `k`: slot `k` holds a child.
    #[inline(always)]
    pub fn valid(&self) -> u32 {
        // Bit 7 of each byte: whether the byte is non-zero; then the eight
        // bits gathered into one byte by a multiply.
        const LOW7: u64 = 0x7f7f_7f7f_7f7f_7f7f;
        let x = u64::from_le_bytes(self.meta);
        let nonzero = (((x & LOW7) + LOW7) | x) & !LOW7;
        ((nonzero >> 7).wrapping_mul(0x0102_0408_1020_4080) >> 56) as u32
    }

    /// The reference of slot `k`: a node index, or [`LEAF`] and the index of
    /// the leaf's first block.
    #[inline(always)]
    fn reference(&self, k: usize) -> u32 {
        if self.imask & (1 << k) != 0 {
            self.child_base + (self.imask as u32 & ((1 << k) - 1)).count_ones()
        } else {
            // Bit 6 of a leaf's meta byte marks its second block: the
            // reference's `PAIR` bit.
            LEAF | ((self.meta[k] as u32 & 0x40) << 24)
                | (self.block_base + (self.meta[k] & 0x1f) as u32)
        }
    }

    /// The decoded box of slot `k`.
    pub fn child_bounds(&self, k: usize) -> Aabb {
        let p = self.planes();
        Aabb::from_array(&std::array::from_fn(|r| p[r][k]))
    }
}

/// The 8-bit frame of one axis of a node's box `[lo, hi]`: the biased
/// exponent of the smallest power-of-two scale with `lo + 255·scale ≥ hi`
/// in f32, or `None` if none is a normal float.
fn frame_exponent(lo: f32, hi: f32) -> Option<u8> {
    let extent = (hi as f64 - lo as f64) / 255.0;
    let mut e = if extent > 0.0 {
        (extent.log2().ceil() as i32 + 127).max(1)
    } else {
        1
    };
    while e <= 254 {
        let s = f32::from_bits((e as u32) << 23);
        if lo + 255.0 * s >= hi {
            return Some(e as u8);
        }
        e += 1;
    }
    None
}

/// The largest `q` whose decoded plane `p + q·s` is at most `v` (a
/// minimum, rounded down).
fn quantize_down(p: f32, s: f32, v: f32) -> u8 {
    let mut q = (((v as f64 - p as f64) / s as f64).floor()).clamp(0.0, 255.0) as u32;
    while q > 0 && p + q as f32 * s > v {
        q -= 1;
    }
    while q < 255 && p + (q + 1) as f32 * s <= v {
        q += 1;
    }
    q as u8
}

/// The smallest `q` whose decoded plane is at least `v` (a maximum,
/// rounded up); `p + 255·s ≥ v` by the frame's choice.
fn quantize_up(p: f32, s: f32, v: f32) -> u8 {
    let mut q = (((v as f64 - p as f64) / s as f64).ceil()).clamp(0.0, 255.0) as u32;
    while q < 255 && p + (q as f32) * s < v {
        q += 1;
    }
    while q > 0 && p + (q - 1) as f32 * s >= v {
        q -= 1;
    }
    q as u8
}

/// A compressed 8-wide BVH over a mesh's triangles.
#[derive(Clone, Debug)]
pub struct CwBvh {
    nodes: Vec<CwNode>,
    blocks: Vec<TriBlock>,
    triangles: Arc<[Triangle]>,
    root_bounds: Aabb,
    /// The root's reference: node 0, or a leaf for a one-leaf tree.
    root: u32,
    /// Canonical BVH id of each node, and of each leaf by its first block.
    node_ids: Vec<u32>,
    leaf_ids: Vec<(u32, u32)>,
    depth: u32,
    leaves: usize,
    sah_cost: f64,
}

impl CwBvh {
    /// Collapses `bvh` (built over `triangles`) into compressed 8-wide nodes.
    ///
    /// # Errors
    /// [`Error::Limit`] for a leaf of more than 12 triangles (three blocks
    /// of four: build with `--max-leaf 12` or less), a node whose
    /// leaves hold more than 32 blocks, a tree deeper than the traversal
    /// stack holds, 2³¹ or more nodes, or a box no 8-bit frame covers
    /// (coordinates near f32's range).
    pub fn from_bvh(bvh: &Bvh, triangles: Arc<[Triangle]>) -> Result<Self> {
        if bvh.stats.depth as usize >= MAX_STACK_DEPTH {
            return Err(Error::Limit(format!(
                "BVH depth {} exceeds the cwbvh's limit of {} levels; use the hybrid builder",
                bvh.stats.depth,
                MAX_STACK_DEPTH - 1
            )));
        }
        if bvh.nodes.len() >= LEAF as usize {
            return Err(Error::Limit(format!(
                "{} BVH nodes exceed the cwbvh's 31-bit references",
                bvh.nodes.len()
            )));
        }
        if bvh.prims.len() >= super::wide::MAX_BLOCKS {
            return Err(Error::Limit(format!(
                "{} triangle references exceed the cwbvh's 30-bit block indices",
                bvh.prims.len()
            )));
        }
        let plan = collapse::plan::<WIDTH>(bvh);
        let mut w = CwBvh {
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
        if let Some(prims) = plan.leaf(bvh, crate::bvh::ROOT) {
            if !prims.is_empty() {
                w.root = LEAF | w.push_leaf(&prims, crate::bvh::ROOT)?.0;
            }
            return Ok(w);
        }
        w.nodes.push(CwNode::zeroed());
        w.node_ids.push(crate::bvh::ROOT);
        w.fill(bvh, &plan, 0, crate::bvh::ROOT, 0)?;
        crate::pages::advise(&w.nodes);
        crate::pages::advise(&w.blocks);
        Ok(w)
    }

    /// Copies a leaf's triangles into blocks; returns its first block and
    /// block count.
    fn push_leaf(&mut self, prims: &[u32], id: u32) -> Result<(u32, usize)> {
        let count = prims.len().div_ceil(tri_block::LANES);
        if count > MAX_LEAF_BLOCKS {
            return Err(Error::Limit(format!(
                "a leaf of {} triangles exceeds the cwbvh's {} per leaf (build with leaves of at most {}: --max-leaf on the command line, max_leaf_size in BuildOptions)",
                prims.len(),
                MAX_LEAF_BLOCKS * tri_block::LANES,
                MAX_LEAF_BLOCKS * tri_block::LANES
            )));
        }
        let at = tri_block::push_leaf(&mut self.blocks, prims, &self.triangles);
        self.leaf_ids.push((at, id));
        self.leaves += 1;
        Ok((at, count))
    }

    /// Encodes node `at` (binary node `id`, at wide depth `depth`) and,
    /// below it, its subtree.
    fn fill(
        &mut self,
        bvh: &Bvh,
        plan: &collapse::Plan,
        at: usize,
        id: u32,
        depth: u32,
    ) -> Result<()> {
        self.depth = self.depth.max(depth);
        // Each child with its triangles if it is a leaf; empty leaves left out.
        let children: Vec<(u32, Option<Vec<u32>>)> = plan
            .children(bvh, id)
            .into_iter()
            .map(|c| (c, plan.leaf(bvh, c)))
            .filter(|(_, leaf)| leaf.as_ref().is_none_or(|p| !p.is_empty()))
            .collect();
        debug_assert!(children.len() <= WIDTH);
        let bounds = bvh.nodes[id as usize].bounds;
        let (lo, hi) = (bounds.min.to_array(), bounds.max.to_array());
        let mut node = CwNode::zeroed();
        for a in 0..3 {
            node.exponent[a] = frame_exponent(lo[a], hi[a]).ok_or_else(|| {
                Error::Limit(format!(
                    "a node's box [{}, {}] on axis {a} is too wide for the cwbvh's 8-bit planes",
                    lo[a], hi[a]
                ))
            })?;
        }
        node.origin = lo.map(f32::to_bits);
        node.child_base = self.nodes.len() as u32;
        node.block_base = self.blocks.len() as u32;
        let (p, s) = (node.origin(), node.scale());
        let mut inner = Vec::new();
        for (k, (c, leaf)) in children.into_iter().enumerate() {
            let cn = &bvh.nodes[c as usize];
            let (clo, chi) = (cn.bounds.min.to_array(), cn.bounds.max.to_array());
            for a in 0..3 {
                node.q_lo[a][k] = quantize_down(p[a], s[a], clo[a]);
                node.q_hi[a][k] = quantize_up(p[a], s[a], chi[a]);
            }
            if let Some(prims) = leaf {
                let (first, count) = self.push_leaf(&prims, c)?;
                let offset = (first - node.block_base) as usize;
                if offset + count > MAX_NODE_BLOCKS {
                    return Err(Error::Limit(format!(
                        "a cwbvh node's leaves hold more than {MAX_NODE_BLOCKS} triangle blocks (its 5-bit offsets); build with smaller leaves"
                    )));
                }
                node.meta[k] = (((1u8 << count) - 1) << 5) | offset as u8;
            } else {
                node.imask |= 1 << k;
                node.meta[k] = INNER_META | (24 + k as u8);
                inner.push(c);
            }
        }
        // The child nodes side by side, then each one's subtree.
        let base = self.nodes.len();
        self.nodes
            .extend(std::iter::repeat_n(CwNode::zeroed(), inner.len()));
        self.node_ids.extend_from_slice(&inner);
        self.nodes[at] = node;
        for (j, &c) in inner.iter().enumerate() {
            self.fill(bvh, plan, base + j, c, depth + 1)?;
        }
        Ok(())
    }

    /// The nodes; node 0 is the root unless the tree is one leaf.
    pub fn nodes(&self) -> &[CwNode] {
        &self.nodes
    }

    /// The leaves' triangle blocks.
    pub fn blocks(&self) -> &[TriBlock] {
        &self.blocks
    }

    /// Bytes of the nodes (80 each).
    pub fn node_bytes(&self) -> usize {
        std::mem::size_of_val(&self.nodes[..])
    }

    /// Bytes of the leaves' triangle blocks (160 per four triangles).
    pub fn index_bytes(&self) -> usize {
        std::mem::size_of_val(&self.blocks[..])
    }

    /// Nodes (inner).
    pub fn inner_nodes(&self) -> usize {
        self.nodes.len()
    }

    /// Leaves (the binary BVH's).
    pub fn leaves(&self) -> usize {
        self.leaves
    }

    /// Levels below the root.
    pub fn depth(&self) -> u32 {
        self.depth
    }

    /// SAH cost of the collapse (as `bvh8`'s, before quantization).
    pub fn sah_cost(&self) -> f64 {
        self.sah_cost
    }

    /// [`Accel::closest_hit`] (`any = false`) or [`Accel::any_hit`] on SIMD
    /// path `path` rather than the active one.
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
        traverse::trace_checked::<WIDTH, Self, S>(path, self, ray, any, stats)
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
        traverse::closest_with_triangle_checked::<WIDTH, Self, S>(path, self, ray, stats)
    }
}

use bytemuck::Zeroable;

impl WideTree<WIDTH> for CwBvh {
    #[inline(always)]
    fn root(&self) -> u32 {
        super::wide::with_pair(self.root, &self.blocks)
    }
    #[inline(always)]
    fn is_empty(&self) -> bool {
        self.blocks.is_empty()
    }
    #[inline(always)]
    fn depth(&self) -> u32 {
        self.depth
    }
    #[inline(always)]
    fn blocks(&self) -> &[TriBlock] {
        &self.blocks
    }
    #[inline(always)]
    fn triangles(&self) -> &[Triangle] {
        &self.triangles
    }
    #[inline(always)]
    fn enter<I: Isa>(&self, node: u32, r: &NodeRay, tmax: f32, e: &mut Entered<WIDTH>) -> u32 {
        let n = &self.nodes[node as usize];
        let valid = n.valid();
        let (d, mask) = I::test::<WIDTH>(r, &n.planes_on::<I>(), tmax);
        gather(&d, |k| n.reference(k), mask & valid, e);
        6 * valid.count_ones()
    }
    fn canonical_id(&self, r: u32) -> u32 {
        traverse::canonical_id(&self.node_ids, &self.leaf_ids, super::wide::plain(r))
    }
}

impl Accel for CwBvh {
    fn name(&self) -> &'static str {
        "cwbvh"
    }

    fn bytes(&self) -> usize {
        self.node_bytes() + self.index_bytes()
    }

    fn closest_hit<S: Stats>(&self, ray: &Ray, stats: &mut S) -> Option<Hit> {
        traverse::trace::<WIDTH, Self, S, false>(self, ray, stats)
    }

    fn any_hit<S: Stats>(&self, ray: &Ray, stats: &mut S) -> Option<Hit> {
        traverse::trace::<WIDTH, Self, S, true>(self, ray, stats)
    }

    fn closest_hit_triangle<S: Stats>(
        &self,
        ray: &Ray,
        stats: &mut S,
    ) -> Option<(Hit, Option<Triangle>)> {
        traverse::closest_with_triangle::<WIDTH, Self, S>(self, ray, stats)
            .map(|(h, t)| (h, Some(t)))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bvh::BuildOptions;
    use crate::scene::Scene;
    use crate::structures::Bvh8;

    #[test]
    fn nodes_are_80_bytes() {
        assert_eq!(std::mem::size_of::<CwNode>(), 80);
    }

    #[test]
    fn the_valid_mask_has_a_bit_per_non_empty_slot() {
        let mut n = CwNode::zeroed();
        assert_eq!(n.valid(), 0);
        for bits in 0..=255u32 {
            for k in 0..WIDTH {
                n.meta[k] = if bits & (1 << k) != 0 {
                    [1, 0x20, 0x7f, 0x80, 0xff, 0x3f][(k + bits as usize) % 6]
                } else {
                    0
                };
            }
            assert_eq!(n.valid(), bits);
        }
    }

    #[test]
    fn quantized_planes_are_conservative_and_tight() {
        let mut rng = crate::rng::Pcg32::new(7, 1);
        for _ in 0..20_000 {
            let scale = 10f32.powi(rng.below(13) as i32 - 6);
            let lo = (rng.next_f32() - 0.5) * scale * 100.0;
            let hi = lo + rng.next_f32() * scale;
            let e = frame_exponent(lo, hi).unwrap();
            let s = f32::from_bits((e as u32) << 23);
            assert!(lo + 255.0 * s >= hi);
            // The frame is the smallest power of two that covers the box,
            // give or take the f32 rounding of the check.
            if e > 1 {
                let half = f32::from_bits(((e - 1) as u32) << 23);
                assert!((hi as f64 - lo as f64) > 255.0 * half as f64 * 0.99);
            }
            let a = lo + rng.next_f32() * (hi - lo);
            let b = lo + rng.next_f32() * (hi - lo);
            let (cl, ch) = (a.min(b), a.max(b));
            let (ql, qh) = (quantize_down(lo, s, cl), quantize_up(lo, s, ch));
            let (dl, dh) = (lo + ql as f32 * s, lo + qh as f32 * s);
            assert!(dl <= cl && dh >= ch, "[{dl}, {dh}] misses [{cl}, {ch}]");
            assert!(ql == 255 || lo + (ql + 1) as f32 * s > cl);
            assert!(qh == 0 || lo + (qh - 1) as f32 * s < ch);
        }
    }

    #[test]
    fn has_bvh8s_nodes_with_boxes_that_contain_the_exact_ones() {
        for spec in ["chess:3000", "hairball:3000", "atrium:3000"] {
            let scene = Scene::builtin(spec).unwrap();
            let bvh = Bvh::build(&scene.triangles, &BuildOptions::sah());
            let cw = CwBvh::from_bvh(&bvh, scene.triangles.clone()).unwrap();
            let b8 = Bvh8::from_bvh(&bvh, scene.triangles.clone()).unwrap();
            assert_eq!(cw.inner_nodes(), b8.inner_nodes());
            assert_eq!(cw.leaves(), b8.leaves());
            assert_eq!(cw.blocks().len(), b8.blocks().len());
            assert_eq!(cw.node_bytes(), 80 * cw.inner_nodes());
            // Every slot's decoded box holds the exact box of what is below
            // it, and is no bigger than one quantization step per plane.
            for (i, n) in cw.nodes().iter().enumerate() {
                let s = n.scale();
                let mut inner = 0;
                for k in 0..WIDTH {
                    if n.meta[k] == 0 {
                        assert_eq!(n.imask & (1 << k), 0);
                        continue;
                    }
                    let exact =
                        bvh.nodes[WideTree::canonical_id(&cw, n.reference(k)) as usize].bounds;
                    let d = n.child_bounds(k);
                    assert!(d.contains(&exact), "node {i} slot {k}");
                    for (a, &s) in s.iter().enumerate() {
                        assert!(exact.min[a] - d.min[a] <= s);
                        assert!(d.max[a] - exact.max[a] <= s);
                    }
                    if n.imask & (1 << k) != 0 {
                        assert_eq!(n.meta[k], INNER_META | (24 + k as u8));
                        assert_eq!(n.reference(k), n.child_base + inner);
                        inner += 1;
                    } else {
                        let blocks = (n.meta[k] >> 5).count_ones();
                        assert!((1..=3).contains(&blocks));
                        assert_eq!(n.meta[k] >> 5, (1 << blocks) - 1, "unary count");
                    }
                }
            }
        }
    }

    #[test]
    fn big_leaves_are_refused_with_the_limit() {
        let scene = Scene::builtin("chess:3000").unwrap();
        let bvh = Bvh::build(
            &scene.triangles,
            &BuildOptions::hybrid().with_max_leaf_size(64),
        );
        let biggest = bvh
            .nodes
            .iter()
            .filter(|n| n.is_leaf())
            .map(|n| bvh.leaf_prims(n).len())
            .max()
            .unwrap();
        assert!(biggest > 12, "the test needs a leaf past the limit");
        let e = CwBvh::from_bvh(&bvh, scene.triangles.clone())
            .unwrap_err()
            .to_string();
        assert!(e.contains("12 per leaf"), "{e}");
        // Leaves of 12 fit.
        let bvh = Bvh::build(
            &scene.triangles,
            &BuildOptions::hybrid().with_max_leaf_size(12),
        );
        CwBvh::from_bvh(&bvh, scene.triangles.clone()).unwrap();
    }
}
