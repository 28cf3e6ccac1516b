//! A Compact BVH in a saved file ([`crate::saved`]): `cbvh.meta` (the
//! root's reference, the scene box and the stack bound), `cbvh.nodes` (the
//! 32-byte nodes), `cbvh.index` (the leaf list), and for visit logs
//! `cbvh.node-ids` and `cbvh.leaf-ids` (canonical ids of the nodes, and of
//! the leaves by their first index-list position). The loader walks the
//! tree from the root: every inner reference is in range and reached once,
//! every node is reached, the tree is no deeper than the stack bound,
//! every leaf list ends inside the list and names real triangles, no two
//! leaves start at one position, and the leaf ids list exactly the leaves.

use super::{CbvhNode, CompactBvh, INDEX_MASK, LEAF};
use crate::geometry::{Aabb, Triangle};
use crate::saved::{leaf_ids_match, leaf_run, Bits, RecordWriter, Sections, Source};
use crate::structures::shared::tri_block::LeafBlocks;
use crate::structures::shared::MAX_STACK_DEPTH;
use std::sync::Arc;

impl CompactBvh {
    /// Writes the tree's sections.
    pub(crate) fn save<'a>(&'a self, s: &mut Sections<'a>) {
        let mut meta = RecordWriter::default();
        meta.u32(self.root)
            .f32s(&self.root_bounds.to_array())
            .u32(self.depth);
        s.record("cbvh.meta", meta);
        s.slice("cbvh.nodes", &self.nodes);
        s.slice("cbvh.index", &self.index);
        s.slice("cbvh.node-ids", &self.node_ids);
        s.owned(
            "cbvh.leaf-ids",
            self.leaf_ids.iter().map(|&(a, b)| [a, b]).collect(),
        );
    }

    /// Reads the tree over `triangles` back and checks it.
    pub(crate) fn load(s: &Source<'_>, triangles: Arc<[Triangle]>) -> Result<Self, String> {
        let what = "cbvh.nodes";
        let mut r = s.record("cbvh.meta")?;
        let root = r.u32()?;
        let root_bounds = Aabb::from_array(&r.f32s()?);
        let depth = r.u32()?;
        r.finish()?;
        let nodes = s.vec::<CbvhNode>("cbvh.nodes")?;
        let index = s.vec::<u32>("cbvh.index")?;
        let node_ids = s.vec::<u32>("cbvh.node-ids")?;
        let leaf_ids: Vec<(u32, u32)> = s
            .vec::<[u32; 2]>("cbvh.leaf-ids")?
            .into_iter()
            .map(|[a, b]| (a, b))
            .collect();
        if depth as usize >= MAX_STACK_DEPTH {
            return Err(format!(
                "cbvh.meta: depth {depth} is past the traversal's {} levels",
                MAX_STACK_DEPTH - 1
            ));
        }
        if root & !(LEAF | INDEX_MASK) != 0 {
            return Err(format!(
                "cbvh.meta: root reference {root:#x} has stray bits"
            ));
        }
        let mut seen = Bits::new(nodes.len());
        let mut starts = Bits::new(index.len());
        let (mut inner, mut leaves) = (0usize, 0usize);
        let mut todo = vec![(root, 0u32)];
        while let Some((r, d)) = todo.pop() {
            if d > depth {
                return Err(format!(
                    "{what}: the tree is deeper than its stack bound of {depth} levels"
                ));
            }
            let i = r & INDEX_MASK;
            if r & LEAF != 0 {
                leaf_run(&index, i, triangles.len(), what)?;
                if !starts.insert(i as usize) {
                    return Err(format!(
                        "{what}: two leaves start at index-list position {i}"
                    ));
                }
                leaves += 1;
                continue;
            }
            if i as usize >= nodes.len() || !seen.insert(i as usize) {
                return Err(format!(
                    "{what}: node {i} is not among the {} nodes, or is reached twice",
                    nodes.len()
                ));
            }
            inner += 1;
            let n = &nodes[i as usize];
            todo.push((n.child(1), d + 1));
            todo.push((n.child(0), d + 1));
        }
        if inner != nodes.len() {
            return Err(format!(
                "{what}: the tree from the root reaches {inner} of its {} nodes",
                nodes.len()
            ));
        }
        if node_ids.len() != inner {
            return Err(format!(
                "cbvh.node-ids: {} ids for {inner} nodes",
                node_ids.len()
            ));
        }
        leaf_ids_match(&leaf_ids, &starts, leaves, "cbvh.leaf-ids")?;
        let blocks = LeafBlocks::new(&index, &triangles);
        crate::pages::advise(&nodes);
        Ok(CompactBvh {
            nodes,
            index,
            blocks,
            root,
            root_bounds,
            triangles,
            depth,
            node_ids,
            leaf_ids,
        })
    }
}
