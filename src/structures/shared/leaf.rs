//! The sign-terminated leaf list every structure stores its leaves' triangles
//! in, and what every traversal does at a leaf and at the root box.

use super::interval::PlaneRay;
use crate::geometry::{Aabb, BoxRay, Hit, Ray, Triangle};
use crate::stats::{Stats, Tally};

/// Index-list bit: the last triangle of a leaf. Every structure keeps its
/// leaves' triangles in one list of mesh triangle indices, a leaf being a
/// run whose last entry has this (sign) bit set, so leaves store no count.
pub const LAST: u32 = 1 << 31;

/// The mesh triangle indices of the leaf whose run starts at `first` in
/// `index`, a sign-terminated list ([`LAST`]).
///
/// # Panics
/// If the run is not terminated before the end of `index`.
pub fn leaf_triangles(index: &[u32], first: u32) -> impl Iterator<Item = u32> + '_ {
    let run = &index[first as usize..];
    let len = run
        .iter()
        .position(|e| e & LAST != 0)
        .expect("unterminated leaf run")
        + 1;
    run[..len].iter().map(|e| e & !LAST)
}

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
/// A sink that wants every hit ([`Stats::HITS`]) gets each one, and
/// neither `tmax` nor `best` changes.
#[inline(always)]
#[allow(clippy::too_many_arguments)]
pub fn intersect_leaf<const ANY: bool, S: Stats>(
    index: &[u32],
    triangles: &[Triangle],
    first: u32,
    ray: &Ray,
    tmax: &mut f32,
    best: &mut Option<Hit>,
    tally: &mut Tally,
    stats: &mut S,
) -> bool {
    let mut i = first as usize;
    loop {
        let entry = index[i];
        let prim = entry & !LAST;
        tally.triangles += 1;
        if let Some(h) = triangles[prim as usize].hit(ray, ray.tmin, *tmax, prim) {
            if take_hit::<ANY, S>(h, tmax, best, stats) {
                return true;
            }
        }
        if entry & LAST != 0 {
            return false;
        }
        i += 1;
    }
}

/// The leaf list's rule for one hit `h` of a leaf test: a sink that wants
/// every hit ([`Stats::HITS`]) gets it; an any-hit trace (`ANY`) keeps it
/// and is done (`true`); a closest-hit trace keeps it if it beats `best`
/// (the tie rule) and shrinks `tmax` to its [`cull_distance`].
#[inline(always)]
pub fn take_hit<const ANY: bool, S: Stats>(
    h: Hit,
    tmax: &mut f32,
    best: &mut Option<Hit>,
    stats: &mut S,
) -> bool {
    if S::HITS {
        stats.hit(h);
    } else if ANY {
        *best = Some(h);
        return true;
    } else if h.beats(best) {
        *tmax = cull_distance(h.t);
        *best = Some(h);
    }
    false
}

/// The root box test every BVH traversal begins with (6 plane tests): the
/// ray's box constants and its tally, or `None` when the ray misses the
/// scene box (the tally then already handed to `stats`).
///
/// A ray whose `tmin` is negative or NaN misses too: [`Ray::new`] refuses
/// such a ray, but `tmin` is a public field a caller can change afterwards,
/// and the box tests are conservative only from `tmin ≥ 0`
/// ([`crate::geometry::aabb::slab_reciprocals`]).
#[inline(always)]
pub fn enter<S: Stats>(ray: &Ray, root: &[f32; 6], stats: &mut S) -> Option<(BoxRay, Tally)> {
    let br = BoxRay::new(ray);
    let tally = Tally {
        planes: 6,
        ..Tally::default()
    };
    if !ray.has_traceable_tmin() || br.test(root, ray.tmin, ray.tmax) == f32::INFINITY {
        stats.add(tally);
        return None;
    }
    Some((br, tally))
}

/// The root box test of the interval traversals (dual-split tree, BIH,
/// H-tree): the ray's plane constants for trees inside `root`, its tally and
/// its interval `[tn, tf]` inside the scene box, or `None` when it misses
/// (the tally then handed to `stats`); as [`enter`], a negative or NaN
/// `tmin` misses.
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
    if !ray.has_traceable_tmin() || tn > tf {
        stats.add(tally);
        return None;
    }
    Some((PlaneRay::new(&br, root), tally, tn, tf))
}

/// The canonical BVH id of reference `r` of a layout that lists its inner
/// nodes' ids in order (wide layouts, the binary BVH's lines) and its leaves' as `(first block, id)` pairs
/// ascending (visit logs only).
pub fn canonical_id(node_ids: &[u32], leaf_ids: &[(u32, u32)], r: u32) -> u32 {
    if r & LAST == 0 {
        return node_ids[r as usize];
    }
    let at = r & !LAST;
    let k = leaf_ids
        .binary_search_by_key(&at, |&(p, _)| p)
        .expect("a placed leaf");
    leaf_ids[k].1
}
