//! A wide BVH in a saved file ([`crate::saved`]): `wide.meta` (the root's
//! reference, the scene box, the depth, the leaf count and the collapse's
//! SAH cost), `wide.nodes` (per node its six plane rows of `W` floats,
//! then its `W` child references, as u32 words), `wide.blocks` (the
//! leaves' triangle blocks), and for visit logs `wide.node-ids` and
//! `wide.leaf-ids`. The loader walks the tree from the root: every node
//! reference is in range and reached once, every node is reached, an empty
//! lane holds the inverted box no ray enters, the tree is no deeper than
//! its stack bound, every leaf's blocks end inside the list with their
//! lanes filled up to the leaf's last triangle and empty after it, no two
//! leaves share a block, every block is some leaf's, every triangle named
//! exists and its copied vertices are the triangle's, and the leaf ids list
//! exactly the leaves.

use super::{WideBvh, WideNode, EMPTY, LEAF};
use crate::geometry::{Aabb, Triangle};
use crate::saved::{leaf_ids_match, Bits, RecordWriter, Sections, Source};
use crate::structures::shared::leaf::LAST;
use crate::structures::shared::tri_block::{TriBlock, EMPTY as EMPTY_LANE, LANES};
use crate::structures::shared::MAX_STACK_DEPTH;
use std::sync::Arc;

impl<const W: usize> WideBvh<W> {
    /// Writes the tree's sections.
    pub(crate) fn save<'a>(&'a self, s: &mut Sections<'a>) {
        let mut meta = RecordWriter::default();
        meta.u32(self.root)
            .f32s(&self.root_bounds.to_array())
            .u32(self.depth)
            .u64(self.leaves as u64)
            .f64(self.sah_cost);
        s.record("wide.meta", meta);
        let mut words = Vec::with_capacity(self.nodes.len() * 7 * W);
        for n in &self.nodes {
            for row in &n.planes {
                words.extend(row.iter().map(|p| p.to_bits()));
            }
            words.extend(n.plain_children());
        }
        s.owned("wide.nodes", words);
        s.slice("wide.blocks", &self.blocks);
        s.slice("wide.node-ids", &self.node_ids);
        s.owned(
            "wide.leaf-ids",
            self.leaf_ids.iter().map(|&(a, b)| [a, b]).collect(),
        );
    }

    /// Reads the tree over `triangles` back and checks it.
    pub(crate) fn load(s: &Source<'_>, triangles: Arc<[Triangle]>) -> Result<Self, String> {
        let what = "wide.nodes";
        let mut r = s.record("wide.meta")?;
        let root = r.u32()?;
        let root_bounds = Aabb::from_array(&r.f32s()?);
        let depth = r.u32()?;
        let saved_leaves = r.usize()?;
        let sah_cost = r.f64()?;
        r.finish()?;
        let blocks = s.vec::<TriBlock>("wide.blocks")?;
        if blocks.len() > super::MAX_BLOCKS {
            return Err(format!(
                "wide.blocks: {} blocks exceed the 30-bit block indices",
                blocks.len()
            ));
        }
        let node_ids = s.vec::<u32>("wide.node-ids")?;
        let leaf_ids: Vec<(u32, u32)> = s
            .vec::<[u32; 2]>("wide.leaf-ids")?
            .into_iter()
            .map(|[a, b]| (a, b))
            .collect();
        let mut nodes = s.with::<u32, _>("wide.nodes", |words| {
            if words.len() % (7 * W) != 0 {
                return Err(format!(
                    "{what}: {} words are not whole {W}-wide nodes",
                    words.len()
                ));
            }
            Ok(words
                .chunks_exact(7 * W)
                .map(|c| WideNode {
                    planes: std::array::from_fn(|row| {
                        std::array::from_fn(|k| f32::from_bits(c[row * W + k]))
                    }),
                    children: std::array::from_fn(|k| c[6 * W + k]),
                })
                .collect::<Vec<WideNode<W>>>())
        })??;
        if depth as usize >= MAX_STACK_DEPTH {
            return Err(format!(
                "wide.meta: depth {depth} is past the traversal's {} levels",
                MAX_STACK_DEPTH - 1
            ));
        }
        let empty = WideNode::<W>::empty();
        let mut seen = Bits::new(nodes.len());
        let mut covered = Bits::new(blocks.len());
        let mut starts = Bits::new(blocks.len());
        let (mut inner, mut leaves, mut used) = (0usize, 0usize, 0usize);
        let mut todo = vec![(root, 0u32)];
        while let Some((r, d)) = todo.pop() {
            if d > depth {
                return Err(format!(
                    "{what}: the tree is deeper than its stack bound of {depth} levels"
                ));
            }
            if r == EMPTY {
                return Err(format!("{what}: the root is an empty lane"));
            }
            if r & LEAF != 0 {
                let first = (r & !LEAF) as usize;
                used += leaf_blocks(&blocks, first, &triangles, &mut covered, "wide.blocks")?;
                starts.insert(first);
                leaves += 1;
                continue;
            }
            let i = r as usize;
            if i >= nodes.len() || !seen.insert(i) {
                return Err(format!(
                    "{what}: node {i} is not among the {} nodes, or is reached twice",
                    nodes.len()
                ));
            }
            inner += 1;
            let n = &nodes[i];
            for k in 0..W {
                let c = n.children[k];
                if c == EMPTY {
                    if (0..6)
                        .any(|row| n.planes[row][k].to_bits() != empty.planes[row][k].to_bits())
                    {
                        return Err(format!(
                            "{what}: node {i}'s empty lane {k} has a box a ray can enter"
                        ));
                    }
                } else {
                    todo.push((c, d + 1));
                }
            }
        }
        if inner != nodes.len() || used != blocks.len() {
            return Err(format!(
                "{what}: the tree from the root reaches {inner} of its {} nodes and {used} of its {} blocks",
                nodes.len(),
                blocks.len()
            ));
        }
        if node_ids.len() != inner {
            return Err(format!(
                "wide.node-ids: {} ids for {inner} nodes",
                node_ids.len()
            ));
        }
        if saved_leaves != leaves {
            return Err(format!(
                "wide.meta: {saved_leaves} leaves, but the tree has {leaves}"
            ));
        }
        leaf_ids_match(&leaf_ids, &starts, leaves, "wide.leaf-ids")?;
        // The leaves' references in memory carry the `PAIR` bit.
        for n in &mut nodes {
            n.children = n.children.map(|c| super::with_pair(c, &blocks));
        }
        let w = WideBvh {
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
        };
        w.advise_pages();
        Ok(w)
    }
}

/// Checks the blocks of the leaf starting at block `first` (of the section
/// named `what`) and marks them in `covered`; returns how many there are.
pub(crate) fn leaf_blocks(
    blocks: &[TriBlock],
    first: usize,
    triangles: &[Triangle],
    covered: &mut Bits,
    what: &str,
) -> Result<usize, String> {
    let mut i = first;
    loop {
        let b = blocks.get(i).ok_or_else(|| {
            format!(
                "{what}: the leaf starting at block {first} runs past the {} blocks",
                blocks.len()
            )
        })?;
        if !covered.insert(i) {
            return Err(format!("{what}: block {i} belongs to two leaves"));
        }
        let mut done = false;
        for l in 0..LANES {
            let e = b.prims[l];
            if done {
                if e != EMPTY_LANE {
                    return Err(format!(
                        "{what}: block {i} has lane {l} filled after its leaf's last triangle"
                    ));
                }
                continue;
            }
            let p = e & !LAST;
            let t = triangles
                .get(p as usize)
                .filter(|_| e != EMPTY_LANE)
                .ok_or_else(|| {
                    format!(
                        "{what}: block {i} lane {l} names triangle {p}, but the scene has {}",
                        triangles.len()
                    )
                })?;
            let same = [t.a, t.b, t.c].iter().enumerate().all(|(v, vert)| {
                (0..3).all(|axis| b.v[3 * v + axis][l].to_bits() == vert[axis].to_bits())
            });
            if !same {
                return Err(format!(
                    "{what}: block {i} lane {l} holds other vertices than triangle {p}"
                ));
            }
            done = e & LAST != 0;
        }
        if done {
            return Ok(i + 1 - first);
        }
        i += 1;
    }
}
