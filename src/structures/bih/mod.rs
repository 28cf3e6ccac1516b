//! The bounding interval hierarchy (Wächter and Keller 2006) with clip
//! nodes (Wächter 2008), converted from the canonical BVH with its
//! partitioning kept exactly, as the dual-split paper compares it.
//!
//! A BIH split node holds two planes on one axis: the first child's maximum
//! and the second child's minimum (they may overlap or leave a gap). A clip
//! node holds two planes on one axis bounding its one child. These are
//! exactly a dual-split tree's splitting node and single-axis carving node,
//! so a BIH here *is* a [`DualSplitTree`] converted under [`Rules::BIH`]:
//! - the conversion tries, for every BVH inner node, the three axes and
//!   both child orders for the split, and under each child the clip chain
//!   (at most one clip node per axis, in the cheapest order) that shrinks
//!   the child's cell to its BVH box, costed by the dual-split paper's
//!   equation 1 with `C_j = 0.3·C_I`; ties keep the BVH's order and the
//!   lowest axis;
//! - nodes use the dual-split encoding ([`super::dst::node`]): a 32-bit
//!   header word (6-bit header, 26-bit relative offset) and two `f32`
//!   planes, 12 bytes for split and clip nodes, 4 bytes for a plain leaf.
//!   Lin et al. used "an optimized node representation comparable to"
//!   theirs; as in the dual-split tree, the last clip node above a BVH leaf
//!   carries the leaf itself (a clip leaf), so such leaves cost no word;
//! - traversal is the dual-split traversal (the dual-split tree's),
//!   which for these two node kinds is the BIH's: near child by the sign of
//!   the direction, the far one pushed with its interval, pop culling
//!   against the closest hit.
//!
//! Every cell of the BIH, rebuilt from the scene box, equals its BVH node's
//! box bit for bit (`tests/baselines.rs`).

use super::dst::plan::Rules;
use super::dst::{DstStats, DualSplitTree};
use super::Accel;
use crate::bvh::Bvh;
use crate::error::Result;
use crate::geometry::{Hit, Ray, Triangle};
use crate::stats::Stats;
use std::sync::Arc;

/// A bounding interval hierarchy with clip nodes.
#[derive(Clone, Debug)]
pub struct Bih {
    tree: DualSplitTree,
}

impl Bih {
    /// Converts `bvh`, keeping its partitioning. Errors as
    /// [`DualSplitTree::from_bvh`] ([`crate::error::Error::Limit`]).
    pub fn from_bvh(bvh: &Bvh, triangles: Arc<[Triangle]>) -> Result<Self> {
        Ok(Bih {
            tree: DualSplitTree::with_rules(bvh, triangles, Rules::BIH)?,
        })
    }

    /// The tree in the dual-split encoding (split nodes and single-axis
    /// carving nodes only).
    pub fn tree(&self) -> &DualSplitTree {
        &self.tree
    }

    /// Node counts: `split_nodes` are BIH split nodes, `carve_single` clip
    /// nodes (`carving_leaves` of them clip leaves); `carve_dual` is 0.
    pub fn stats(&self) -> &DstStats {
        &self.tree.stats
    }
}

impl Accel for Bih {
    fn name(&self) -> &'static str {
        "bih"
    }

    fn bytes(&self) -> usize {
        self.tree.bytes()
    }

    #[inline]
    fn closest_hit<S: Stats>(&self, ray: &Ray, stats: &mut S) -> Option<Hit> {
        self.tree.closest_hit(ray, stats)
    }

    #[inline]
    fn any_hit<S: Stats>(&self, ray: &Ray, stats: &mut S) -> Option<Hit> {
        self.tree.any_hit(ray, stats)
    }
}

impl Bih {
    /// Writes the tree's sections (a dual-split tree's: `dst.*`).
    pub(crate) fn save<'a>(&'a self, s: &mut crate::saved::Sections<'a>) {
        self.tree.save(s)
    }

    /// Reads the tree back and checks it, as a dual-split tree without
    /// dual-axis nodes.
    pub(crate) fn load(
        s: &crate::saved::Source<'_>,
        triangles: Arc<[Triangle]>,
    ) -> std::result::Result<Self, String> {
        Ok(Bih {
            tree: DualSplitTree::load(s, triangles, Rules::BIH)?,
        })
    }
}
