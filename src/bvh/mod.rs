//! The canonical binary BVH, from which every layout is derived.
//!
//! Nodes are stored in depth-first preorder: the root is node 0 and an inner
//! node's left child directly follows it. Leaves hold ranges of
//! [`Bvh::prims`], which lists mesh triangle indices. Degenerate triangles are
//! left out: they can never be hit. The `sah`, `hybrid` and `lbvh` builders list each
//! triangle once; `sbvh` (spatial splits, [`Builder::Sbvh`]) may list a
//! triangle in several leaves, each leaf's box then bounding only the part of
//! the triangle it holds.

mod binning;
mod build;
mod lbvh;
mod node;
mod optimize;
mod saved;
mod sbvh;

pub use build::{BuildOptions, Builder};
pub use node::{Node, NodeKind};
pub use optimize::{OptimizeOptions, OptimizeStats};

use crate::geometry::Aabb;
use serde::Serialize;

/// What a build reports.
#[derive(Clone, Debug, Default, Serialize)]
pub struct BuildStats {
    /// [`Builder::name`] of the builder used: `"sah"`, `"hybrid"`, `"sbvh"`
    /// or `"lbvh"`.
    pub builder: String,
    /// [`BuildOptions::max_leaf_size`] of the build.
    pub max_leaf_size: usize,
    /// [`BuildOptions::sah_block`] of the build: the SAH counted
    /// intersection costs per block of this many triangles (1: per
    /// triangle).
    pub sah_block: usize,
    /// Wall-clock time of the build, in seconds.
    pub build_seconds: f64,
    /// Nodes in total: `inner_nodes + leaves`, which is `2 · leaves - 1`.
    pub nodes: usize,
    /// Nodes with two children.
    pub inner_nodes: usize,
    /// Leaf nodes.
    pub leaves: usize,
    /// Triangle references in the leaves (`prims.len()`): the non-degenerate
    /// triangles, plus the duplicates spatial splits made.
    pub references: usize,
    /// Depth of the deepest node; the root has depth 0.
    pub depth: u32,
    /// SAH cost with a traversal cost of 1 and an intersection cost of 1.
    pub sah_cost: f64,
    /// Triangles of the mesh left out because they have zero area (or a
    /// NaN or infinite coordinate: [`crate::geometry::Triangle::is_degenerate`]).
    pub degenerate_triangles: usize,
    /// What [`Bvh::optimize`] did to the tree, if it ran (not kept in saved
    /// files).
    pub optimized: Option<OptimizeStats>,
    /// The most heap bytes the build (and the optimization, if it ran) held
    /// at once beyond what was live before it, output included. `None`
    /// unless the program meters its heap: the library cannot, and the
    /// `raytree` command does (its global allocator counts live bytes). Not
    /// kept in saved files.
    pub peak_heap_bytes: Option<u64>,
}

/// A binary BVH over triangle references.
#[derive(Clone, Debug)]
pub struct Bvh {
    /// Every node in depth-first preorder; the root is [`ROOT`].
    pub nodes: Vec<Node>,
    /// Mesh triangle indices; leaves refer to ranges of it.
    pub prims: Vec<u32>,
    /// What the build reported.
    pub stats: BuildStats,
}

/// Node id of the root.
pub const ROOT: u32 = 0;
/// Parent link of the root.
pub const NO_PARENT: u32 = u32::MAX;

impl Bvh {
    /// Builds a BVH over `triangles` (mesh order) with `options`.
    ///
    /// # Panics
    ///
    /// If `options.max_leaf_size` is not in `1..=255`.
    pub fn build(triangles: &[crate::geometry::Triangle], options: &BuildOptions) -> Bvh {
        build::build(triangles, options)
    }

    /// The tree improved by reinsertion (Bittner, Hapala and Havran 2013;
    /// see `bvh/optimize.rs`): the same leaves with the same triangle
    /// references, arranged for a lower SAH cost, never a higher one.
    /// [`BuildStats::optimized`] reports the costs before and after;
    /// [`BuildStats::build_seconds`] grows by the pass's time.
    pub fn optimize(&self, options: &OptimizeOptions) -> Bvh {
        let (mut out, stats) = optimize::optimize(self, options);
        out.stats.build_seconds = self.stats.build_seconds + stats.seconds;
        out.stats.optimized = Some(stats);
        out
    }

    /// Node [`ROOT`].
    pub fn root(&self) -> &Node {
        &self.nodes[ROOT as usize]
    }

    /// The root's box: the scene box of every non-degenerate triangle
    /// ([`Aabb::EMPTY`] for none).
    pub fn bounds(&self) -> Aabb {
        self.root().bounds
    }

    /// The triangles of leaf node `node` (empty for an inner node).
    pub fn leaf_prims(&self, node: &Node) -> &[u32] {
        match node.kind {
            NodeKind::Leaf { first, count } => {
                &self.prims[first as usize..(first + count) as usize]
            }
            NodeKind::Inner { .. } => &[],
        }
    }

    /// SAH cost (traversal 1, intersection 1), relative to the root's area.
    pub fn sah_cost(&self) -> f64 {
        let root_area = self.bounds().area() as f64;
        if root_area <= 0.0 {
            return self.prims.len() as f64;
        }
        self.nodes
            .iter()
            .map(|n| {
                let a = n.bounds.area() as f64 / root_area;
                match n.kind {
                    NodeKind::Inner { .. } => a,
                    NodeKind::Leaf { count, .. } => a * count as f64,
                }
            })
            .sum()
    }

    /// Checks the tree's invariants and says which one fails: preorder with
    /// the left child next, parent links and depths consistent, every box
    /// holding its children's boxes, leaves within the size limit, every
    /// non-degenerate triangle in at least one leaf (and no degenerate one),
    /// no leaf listing a triangle twice. A triangle listed once lies inside
    /// its leaf's box; one listed in several leaves (spatial splits) meets
    /// each of their boxes, which together span its box. Never panics,
    /// whatever the nodes hold (a loaded file's tree is checked with it).
    pub fn validate(&self, triangles: &[crate::geometry::Triangle]) -> Result<(), String> {
        if self.nodes.is_empty() {
            return Err("no nodes".into());
        }
        if self.root().parent != NO_PARENT || self.root().depth != 0 {
            return Err("root has a parent or a depth".into());
        }
        let mut seen = vec![0u8; triangles.len()];
        // Union of the boxes of the leaves listing each triangle.
        let mut span = vec![Aabb::EMPTY; triangles.len()];
        for (i, n) in self.nodes.iter().enumerate() {
            match n.kind {
                NodeKind::Inner { left, right, .. } => {
                    if left as usize != i + 1
                        || right as usize <= i + 1
                        || right as usize >= self.nodes.len()
                    {
                        return Err(format!("node {i}: children {left}, {right} break preorder"));
                    }
                    for c in [left, right] {
                        let child = &self.nodes[c as usize];
                        if child.parent as usize != i || child.depth != n.depth + 1 {
                            return Err(format!("node {c}: wrong parent or depth"));
                        }
                        if !n.bounds.contains(&child.bounds) {
                            return Err(format!("node {i} does not contain child {c}"));
                        }
                    }
                }
                NodeKind::Leaf { first, count } => {
                    // Only the root of a tree over no triangles is empty.
                    let empty_ok = i == 0 && self.prims.is_empty();
                    if (count == 0 && !empty_ok) || count as usize > self.stats.max_leaf_size {
                        return Err(format!("leaf {i} holds {count} triangles"));
                    }
                    let prims = (first as usize)
                        .checked_add(count as usize)
                        .and_then(|end| self.prims.get(first as usize..end))
                        .ok_or_else(|| {
                            format!(
                                "leaf {i}: triangles {first}..+{count} past the {} listed",
                                self.prims.len()
                            )
                        })?;
                    for (k, &p) in prims.iter().enumerate() {
                        let t = triangles
                            .get(p as usize)
                            .ok_or_else(|| format!("leaf {i}: bad triangle {p}"))?;
                        let tb = t.bounds();
                        if tb.min.cmpgt(n.bounds.max).any() || tb.max.cmplt(n.bounds.min).any() {
                            return Err(format!("leaf {i}'s box misses triangle {p}"));
                        }
                        if prims[..k].contains(&p) {
                            return Err(format!("leaf {i} lists triangle {p} twice"));
                        }
                        seen[p as usize] = seen[p as usize].saturating_add(1);
                        span[p as usize] = span[p as usize].union(n.bounds);
                    }
                }
            }
        }
        for (p, (&s, t)) in seen.iter().zip(triangles).enumerate() {
            if t.is_degenerate() != (s == 0) {
                let want = if t.is_degenerate() {
                    "none"
                } else {
                    "one or more"
                };
                return Err(format!(
                    "triangle {p} appears in {s} leaves, expected {want}"
                ));
            }
            if s > 0 && !span[p].contains(&t.bounds()) {
                return Err(format!(
                    "the boxes of the leaves listing triangle {p} do not contain it"
                ));
            }
        }
        Ok(())
    }
}
