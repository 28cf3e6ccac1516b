//! H-tree traversal: kd-tree like over the ray interval `[tmin, tmax]`, as
//! the BIH's (baselines.md §4–5). A split node narrows the interval to the
//! near child (by the direction's sign) and pushes the far one with its
//! interval; a bounding node narrows it by each stored face, an entry face
//! (a minimum going +axis, a maximum going −axis) raising `tmin` and an exit
//! face lowering `tmax`. Faces it does not store are the cell's own, which
//! the interval is already clipped to. Popped entries are culled against
//! the closest hit; the traversal runs until the stack is empty.

use super::node::{LEAF_MASK, OFFSET_BITS, OFFSET_MASK, SPLIT_PLANES};
use super::HTree;
use crate::geometry::{Hit, Ray};
use crate::stats::Stats;
use crate::structures::shared::interval::{
    face_code, next_child, nonempty, pop_live, split_children,
};
use crate::structures::shared::leaf::enter_interval;
use crate::structures::shared::with_stack;

#[inline]
pub fn trace<S: Stats, const ANY: bool>(h: &HTree, ray: &Ray, stats: &mut S) -> Option<Hit> {
    with_stack!(h.depth, trace_n::<S; ANY>(h, ray, stats))
}

#[inline]
fn trace_n<S: Stats, const ANY: bool, const N: usize>(
    h: &HTree,
    ray: &Ray,
    stats: &mut S,
) -> Option<Hit> {
    if h.is_empty() {
        return None;
    }
    let (r, mut tally, tn, tf) = enter_interval(ray, &h.root_bounds, stats)?;
    let words = &h.words[..];
    let mut best: Option<Hit> = None;
    let mut best_t = ray.tmax;
    let mut stack = [(0u32, 0f32, 0f32); N];
    let mut sp = 0;
    let (mut node, mut tmin, mut tmax) = (0usize, tn, tf);
    loop {
        tally.nodes += 1;
        if S::LOGS {
            stats.visit(node as u32);
        }
        let w = words[node];
        match w >> 30 {
            0 => {
                tally.planes += SPLIT_PLANES as u32;
                let a = (w >> OFFSET_BITS & 3) as usize;
                let planes = words[node + 1..node + 1 + SPLIT_PLANES].try_into().unwrap();
                let (first, second) = (node + 3, node + (w & OFFSET_MASK) as usize);
                let children = split_children(&r, a, planes, first, second, tmin, tmax);
                if let Some(next) = next_child(children, &mut stack, &mut sp) {
                    (node, tmin, tmax) = next;
                    continue;
                }
            }
            1 => {
                let mut mask = w & 63;
                tally.planes += mask.count_ones();
                let mut at = node + 1;
                while mask != 0 {
                    let k = mask.trailing_zeros() as usize;
                    mask &= mask - 1;
                    let p = f32::from_bits(words[at]);
                    at += 1;
                    (tmin, tmax) = r.clip(face_code(k % 3, k >= 3), p, tmin, tmax);
                }
                if nonempty(tmin, tmax) {
                    node = at;
                    continue;
                }
            }
            _ => {
                if h.blocks.intersect::<ANY, S>(
                    w & LEAF_MASK,
                    &h.triangles,
                    ray,
                    &mut best_t,
                    &mut best,
                    &mut tally,
                    stats,
                ) {
                    break;
                }
            }
        }
        match pop_live(&stack, &mut sp, best_t) {
            Some(next) => (node, tmin, tmax) = next,
            None => break,
        }
    }
    stats.add(tally);
    best
}
