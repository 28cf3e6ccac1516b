//! STACK over the Compact BVH: the reference traversal, with each child box
//! rebuilt from the current node's box and the node's six planes.
//!
//! The traversal carries the six plane distances `(plane - o) · inv` of the
//! current node's box and computes only the six stored planes per node
//! (6 plane tests against the uncompressed layout's 12); each child's
//! distances are picked from the two sets by the owner bits. The slab test
//! on them is [`crate::geometry::BoxRay::test_pair`]'s, on the same floats,
//! so entry distances, child order and the visited node sequence equal
//! STACK's over the uncompressed BVH bit for bit. A stack entry is a child
//! reference and its plane distances.

use super::{CbvhNode, CompactBvh, INDEX_MASK, LEAF, OWNER_SHIFT};
use crate::geometry::{Hit, Ray};
use crate::stats::Stats;
use crate::structures::shared::leaf::enter;
use crate::structures::shared::with_stack;
use glam::{BVec4A, Vec4, Vec4Swizzles};

/// The current node's plane distances per axis, `[lo, lo, hi, hi]`: the
/// lanes either child takes where it owns the node's plane.
type Here = [Vec4; 3];

/// For the owner bits `min | max << 3` of a node, per axis, the lanes
/// `[lo_0, lo_1, hi_0, hi_1]` that take the parent's plane.
static PARENT_LANES: [[BVec4A; 3]; 64] = {
    let mut t = [[BVec4A::FALSE; 3]; 64];
    let mut bits = 0;
    while bits < 64 {
        let mut a = 0;
        while a < 3 {
            let mn = bits >> a & 1 == 1;
            let mx = bits >> (a + 3) & 1 == 1;
            t[bits][a] = BVec4A::new(!mn, mn, !mx, mx);
            a += 1;
        }
        bits += 1;
    }
    t
};

#[inline]
pub fn trace<S: Stats, const ANY: bool>(c: &CompactBvh, ray: &Ray, stats: &mut S) -> Option<Hit> {
    with_stack!(c.depth, trace_n::<S; ANY>(c, ray, stats))
}

#[inline]
fn trace_n<S: Stats, const ANY: bool, const N: usize>(
    c: &CompactBvh,
    ray: &Ray,
    stats: &mut S,
) -> Option<Hit> {
    if c.is_empty() {
        return None;
    }
    let root_box = c.root_bounds.to_array();
    let (br, mut tally) = enter(ray, &root_box, stats)?;
    let tmin = ray.tmin;
    let mut tmax = ray.tmax;
    let mut best: Option<Hit> = None;
    let mut stack = [(0u32, [Vec4::ZERO; 3]); N];
    let mut sp = 0;
    let mut node = c.root;
    let mut here: Here = std::array::from_fn(|a| {
        let (lo, hi) = (root_box[a], root_box[a + 3]);
        br.pair_distances(Vec4::new(lo, lo, hi, hi), a)
    });
    let nodes = &c.nodes[..];
    loop {
        tally.nodes += 1;
        if S::LOGS {
            stats.visit(c.canonical_id(node));
        }
        if node & LEAF != 0 {
            if c.blocks.intersect::<ANY, S>(
                node & INDEX_MASK,
                &c.triangles,
                ray,
                &mut tmax,
                &mut best,
                &mut tally,
                stats,
            ) {
                break;
            }
        } else {
            let n = &nodes[node as usize];
            tally.planes += CbvhNode::PLANES;
            // Per axis, lanes [lo_0, lo_1, hi_0, hi_1]: a child's plane is
            // the node's own where the child owns it (its distance is in
            // `here`), the stored one otherwise.
            let owners = (n.refs[0] >> OWNER_SHIFT & 7) | (n.refs[1] >> OWNER_SHIFT & 7) << 3;
            let parents = &PARENT_LANES[owners as usize];
            let t: [Vec4; 3] = std::array::from_fn(|a| {
                let stored = br.pair_distances(Vec4::new(n.lo[a], n.lo[a], n.hi[a], n.hi[a]), a);
                Vec4::select(parents[a], here[a], stored)
            });
            let [tl, tr] = br.test_pair_distances(t, tmin, tmax);
            let (left, right) = (n.child(0), n.child(1));
            let (hit_l, hit_r) = (tl != f32::INFINITY, tr != f32::INFINITY);
            let child = |j: usize| -> Here {
                if j == 0 {
                    t.map(|v| v.xxzz())
                } else {
                    t.map(|v| v.yyww())
                }
            };
            if hit_l && hit_r {
                // Ties go to the left child, as in STACK.
                let (near, far) = if tr < tl { (1, 0) } else { (0, 1) };
                node = if near == 0 { left } else { right };
                here = child(near);
                stack[sp] = (if far == 0 { left } else { right }, child(far));
                sp += 1;
                continue;
            }
            if hit_l {
                (node, here) = (left, child(0));
                continue;
            }
            if hit_r {
                (node, here) = (right, child(1));
                continue;
            }
        }
        if sp == 0 {
            break;
        }
        sp -= 1;
        (node, here) = stack[sp];
    }
    stats.add(tally);
    best
}
