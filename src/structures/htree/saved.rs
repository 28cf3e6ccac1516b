//! An H-tree in a saved file ([`crate::saved`]): `htree.meta` (the scene
//! box, the stack bound and the conversion time), `htree.words` (the
//! encoded nodes) and `htree.index` (the leaf list). The loader decodes
//! every node it reaches from word 0 with the untrusted decoder
//! ([`HNode::try_decode`]), checks that children lie after their parent,
//! that the nodes tile the words exactly (each reached once), that no path
//! holds more split nodes than the traversal's stack, and that every leaf
//! list ends inside the list and names real triangles; node counts are
//! recounted.

use super::node::HNode;
use super::{HTree, HtreeStats};
use crate::geometry::{Aabb, Triangle};
use crate::saved::{leaf_run, Bits, RecordWriter, Sections, Source};
use crate::structures::shared::tri_block::LeafBlocks;
use crate::structures::shared::MAX_STACK_DEPTH;
use std::sync::Arc;

impl HTree {
    /// Writes the tree's sections.
    pub(crate) fn save<'a>(&'a self, s: &mut Sections<'a>) {
        let mut meta = RecordWriter::default();
        meta.f32s(&self.root_bounds.to_array())
            .u32(self.depth)
            .f64(self.stats.conversion_seconds);
        s.record("htree.meta", meta);
        s.slice("htree.words", &self.words);
        s.slice("htree.index", &self.index);
    }

    /// Reads the tree over `triangles` back and checks it.
    pub(crate) fn load(s: &Source<'_>, triangles: Arc<[Triangle]>) -> Result<Self, String> {
        let what = "htree.words";
        let mut r = s.record("htree.meta")?;
        let root_bounds = Aabb::from_array(&r.f32s()?);
        let depth = r.u32()?;
        let conversion_seconds = r.f64()?;
        r.finish()?;
        let words = s.vec::<u32>("htree.words")?;
        let index = s.vec::<u32>("htree.index")?;
        if depth as usize >= MAX_STACK_DEPTH {
            return Err(format!(
                "htree.meta: depth {depth} is past the traversal's {} levels",
                MAX_STACK_DEPTH - 1
            ));
        }
        let mut stats = HtreeStats::default();
        let mut covered = Bits::new(words.len());
        let mut used = 0usize;
        let mut todo = vec![(0usize, 0u32)];
        while let Some((at, splits)) = todo.pop() {
            let node = words
                .get(at..)
                .and_then(HNode::try_decode)
                .ok_or_else(|| format!("{what}: no well-formed node at word {at}"))?;
            let size = node.words();
            for w in at..at + size {
                if !covered.insert(w) {
                    return Err(format!(
                        "{what}: the node at word {at} overlaps another, or is reached twice"
                    ));
                }
            }
            used += size;
            match node {
                HNode::Split { second, .. } => {
                    stats.split_nodes += 1;
                    if splits + 1 > depth {
                        return Err(format!(
                            "{what}: a path holds more than {depth} split nodes, the traversal stack's bound"
                        ));
                    }
                    if (second as usize) <= size {
                        return Err(format!(
                            "{what}: the split node at word {at} has its second child {second} words on, not after its first"
                        ));
                    }
                    todo.push((at + second as usize, splits + 1));
                    todo.push((at + size, splits + 1));
                }
                HNode::Bound { mask, .. } => {
                    stats.bound_nodes += 1;
                    stats.bound_faces[mask.count_ones() as usize] += 1;
                    todo.push((at + size, splits));
                }
                HNode::Leaf { offset } => {
                    stats.leaves += 1;
                    leaf_run(&index, offset, triangles.len(), what)?;
                }
            }
        }
        if used != words.len() {
            return Err(format!(
                "{what}: the tree's nodes cover {used} of its {} words",
                words.len()
            ));
        }
        stats.node_bytes = words.len() * 4;
        stats.index_bytes = index.len() * 4;
        stats.conversion_seconds = conversion_seconds;
        let blocks = LeafBlocks::new(&index, &triangles);
        crate::pages::advise(&words);
        Ok(HTree {
            words,
            index,
            blocks,
            triangles,
            root_bounds,
            depth,
            stats,
        })
    }
}
