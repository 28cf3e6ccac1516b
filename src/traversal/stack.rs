//! STACK: the reference traversal (as the stackless paper means it). At an
//! inner node both children's boxes are tested; the nearer hit child is
//! visited next and the farther one pushed. The stack holds node references
//! only: a popped node is always visited, even if its box now lies beyond
//! the closest hit. Ties between the two children go to the left.

use super::leaf::{enter, intersect_leaf, test_children};
use crate::accel::binary_bvh::{
    BinaryBvh, NodeRef, INNER_WORDS, LAST, LEFT_LEAF, OFFSET_MASK, RIGHT_LEAF,
};
use crate::accel::sparse_bvh::SparseBvh;
use crate::geometry::{Hit, Ray};
use crate::stats::Stats;
use crate::traversal::with_stack;

/// Closest hit (`ANY = false`) or any hit (`ANY = true`) over the
/// uncompressed binary BVH.
#[inline]
pub fn trace<S: Stats, const ANY: bool>(bvh: &BinaryBvh, ray: &Ray, stats: &mut S) -> Option<Hit> {
    with_stack!(bvh.depth, trace_n::<S; ANY>(bvh, ray, stats))
}

#[inline]
fn trace_n<S: Stats, const ANY: bool, const N: usize>(
    bvh: &BinaryBvh,
    ray: &Ray,
    stats: &mut S,
) -> Option<Hit> {
    if bvh.is_empty() {
        return None;
    }
    let (br, mut tally) = enter(ray, &bvh.root_bounds.to_array(), stats)?;
    let tmin = ray.tmin;
    let mut tmax = ray.tmax;
    let words = &bvh.words[..];
    let mut best: Option<Hit> = None;
    let mut stack = [0 as NodeRef; N];
    let mut sp = 0;
    let mut node = bvh.root;
    loop {
        tally.nodes += 1;
        if S::LOGS {
            stats.visit(bvh.canonical_id(node));
        }
        if node & LAST != 0 {
            let first = words[(node & !LAST) as usize];
            if intersect_leaf::<ANY>(
                &bvh.index,
                &bvh.triangles,
                first,
                ray,
                &mut tmax,
                &mut best,
                &mut tally,
            ) {
                break;
            }
        } else {
            let at = node as usize;
            let n: &[u32; INNER_WORDS] = words[at..at + INNER_WORDS].try_into().unwrap();
            tally.planes += 12;
            let boxes: [f32; 12] = std::array::from_fn(|k| f32::from_bits(n[k]));
            let [tl, tr] = br.test_pair(&boxes, tmin, tmax);
            let link = n[12];
            let l = link & OFFSET_MASK;
            let left = l | ((link & LEFT_LEAF != 0) as u32) << 31;
            let r = l + if link & LEFT_LEAF != 0 {
                1
            } else {
                INNER_WORDS as u32
            };
            let right = r | ((link & RIGHT_LEAF != 0) as u32) << 31;
            let (hit_l, hit_r) = (tl != f32::INFINITY, tr != f32::INFINITY);
            // Both hit, one hit, none: three plain branches. Choosing the
            // near child by distance only when both are hit measured 1.5×
            // faster than one select covering both cases.
            if hit_l && hit_r {
                let (near, far) = if tr < tl {
                    (right, left)
                } else {
                    (left, right)
                };
                node = near;
                stack[sp] = far;
                sp += 1;
                continue;
            }
            if hit_l || hit_r {
                node = if hit_l { left } else { right };
                continue;
            }
        }
        if sp == 0 {
            break;
        }
        sp -= 1;
        node = stack[sp];
    }
    stats.add(tally);
    best
}

/// STACK over the sparse layout's own-box nodes: the same algorithm on the
/// nodes the stackless traversals use, so that timing ratios compare
/// algorithms, not layouts.
#[inline]
pub fn trace_sparse<S: Stats, const ANY: bool>(
    sp_bvh: &SparseBvh,
    ray: &Ray,
    stats: &mut S,
) -> Option<Hit> {
    with_stack!(sp_bvh.depth, trace_sparse_n::<S; ANY>(sp_bvh, ray, stats))
}

#[inline]
fn trace_sparse_n<S: Stats, const ANY: bool, const N: usize>(
    sp_bvh: &SparseBvh,
    ray: &Ray,
    stats: &mut S,
) -> Option<Hit> {
    if sp_bvh.is_empty() {
        return None;
    }
    let nodes = &sp_bvh.nodes[..];
    let (br, mut tally) = enter(ray, &nodes[0].bounds, stats)?;
    let tmin = ray.tmin;
    let mut tmax = ray.tmax;
    let mut best: Option<Hit> = None;
    let mut stack = [0u32; N];
    let mut sp = 0;
    let mut node = 0u32;
    loop {
        tally.nodes += 1;
        if S::LOGS {
            stats.visit(sp_bvh.ids[node as usize]);
        }
        let n = &nodes[node as usize];
        if n.is_leaf() {
            if intersect_leaf::<ANY>(
                &sp_bvh.index,
                &sp_bvh.triangles,
                n.target(),
                ray,
                &mut tmax,
                &mut best,
                &mut tally,
            ) {
                break;
            }
        } else {
            tally.planes += 12;
            let l = n.target();
            let [tl, tr] = test_children(&br, nodes, l as usize, tmin, tmax);
            let (hit_l, hit_r) = (tl != f32::INFINITY, tr != f32::INFINITY);
            if hit_l && hit_r {
                let (near, far) = if tr < tl { (l + 1, l) } else { (l, l + 1) };
                node = near;
                stack[sp] = far;
                sp += 1;
                continue;
            }
            if hit_l || hit_r {
                node = if hit_l { l } else { l + 1 };
                continue;
            }
        }
        if sp == 0 {
            break;
        }
        sp -= 1;
        node = stack[sp];
    }
    stats.add(tally);
    best
}
