//! What every BVH traversal does at a leaf and at an inner node of
//! own-box nodes.

use super::interval::PlaneRay;
use crate::accel::own_box_node::OwnBoxNode;
use crate::geometry::{Aabb, BoxRay, Hit, Ray, Triangle};
use crate::stats::{Stats, Tally};

/// Index-list bit: the last triangle of a leaf (one list format for every layout).
pub use crate::accel::binary_bvh::LAST;

/// How far past the closest hit so far a traversal still looks, relative
/// to its distance: boxes and regions are culled against
/// [`cull_distance`], not the hit itself. The `t` of a watertight hit is
/// computed from the triangle's scaled vertices and may lie a few ulps
/// before the point where the ray meets the triangle's box; a triangle that
/// ties with the closest hit (overlapping coplanar triangles, common in
/// game levels), whose smaller index must win, would otherwise be culled by
/// whichever structure happened to find the other one first.
pub const TIE_MARGIN: f32 = 1.0 / (1 << 17) as f32;

/// The culling distance for a closest hit at `t`.
#[inline(always)]
pub fn cull_distance(t: f32) -> f32 {
    t + t.abs() * TIE_MARGIN
}

/// Tests the triangles of the leaf whose list starts at `first` against
/// `[ray.tmin, *tmax]`. For closest hit (`ANY = false`) the nearest hit is
/// kept in `best` and `tmax` shrinks to its [`cull_distance`]; for any hit
/// the first hit is stored and `true` returned, which ends the traversal.
#[inline(always)]
pub fn intersect_leaf<const ANY: bool>(
    index: &[u32],
    triangles: &[Triangle],
    first: u32,
    ray: &Ray,
    tmax: &mut f32,
    best: &mut Option<Hit>,
    tally: &mut Tally,
) -> bool {
    let mut i = first as usize;
    loop {
        let entry = index[i];
        let prim = entry & !LAST;
        tally.triangles += 1;
        if let Some(h) = triangles[prim as usize].hit(ray, ray.tmin, *tmax, prim) {
            if ANY {
                *best = Some(h);
                return true;
            }
            if h.beats(best) {
                *tmax = cull_distance(h.t);
                *best = Some(h);
            }
        }
        if entry & LAST != 0 {
            return false;
        }
        i += 1;
    }
}

/// The root box test every BVH traversal begins with (6 plane tests): the
/// ray's box constants and its tally, or `None` when the ray misses the
/// scene box (the tally then already handed to `stats`).
#[inline(always)]
pub fn enter<S: Stats>(ray: &Ray, root: &[f32; 6], stats: &mut S) -> Option<(BoxRay, Tally)> {
    let br = BoxRay::new(ray);
    let tally = Tally {
        planes: 6,
        ..Tally::default()
    };
    if br.test(root, ray.tmin, ray.tmax) == f32::INFINITY {
        stats.add(tally);
        return None;
    }
    Some((br, tally))
}

/// The root box test of the interval traversals (dual-split tree, BIH,
/// H-tree): the ray's plane constants for trees inside `root`, its tally and
/// its interval `[tn, tf]` inside the scene box, or `None` when it misses
/// (the tally then handed to `stats`).
#[inline(always)]
pub fn enter_interval<S: Stats>(
    ray: &Ray,
    root: &Aabb,
    stats: &mut S,
) -> Option<(PlaneRay, Tally, f32, f32)> {
    let br = BoxRay::new(ray);
    let tally = Tally {
        planes: 6,
        ..Tally::default()
    };
    let (tn, tf) = br.interval(&root.to_array(), ray.tmin, ray.tmax);
    if tn > tf {
        stats.add(tally);
        return None;
    }
    Some((PlaneRay::new(&br, root), tally, tn, tf))
}

/// Entry distances (`+inf` on a miss) of the sibling pair whose left node is
/// `nodes[left]`.
#[inline(always)]
pub fn test_children(
    br: &BoxRay,
    nodes: &[OwnBoxNode],
    left: usize,
    tmin: f32,
    tmax: f32,
) -> [f32; 2] {
    let pair: &[OwnBoxNode; 2] = nodes[left..left + 2].try_into().unwrap();
    [
        br.test(&pair[0].bounds, tmin, tmax),
        br.test(&pair[1].bounds, tmin, tmax),
    ]
}
