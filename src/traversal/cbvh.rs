//! STACK over the Compact BVH: the reference traversal, with each child box
//! rebuilt from the current node's box and the node's six planes.
//!
//! The traversal carries the six plane distances `(plane - o) · inv` of the
//! current node's box and computes only the six stored planes per node
//! (6 plane tests against the uncompressed layout's 12); each child's
//! distances are picked from the two sets by the owner bits. The slab test
//! on them is [`crate::geometry::BoxRay::test`]'s, on the same floats, so
//! entry distances, child order and the visited node sequence equal STACK's
//! over the uncompressed BVH bit for bit. A stack entry is a child
//! reference and its six distances (28 bytes).

use super::leaf::{enter, intersect_leaf};
use super::with_stack;
use crate::accel::cbvh::{CompactBvh, INDEX_MASK, LEAF, OWNER_SHIFT};
use crate::geometry::aabb::widen_up;
use crate::geometry::{Hit, Ray};
use crate::stats::Stats;

/// Plane distances of a box, `[min x, y, z, max x, y, z]`, not yet ordered
/// by the ray's direction.
type Planes = [f32; 6];

/// The slab test of [`crate::geometry::BoxRay::test`] on precomputed plane
/// distances: the entry distance, or `+inf` on a miss.
#[inline(always)]
fn test(d: &Planes, neg: [bool; 3], tmin: f32, tmax: f32) -> f32 {
    let mut tn = tmin;
    let mut tf = f32::INFINITY;
    for a in 0..3 {
        let (n, f) = if neg[a] {
            (d[a + 3], d[a])
        } else {
            (d[a], d[a + 3])
        };
        tn = if n > tn { n } else { tn };
        tf = if f < tf { f } else { tf };
    }
    let tf = widen_up(tf);
    let tf = if tmax < tf { tmax } else { tf };
    if tn <= tf {
        tn
    } else {
        f32::INFINITY
    }
}

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
    let (o, inv, neg) = (br.org, br.inv, br.neg);
    let dist = |p: f32, a: usize| (p - o[a]) * inv[a];
    let tmin = ray.tmin;
    let mut tmax = ray.tmax;
    let mut best: Option<Hit> = None;
    let mut stack = [(0u32, [0f32; 6]); N];
    let mut sp = 0;
    let mut node = c.root;
    let mut here: Planes = std::array::from_fn(|k| dist(root_box[k], k % 3));
    let nodes = &c.nodes[..];
    loop {
        tally.nodes += 1;
        if S::LOGS {
            stats.visit(c.canonical_id(node));
        }
        if node & LEAF != 0 {
            if intersect_leaf::<ANY>(
                &c.index,
                &c.triangles,
                node & INDEX_MASK,
                ray,
                &mut tmax,
                &mut best,
                &mut tally,
            ) {
                break;
            }
        } else {
            let n = &nodes[node as usize];
            tally.planes += 6;
            // Child j's planes: the parent's where j owns them, the
            // node's stored ones otherwise.
            let (mut d0, mut d1) = (here, here);
            for a in 0..3 {
                let lo = dist(n.lo[a], a);
                let hi = dist(n.hi[a], a);
                if n.refs[0] >> (OWNER_SHIFT + a as u32) & 1 == 0 {
                    d1[a] = lo;
                } else {
                    d0[a] = lo;
                }
                if n.refs[1] >> (OWNER_SHIFT + a as u32) & 1 == 0 {
                    d1[a + 3] = hi;
                } else {
                    d0[a + 3] = hi;
                }
            }
            let tl = test(&d0, neg, tmin, tmax);
            let tr = test(&d1, neg, tmin, tmax);
            let (left, right) = (n.child(0), n.child(1));
            let (hit_l, hit_r) = (tl != f32::INFINITY, tr != f32::INFINITY);
            if hit_l && hit_r {
                // Ties go to the left child, as in STACK.
                let (near, far) = if tr < tl {
                    ((right, d1), (left, d0))
                } else {
                    ((left, d0), (right, d1))
                };
                (node, here) = near;
                stack[sp] = far;
                sp += 1;
                continue;
            }
            if hit_l {
                (node, here) = (left, d0);
                continue;
            }
            if hit_r {
                (node, here) = (right, d1);
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
