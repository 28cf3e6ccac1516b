//! The implicit layout in a saved file ([`crate::saved`]): only its
//! resident nodes, `implicit.positions` (heap positions, ascending) and
//! `implicit.nodes` (the 32-byte node at each), and `implicit.index` (the
//! leaf list). The loader reserves the mapping again (its depth is that of
//! the deepest position, under the caller's reservation limit) and checks
//! that the nodes form the tree the traversals compute positions in: the
//! root at position 0, both children of every inner node present, nothing
//! else present, and every leaf list ending inside the list and naming
//! real triangles.

use super::{reserve, ImplicitBvh, PAGE};
use crate::geometry::Triangle;
use crate::saved::{leaf_run, Sections, Source};
use crate::structures::shared::own_box::OwnBoxNode;
use crate::structures::shared::tri_block::LeafBlocks;
use std::sync::Arc;

impl ImplicitBvh {
    /// Writes the layout's sections: the nodes found by walking the heap
    /// level by level (so their positions ascend).
    pub(crate) fn save<'a>(&'a self, s: &mut Sections<'a>) {
        let slots = self.slots();
        let mut positions = Vec::with_capacity(self.node_count);
        let mut nodes = Vec::with_capacity(self.node_count);
        let mut level = vec![0u32];
        while !level.is_empty() {
            let mut next = Vec::new();
            for &p in &level {
                let n = slots[p as usize + 1];
                positions.push(p);
                nodes.push(n);
                if !n.is_leaf() {
                    next.extend([2 * p + 1, 2 * p + 2]);
                }
            }
            level = next;
        }
        s.owned("implicit.positions", positions);
        s.owned("implicit.nodes", nodes);
        s.slice("implicit.index", &self.index);
    }

    /// Reads the layout over `triangles` back and checks it; its mapping
    /// may reserve at most `reservation_limit` bytes.
    pub(crate) fn load(
        s: &Source<'_>,
        triangles: Arc<[Triangle]>,
        reservation_limit: u64,
    ) -> Result<Self, String> {
        let what = "implicit.nodes";
        let positions = s.vec::<u32>("implicit.positions")?;
        let nodes = s.vec::<OwnBoxNode>("implicit.nodes")?;
        let index = s.vec::<u32>("implicit.index")?;
        if positions.len() != nodes.len() || nodes.is_empty() {
            return Err(format!(
                "{what}: {} nodes at {} positions",
                nodes.len(),
                positions.len()
            ));
        }
        if positions[0] != 0 || positions.windows(2).any(|w| w[0] >= w[1]) {
            return Err("implicit.positions: not ascending from the root's 0".into());
        }
        let last = *positions.last().expect("a node");
        // A node at depth d has position 2^d - 1 .. 2^(d+1) - 2.
        let depth = (last as u64 + 1).ilog2();
        let (mut map, reserved) = reserve(depth, reservation_limit).map_err(|e| e.to_string())?;
        // Both children of every inner node present, in ascending order as
        // their parents are; with 1 + 2 × inner nodes in all, nothing else
        // is present and every node hangs from the root.
        let mut inner = 0;
        let mut j = 1;
        for (&p, n) in positions.iter().zip(&nodes) {
            if n.is_leaf() {
                leaf_run(&index, n.target(), triangles.len(), what)?;
                continue;
            }
            inner += 1;
            let child = 2 * p as u64 + 1;
            while j < positions.len() && (positions[j] as u64) < child {
                j += 1;
            }
            let pair = positions.get(j..j + 2).map(|c| [c[0] as u64, c[1] as u64]);
            if pair != Some([child, child + 1]) {
                return Err(format!(
                    "{what}: the inner node at position {p} lacks a child at {child} or {}",
                    child + 1
                ));
            }
            j += 2;
        }
        if 1 + 2 * inner != nodes.len() {
            return Err(format!(
                "{what}: {} nodes, but a tree of {inner} inner nodes has {}",
                nodes.len(),
                1 + 2 * inner
            ));
        }
        let slots: &mut [OwnBoxNode] = bytemuck::cast_slice_mut(&mut map[..]);
        let mut pages = 0;
        let mut last_page = usize::MAX;
        for (&p, n) in positions.iter().zip(&nodes) {
            slots[p as usize + 1] = *n;
            let page = (p as usize + 1) * std::mem::size_of::<OwnBoxNode>() / PAGE;
            if page != last_page {
                pages += 1;
                last_page = page;
            }
        }
        let blocks = LeafBlocks::new(&index, &triangles);
        Ok(ImplicitBvh {
            map,
            index,
            blocks,
            triangles,
            reserved,
            resident: pages * PAGE,
            node_count: nodes.len(),
            inner_nodes: inner,
        })
    }
}
