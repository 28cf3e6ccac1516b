//! A dual-split tree (or a BIH, which is one) in a saved file
//! ([`crate::saved`]): `dst.meta` (the scene box, the stack bound, the
//! least identical storage and the conversion time), `dst.words` (the
//! encoded nodes) and `dst.index` (the leaf list). The loader decodes every
//! node it reaches from word 0 with the untrusted decoder
//! ([`DstNode::try_decode`]), checks that children lie after their parent,
//! that the nodes tile the words exactly (each reached once), that no path
//! holds more splitting nodes than the traversal's stack, that every leaf
//! list ends inside the list and names real triangles, and (for a BIH)
//! that no node carves on two axes; node counts are recounted.

use super::node::DstNode;
use super::plan::Rules;
use super::{DstStats, DualSplitTree};
use crate::geometry::{Aabb, Triangle};
use crate::saved::{leaf_run, Bits, RecordWriter, Sections, Source};
use crate::structures::shared::tri_block::LeafBlocks;
use crate::structures::shared::MAX_STACK_DEPTH;
use std::sync::Arc;

impl DualSplitTree {
    /// Writes the tree's sections.
    pub(crate) fn save<'a>(&'a self, s: &mut Sections<'a>) {
        let mut meta = RecordWriter::default();
        meta.f32s(&self.root_bounds.to_array())
            .u32(self.depth)
            .u64(self.stats.least_identical_bytes as u64)
            .f64(self.stats.conversion_seconds);
        s.record("dst.meta", meta);
        s.slice("dst.words", &self.words);
        s.slice("dst.index", &self.index);
    }

    /// Reads a tree converted under `rules` over `triangles` back and
    /// checks it.
    pub(crate) fn load(
        s: &Source<'_>,
        triangles: Arc<[Triangle]>,
        rules: Rules,
    ) -> Result<Self, String> {
        let what = "dst.words";
        let mut r = s.record("dst.meta")?;
        let root_bounds = Aabb::from_array(&r.f32s()?);
        let depth = r.u32()?;
        let least_identical_bytes = r.usize()?;
        let conversion_seconds = r.f64()?;
        r.finish()?;
        let words = s.vec::<u32>("dst.words")?;
        let index = s.vec::<u32>("dst.index")?;
        if depth as usize >= MAX_STACK_DEPTH {
            return Err(format!(
                "dst.meta: depth {depth} is past the traversal's {} levels",
                MAX_STACK_DEPTH - 1
            ));
        }
        let mut stats = DstStats::default();
        let mut covered = Bits::new(words.len());
        let mut used = 0usize;
        // (word, splitting nodes above, carving levels below the last split)
        let mut todo = vec![(0usize, 0u32, None::<usize>)];
        let level = |stats: &mut DstStats, l: Option<usize>| {
            if let Some(l) = l {
                stats.carving_levels[l.min(3)] += 1;
            }
        };
        while let Some((at, splits, levels)) = todo.pop() {
            let node = words
                .get(at..)
                .and_then(DstNode::try_decode)
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
            let after = |offset: u32| -> Result<usize, String> {
                if (offset as usize) < size {
                    return Err(format!(
                        "{what}: the node at word {at} has a child {offset} words on, not after it"
                    ));
                }
                Ok(at + offset as usize)
            };
            match node {
                DstNode::Split {
                    first_words,
                    offset,
                    ..
                } => {
                    level(&mut stats, levels);
                    stats.split_nodes += 1;
                    if splits + 1 > depth {
                        return Err(format!(
                            "{what}: a path holds more than {depth} splitting nodes, the traversal stack's bound"
                        ));
                    }
                    let first = after(offset)?;
                    todo.push((first + first_words as usize, splits + 1, Some(0)));
                    todo.push((first, splits + 1, Some(0)));
                }
                DstNode::CarveSingle { leaf, offset, .. }
                | DstNode::CarveDual { leaf, offset, .. } => {
                    if matches!(node, DstNode::CarveDual { .. }) {
                        if !rules.dual {
                            return Err(format!(
                                "{what}: a dual-axis carving node at word {at} in a BIH"
                            ));
                        }
                        stats.carve_dual += 1;
                    } else {
                        stats.carve_single += 1;
                    }
                    if leaf {
                        stats.carving_leaves += 1;
                        level(&mut stats, levels.map(|l| l + 1));
                        leaf_run(&index, offset, triangles.len(), what)?;
                    } else {
                        todo.push((after(offset)?, splits, levels.map(|l| l + 1)));
                    }
                }
                DstNode::Leaf { offset } => {
                    level(&mut stats, levels);
                    stats.plain_leaves += 1;
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
        stats.least_identical_bytes = least_identical_bytes;
        stats.conversion_seconds = conversion_seconds;
        let blocks = LeafBlocks::new(&index, &triangles);
        crate::pages::advise(&words);
        Ok(DualSplitTree {
            words,
            index,
            blocks,
            triangles,
            root_bounds,
            rules,
            depth,
            stats,
        })
    }
}
