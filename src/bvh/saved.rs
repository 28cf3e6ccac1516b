//! The canonical BVH in a saved file ([`crate::saved`]): `bvh.meta` (the
//! builder's name, the leaf size limit, build time, SAH cost, and the SAH
//! block size where it is not 1, so that a default build's file is the one
//! earlier versions wrote), `bvh.nodes`
//! (nine u32 words per node in preorder: the box as six f32, then a kind
//! word (bit 31 set for a leaf; an inner node's split axis in bits 0–1),
//! then the right child and 0 for an inner node, whose left child is the
//! next node, or the first position in `bvh.prims` and the triangle count
//! for a leaf) and `bvh.prims`. Parent links and depths are not stored:
//! the loader derives them, checking that every node but the root has
//! exactly one parent before it, and then runs [`Bvh::validate`].

use super::{BuildOptions, BuildStats, Builder, Bvh, Node, NodeKind, NO_PARENT};
use crate::geometry::{Aabb, Triangle};
use crate::saved::{RecordWriter, Sections, Source};
use rayon::prelude::*;

/// Kind word bit: a leaf.
const LEAF: u32 = 1 << 31;

/// The deepest canonical tree a file may hold. The builder's trees are at
/// most 64 SAH levels and then median splits (at most 31 more levels for
/// 2³¹ triangles) deep; a deeper tree in a file is refused, so that the
/// conversions that recurse over a loaded tree stay within their stack.
pub(crate) const MAX_SAVED_DEPTH: u32 = 128;

fn encode(n: &Node) -> [u32; 9] {
    let b = n.bounds.to_array().map(f32::to_bits);
    let (kind, a, c) = match n.kind {
        NodeKind::Inner { right, axis, .. } => (axis as u32, right, 0),
        NodeKind::Leaf { first, count } => (LEAF, first, count),
    };
    [b[0], b[1], b[2], b[3], b[4], b[5], kind, a, c]
}

/// The nodes of the records, parent links and depths not yet set.
fn decode(records: &[[u32; 9]]) -> Result<Vec<Node>, String> {
    let n = records.len();
    if n == 0 || n >= NO_PARENT as usize {
        return Err(format!("the BVH has {n} nodes"));
    }
    let mut nodes = Vec::with_capacity(n);
    for (i, w) in records.iter().enumerate() {
        let bounds = Aabb::from_array(&std::array::from_fn(|k| f32::from_bits(w[k])));
        let kind = if w[6] == LEAF {
            NodeKind::Leaf {
                first: w[7],
                count: w[8],
            }
        } else if w[6] < 3 && w[8] == 0 {
            NodeKind::Inner {
                left: i as u32 + 1,
                right: w[7],
                axis: w[6] as u8,
            }
        } else {
            return Err(format!(
                "BVH node {i}: kind word {:#x} with {} is neither a leaf nor an inner node",
                w[6], w[8]
            ));
        };
        nodes.push(Node {
            bounds,
            parent: NO_PARENT,
            depth: 0,
            kind,
        });
    }
    Ok(nodes)
}

impl Bvh {
    /// Writes the tree's sections.
    pub(crate) fn save<'a>(&'a self, s: &mut Sections<'a>) {
        let mut meta = RecordWriter::default();
        meta.str(&self.stats.builder)
            .u32(self.stats.max_leaf_size as u32)
            .f64(self.stats.build_seconds)
            .f64(self.stats.sah_cost);
        // Written only where it is not the default, so that a file of a
        // default build is the one earlier versions wrote (and read).
        if self.stats.sah_block != 1 {
            meta.u32(self.stats.sah_block as u32);
        }
        s.record("bvh.meta", meta);
        s.owned("bvh.nodes", self.nodes.par_iter().map(encode).collect());
        s.slice("bvh.prims", &self.prims);
    }

    /// Reads the tree over `triangles` back and checks it; the error says
    /// what is wrong.
    pub(crate) fn load(s: &Source<'_>, triangles: &[Triangle]) -> Result<Bvh, String> {
        let mut r = s.record("bvh.meta")?;
        let builder = r.str()?;
        let max_leaf_size = r.u32()? as usize;
        let build_seconds = r.f64()?;
        let sah_cost = r.f64()?;
        let sah_block = if r.at_end() { 1 } else { r.u32()? as usize };
        r.finish()?;
        if !BuildOptions::SAH_BLOCKS.contains(&sah_block) {
            return Err(format!(
                "the BVH's SAH block size {sah_block} is not 1, 2, 4, 8 or 16"
            ));
        }
        if !Builder::ALL.iter().any(|b| b.name() == builder) {
            return Err(format!("the BVH names an unknown builder '{builder}'"));
        }
        if !(1..=255).contains(&max_leaf_size) {
            return Err(format!(
                "the BVH's leaf size limit {max_leaf_size} is not in 1..=255"
            ));
        }
        let prims = s.vec::<u32>("bvh.prims")?;
        let mut nodes = s.with::<[u32; 9], _>("bvh.nodes", decode)??;
        let n = nodes.len();
        let (mut inner, mut depth) = (0, 0);
        for i in 0..n {
            let NodeKind::Inner { left, right, .. } = nodes[i].kind else {
                continue;
            };
            inner += 1;
            if left as usize >= n || right <= left || right as usize >= n {
                return Err(format!(
                    "BVH node {i}: children {left} and {right} are not after it in a tree of {n} nodes"
                ));
            }
            let d = nodes[i].depth + 1;
            if d > MAX_SAVED_DEPTH {
                return Err(format!(
                    "the BVH is deeper than {MAX_SAVED_DEPTH} levels, deeper than any this raytree builds"
                ));
            }
            depth = depth.max(d);
            for c in [left, right] {
                let child = &mut nodes[c as usize];
                if child.parent != NO_PARENT {
                    return Err(format!(
                        "BVH node {c} is a child of both {} and {i}",
                        child.parent
                    ));
                }
                child.parent = i as u32;
                child.depth = d;
            }
        }
        if let Some(orphan) = (1..n).find(|&i| nodes[i].parent == NO_PARENT) {
            return Err(format!("BVH node {orphan} has no parent"));
        }
        let leaves = n - inner;
        let mut bvh = Bvh {
            nodes,
            prims,
            stats: BuildStats {
                builder,
                max_leaf_size,
                sah_block,
                build_seconds,
                nodes: n,
                inner_nodes: inner,
                leaves,
                references: 0,
                depth,
                sah_cost,
                degenerate_triangles: 0,
                optimized: None,
                peak_heap_bytes: None,
            },
        };
        bvh.validate(triangles)
            .map_err(|e| format!("the BVH: {e}"))?;
        // Validated: the degenerate triangles are the ones no leaf lists
        // (a triangle may be listed in several leaves, spatial splits).
        bvh.stats.references = bvh.prims.len();
        bvh.stats.degenerate_triangles = triangles.iter().filter(|t| t.is_degenerate()).count();
        Ok(bvh)
    }
}
