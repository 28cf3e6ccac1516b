//! The sparse layout in a saved file ([`crate::saved`]): `sparse.nodes`
//! (32-byte own-box nodes), `sparse.index` (the leaf list) and
//! `sparse.ids` (canonical ids, for visit logs). The loader walks the tree
//! from node 0: every inner node's children are an odd-even sibling pair
//! after it whose parent links point back to it, every node is reached
//! once, every split axis is below 3, and every leaf list ends inside the
//! list and names real triangles. The depth it finds is the one the
//! traversals check against their limits.

use super::{SparseBvh, NO_PARENT, PARENT_MASK};
use crate::geometry::Triangle;
use crate::saved::{leaf_run, Bits, Sections, Source};
use crate::structures::shared::own_box::OwnBoxNode;
use crate::structures::shared::tri_block::LeafBlocks;
use std::sync::Arc;

impl SparseBvh {
    /// Writes the layout's sections.
    pub(crate) fn save<'a>(&'a self, s: &mut Sections<'a>) {
        s.slice("sparse.nodes", &self.nodes);
        s.slice("sparse.index", &self.index);
        s.slice("sparse.ids", &self.ids);
    }

    /// Reads the layout over `triangles` back and checks it.
    pub(crate) fn load(s: &Source<'_>, triangles: Arc<[Triangle]>) -> Result<Self, String> {
        let what = "sparse.nodes";
        let nodes = s.vec::<OwnBoxNode>("sparse.nodes")?;
        let index = s.vec::<u32>("sparse.index")?;
        let ids = s.vec::<u32>("sparse.ids")?;
        let n = nodes.len();
        if n == 0 || n >= PARENT_MASK as usize {
            return Err(format!("{what}: {n} nodes"));
        }
        if ids.len() != n {
            return Err(format!("sparse.ids: {} ids for {n} nodes", ids.len()));
        }
        if let Some(i) = nodes.iter().position(|n| n.extra >> 30 == 3) {
            return Err(format!("{what}: node {i} splits on axis 3"));
        }
        if nodes[0].extra & PARENT_MASK != NO_PARENT {
            return Err(format!("{what}: the root has a parent"));
        }
        let mut seen = Bits::new(n);
        let (mut inner, mut depth) = (0usize, 0u32);
        let mut todo = vec![(0u32, 0u32)];
        while let Some((i, d)) = todo.pop() {
            if !seen.insert(i as usize) {
                return Err(format!("{what}: node {i} is reached twice"));
            }
            depth = depth.max(d);
            let node = &nodes[i as usize];
            if node.is_leaf() {
                leaf_run(&index, node.target(), triangles.len(), what)?;
                continue;
            }
            inner += 1;
            let l = node.target();
            if l % 2 == 0 || l <= i || l as usize + 1 >= n {
                return Err(format!(
                    "{what}: node {i} has its children at {l}, not an odd slot after it among {n}"
                ));
            }
            for c in [l, l + 1] {
                if nodes[c as usize].extra & PARENT_MASK != i {
                    return Err(format!("{what}: node {c}'s parent link is not {i}"));
                }
                todo.push((c, d + 1));
            }
        }
        if inner * 2 + 1 != n {
            return Err(format!(
                "{what}: the tree from node 0 reaches {} of its {n} nodes",
                inner * 2 + 1
            ));
        }
        let blocks = LeafBlocks::new(&index, &triangles);
        crate::pages::advise(&nodes);
        Ok(SparseBvh {
            nodes,
            index,
            blocks,
            triangles,
            ids,
            depth,
            inner_nodes: inner,
        })
    }
}
