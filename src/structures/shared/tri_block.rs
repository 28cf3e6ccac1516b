//! Leaves whose triangles are tested four at a time: a leaf's triangles are
//! copied side by side into blocks of [`LANES`] (vertex coordinates as nine
//! rows of four lanes), and the watertight test (Woop, Benthin and Wald
//! 2013) runs on all lanes in one pass of vector arithmetic.
//!
//! The lanes compute exactly the f32 operations of
//! [`crate::geometry::Triangle::intersect`], in the same order, so a lane's
//! answer is bit for bit the scalar test's; a lane the f32 test cannot decide
//! (an edge function exactly zero, an ill-conditioned or overflowing
//! configuration) is handed to the scalar test, which takes its exact
//! paths. Lanes are then taken in leaf order with the leaf list's rules (the
//! tie rule, any hit, every hit), so a leaf answers as
//! [`super::leaf::intersect_leaf`] does, ray for ray.

use super::leaf::{cull_distance, LAST};
use crate::geometry::{Hit, Ray, Triangle, ILL_CONDITIONED, TINY_DETERMINANT, TINY_SCALE};
use crate::stats::{Stats, Tally};

/// Triangles per block.
pub const LANES: usize = 4;
/// The entry of an unused lane (after the leaf's last triangle).
pub(crate) const EMPTY: u32 = u32::MAX;

/// Four triangles: `v[3·vertex + axis][lane]` (vertices a, b, c; axes x, y,
/// z) and their entries in the sign-terminated leaf list (`LAST` on the
/// leaf's last triangle; `u32::MAX` in unused lanes after it). 160 bytes.
#[derive(Clone, Copy, Debug, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
#[repr(C, align(16))]
pub struct TriBlock {
    /// Vertex coordinates, one row per vertex axis, one lane per triangle.
    pub v: [[f32; LANES]; 9],
    /// Mesh triangle indices, the leaf's last with [`LAST`] set.
    pub prims: [u32; LANES],
}

/// Appends the blocks of a leaf whose triangles are `prims` (mesh indices,
/// at least one) and returns the first block's index.
pub fn push_leaf(blocks: &mut Vec<TriBlock>, prims: &[u32], triangles: &[Triangle]) -> u32 {
    assert!(!prims.is_empty(), "a leaf has triangles");
    let first = blocks.len() as u32;
    for (j, chunk) in prims.chunks(LANES).enumerate() {
        let mut b = TriBlock {
            v: [[0.0; LANES]; 9],
            prims: [EMPTY; LANES],
        };
        for (l, &p) in chunk.iter().enumerate() {
            let t = &triangles[p as usize];
            for (vi, vert) in [t.a, t.b, t.c].into_iter().enumerate() {
                for axis in 0..3 {
                    b.v[3 * vi + axis][l] = vert[axis];
                }
            }
            b.prims[l] = p;
            if j * LANES + l + 1 == prims.len() {
                b.prims[l] |= LAST;
            }
        }
        blocks.push(b);
    }
    first
}

/// `f` over the lanes.
#[inline(always)]
fn lanes(f: impl Fn(usize) -> f32) -> [f32; LANES] {
    std::array::from_fn(f)
}

/// Tests the triangles of the leaf whose blocks start at `first` against
/// `[ray.tmin, *tmax]`, with the rules of [`super::leaf::intersect_leaf`]:
/// closest hit (`ANY = false`: `best` and `tmax` updated, ties to the
/// smaller index), any hit (`true` returned on the first), or every hit to a
/// sink that wants them ([`Stats::HITS`]).
#[inline(always)]
#[allow(clippy::too_many_arguments)]
pub fn intersect_blocks<const ANY: bool, S: Stats>(
    blocks: &[TriBlock],
    first: u32,
    triangles: &[Triangle],
    ray: &Ray,
    tmax: &mut f32,
    best: &mut Option<Hit>,
    tally: &mut Tally,
    stats: &mut S,
) -> bool {
    let [kx, ky, kz] = ray.k.map(|k| k & 3);
    let s = ray.shear;
    let o = ray.origin().to_array();
    let mut i = first as usize;
    loop {
        let blk = &blocks[i];
        // Vertex coordinates relative to the origin, on the ray's axes.
        let rel = |vert: usize, axis: usize| -> [f32; LANES] {
            let row = &blk.v[3 * vert + axis];
            std::array::from_fn(|l| row[l] - o[axis])
        };
        let (a_x, a_y, a_z) = (rel(0, kx), rel(0, ky), rel(0, kz));
        let (b_x, b_y, b_z) = (rel(1, kx), rel(1, ky), rel(1, kz));
        let (c_x, c_y, c_z) = (rel(2, kx), rel(2, ky), rel(2, kz));
        let ax = lanes(|l| a_x[l] - s.x * a_z[l]);
        let ay = lanes(|l| a_y[l] - s.y * a_z[l]);
        let bx = lanes(|l| b_x[l] - s.x * b_z[l]);
        let by = lanes(|l| b_y[l] - s.y * b_z[l]);
        let cx = lanes(|l| c_x[l] - s.x * c_z[l]);
        let cy = lanes(|l| c_y[l] - s.y * c_z[l]);
        let u = lanes(|l| cx[l] * by[l] - cy[l] * bx[l]);
        let v = lanes(|l| ax[l] * cy[l] - ay[l] * cx[l]);
        let w = lanes(|l| bx[l] * ay[l] - by[l] * ax[l]);
        let det = lanes(|l| u[l] + v[l] + w[l]);
        let m = lanes(|l| ax[l].abs() + ay[l].abs() + a_z[l].abs());
        let t_scaled =
            lanes(|l| u[l] * (s.z * a_z[l]) + v[l] * (s.z * b_z[l]) + w[l] * (s.z * c_z[l]));
        for l in 0..LANES {
            let entry = blk.prims[l];
            if entry == EMPTY {
                break;
            }
            let prim = entry & !LAST;
            tally.triangles += 1;
            let (u, v, w, det) = (u[l], v[l], w[l], det[l]);
            let hit = if u == 0.0
                || v == 0.0
                || w == 0.0
                || !(det.abs() >= m[l] * m[l] * ILL_CONDITIONED && m[l] >= TINY_SCALE)
            {
                // The scalar test's exact paths.
                triangles[prim as usize].hit(ray, ray.tmin, *tmax, prim)
            } else if ((u < 0.0 || v < 0.0 || w < 0.0) && (u > 0.0 || v > 0.0 || w > 0.0))
                || det == 0.0
            {
                None
            } else if !(det.abs() >= TINY_DETERMINANT && det.is_finite() && t_scaled[l].is_finite())
            {
                triangles[prim as usize].hit(ray, ray.tmin, *tmax, prim)
            } else {
                let sign = det.to_bits() & 0x8000_0000;
                let t_abs = f32::from_bits(t_scaled[l].to_bits() ^ sign);
                let det_abs = det.abs();
                if t_abs < ray.tmin * det_abs || t_abs > *tmax * det_abs {
                    None
                } else {
                    let rcp = 1.0 / det;
                    Some(Hit {
                        t: t_scaled[l] * rcp,
                        prim,
                        u: v * rcp,
                        v: w * rcp,
                    })
                }
            };
            if let Some(h) = hit {
                if S::HITS {
                    stats.hit(h);
                } else if ANY {
                    *best = Some(h);
                    return true;
                } else if h.beats(best) {
                    *tmax = cull_distance(h.t);
                    *best = Some(h);
                }
            }
            if entry & LAST != 0 {
                return false;
            }
        }
        i += 1;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::Pcg32;
    use crate::stats::{HitList, NoStats};
    use crate::structures::shared::leaf::intersect_leaf;
    use glam::Vec3;

    /// Leaves of 1 to 9 triangles at scales from 1e-6 to 1e6, with shared
    /// edges, coplanar overlaps and edge-on triangles, and rays through
    /// them: the blocks answer exactly as the scalar leaf test, for closest
    /// hit, any hit and every hit.
    #[test]
    fn blocks_answer_as_the_scalar_leaf_test() {
        let mut rng = Pcg32::new(7, 3);
        let mut f = || rng.next_f32() * 2.0 - 1.0;
        let mut checked = 0;
        for case in 0..4000 {
            let scale = 10f32.powi(case % 13 - 6);
            let n = 1 + case as usize % 9;
            let p = |f: &mut dyn FnMut() -> f32| Vec3::new(f(), f(), f()) * scale;
            let mut tris = Vec::new();
            for i in 0..n {
                let t = match i % 4 {
                    // A neighbour sharing the previous triangle's edge.
                    1 if i > 0 => {
                        let q: &Triangle = &tris[i - 1];
                        Triangle::new(q.b, q.a, p(&mut f))
                    }
                    // A copy: an exact tie.
                    2 if i > 0 => tris[i - 1],
                    // Edge-on: the three points on a line through the origin's region.
                    3 => {
                        let a = p(&mut f);
                        Triangle::new(a, a * 2.0, a * 3.0 + Vec3::splat(scale * 1e-7))
                    }
                    _ => Triangle::new(p(&mut f), p(&mut f), p(&mut f)),
                };
                tris.push(t);
            }
            let prims: Vec<u32> = (0..n as u32).collect();
            let mut index = prims.clone();
            *index.last_mut().unwrap() |= LAST;
            let mut blocks = Vec::new();
            let first = push_leaf(&mut blocks, &prims, &tris);
            for _ in 0..8 {
                let target = tris[rng_index(&mut f, n)].centroid() + p(&mut f) * 0.01;
                let origin = p(&mut f) * 3.0;
                let ray = Ray::new(origin, target - origin, 0.0, f32::INFINITY);
                for any in [false, true] {
                    let scalar = run(
                        any,
                        |tm, b, ta| {
                            if any {
                                intersect_leaf::<true, NoStats>(
                                    &index,
                                    &tris,
                                    0,
                                    &ray,
                                    tm,
                                    b,
                                    ta,
                                    &mut NoStats,
                                )
                            } else {
                                intersect_leaf::<false, NoStats>(
                                    &index,
                                    &tris,
                                    0,
                                    &ray,
                                    tm,
                                    b,
                                    ta,
                                    &mut NoStats,
                                )
                            }
                        },
                        &ray,
                    );
                    let block = run(
                        any,
                        |tm, b, ta| {
                            if any {
                                intersect_blocks::<true, NoStats>(
                                    &blocks,
                                    first,
                                    &tris,
                                    &ray,
                                    tm,
                                    b,
                                    ta,
                                    &mut NoStats,
                                )
                            } else {
                                intersect_blocks::<false, NoStats>(
                                    &blocks,
                                    first,
                                    &tris,
                                    &ray,
                                    tm,
                                    b,
                                    ta,
                                    &mut NoStats,
                                )
                            }
                        },
                        &ray,
                    );
                    assert_eq!(block, scalar, "case {case} any {any}: {tris:?} {ray:?}");
                }
                let (mut sa, mut sb) =
                    (HitList::<NoStats>::default(), HitList::<NoStats>::default());
                let (mut tm, mut b, mut ta) = (ray.tmax, None, Tally::default());
                intersect_leaf::<false, _>(
                    &index, &tris, 0, &ray, &mut tm, &mut b, &mut ta, &mut sa,
                );
                let (mut tm, mut b, mut ta) = (ray.tmax, None, Tally::default());
                intersect_blocks::<false, _>(
                    &blocks, first, &tris, &ray, &mut tm, &mut b, &mut ta, &mut sb,
                );
                assert_eq!(sa.hits, sb.hits, "case {case}: every hit");
                checked += sa.hits.len();
            }
        }
        assert!(checked > 1000, "too few hits to mean anything: {checked}");
    }

    fn rng_index(f: &mut dyn FnMut() -> f32, n: usize) -> usize {
        (((f() + 1.0) * 0.5 * n as f32) as usize).min(n - 1)
    }

    /// Runs a leaf test from a fresh state: (stopped, tmax, best, tally).
    fn run(
        _any: bool,
        test: impl Fn(&mut f32, &mut Option<Hit>, &mut Tally) -> bool,
        ray: &Ray,
    ) -> (bool, f32, Option<Hit>, Tally) {
        let (mut tmax, mut best, mut tally) = (ray.tmax, None, Tally::default());
        let stop = test(&mut tmax, &mut best, &mut tally);
        (stop, tmax, best, tally)
    }
}
