//! Dual-split tree traversal (Lin et al. 2019, §3.4, Algorithm 1): kd-tree
//! like, over the ray interval `[tmin, tmax]`. A splitting node narrows the
//! interval to the nearer child and pushes the farther with its interval; a
//! carving node trims the interval to its non-empty region; popped entries
//! are culled against the closest hit. Because regions may overlap, the
//! traversal runs until the stack is empty.
//!
//! Plane distances are widened by the ray's slack ([`crate::structures::shared::interval::PlaneRay`]).
//! The loop decodes headers itself rather than through
//! [`super::node::DstNode`], so that only the node's kind
//! (split, carve, plain leaf) and the ray's interval steer branches: the
//! ray's signs and a carving node's axes and corner pick table entries.
//! This halved the branch mispredictions per ray (callgrind's branch
//! simulation on bunny.obj's path rays) and sped the traversal up by
//! about 10%.

use super::node::{is_split, CARVE_FACES, LEAF_HEADER, NODE_PLANES, OFFSET_BITS, OFFSET_MASK};
use super::DualSplitTree;
use crate::geometry::{Hit, Ray};
use crate::stats::Stats;
use crate::structures::shared::interval::{next_child, nonempty, pop_live, split_children};
use crate::structures::shared::leaf::enter_interval;
use crate::structures::shared::with_stack;

#[inline]
pub fn trace<S: Stats, const ANY: bool>(
    dst: &DualSplitTree,
    ray: &Ray,
    stats: &mut S,
) -> Option<Hit> {
    with_stack!(dst.depth, trace_n::<S; ANY>(dst, ray, stats))
}

#[inline]
fn trace_n<S: Stats, const ANY: bool, const N: usize>(
    dst: &DualSplitTree,
    ray: &Ray,
    stats: &mut S,
) -> Option<Hit> {
    if dst.is_empty() {
        return None;
    }
    let (r, mut tally, tn, tf) = enter_interval(ray, &dst.root_bounds, stats)?;
    let words = &dst.words[..];
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
        // The header decoded by hand: one test for a split, one for a
        // plain leaf, and a table lookup for all 30 carving kinds, so that
        // no branch depends on a carving node's kind or the ray's signs.
        let w = words[node];
        let h = w >> OFFSET_BITS;
        let offset = w & OFFSET_MASK;
        // A plain leaf, the only node without planes, may end the words.
        let planes = || -> &[u32; NODE_PLANES] {
            words[node + 1..node + 1 + NODE_PLANES].try_into().unwrap()
        };
        let descend = if is_split(h) {
            tally.planes += NODE_PLANES as u32;
            let a = (h >> 2 & 3) as usize;
            let first = node + offset as usize;
            let second = first + (h & 3) as usize;
            let children = split_children(&r, a, planes(), first, second, tmin, tmax);
            match next_child(children, &mut stack, &mut sp) {
                Some(next) => {
                    (node, tmin, tmax) = next;
                    continue;
                }
                None => None,
            }
        } else if h != LEAF_HEADER {
            tally.planes += NODE_PLANES as u32;
            let c = CARVE_FACES[h as usize];
            for (&face, &p) in c.faces.iter().zip(planes()) {
                (tmin, tmax) = r.clip(face as usize, f32::from_bits(p), tmin, tmax);
            }
            nonempty(tmin, tmax).then_some((c.leaf, offset))
        } else {
            Some((true, offset))
        };
        if let Some((leaf, offset)) = descend {
            if !leaf {
                node += offset as usize;
                continue;
            }
            if dst.blocks.intersect::<ANY, S>(
                offset,
                &dst.triangles,
                ray,
                &mut best_t,
                &mut best,
                &mut tally,
                stats,
            ) {
                break;
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
