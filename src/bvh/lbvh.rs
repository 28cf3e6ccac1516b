//! The `lbvh` builder: a linear BVH (Lauterbach, Garland, Sengupta, Luebke
//! and Manocha 2009, "Fast BVH Construction on GPUs"; the split rule of
//! Karras 2012, "Maximizing Parallelism in the Construction of BVHs,
//! Octrees, and k-d Trees", §3). Triangles are sorted along a 63-bit Morton
//! curve of their centroids (21 bits per axis over the centroids' box);
//! each node's range is split where its codes first differ (the highest
//! differing bit, found by a binary search), a range of equal codes at its
//! middle. Built top down in preorder, each node's box the union of its
//! children's; a subtree of at most `max_leaf_size` triangles becomes one
//! leaf where the SAH (blocks of [`super::BuildOptions::sah_block`]) counts
//! the leaf no dearer than the subtree.
//!
//! There is no split search: the build is a sort and one pass over the
//! tree, several times faster than the binned SAH build, for trees of
//! higher SAH cost (README, "Builders, measured"). The tree does not
//! depend on the thread count: the sort's keys are unique (code, index)
//! pairs and the subtrees built on other threads are appended in preorder.

use super::binning::{Blocks, PrimRef};
use super::build::{append_subtree, bounds_of, node_capacity, BuildOptions, PARALLEL_SUBTREE};
use super::{Node, NodeKind, NO_PARENT};
use crate::geometry::Aabb;
use rayon::prelude::*;

/// Bits of each centroid coordinate in a code.
const BITS: u32 = 21;

/// The 21 low bits of `x` spread to every third bit (bit `i` to bit `3i`).
fn spread(x: u64) -> u64 {
    let mut x = x & 0x1f_ffff;
    x = (x | x << 32) & 0x001f_0000_0000_ffff;
    x = (x | x << 16) & 0x001f_0000_ff00_00ff;
    x = (x | x << 8) & 0x100f_00f0_0f00_f00f;
    x = (x | x << 4) & 0x10c3_0c30_c30c_30c3;
    x = (x | x << 2) & 0x1249_2492_4924_9249;
    x
}

/// The Morton code of centroid coordinates quantized to `q` (each below
/// `2^21`): x in the bits `3i + 2`, y in `3i + 1`, z in `3i`.
fn morton(q: [u32; 3]) -> u64 {
    spread(q[0] as u64) << 2 | spread(q[1] as u64) << 1 | spread(q[2] as u64)
}

/// The axis of code bit `p`.
fn axis_of_bit(p: u32) -> u8 {
    (2 - p % 3) as u8
}

struct Ctx<'a> {
    opts: &'a BuildOptions,
    /// References in code order, and their codes.
    refs: &'a [PrimRef],
    codes: &'a [u64],
    max_leaf: usize,
    blocks: Blocks,
    spawn_depth: u32,
}

/// The nodes (preorder) and the triangle order of an LBVH over `refs`.
pub(super) fn build(
    refs: Vec<PrimRef>,
    opts: &BuildOptions,
    spawn_depth: u32,
) -> (Vec<Node>, Vec<u32>) {
    if refs.is_empty() {
        return (vec![Node::EMPTY_ROOT], Vec::new());
    }
    let mut keys: Vec<(u64, u32)> = codes(&refs)
        .into_par_iter()
        .enumerate()
        .map(|(i, k)| (k, i as u32))
        .collect();
    keys.par_sort_unstable();
    let sorted: Vec<PrimRef> = keys.par_iter().map(|&(_, i)| refs[i as usize]).collect();
    drop(refs);
    let codes: Vec<u64> = keys.into_par_iter().map(|(k, _)| k).collect();
    let ctx = Ctx {
        opts,
        refs: &sorted,
        codes: &codes,
        max_leaf: opts.max_leaf_size,
        blocks: opts.blocks(),
        spawn_depth,
    };
    let mut nodes = Vec::with_capacity(node_capacity(opts, sorted.len()));
    subtree(&ctx, 0, sorted.len(), 0, NO_PARENT, &mut nodes);
    nodes.shrink_to_fit();
    let prims = sorted.par_iter().map(PrimRef::id).collect();
    (nodes, prims)
}

/// The Morton code of each reference's centroid, quantized to `2^21`
/// cells per axis over the centroids' box (a flat axis: every centroid in
/// cell 0).
fn codes(refs: &[PrimRef]) -> Vec<u64> {
    let (_, cb) = bounds_of(refs);
    let extent = cb.extent();
    let cells = (1u32 << BITS) as f32;
    // Cells per unit length; the largest coordinate lands in the last cell.
    let scale = extent.to_array().map(|e| {
        if e > 0.0 {
            cells * (1.0 - 1e-6) / e
        } else {
            0.0
        }
    });
    let (lo, last) = (cb.min.to_array(), (1u32 << BITS) - 1);
    refs.par_iter()
        .map(|r| {
            let c = r.centroid().to_array();
            // `as u32` saturates (NaN to 0); the clamp keeps rounding at the
            // top inside the grid.
            morton(std::array::from_fn(|a| {
                (((c[a] - lo[a]) * scale[a]) as u32).min(last)
            }))
        })
        .collect()
}

/// Where range `codes` (sorted, at least two) splits, and the axis: after
/// the last code whose highest bit differing across the range is clear;
/// the middle of a range of equal codes.
fn split(codes: &[u64]) -> (usize, u8) {
    let (first, last) = (codes[0], codes[codes.len() - 1]);
    if first == last {
        return (codes.len() / 2, 0);
    }
    let p = 63 - (first ^ last).leading_zeros();
    // The codes share every bit above `p`: those with bit `p` clear come
    // first.
    let mid = codes.partition_point(|&k| k & (1 << p) == 0);
    (mid, axis_of_bit(p))
}

/// Builds the subtree over `ctx.refs[lo..hi]` into `nodes` (preorder, its
/// root's parent `parent`); returns its box and its SAH cost in unnormalized
/// area units (traversal 1 per inner node, blocks per leaf).
fn subtree(
    ctx: &Ctx,
    lo: usize,
    hi: usize,
    depth: u32,
    parent: u32,
    nodes: &mut Vec<Node>,
) -> (Aabb, f32) {
    let n = hi - lo;
    let id = nodes.len() as u32;
    // A leaf over the range, whose box is `bounds`.
    let leaf = |nodes: &mut Vec<Node>, bounds: Aabb| {
        nodes.push(Node {
            bounds,
            parent,
            depth,
            kind: NodeKind::Leaf {
                first: lo as u32,
                count: n as u32,
            },
        });
        (bounds, bounds.area() * ctx.blocks.cost(n as u32))
    };
    // One block is never dearer than a split (as in the SAH build).
    if n == 1 || (n <= ctx.max_leaf && n <= ctx.blocks.size()) {
        return leaf(nodes, bounds_of(&ctx.refs[lo..hi]).0);
    }
    let (mid, axis) = split(&ctx.codes[lo..hi]);
    let mid = lo + mid;
    nodes.push(Node {
        bounds: Aabb::EMPTY,
        parent,
        depth,
        kind: NodeKind::Inner {
            left: id + 1,
            right: 0,
            axis,
        },
    });
    let ((lb, lc), (rb, rc), right) = if n > PARALLEL_SUBTREE && depth < ctx.spawn_depth {
        let mut theirs = Vec::with_capacity(node_capacity(ctx.opts, hi - mid));
        let (l, r) = rayon::join(
            || subtree(ctx, lo, mid, depth + 1, id, nodes),
            || subtree(ctx, mid, hi, depth + 1, NO_PARENT, &mut theirs),
        );
        (l, r, append_subtree(nodes, theirs, id))
    } else {
        let l = subtree(ctx, lo, mid, depth + 1, id, nodes);
        let right = nodes.len() as u32;
        let r = subtree(ctx, mid, hi, depth + 1, id, nodes);
        (l, r, right)
    };
    let bounds = lb.union(rb);
    let cost = bounds.area() + lc + rc;
    if n <= ctx.max_leaf && bounds.area() * ctx.blocks.cost(n as u32) <= cost {
        // The subtree's nodes are all after its root: one leaf instead.
        // Its box, the union of its children's, is the leaf's.
        nodes.truncate(id as usize);
        return leaf(nodes, bounds);
    }
    let node = &mut nodes[id as usize];
    node.bounds = bounds;
    node.kind = NodeKind::Inner {
        left: id + 1,
        right,
        axis,
    };
    (bounds, cost)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bvh::{Builder, Bvh};
    use crate::scene::Scene;

    /// The tree's triangles lie along the curve (their codes in order), and
    /// every subtree of at most `max_leaf_size` triangles that is not a
    /// leaf costs less than its leaf would: the SAH collapse.
    #[test]
    fn leaves_follow_the_curve_and_the_sah() {
        for block in [1, 4] {
            let scene = Scene::builtin("chess:6000").unwrap();
            let opts = BuildOptions::new(Builder::Lbvh).with_sah_block(block);
            let bvh = Bvh::build(&scene.triangles, &opts);
            bvh.validate(&scene.triangles).unwrap();
            let refs: Vec<PrimRef> = bvh
                .prims
                .iter()
                .map(|&i| PrimRef::new(&scene.triangles[i as usize].bounds(), i))
                .collect();
            let k = codes(&refs);
            assert!(
                k.windows(2).all(|w| w[0] <= w[1]),
                "block {block}: off the curve"
            );
            // Triangles and SAH cost of each subtree, children before parents.
            let blocks = opts.blocks();
            let mut count = vec![0u32; bvh.nodes.len()];
            let mut cost = vec![0f32; bvh.nodes.len()];
            let mut collapsed = 0;
            for (i, n) in bvh.nodes.iter().enumerate().rev() {
                let area = n.bounds.area();
                match n.kind {
                    NodeKind::Leaf { count: c, .. } => {
                        count[i] = c;
                        cost[i] = area * blocks.cost(c);
                        collapsed += (c > blocks.size() as u32) as usize;
                    }
                    NodeKind::Inner { left, right, .. } => {
                        let (l, r) = (left as usize, right as usize);
                        count[i] = count[l] + count[r];
                        cost[i] = area + cost[l] + cost[r];
                        if count[i] as usize <= opts.max_leaf_size {
                            assert!(
                                cost[i] < area * blocks.cost(count[i]),
                                "block {block}: node {i} dearer than its leaf"
                            );
                        }
                    }
                }
            }
            assert!(collapsed > 0, "block {block}: no subtree became a leaf");
        }
    }

    #[test]
    fn codes_interleave_the_axes_from_x_down() {
        assert_eq!(morton([1, 0, 0]), 0b100);
        assert_eq!(morton([0, 1, 0]), 0b010);
        assert_eq!(morton([0, 0, 1]), 0b001);
        let top = (1u32 << BITS) - 1;
        assert_eq!(morton([top, top, top]), (1u64 << 63) - 1);
        assert_eq!(morton([1 << 20, 0, 0]), 1 << 62);
        assert_eq!(axis_of_bit(62), 0);
        assert_eq!(axis_of_bit(61), 1);
        assert_eq!(axis_of_bit(60), 2);
    }

    #[test]
    fn ranges_split_at_their_highest_differing_bit() {
        assert_eq!(split(&[0b000, 0b001, 0b100, 0b101]), (2, 0));
        assert_eq!(split(&[0b000, 0b001, 0b011]), (2, 1));
        assert_eq!(split(&[0b1000, 0b1001]), (1, 2));
        assert_eq!(split(&[7, 7, 7, 7, 7]), (2, 0));
    }
}
