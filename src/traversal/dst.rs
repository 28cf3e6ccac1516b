//! Dual-split tree traversal (Lin et al. 2019, §3.4, Algorithm 1): kd-tree
//! like, over the ray interval `[tmin, tmax]`. A splitting node narrows the
//! interval to the nearer child and pushes the farther with its interval; a
//! carving node trims the interval to its non-empty region; popped entries
//! are culled against the closest hit. Because regions may overlap, the
//! traversal runs until the stack is empty.
//!
//! Plane distances are widened by the ray's slack ([`super::interval::PlaneRay`]).

use super::interval::{lower, nonempty, pop_live, raise, split_children};
use super::leaf::{enter_interval, intersect_leaf};
use super::with_stack;
use crate::accel::dst::node::DstNode;
use crate::accel::dst::DualSplitTree;
use crate::geometry::{Hit, Ray};
use crate::stats::Stats;

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
        let descend = match DstNode::decode(&words[node..]) {
            DstNode::Split {
                axis,
                planes,
                first_words,
                offset,
            } => {
                tally.planes += 2;
                let a = axis as usize & 3;
                let first = node + offset as usize;
                let second = first + first_words as usize;
                match split_children(&r, a, planes, first, second, tmin, tmax) {
                    [Some(near), Some(far)] => {
                        stack[sp] = (far.0 as u32, far.1, far.2);
                        sp += 1;
                        (node, tmin, tmax) = near;
                        continue;
                    }
                    [Some(c), None] | [None, Some(c)] => {
                        (node, tmin, tmax) = c;
                        continue;
                    }
                    [None, None] => None,
                }
            }
            DstNode::CarveSingle {
                axis,
                planes,
                leaf,
                offset,
            } => {
                tally.planes += 2;
                let a = axis as usize & 3;
                let [p_in, p_out] = if r.neg[a] {
                    [planes[1], planes[0]]
                } else {
                    planes
                };
                tmin = raise(tmin, r.entry(a, p_in));
                tmax = lower(tmax, r.exit(a, p_out));
                nonempty(tmin, tmax).then_some((leaf, offset))
            }
            DstNode::CarveDual {
                axes,
                max_side,
                planes,
                leaf,
                offset,
            } => {
                tally.planes += 2;
                for k in 0..2 {
                    let a = axes[k] as usize & 3;
                    // A minimum plane is entered going +axis, a maximum
                    // plane left; a negative direction swaps the two.
                    if max_side[k] != r.neg[a] {
                        tmax = lower(tmax, r.exit(a, planes[k]));
                    } else {
                        tmin = raise(tmin, r.entry(a, planes[k]));
                    }
                }
                nonempty(tmin, tmax).then_some((leaf, offset))
            }
            DstNode::Leaf { offset } => Some((true, offset)),
        };
        if let Some((leaf, offset)) = descend {
            if !leaf {
                node += offset as usize;
                continue;
            }
            if intersect_leaf::<ANY>(
                &dst.index,
                &dst.triangles,
                offset,
                ray,
                &mut best_t,
                &mut best,
                &mut tally,
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
