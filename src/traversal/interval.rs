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

