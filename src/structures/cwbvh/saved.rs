//! A `cwbvh` in a saved file ([`crate::saved`]): `cwbvh.meta` (the root's
//! reference, the scene box, the depth, the leaf count and the collapse's
//! SAH cost), `cwbvh.nodes` (the 80-byte nodes as they are in memory),
//! `cwbvh.blocks` (the leaves' triangle blocks), and for visit logs
//! `cwbvh.node-ids` and `cwbvh.leaf-ids`.
//!
//! The loader walks the tree from the root and checks what the traversal
//! relies on: exponents of normal floats and a finite origin; meta bytes of
//! the paper's forms, agreeing with `imask`; child nodes inside the array
//! and each reached once, all of them reached; leaves whose blocks match
//! their unary count, lie inside the node's 32-block window and are each
//! one leaf's, with lanes naming existing triangles and holding their
//! vertices; a tree no deeper than its stack bound. Boxes are not checked
//! against the triangles (a spatial-split build's leaf boxes hold only
//! parts of theirs), as no saved layout's are: a file whose boxes were
//! altered and checksums recomputed answers wrongly, never unsafely.

use super::{CwBvh, CwNode, INNER_META, LEAF, MAX_LEAF_BLOCKS, MAX_NODE_BLOCKS, WIDTH};
use crate::geometry::{Aabb, Triangle};
use crate::saved::{leaf_ids_match, Bits, RecordWriter, Sections, Source};
use crate::structures::shared::tri_block::TriBlock;
use crate::structures::shared::MAX_STACK_DEPTH;
use crate::structures::wide::saved::leaf_blocks;
use std::sync::Arc;

const WHAT: &str = "cwbvh.nodes";

impl CwBvh {
    /// Writes the tree's sections.
    pub(crate) fn save<'a>(&'a self, s: &mut Sections<'a>) {
        let mut meta = RecordWriter::default();
        meta.u32(self.root)
            .f32s(&self.root_bounds.to_array())
            .u32(self.depth)
            .u64(self.leaves as u64)
            .f64(self.sah_cost);
        s.record("cwbvh.meta", meta);
        s.slice("cwbvh.nodes", &self.nodes);
        s.slice("cwbvh.blocks", &self.blocks);
        s.slice("cwbvh.node-ids", &self.node_ids);
        s.owned(
            "cwbvh.leaf-ids",
            self.leaf_ids.iter().map(|&(a, b)| [a, b]).collect(),
        );
    }

    /// Reads the tree over `triangles` back and checks it.
    pub(crate) fn load(s: &Source<'_>, triangles: Arc<[Triangle]>) -> Result<Self, String> {
        let mut r = s.record("cwbvh.meta")?;
        let root = r.u32()?;
        let root_bounds = Aabb::from_array(&r.f32s()?);
        let depth = r.u32()?;
        let saved_leaves = r.usize()?;
        let sah_cost = r.f64()?;
        r.finish()?;
        let nodes = s.vec::<CwNode>("cwbvh.nodes")?;
        let blocks = s.vec::<TriBlock>("cwbvh.blocks")?;
        if blocks.len() > crate::structures::wide::MAX_BLOCKS {
            return Err(format!(
                "cwbvh.blocks: {} blocks exceed the 30-bit block indices",
                blocks.len()
            ));
        }
        let node_ids = s.vec::<u32>("cwbvh.node-ids")?;
        let leaf_ids: Vec<(u32, u32)> = s
            .vec::<[u32; 2]>("cwbvh.leaf-ids")?
            .into_iter()
            .map(|[a, b]| (a, b))
            .collect();
        if depth as usize >= MAX_STACK_DEPTH {
            return Err(format!(
                "cwbvh.meta: depth {depth} is past the traversal's {} levels",
                MAX_STACK_DEPTH - 1
            ));
        }
        let mut walk = Walk {
            nodes: &nodes,
            blocks: &blocks,
            triangles: &triangles,
            depth,
            seen: Bits::new(nodes.len()),
            covered: Bits::new(blocks.len()),
            starts: Bits::new(blocks.len()),
            inner: 0,
            leaves: 0,
            used: 0,
        };
        if !(blocks.is_empty() && nodes.is_empty()) {
            if root & LEAF != 0 {
                walk.leaf((root & !LEAF) as usize, None)?;
            } else {
                walk.node(root as usize, 0)?;
            }
        }
        let (inner, leaves, used) = (walk.inner, walk.leaves, walk.used);
        if inner != nodes.len() || used != blocks.len() {
            return Err(format!(
                "{WHAT}: the tree from the root reaches {inner} of its {} nodes and {used} of its {} blocks",
                nodes.len(),
                blocks.len()
            ));
        }
        if node_ids.len() != inner {
            return Err(format!(
                "cwbvh.node-ids: {} ids for {inner} nodes",
                node_ids.len()
            ));
        }
        if saved_leaves != leaves {
            return Err(format!(
                "cwbvh.meta: {saved_leaves} leaves, but the tree has {leaves}"
            ));
        }
        let starts = walk.starts;
        leaf_ids_match(&leaf_ids, &starts, leaves, "cwbvh.leaf-ids")?;
        crate::pages::advise(&nodes);
        crate::pages::advise(&blocks);
        Ok(CwBvh {
            nodes,
            blocks,
            triangles,
            root_bounds,
            root,
            node_ids,
            leaf_ids,
            depth,
            leaves,
            sah_cost,
        })
    }
}

/// The loader's walk over the tree.
struct Walk<'a> {
    nodes: &'a [CwNode],
    blocks: &'a [TriBlock],
    triangles: &'a [Triangle],
    depth: u32,
    seen: Bits,
    covered: Bits,
    starts: Bits,
    inner: usize,
    leaves: usize,
    used: usize,
}

impl Walk<'_> {
    /// Checks the leaf starting at block `first` (of `count` blocks, when
    /// its parent says).
    fn leaf(&mut self, first: usize, count: Option<usize>) -> Result<(), String> {
        let n = leaf_blocks(
            self.blocks,
            first,
            self.triangles,
            &mut self.covered,
            "cwbvh.blocks",
        )?;
        if count.is_some_and(|c| c != n) {
            return Err(format!(
                "cwbvh.blocks: the leaf at block {first} has {n} blocks, its meta byte says {}",
                count.unwrap_or(0)
            ));
        }
        self.starts.insert(first);
        self.leaves += 1;
        self.used += n;
        Ok(())
    }

    /// Checks node `i` at wide depth `d` and its subtree.
    fn node(&mut self, i: usize, d: u32) -> Result<(), String> {
        if d > self.depth {
            return Err(format!(
                "{WHAT}: the tree is deeper than its stack bound of {} levels",
                self.depth
            ));
        }
        if i >= self.nodes.len() || !self.seen.insert(i) {
            return Err(format!(
                "{WHAT}: node {i} is not among the {} nodes, or is reached twice",
                self.nodes.len()
            ));
        }
        self.inner += 1;
        let n = self.nodes[i];
        if n.exponent.iter().any(|&e| !(1..=254).contains(&e))
            || n.origin().iter().any(|p| !p.is_finite())
        {
            return Err(format!(
                "{WHAT}: node {i} has an exponent outside 1..=254 or an origin that is not finite"
            ));
        }
        let children = n.imask.count_ones() as usize;
        if n.child_base as usize + children > self.nodes.len() {
            return Err(format!(
                "{WHAT}: node {i}'s {children} child nodes from {} run past the {} nodes",
                n.child_base,
                self.nodes.len()
            ));
        }
        let mut slots = 0;
        for k in 0..WIDTH {
            let m = n.meta[k];
            let inner = n.imask & (1 << k) != 0;
            if m == 0 {
                if inner {
                    return Err(format!(
                        "{WHAT}: node {i} slot {k} is empty but marked a node"
                    ));
                }
                continue;
            } else if inner {
                if m != INNER_META | (24 + k as u8) {
                    return Err(format!(
                        "{WHAT}: node {i} slot {k} is a node with meta byte {m:#010b}"
                    ));
                }
                let c =
                    n.child_base as usize + (n.imask as u32 & ((1 << k) - 1)).count_ones() as usize;
                self.node(c, d + 1)?;
            } else {
                let count = (m >> 5).count_ones() as usize;
                let offset = (m & 0x1f) as usize;
                if m >> 5 != (1 << count) - 1 || count > MAX_LEAF_BLOCKS {
                    return Err(format!(
                        "{WHAT}: node {i} slot {k}'s meta byte {m:#010b} has no unary block count"
                    ));
                }
                if offset + count > MAX_NODE_BLOCKS {
                    return Err(format!(
                        "{WHAT}: node {i} slot {k}'s blocks run past the node's {MAX_NODE_BLOCKS}"
                    ));
                }
                self.leaf(n.block_base as usize + offset, Some(count))?;
            }
            slots += 1;
        }
        if slots == 0 {
            return Err(format!("{WHAT}: node {i} has no children"));
        }
        Ok(())
    }
}
