//! The H-tree (Havran, Herzog and Seidel 2006) as the dual-split paper
//! compares it: a spatial kd-tree whose split nodes hold two planes on one
//! axis (the first child's maximum and the second child's minimum, which
//! may overlap), with bounding nodes that cut empty space off a child,
//! converted from the canonical BVH with its partitioning kept exactly.
//!
//! - [`node`]: the encoding (12-byte split nodes, bounding nodes of 4 bytes
//!   plus 4 per stored face, 4-byte leaves);
//! - `convert.rs`: the SAH conversion;
//! - traversal: `traverse.rs`.
//!
//! Choices where the papers are open (baselines.md §5, §8): a bounding node
//! stores any subset of the six faces (63 types), exactly those by which the
//! child's cell exceeds its BVH box, so every cell equals its BVH node's box
//! bit for bit; the face cost is `0.15·C_I` per face.

mod convert;
pub mod node;
mod saved;
mod traverse;

use self::convert::{convert_bvh, Tree};
use self::node::HNode;
use super::shared::MAX_STACK_DEPTH;
use super::Accel;
use crate::bvh::Bvh;
use crate::error::{Error, Result};
use crate::geometry::{Aabb, Hit, Ray, Triangle};
use crate::stats::Stats;
use crate::structures::shared::tri_block::LeafBlocks;
use serde::Serialize;
use std::sync::Arc;

use super::shared::leaf::LAST;

/// Node counts and storage of an H-tree.
#[derive(Clone, Debug, Default, Serialize, PartialEq)]
pub struct HtreeStats {
    /// Split nodes, 12 bytes each.
    pub split_nodes: usize,
    /// Bounding nodes, 4 bytes plus 4 per stored face.
    pub bound_nodes: usize,
    /// Leaves, 4 bytes each.
    pub leaves: usize,
    /// Bounding nodes by the number of faces they store (index 1 to 6).
    pub bound_faces: [usize; 7],
    /// Bytes of the encoded nodes.
    pub node_bytes: usize,
    /// Bytes of the triangle index list: 4 per triangle reference.
    pub index_bytes: usize,
    /// Time to convert from the BVH, in seconds.
    pub conversion_seconds: f64,
}

impl HtreeStats {
    /// Nodes of every kind.
    pub fn nodes(&self) -> usize {
        self.split_nodes + self.bound_nodes + self.leaves
    }
}

/// An H-tree: encoded nodes, the sign-terminated triangle index list and
/// the scene box (tested before the root, not counted in the bytes).
#[derive(Clone, Debug)]
pub struct HTree {
    pub(crate) words: Vec<u32>,
    pub(crate) index: Vec<u32>,
    /// The leaf list's triangles in blocks, as the traversal tests them.
    pub(crate) blocks: LeafBlocks,
    pub(crate) triangles: Arc<[Triangle]>,
    pub(crate) root_bounds: Aabb,
    /// A bound on the traversal stack: split nodes on any path.
    pub(crate) depth: u32,
    /// Node counts and storage of this tree.
    pub stats: HtreeStats,
}

impl HTree {
    /// Converts `bvh` (keeping its partitioning). [`Error::Limit`] for a BVH
    /// deeper than the traversal stack or a tree whose offsets do not fit
    /// their fields.
    pub fn from_bvh(bvh: &Bvh, triangles: Arc<[Triangle]>) -> Result<Self> {
        let start = std::time::Instant::now();
        if bvh.stats.depth as usize >= MAX_STACK_DEPTH {
            return Err(Error::Limit(format!(
                "BVH depth {} exceeds the H-tree traversal's limit of {} levels; use the hybrid builder",
                bvh.stats.depth,
                MAX_STACK_DEPTH - 1
            )));
        }
        let mut h = HTree {
            words: Vec::new(),
            index: Vec::with_capacity(bvh.prims.len()),
            blocks: LeafBlocks::default(),
            triangles,
            root_bounds: bvh.bounds(),
            depth: bvh.stats.depth,
            stats: HtreeStats::default(),
        };
        if !bvh.prims.is_empty() {
            let tree = convert_bvh(bvh);
            h.emit(bvh, &tree)?;
        }
        h.blocks = LeafBlocks::new(&h.index, &h.triangles);
        h.stats.node_bytes = h.words.len() * 4;
        h.stats.index_bytes = h.index.len() * 4;
        h.stats.conversion_seconds = start.elapsed().as_secs_f64();
        crate::pages::advise(&h.words);
        Ok(h)
    }

    /// Appends `t` and its subtree depth-first.
    fn emit(&mut self, bvh: &Bvh, t: &Tree) -> Result<()> {
        let at = self.words.len();
        match t {
            Tree::Leaf { node } => {
                let offset = self.index.len() as u32;
                self.index
                    .extend_from_slice(bvh.leaf_prims(&bvh.nodes[*node as usize]));
                if let Some(last) = self.index.last_mut() {
                    *last |= LAST;
                }
                self.stats.leaves += 1;
                HNode::Leaf { offset }.encode(&mut self.words)
            }
            Tree::Bound {
                mask,
                planes,
                child,
            } => {
                self.stats.bound_nodes += 1;
                self.stats.bound_faces[mask.count_ones() as usize] += 1;
                HNode::Bound {
                    mask: *mask,
                    planes: *planes,
                }
                .encode(&mut self.words)?;
                self.emit(bvh, child)
            }
            Tree::Split { axis, planes, kids } => {
                self.stats.split_nodes += 1;
                self.words.extend([0; 3]);
                self.emit(bvh, &kids[0])?;
                let second = (self.words.len() - at) as u32;
                let mut w = Vec::with_capacity(3);
                HNode::Split {
                    axis: *axis,
                    planes: *planes,
                    second,
                }
                .encode(&mut w)?;
                self.words[at..at + 3].copy_from_slice(&w);
                self.emit(bvh, &kids[1])
            }
        }
    }

    /// The encoded nodes.
    pub fn words(&self) -> &[u32] {
        &self.words
    }

    /// The triangle index list (last index of each leaf with [`LAST`] set).
    pub fn index_list(&self) -> &[u32] {
        &self.index
    }

    /// The scene box, tested before the root.
    pub fn root_bounds(&self) -> Aabb {
        self.root_bounds
    }

    /// Whether the tree holds no triangles.
    pub fn is_empty(&self) -> bool {
        self.index.is_empty()
    }

    /// The node at word `at` of [`Self::words`], decoded.
    pub fn node(&self, at: usize) -> HNode {
        HNode::decode(&self.words[at..])
    }
}

impl Accel for HTree {
    fn name(&self) -> &'static str {
        "htree"
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
