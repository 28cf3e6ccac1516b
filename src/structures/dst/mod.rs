//! Dual-split trees (Lin, Shkurko, Mallett and Yuksel, I3D 2019): two
//! axis-aligned planes per node, in splitting nodes and carving nodes, with
//! compact 4- and 12-byte nodes, converted from the canonical BVH.
//!
//! - [`node`]: the bit-exact encoding of §4.1 and its decoder;
//! - [`plan`]: the SAH choice of carving nodes (§4.2, equation 1);
//! - [`bound`]: the least storage any identical conversion can have;
//! - `convert.rs`: the identical and similar conversions (§4.2);
//! - traversal: `traverse.rs`.

pub mod bound;
pub(crate) mod convert;
pub mod node;
pub mod plan;
mod saved;
mod traverse;

use self::convert::{convert, triangle_counts, Tree};
use self::node::DstNode;
use self::plan::{CarveOp, Rules};
use super::shared::MAX_STACK_DEPTH;
use super::Accel;
use crate::bvh::{Bvh, ROOT};
use crate::error::{Error, Result};
use crate::geometry::{Aabb, Hit, Ray, Triangle};
use crate::stats::Stats;
use crate::structures::shared::tri_block::LeafBlocks;
use serde::Serialize;
use std::sync::Arc;

/// Index-list bit: the last triangle of a leaf.
use super::shared::leaf::LAST;

/// The paper's Tables 1–3 for one tree.
#[derive(Clone, Debug, Default, Serialize, PartialEq)]
pub struct DstStats {
    /// Splitting nodes (§3.1), 12 bytes each.
    pub split_nodes: usize,
    /// Single-axis carving nodes (§3.2), 12 bytes each, leaves included.
    pub carve_single: usize,
    /// Dual-axis carving nodes (§3.2), 12 bytes each, leaves included.
    pub carve_dual: usize,
    /// Carving nodes that are leaves (counted in the two above as well).
    pub carving_leaves: usize,
    /// Leaves without planes (4 bytes).
    pub plain_leaves: usize,
    /// How many children of splitting nodes have 0, 1, 2 and 3 carving
    /// levels below them.
    pub carving_levels: [usize; 4],
    /// Bytes of the encoded nodes (4 per plain leaf, 12 per other node).
    pub node_bytes: usize,
    /// Bytes of the triangle index list: 4 per triangle reference.
    pub index_bytes: usize,
    /// The least bytes of any identical conversion of the same BVH
    /// ([`bound::least_identical_bytes`]).
    pub least_identical_bytes: usize,
    /// Time to convert from the BVH, in seconds.
    pub conversion_seconds: f64,
}

impl DstStats {
    /// Nodes of every kind: splitting, carving (leaves included) and plain
    /// leaves.
    pub fn nodes(&self) -> usize {
        self.split_nodes + self.carve_single + self.carve_dual + self.plain_leaves
    }

    /// Nodes that hold triangles: plain leaves and carving leaves.
    pub fn leaves(&self) -> usize {
        self.plain_leaves + self.carving_leaves
    }
}

/// A dual-split tree: encoded nodes, a sign-terminated triangle index list
/// and the scene box (tested before the root, not counted in the bytes).
#[derive(Clone, Debug)]
pub struct DualSplitTree {
    pub(crate) words: Vec<u32>,
    pub(crate) index: Vec<u32>,
    /// The leaf list's triangles in blocks, as the traversal tests them.
    pub(crate) blocks: LeafBlocks,
    pub(crate) triangles: Arc<[Triangle]>,
    pub(crate) root_bounds: Aabb,
    rules: Rules,
    /// The BVH's depth: a bound on the traversal stack.
    pub(crate) depth: u32,
    /// Node counts and storage of this tree.
    pub stats: DstStats,
}

impl DualSplitTree {
    /// Converts `bvh`: with `similar`, the approximate conversion (§4.2.2);
    /// otherwise the identical one (§4.2.1). [`Error::Limit`] for a BVH
    /// deeper than the traversal stack or a tree whose offsets pass 26 bits.
    pub fn from_bvh(bvh: &Bvh, triangles: Arc<[Triangle]>, similar: bool) -> Result<Self> {
        let rules = if similar {
            Rules::SIMILAR
        } else {
            Rules::IDENTICAL
        };
        Self::with_rules(bvh, triangles, rules)
    }

    /// Converts `bvh` under `rules` (also used for the BIH, which is a
    /// dual-split tree without dual-axis nodes: [`crate::structures::Bih`]).
    /// Errors as [`Self::from_bvh`].
    pub fn with_rules(bvh: &Bvh, triangles: Arc<[Triangle]>, rules: Rules) -> Result<Self> {
        let start = std::time::Instant::now();
        if bvh.stats.depth as usize >= MAX_STACK_DEPTH {
            return Err(Error::Limit(format!(
                "BVH depth {} exceeds the {} traversal's limit of {} levels; use the hybrid builder",
                bvh.stats.depth,
                name(rules),
                MAX_STACK_DEPTH - 1
            )));
        }
        let counts = triangle_counts(bvh);
        let tree = convert(bvh, ROOT, bvh.bounds(), rules, &counts);
        let mut t = DualSplitTree {
            words: Vec::new(),
            index: Vec::with_capacity(bvh.prims.len()),
            blocks: LeafBlocks::default(),
            triangles,
            root_bounds: bvh.bounds(),
            rules,
            depth: bvh.stats.depth,
            stats: DstStats::default(),
        };
        if !bvh.prims.is_empty() {
            let root = t.reserve(&tree);
            t.fill(bvh, &tree, root)?;
        }
        t.blocks = LeafBlocks::new(&t.index, &t.triangles);
        count(&tree, &mut t.stats, None);
        t.stats.node_bytes = t.words.len() * 4;
        t.stats.index_bytes = t.index.len() * 4;
        t.stats.least_identical_bytes = bound::least_identical_bytes(bvh);
        t.stats.conversion_seconds = start.elapsed().as_secs_f64();
        crate::pages::advise(&t.words);
        Ok(t)
    }

    /// The encoded nodes.
    pub fn words(&self) -> &[u32] {
        &self.words
    }

    /// The triangle index list (last index of each leaf with [`LAST`] set).
    pub fn index_list(&self) -> &[u32] {
        &self.index
    }

    /// The rules it was converted under.
    pub fn rules(&self) -> Rules {
        self.rules
    }

    /// Whether the tree holds no triangles.
    pub fn is_empty(&self) -> bool {
        self.index.is_empty()
    }

    /// The root's own box (the scene box), which the traversal enters.
    pub fn root_bounds(&self) -> Aabb {
        self.root_bounds
    }

    /// The tree's depth (the canonical BVH's; sizes the traversal stack).
    pub fn depth(&self) -> u32 {
        self.depth
    }

    /// The mesh's triangles, in mesh order.
    pub fn triangles(&self) -> &[Triangle] {
        &self.triangles
    }

    /// The node at word `at` of [`Self::words`], decoded.
    pub fn node(&self, at: usize) -> DstNode {
        DstNode::decode(&self.words[at..])
    }

    fn reserve(&mut self, t: &Tree) -> usize {
        let at = self.words.len();
        let words = if matches!(t, Tree::Leaf { .. }) { 1 } else { 3 };
        self.words.resize(at + words, 0);
        at
    }

    fn write(&mut self, at: usize, n: DstNode) -> Result<()> {
        let mut w = Vec::with_capacity(3);
        n.encode(&mut w)?;
        self.words[at..at + w.len()].copy_from_slice(&w);
        Ok(())
    }

    /// Appends BVH leaf `node`'s triangles to the index list; returns where
    /// they start.
    fn push_leaf(&mut self, bvh: &Bvh, node: u32) -> u32 {
        let first = self.index.len() as u32;
        self.index
            .extend_from_slice(bvh.leaf_prims(&bvh.nodes[node as usize]));
        if let Some(last) = self.index.last_mut() {
            *last |= LAST;
        }
        first
    }

    /// Writes `t` at `at` (already reserved) and places its subtree:
    /// depth-first, the two children of a splitting node side by side.
    fn fill(&mut self, bvh: &Bvh, t: &Tree, at: usize) -> Result<()> {
        match t {
            Tree::Leaf { node } => {
                let offset = self.push_leaf(bvh, *node);
                self.write(at, DstNode::Leaf { offset })
            }
            Tree::Split { axis, planes, kids } => {
                let p0 = self.reserve(&kids[0]);
                let p1 = self.reserve(&kids[1]);
                self.write(
                    at,
                    DstNode::Split {
                        axis: *axis,
                        planes: *planes,
                        first_words: (p1 - p0) as u8,
                        offset: (p0 - at) as u32,
                    },
                )?;
                self.fill(bvh, &kids[0], p0)?;
                self.fill(bvh, &kids[1], p1)
            }
            Tree::Carve { op, child } => {
                let (leaf, offset) = match **child {
                    Tree::Leaf { node } => (true, self.push_leaf(bvh, node)),
                    _ => {
                        let pc = self.reserve(child);
                        (false, (pc - at) as u32)
                    }
                };
                let n = match *op {
                    CarveOp::Single { axis, lo, hi } => DstNode::CarveSingle {
                        axis,
                        planes: [lo, hi],
                        leaf,
                        offset,
                    },
                    CarveOp::Dual { a, b } => DstNode::CarveDual {
                        axes: [a.axis, b.axis],
                        max_side: [a.max_side, b.max_side],
                        planes: [a.at, b.at],
                        leaf,
                        offset,
                    },
                };
                self.write(at, n)?;
                if !leaf {
                    self.fill(bvh, child, at + offset as usize)?;
                }
                Ok(())
            }
        }
    }
}

/// The structure's name for a conversion's rules.
fn name(rules: Rules) -> &'static str {
    match (rules.complete, rules.dual) {
        (true, true) => "dst",
        (false, _) => "dst-similar",
        (true, false) => "bih",
    }
}

/// Counts node kinds and carving levels; `levels` counts the carving nodes
/// in the chain below a splitting node's child.
fn count(t: &Tree, s: &mut DstStats, levels: Option<usize>) {
    match t {
        Tree::Split { kids, .. } => {
            if let Some(l) = levels {
                s.carving_levels[l.min(3)] += 1;
            }
            s.split_nodes += 1;
            for k in kids.iter() {
                count(k, s, Some(0));
            }
        }
        Tree::Carve { op, child } => {
            match op {
                CarveOp::Single { .. } => s.carve_single += 1,
                CarveOp::Dual { .. } => s.carve_dual += 1,
            }
            if let Tree::Leaf { .. } = **child {
                s.carving_leaves += 1;
                if let Some(l) = levels {
                    s.carving_levels[(l + 1).min(3)] += 1;
                }
            } else {
                count(child, s, levels.map(|l| l + 1));
            }
        }
        Tree::Leaf { .. } => {
            if let Some(l) = levels {
                s.carving_levels[l.min(3)] += 1;
            }
            s.plain_leaves += 1;
        }
    }
}

impl Accel for DualSplitTree {
    fn name(&self) -> &'static str {
        name(self.rules)
    }

    fn bytes(&self) -> usize {
        self.stats.node_bytes + self.stats.index_bytes
    }

    fn closest_hit<S: Stats>(&self, ray: &Ray, stats: &mut S) -> Option<Hit> {
        traverse::trace::<S, false>(self, ray, stats)
    }

    fn any_hit<S: Stats>(&self, ray: &Ray, stats: &mut S) -> Option<Hit> {
        traverse::trace::<S, true>(self, ray, stats)
    }
}
