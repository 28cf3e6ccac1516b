//! The binary layout in a saved file ([`crate::saved`]): `binary.meta`
//! (the root's reference and the scene box), `binary.words` (the nodes),
//! `binary.index` (the leaf list) and `binary.ids` (canonical ids of the
//! nodes in placement order, for visit logs). The loader walks the tree
//! from the root: every node lies inside the words and after its parent,
//! the nodes tile the words exactly (each reached once), every leaf list
//! ends inside the list and names real triangles, and the tree is shallow
//! enough for the traversal's stack.

use super::{children_of, BinaryBvh, INNER_WORDS, OFFSET_MASK};
use crate::geometry::{Aabb, Triangle};
use crate::saved::{leaf_run, Bits, RecordWriter, Sections, Source};
use crate::structures::shared::leaf::LAST;
use crate::structures::shared::tri_block::LeafBlocks;
use crate::structures::shared::MAX_STACK_DEPTH;
use std::sync::Arc;

impl BinaryBvh {
    /// Writes the layout's sections.
    pub(crate) fn save<'a>(&'a self, s: &mut Sections<'a>) {
        let mut meta = RecordWriter::default();
        meta.u32(self.root).f32s(&self.root_bounds.to_array());
        s.record("binary.meta", meta);
        s.slice("binary.words", &self.words);
        s.slice("binary.index", &self.index);
        s.slice("binary.ids", &self.ids);
    }

    /// Reads the layout over `triangles` back and checks it.
    pub(crate) fn load(s: &Source<'_>, triangles: Arc<[Triangle]>) -> Result<Self, String> {
        let what = "binary.words";
        let mut r = s.record("binary.meta")?;
        let root = r.u32()?;
        let root_bounds = Aabb::from_array(&r.f32s()?);
        r.finish()?;
        let words = s.vec::<u32>("binary.words")?;
        let index = s.vec::<u32>("binary.index")?;
        let ids = s.vec::<u32>("binary.ids")?;
        if words.len() > OFFSET_MASK as usize {
            return Err(format!(
                "{what}: {} words, past the layout's 30-bit offsets",
                words.len()
            ));
        }
        let mut covered = Bits::new(words.len());
        let mut starts = Bits::new(words.len());
        let (mut inner, mut leaves, mut depth) = (0usize, 0usize, 0u32);
        let mut todo = vec![(root, 0u32)];
        while let Some((r, d)) = todo.pop() {
            let at = (r & !LAST) as usize;
            let leaf = r & LAST != 0;
            let size = if leaf { 1 } else { INNER_WORDS };
            if at + size > words.len() {
                return Err(format!(
                    "{what}: a node at word {at} runs past the {} words",
                    words.len()
                ));
            }
            if d as usize >= MAX_STACK_DEPTH {
                return Err(format!(
                    "{what}: the tree is deeper than the traversal's {} levels",
                    MAX_STACK_DEPTH - 1
                ));
            }
            depth = depth.max(d);
            starts.insert(at);
            for w in at..at + size {
                if !covered.insert(w) {
                    return Err(format!(
                        "{what}: the node at word {at} overlaps another, or is reached twice"
                    ));
                }
            }
            if leaf {
                leaves += 1;
                leaf_run(&index, words[at], triangles.len(), what)?;
                continue;
            }
            inner += 1;
            let link = words[at + 12];
            let l = link & OFFSET_MASK;
            if (l as usize) < at + INNER_WORDS {
                return Err(format!(
                    "{what}: the node at word {at} has its children at {l}, not after it"
                ));
            }
            let [left, right] = children_of(link);
            todo.push((right, d + 1));
            todo.push((left, d + 1));
        }
        let tiled = (inner * INNER_WORDS + leaves) == words.len();
        if !tiled {
            return Err(format!(
                "{what}: the tree's nodes cover {} of its {} words",
                inner * INNER_WORDS + leaves,
                words.len()
            ));
        }
        if ids.len() != inner + leaves {
            return Err(format!(
                "binary.ids: {} ids for {} nodes",
                ids.len(),
                inner + leaves
            ));
        }
        let offsets = starts.iter().map(|i| i as u32).collect();
        let blocks = LeafBlocks::new(&index, &triangles);
        crate::pages::advise(&words);
        let mut b = BinaryBvh {
            words,
            index,
            blocks,
            root,
            root_bounds,
            triangles,
            offsets,
            ids,
            inner_nodes: inner,
            leaves,
            depth,
            lines: Default::default(),
        };
        b.lines = super::lines::Lines::new(&b);
        Ok(b)
    }
}
