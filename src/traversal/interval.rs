//! The ray interval `[tmin, tmax]` of the plane-based traversals (dual-split
//! tree, BIH, H-tree): planes narrow it, NaN distances (a ray lying in a
//! plane) leave it alone.
//!
//! Plane distances are widened by `2γ₃` of themselves, entries down and
//! exits up, as the box test's exits are: a hit on a region's boundary is
//! never lost to rounding.

use crate::geometry::aabb::{widen_down, widen_up};

/// An entry distance, widened down.
#[inline(always)]
pub fn entry(t: f32) -> f32 {
    widen_down(t)
}

/// An exit distance, widened up.
#[inline(always)]
pub fn exit(t: f32) -> f32 {
    widen_up(t)
}

/// Whether `[tmin, tmax]` holds a point of the ray: an interval starting at
/// +inf (a ray parallel to a plane, outside it) does not.
#[inline(always)]
pub fn nonempty(tmin: f32, tmax: f32) -> bool {
    tmin <= tmax && tmin < f32::INFINITY
}

/// `max(t, acc)` keeping `acc` when `t` is NaN (a ray in the plane).
#[inline(always)]
pub fn raise(acc: f32, t: f32) -> f32 {
    if t > acc {
        t
    } else {
        acc
    }
}

/// `min(t, acc)` keeping `acc` when `t` is NaN.
#[inline(always)]
pub fn lower(acc: f32, t: f32) -> f32 {
    if t < acc {
        t
    } else {
        acc
    }
}

/// The children of a two-plane split node that the interval `[tmin, tmax]`
/// reaches, as `[near, far]`, each with its node and narrowed interval.
///
/// `planes` are the first child's maximum and the second child's minimum
/// on an axis where the ray's origin is `o` and its reciprocal direction
/// `inv` (`neg`: negative). Along +axis the first child (below plane 0)
/// comes first and ends at `t1`; the second begins at `t2`; reversed
/// otherwise. A NaN distance (a ray in the plane) keeps the child; an entry
/// at +inf (a ray parallel to the plane, outside it) is never reached.
#[allow(clippy::too_many_arguments)]
#[inline(always)]
pub fn split_children(
    first: usize,
    second: usize,
    planes: [f32; 2],
    o: f32,
    inv: f32,
    neg: bool,
    tmin: f32,
    tmax: f32,
) -> [Option<(usize, f32, f32)>; 2] {
    let t1 = (planes[0] - o) * inv;
    let t2 = (planes[1] - o) * inv;
    let (near, t_near_exit, far, t_far_entry) = if neg {
        (second, exit(t2), first, entry(t1))
    } else {
        (first, exit(t1), second, entry(t2))
    };
    let hit_near = t_near_exit >= tmin || t_near_exit.is_nan();
    let hit_far = (t_far_entry <= tmax && t_far_entry < f32::INFINITY) || t_far_entry.is_nan();
    [
        hit_near.then(|| (near, tmin, lower(tmax, t_near_exit))),
        hit_far.then(|| (far, raise(tmin, t_far_entry), tmax)),
    ]
}

/// Pops the next stack entry `(node, tmin, tmax)` whose interval still
/// starts before the closest hit `best_t`, its `tmax` lowered to `best_t`;
/// `None` when the stack runs out.
#[inline(always)]
pub fn pop_live(
    stack: &[(u32, f32, f32)],
    sp: &mut usize,
    best_t: f32,
) -> Option<(usize, f32, f32)> {
    while *sp > 0 {
        *sp -= 1;
        let (n, t0, t1) = stack[*sp];
        if t0 <= best_t && t0 < f32::INFINITY {
            return Some((n as usize, t0, lower(t1, best_t)));
        }
    }
    None
}
