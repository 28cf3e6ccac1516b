//! The ray interval `[tmin, tmax]` of the plane-based traversals (dual-split
//! tree, BIH, H-tree): planes narrow it, NaN distances (a ray lying in a
//! plane) leave it alone.
//!
//! Plane distances are widened, entries down and exits up, so that a hit on
//! a region's boundary is never lost to rounding: by a per-ray, per-axis
//! slack ([`PlaneRay`]) that bounds the rounding error of every plane inside
//! the scene box, one addition per plane instead of a product picked by the
//! sign of each distance.

use crate::geometry::aabb::{Aabb, BoxRay, ROBUST_WIDENING};

/// The slack's factor over the largest plane distance on an axis: `2⁻²⁰`,
/// more than the `γ₃` relative error of a distance `(p - o) · inv` with
/// room for the roundings of the bound itself.
pub const SLACK: f32 = 1.0 / (1u32 << 20) as f32;
const _: () = assert!(SLACK * (1.0 - 4.0 * f32::EPSILON) > ROBUST_WIDENING);

/// A ray's constants for plane tests against the planes of a tree inside
/// `bounds`: origin, reciprocal direction, its signs and each axis' slack.
///
/// The computed distance `t' = (p - o) · inv` of a plane `p` differs from
/// the exact `(p - o) / d` by at most `γ₃|t|`, and `|t|` is at most the
/// distance `T` to the farther face of the scene box on that axis, so
/// `SLACK · T` covers every plane of the tree. On an axis the ray does not
/// move along (`inv` infinite) the distances are exactly ±inf or NaN and the
/// slack is 0.
#[derive(Clone, Copy, Debug)]
pub struct PlaneRay {
    /// The ray's origin, xyz.
    pub org: [f32; 3],
    /// The ray's reciprocal direction, xyz (±inf for zero components).
    pub inv: [f32; 3],
    /// Whether `inv` is negative on each axis (`-inf` included): the
    /// maximum face is then the one entered.
    pub neg: [bool; 3],
    slack: [f32; 3],
    /// What [`Self::clip`] adds to a face's distance for `tmin` and for
    /// `tmax`, by face code: the slack on the side the face bounds, an
    /// infinity that leaves the other side alone.
    lo_bias: [f32; 6],
    hi_bias: [f32; 6],
}

/// The code of a region's face on `axis`: its minimum (`max_side` false,
/// the region lies above it) or its maximum.
#[inline(always)]
pub const fn face_code(axis: usize, max_side: bool) -> usize {
    2 * axis + max_side as usize
}

impl PlaneRay {
    /// The constants of `br` for planes inside `bounds`.
    pub fn new(br: &BoxRay, bounds: &Aabb) -> Self {
        let (lo, hi) = (bounds.min.to_array(), bounds.max.to_array());
        let slack = std::array::from_fn(|a| {
            let far = (lo[a] - br.org[a]).abs().max((hi[a] - br.org[a]).abs());
            if br.inv[a].is_finite() {
                far * br.inv[a].abs() * SLACK
            } else {
                0.0
            }
        });
        // A minimum face is entered going +axis, a maximum face left; a
        // negative direction swaps the two.
        let exits = |code: usize| (code & 1 == 1) != br.neg[code / 2];
        let lo_bias = std::array::from_fn(|c| {
            if exits(c) {
                f32::NEG_INFINITY
            } else {
                -slack[c / 2]
            }
        });
        let hi_bias = std::array::from_fn(|c| {
            if exits(c) {
                slack[c / 2]
            } else {
                f32::INFINITY
            }
        });
        PlaneRay {
            org: br.org,
            inv: br.inv,
            neg: br.neg,
            slack,
            lo_bias,
            hi_bias,
        }
    }

    /// The distance to plane `p` on axis `a`, unwidened.
    #[inline(always)]
    fn t(&self, a: usize, p: f32) -> f32 {
        (p - self.org[a]) * self.inv[a]
    }

    /// The distance to plane `p` on axis `a` as an entry: widened down.
    #[inline(always)]
    pub fn entry(&self, a: usize, p: f32) -> f32 {
        self.t(a, p) - self.slack[a]
    }

    /// The distance to plane `p` on axis `a` as an exit: widened up.
    #[inline(always)]
    pub fn exit(&self, a: usize, p: f32) -> f32 {
        self.t(a, p) + self.slack[a]
    }

    /// `[tmin, tmax]` narrowed by the region face `code` ([`face_code`])
    /// at `p`: raised to its entry or lowered to its exit, whichever it is
    /// for this ray, without a branch. Equal to `raise(tmin, entry)` or
    /// `lower(tmax, exit)`: the other side gets `t ∓ inf`, which is
    /// `∓inf` or NaN and leaves its bound alone.
    #[inline(always)]
    pub fn clip(&self, code: usize, p: f32, tmin: f32, tmax: f32) -> (f32, f32) {
        let t = self.t(code / 2, p);
        (
            raise(tmin, t + self.lo_bias[code]),
            lower(tmax, t + self.hi_bias[code]),
        )
    }
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
/// `planes` are the bits of the first child's maximum and the second
/// child's minimum on axis `a`. Along +axis the first child (below plane 0)
/// comes first and ends at `t1`; the second begins at `t2`; reversed
/// otherwise, picked by indexing with the sign rather than a branch. A NaN
/// distance (a ray in the plane) keeps the child; an entry at +inf (a ray
/// parallel to the plane, outside it) is never reached.
#[inline(always)]
pub fn split_children(
    ray: &PlaneRay,
    a: usize,
    planes: &[u32; 2],
    first: usize,
    second: usize,
    tmin: f32,
    tmax: f32,
) -> [Option<(usize, f32, f32)>; 2] {
    let s = ray.neg[a] as usize;
    let kids = [first, second];
    let (near, far) = (kids[s], kids[s ^ 1]);
    let t_near_exit = ray.exit(a, f32::from_bits(planes[s]));
    let t_far_entry = ray.entry(a, f32::from_bits(planes[s ^ 1]));
    let hit_near = t_near_exit >= tmin || t_near_exit.is_nan();
    let hit_far = (t_far_entry <= tmax && t_far_entry < f32::INFINITY) || t_far_entry.is_nan();
    [
        hit_near.then(|| (near, tmin, lower(tmax, t_near_exit))),
        hit_far.then(|| (far, raise(tmin, t_far_entry), tmax)),
    ]
}

/// The child to visit next of the `[near, far]` pair from
/// [`split_children`], the far one pushed when both are reached; `None`
/// when neither is.
#[inline(always)]
pub fn next_child(
    children: [Option<(usize, f32, f32)>; 2],
    stack: &mut [(u32, f32, f32)],
    sp: &mut usize,
) -> Option<(usize, f32, f32)> {
    match children {
        [Some(near), Some(far)] => {
            stack[*sp] = (far.0 as u32, far.1, far.2);
            *sp += 1;
            Some(near)
        }
        [near, far] => near.or(far),
    }
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::Ray;
    use crate::rng::Pcg32;
    use glam::Vec3;

    /// A coordinate spread over many magnitudes: `±m · 2^e`.
    fn wide(rng: &mut Pcg32, lo: i32, hi: i32) -> f32 {
        let e = lo + rng.below((hi - lo) as u32) as i32;
        let m = rng.range(1.0, 2.0) * 2f32.powi(e);
        if rng.below(2) == 0 {
            m
        } else {
            -m
        }
    }

    #[test]
    fn clip_narrows_exactly_as_the_entry_or_exit_of_the_face_would() {
        let mut rng = Pcg32::new(11, 3);
        let bounds = Aabb::new(Vec3::splat(-4.0), Vec3::splat(4.0));
        let (mut entries, mut exits, mut in_plane) = (0, 0, 0);
        for _ in 0..20_000 {
            let o = Vec3::new(wide(&mut rng, -3, 4), wide(&mut rng, -3, 4), 0.0);
            let mut d = Vec3::new(
                wide(&mut rng, -4, 2),
                wide(&mut rng, -4, 2),
                wide(&mut rng, -4, 2),
            );
            if rng.below(4) == 0 {
                d[rng.below(3) as usize] = 0.0;
            }
            let r = PlaneRay::new(&BoxRay::new(&Ray::infinite(o, d)), &bounds);
            let (tmin, tmax) = (rng.range(-8.0, 8.0), rng.range(-8.0, 8.0));
            for code in 0..6 {
                let a = code / 2;
                // A plane through the origin gives a NaN distance on an
                // axis the ray does not move along.
                let p = match rng.below(4) {
                    0 => o[a],
                    _ => rng.range(-4.0, 4.0),
                };
                let want = if (code & 1 == 1) != r.neg[a] {
                    exits += 1;
                    (tmin, lower(tmax, r.exit(a, p)))
                } else {
                    entries += 1;
                    (raise(tmin, r.entry(a, p)), tmax)
                };
                in_plane += r.t(a, p).is_nan() as u32;
                let got = r.clip(code, p, tmin, tmax);
                assert_eq!(
                    (got.0.to_bits(), got.1.to_bits()),
                    (want.0.to_bits(), want.1.to_bits()),
                    "face {code} at {p}, origin {o}, direction {d}"
                );
            }
        }
        assert!(entries > 10_000 && exits > 10_000 && in_plane > 100);
    }

    #[test]
    fn slack_brackets_the_exact_distance_of_every_plane_inside_the_box() {
        let mut rng = Pcg32::new(7, 1);
        let mut checked = 0;
        for _ in 0..20_000 {
            let c = Vec3::new(wide(&mut rng, -4, 12), wide(&mut rng, -4, 12), 0.5);
            let r = Vec3::splat(2f32.powi(rng.below(16) as i32 - 6));
            let bounds = Aabb::new(c - r, c + r);
            // Origins inside, near and far outside the box.
            let o = c + Vec3::new(
                wide(&mut rng, -8, 20),
                wide(&mut rng, -8, 20),
                wide(&mut rng, -8, 20),
            );
            // Directions from axis-parallel (a zero component) to
            // grazing (components 2^-20 of the others).
            let mut d = Vec3::new(
                wide(&mut rng, -20, 2),
                wide(&mut rng, -20, 2),
                wide(&mut rng, -20, 2),
            );
            if rng.below(8) == 0 {
                d[rng.below(3) as usize] = 0.0;
            }
            let ray = Ray::infinite(o, d);
            let pr = PlaneRay::new(&BoxRay::new(&ray), &bounds);
            for a in 0..3 {
                let p = rng.range(bounds.min[a], bounds.max[a]);
                let exact = (p as f64 - o[a] as f64) / d[a] as f64;
                let (lo, hi) = (pr.entry(a, p), pr.exit(a, p));
                if d[a] == 0.0 {
                    // Exactly ±inf (or NaN in the plane), no slack added.
                    assert_eq!(pr.slack[a], 0.0);
                    assert!(lo.is_nan() || (lo.is_infinite() && lo == hi));
                    continue;
                }
                assert!(
                    lo as f64 <= exact && exact <= hi as f64,
                    "axis {a}: plane {p}, origin {o}, direction {d}: exact {exact} outside [{lo}, {hi}]"
                );
                // The slack stays small beside the box's own extent.
                let extent = (bounds.max[a] - bounds.min[a]) as f64 / d[a].abs() as f64;
                let far = (o[a] - c[a]).abs() as f64 / d[a].abs() as f64;
                assert!((hi - lo) as f64 <= 4.0 * SLACK as f64 * (extent + far) + 1e-30);
                checked += 1;
            }
        }
        assert!(checked > 50_000);
    }
}
