use super::Ray;
use glam::{Vec3, Vec4, Vec4Swizzles};

/// An axis-aligned box. The empty box has `min = +inf`, `max = -inf`, so that
/// growing it by anything gives that thing.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Aabb {
    /// The lower corner, in scene units.
    pub min: Vec3,
    /// The upper corner, in scene units.
    pub max: Vec3,
}

impl Default for Aabb {
    fn default() -> Self {
        Self::EMPTY
    }
}

impl Aabb {
    /// The empty box: `min = +inf`, `max = -inf`.
    pub const EMPTY: Aabb = Aabb {
        min: Vec3::INFINITY,
        max: Vec3::NEG_INFINITY,
    };

    /// The box from `min` to `max` (not checked: `min > max` on an axis is empty).
    pub fn new(min: Vec3, max: Vec3) -> Self {
        Aabb { min, max }
    }

    /// The smallest box holding all `points`.
    pub fn from_points(points: impl IntoIterator<Item = Vec3>) -> Self {
        points.into_iter().fold(Self::EMPTY, |b, p| b.grow(p))
    }

    /// The smallest box holding `self` and the point `p`.
    pub fn grow(self, p: Vec3) -> Self {
        Aabb {
            min: self.min.min(p),
            max: self.max.max(p),
        }
    }

    /// The smallest box holding `self` and `o`.
    pub fn union(self, o: Aabb) -> Self {
        Aabb {
            min: self.min.min(o.min),
            max: self.max.max(o.max),
        }
    }

    /// Whether `min > max` on some axis (a flat box, `min == max`, is not empty).
    pub fn is_empty(&self) -> bool {
        self.min.x > self.max.x || self.min.y > self.max.y || self.min.z > self.max.z
    }

    /// `max - min` per axis, clamped at 0 (zero for the empty box).
    pub fn extent(&self) -> Vec3 {
        (self.max - self.min).max(Vec3::ZERO)
    }

    /// `(min + max) / 2` (NaN for the empty box).
    pub fn center(&self) -> Vec3 {
        (self.min + self.max) * 0.5
    }

    /// Surface area; 0 for the empty box.
    pub fn area(&self) -> f32 {
        if self.is_empty() {
            return 0.0;
        }
        let e = self.extent();
        2.0 * (e.x * e.y + e.y * e.z + e.z * e.x)
    }

    /// The axis of largest extent (first maximum on ties).
    pub fn largest_axis(&self) -> usize {
        let e = self.extent();
        if e.x >= e.y && e.x >= e.z {
            0
        } else if e.y >= e.z {
            1
        } else {
            2
        }
    }

    /// Whether `o` lies inside `self`, faces included (the empty box lies
    /// inside every box).
    pub fn contains(&self, o: &Aabb) -> bool {
        self.min.cmple(o.min).all() && self.max.cmpge(o.max).all()
    }

    /// Slab test over `[ray.tmin, tmax]`: the entry distance, or `None` on a miss.
    pub fn intersect(&self, ray: &Ray, tmax: f32) -> Option<f32> {
        let t = BoxRay::new(ray).test(&self.to_array(), ray.tmin, tmax);
        (t != f32::INFINITY).then_some(t)
    }

    /// `[min.x, min.y, min.z, max.x, max.y, max.z]`: the order in which layouts
    /// store boxes and [`BoxRay::test`] reads them.
    pub fn to_array(&self) -> [f32; 6] {
        [
            self.min.x, self.min.y, self.min.z, self.max.x, self.max.y, self.max.z,
        ]
    }

    /// The inverse of [`Self::to_array`]: `[min xyz, max xyz]`.
    pub fn from_array(a: &[f32; 6]) -> Self {
        Aabb::new(Vec3::new(a[0], a[1], a[2]), Vec3::new(a[3], a[4], a[5]))
    }
}

/// `2γ₃ = 2·3u/(1-3u)` with `u = 2⁻²⁴`: the relative error bound of a slab
/// distance `(b - o) · inv` (three roundings), doubled to cover both the
/// near and the far distance.
pub const ROBUST_WIDENING: f32 =
    2.0 * (3.0 * f32::EPSILON * 0.5) / (1.0 - 3.0 * f32::EPSILON * 0.5);

/// The relative margin of [`slab_reciprocals`]: `2⁻²¹`, so that `1 ± step`
/// is exact and covers four roundings of `u = 2⁻²⁴` each:
/// `(1 + step)(1 − u)⁴ > 1` and `(1 − step)(1 + u)⁴ < 1` (checked below in
/// f64, where both products are exact to far below the margin).
pub const WIDENING_STEP: f32 = 1.0 / (1u32 << 21) as f32;
const _: () = {
    let (s, u) = (WIDENING_STEP as f64, 1.0 / (1u32 << 24) as f64);
    assert!((1.0 + s) * (1.0 - u) * (1.0 - u) * (1.0 - u) * (1.0 - u) > 1.0);
    assert!((1.0 - s) * (1.0 + u) * (1.0 + u) * (1.0 + u) * (1.0 + u) < 1.0);
};

/// Per-ray constants of the slab test, computed once per ray.
#[derive(Clone, Copy, Debug)]
pub struct BoxRay {
    /// The ray's origin, xyz.
    pub org: [f32; 3],
    /// The ray's reciprocal direction, xyz ([`Ray::inv_direction`]: ±inf
    /// for zero components).
    pub inv: [f32; 3],
    /// Whether the reciprocal direction is negative on each axis (the max
    /// plane is then the near one). `1/-0 = -inf` counts as negative.
    pub neg: [bool; 3],
    /// Per axis, the reciprocal that scales the distance to the min plane
    /// and to the max plane: [`slab_reciprocals`]'s near or far factor,
    /// whichever role the plane plays for this ray.
    inv_lo: [f32; 3],
    inv_hi: [f32; 3],
    org4: [Vec4; 3],
    /// Per axis, `[inv_lo, inv_lo, inv_hi, inv_hi]`: the lanes of
    /// [`Self::test_pair`]'s `[lo_0, lo_1, hi_0, hi_1]`.
    inv4: [Vec4; 3],
}

/// A ray's reciprocal direction `inv` on one axis scaled for the slab
/// test's near plane and for its far plane (returned in that order), so that the rounded plane distances need no widening at each
/// box (Ize 2013 widens each exit distance by `1 + 2γ₃`; here the factor
/// is folded into the reciprocal once per ray).
///
/// A plane distance `fl(fl(p - o) · fl(r · (1 ± s)))`, with `r = fl(1/d)`
/// and `s` = [`WIDENING_STEP`] (`2⁻²¹`, so `1 ± s` is exact), is the exact
/// `(p - o)/d` times `(1 ± s)` and four roundings of at most `u = 2⁻²⁴`
/// each while the results stay normal; `(1 + s)(1 - u)⁴ > 1` and
/// `(1 - s)(1 + u)⁴ < 1`, so before the product's own rounding a far
/// distance that is not negative lies above the exact one and a near
/// distance below it. Rounding is monotone, so after that last rounding a
/// near distance is at most the exact entry rounded and a far one at least
/// the exact exit rounded; as `tmin` and `tmax` are floats themselves, a
/// box whose exact interval meets `[tmin, tmax]` passes `max(tmin, nears)
/// ≤ min(tmax, fars)`, even where the product is subnormal and its
/// rounding absolute (there the returned entry can exceed the exact one by
/// up to 2⁻¹⁵⁰).
/// Negative distances are moved the other way, but the test clamps them at
/// `tmin ≥ 0` (which [`Ray::new`] requires and the traversals' root tests
/// check), where the exact ones lie too: a box whose exact exit is negative
/// holds no hit in `[tmin, tmax]`. An infinite reciprocal stays infinite,
/// so a ray parallel to a slab is treated as before (±inf, or NaN for an
/// origin in the plane, which the test ignores); `r·(1 + s)` cannot
/// overflow, as `Ray::new` keeps `|r| ≤ 2¹²⁶`. An entry beyond `f32::MAX`
/// becomes `+inf`, a miss: such a hit has no f32 distance either.
/// Checked against exact rational arithmetic on 4M adversarial rays and
/// boxes (faces, edges and corners grazed, origins in box planes,
/// coordinates to 2¹²⁶, directions from 2⁻¹⁰⁰, ±0 components) by a review
/// while this was built, and by
/// `scaled_reciprocals_put_far_planes_beyond_and_near_planes_before_the_exact_distance`.
#[inline(always)]
pub fn slab_reciprocals(inv: f32) -> (f32, f32) {
    (inv * (1.0 - WIDENING_STEP), inv * (1.0 + WIDENING_STEP))
}

/// `max(t, acc)` that keeps `acc` when `t` is NaN (an ignored slab).
#[inline(always)]
fn max_keep(t: Vec4, acc: Vec4) -> Vec4 {
    // SSE's maxps returns its second operand when either is NaN.
    #[cfg(target_arch = "x86_64")]
    return t.max(acc);
    #[cfg(not(target_arch = "x86_64"))]
    return Vec4::select(t.cmpgt(acc), t, acc);
}

/// `min(t, acc)` that keeps `acc` when `t` is NaN.
#[inline(always)]
fn min_keep(t: Vec4, acc: Vec4) -> Vec4 {
    #[cfg(target_arch = "x86_64")]
    return t.min(acc);
    #[cfg(not(target_arch = "x86_64"))]
    return Vec4::select(t.cmplt(acc), t, acc);
}

impl BoxRay {
    /// The constants of `ray`; its interval is passed to each test instead.
    pub fn new(ray: &Ray) -> Self {
        let o = ray.origin().to_array();
        let inv = ray.inv_direction().to_array();
        let neg = inv.map(f32::is_sign_negative);
        // The min plane is the near one unless the direction is negative.
        let scaled = inv.map(slab_reciprocals);
        let inv_lo = std::array::from_fn(|a| if neg[a] { scaled[a].1 } else { scaled[a].0 });
        let inv_hi = std::array::from_fn(|a| if neg[a] { scaled[a].0 } else { scaled[a].1 });
        BoxRay {
            org: o,
            inv,
            neg,
            inv_lo,
            inv_hi,
            org4: o.map(Vec4::splat),
            inv4: std::array::from_fn(|a| Vec4::new(inv_lo[a], inv_lo[a], inv_hi[a], inv_hi[a])),
        }
    }

    /// Entry distance of the ray into box `b` (`[min xyz, max xyz]`) within
    /// `[tmin, tmax]`, or `+inf` on a miss.
    ///
    /// `tnear = max(tmin, near slabs)`, `tfar = min(tmax, far slabs)`, hit iff
    /// `tnear <= tfar`. A slab that is NaN (origin exactly on a plane of a
    /// zero direction component: `0 * inf`) is ignored, because each
    /// comparison keeps the accumulator when the slab value is NaN.
    /// `tnear` does not depend on `tmax`, which the restart-trail traversal
    /// relies on.
    ///
    /// The test is conservative (Ize 2013; Woop et al. 2013, §5): the
    /// reciprocals are scaled once per ray ([`slab_reciprocals`]) so that every far
    /// plane's distance comes out at or beyond the exact one and every near
    /// plane's at or before it, whatever the roundings of `(b - o) · inv`.
    /// Without that margin on the exit a ray hitting a triangle exactly at a
    /// vertex or edge that lies on its box's boundary can compute `tnear >
    /// tfar` and lose the hit the watertight test found; without the entry
    /// margin on the entry a triangle lying in its box's entry face, hit at exactly the
    /// closest distance so far (a tie, which the smaller triangle index
    /// wins) or one ulp before it, can be culled against that distance.
    #[inline(always)]
    pub fn test(&self, b: &[f32; 6], tmin: f32, tmax: f32) -> f32 {
        let (tn, tf) = self.slabs(b, tmin, tmax);
        if tn <= tf {
            tn
        } else {
            f32::INFINITY
        }
    }

    /// The interval `(tnear, tfar)` of [`Self::test`]: a hit iff `tnear <= tfar`.
    #[inline(always)]
    pub fn interval(&self, b: &[f32; 6], tmin: f32, tmax: f32) -> (f32, f32) {
        self.slabs(b, tmin, tmax)
    }

    /// The entry (from `tmin`) and exit (from `tmax`) of the box's slabs,
    /// each plane's distance scaled by its role ([`slab_reciprocals`]).
    /// Both chains start from the ray's interval, so that each is three
    /// dependent steps long (the exit's was four with `tmax` taken last:
    /// the same minimum, one step later).
    #[inline(always)]
    fn slabs(&self, b: &[f32; 6], tmin: f32, tmax: f32) -> (f32, f32) {
        let mut tn = tmin;
        let mut tf = tmax;
        for a in 0..3 {
            let lo = (b[a] - self.org[a]) * self.inv_lo[a];
            let hi = (b[a + 3] - self.org[a]) * self.inv_hi[a];
            let (n, f) = if self.neg[a] { (hi, lo) } else { (lo, hi) };
            tn = if n > tn { n } else { tn };
            tf = if f < tf { f } else { tf };
        }
        (tn, tf)
    }

    /// [`Self::test`] for two boxes at once, stored per axis as
    /// `[lo_0, lo_1, hi_0, hi_1]` for x, then y, then z (12 floats). Gives the
    /// same distances as two calls of `test`, bit for bit.
    #[inline(always)]
    pub fn test_pair(&self, b: &[f32; 12], tmin: f32, tmax: f32) -> [f32; 2] {
        self.test_pair_distances(self.pair_planes(b), tmin, tmax)
    }

    /// The plane distances of [`Self::test_pair`]'s two boxes, per axis.
    #[inline(always)]
    fn pair_planes(&self, b: &[f32; 12]) -> [Vec4; 3] {
        std::array::from_fn(|a| self.pair_distances(Vec4::from_slice(&b[4 * a..4 * a + 4]), a))
    }

    /// [`Self::test_pair`] as a hit mask (bit 0 the first box, bit 1 the
    /// second) and the entry distances (lanes x and y, meaningful where the
    /// mask is set): the same decisions, the mask read straight off the
    /// comparison rather than the distances compared with infinity.
    #[inline(always)]
    pub fn test_pair_mask(&self, b: &[f32; 12], tmin: f32, tmax: f32) -> (u32, Vec4) {
        let (tn, tf) = self.pair_interval(self.pair_planes(b), tmin, tmax);
        (tn.cmple(tf).bitmask() & 3, tn)
    }

    /// The distances `(plane - o) · inv` of two boxes' planes on axis `a`,
    /// as [`Self::test_pair`] lays them out: `[lo_0, lo_1, hi_0, hi_1]`.
    #[inline(always)]
    pub fn pair_distances(&self, planes: Vec4, a: usize) -> Vec4 {
        (planes - self.org4[a]) * self.inv4[a]
    }

    /// [`Self::test_pair`] on plane distances already computed (per axis,
    /// `[lo_0, lo_1, hi_0, hi_1]`), for layouts that reuse some of them.
    #[inline(always)]
    pub fn test_pair_distances(&self, t: [Vec4; 3], tmin: f32, tmax: f32) -> [f32; 2] {
        let (tn, tf) = self.pair_interval(t, tmin, tmax);
        let hit = tn.cmple(tf);
        let t = Vec4::select(hit, tn, Vec4::INFINITY);
        [t.x, t.y]
    }

    /// Entries and exits (lanes x, y) of two boxes from their plane
    /// distances, within `[tmin, tmax]`.
    #[inline(always)]
    fn pair_interval(&self, t: [Vec4; 3], tmin: f32, tmax: f32) -> (Vec4, Vec4) {
        // Both chains start from the ray's interval, so that each is three
        // dependent steps long (the exit's was four, `tmax` taken last): the
        // same minimum, the compare after it the same.
        let mut tn = Vec4::splat(tmin);
        let mut tf = Vec4::splat(tmax);
        for (a, t) in t.into_iter().enumerate() {
            // Lanes xy: the near planes, zw: the far planes.
            let t = if self.neg[a] { t.zwxy() } else { t };
            tn = max_keep(t, tn);
            tf = min_keep(t.zwxy(), tf);
        }
        (tn, tf)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn unit() -> Aabb {
        Aabb::new(Vec3::ZERO, Vec3::ONE)
    }

    /// The entry distance of a ray with a unit direction component on the
    /// entry plane's axis into a plane at exactly `t`: `t` times the near
    /// reciprocal's factor (exact for the small integers used here).
    fn entered(t: f32) -> Option<f32> {
        Some(t * (1.0 - WIDENING_STEP))
    }

    #[test]
    fn hits_and_misses() {
        let r = Ray::infinite(Vec3::new(-1.0, 0.5, 0.5), Vec3::X);
        assert_eq!(unit().intersect(&r, f32::INFINITY), entered(1.0));
        assert!(entered(1.0).unwrap() < 1.0);
        assert_eq!(unit().intersect(&r, 0.5), None);
        let r = Ray::infinite(Vec3::new(-1.0, 1.5, 0.5), Vec3::X);
        assert_eq!(unit().intersect(&r, f32::INFINITY), None);
        // Pointing away.
        let r = Ray::infinite(Vec3::new(-1.0, 0.5, 0.5), -Vec3::X);
        assert_eq!(unit().intersect(&r, f32::INFINITY), None);
    }

    #[test]
    fn origin_inside_enters_at_tmin() {
        let r = Ray::new(Vec3::splat(0.5), Vec3::new(1.0, -2.0, 0.0), 0.25, 10.0);
        assert_eq!(unit().intersect(&r, 10.0), Some(0.25));
    }

    #[test]
    fn ray_in_a_face_plane_with_zero_component_is_kept() {
        // Origin exactly on the plane y = 0 with d.y = 0: 0 * inf = NaN, ignored.
        for dy in [0.0f32, -0.0] {
            let r = Ray::infinite(Vec3::new(-1.0, 0.0, 0.5), Vec3::new(1.0, dy, 0.0));
            assert_eq!(unit().intersect(&r, f32::INFINITY), entered(1.0));
        }
        // Just outside the slab with d.y = 0 misses.
        let r = Ray::infinite(Vec3::new(-1.0, -1e-30, 0.5), Vec3::X);
        assert_eq!(unit().intersect(&r, f32::INFINITY), None);
    }

    #[test]
    fn parallel_rays_outside_a_slab_miss_without_nans() {
        // d.x = 0 with the origin beside the box: both x slabs are -inf.
        let r = Ray::infinite(Vec3::new(2.0, 0.5, -1.0), Vec3::Z);
        let (tn, tf) = BoxRay::new(&r).interval(&unit().to_array(), 0.0, f32::INFINITY);
        assert!(tn > tf && !tf.is_nan(), "{tn} {tf}");
    }

    #[test]
    fn scaled_reciprocals_put_far_planes_beyond_and_near_planes_before_the_exact_distance() {
        // Plane distances (p - o) · inv over coordinates and directions of
        // every magnitude, against the exact quotient in f64 (the f64
        // difference of two f32 is exact here, and its quotient is within
        // 2⁻⁵³, far below the 2⁻²¹ margin). Results in the subnormal range
        // are left out: there the roundings are absolute, not relative.
        let mut rng = crate::rng::Pcg32::new(5, 9);
        let value = |rng: &mut crate::rng::Pcg32| {
            let e = rng.range(-60.0, 60.0);
            let m = rng.range(1.0, 2.0);
            let s = if rng.next_f32() < 0.5 { -1.0 } else { 1.0 };
            s * m * e.exp2()
        };
        let mut checked = 0;
        for _ in 0..400_000 {
            let (p, o, d) = (value(&mut rng), value(&mut rng), value(&mut rng));
            let inv = 1.0 / d;
            let (near, far) = slab_reciprocals(inv);
            let exact = (f64::from(p) - f64::from(o)) / f64::from(d);
            let tn = (p - o) * near;
            let tf = (p - o) * far;
            if exact < 0.0 || !tn.is_normal() || !tf.is_normal() {
                continue;
            }
            assert!(f64::from(tf) >= exact, "far {p} {o} {d}: {tf} < {exact}");
            assert!(f64::from(tn) <= exact, "near {p} {o} {d}: {tn} > {exact}");
            checked += 1;
        }
        assert!(checked > 150_000, "{checked}");
    }

    #[test]
    fn negative_tmin_is_not_traced() {
        let r = Ray::new(Vec3::new(-1.0, 0.5, 0.5), Vec3::X, -1.0, 10.0);
        assert!(!r.is_valid());
        assert_eq!(unit().intersect(&r, 10.0), None);
        let why = Ray::invalid_reason(Vec3::ZERO, Vec3::X, -1.0, 1.0).unwrap();
        assert!(why.contains("negative tmin"), "{why}");
        assert!(Ray::new(Vec3::ZERO, Vec3::X, -0.0, 1.0).is_valid());
    }

    #[test]
    fn flat_box_is_hit() {
        let b = Aabb::new(Vec3::new(0.0, 0.0, 0.0), Vec3::new(1.0, 0.0, 1.0));
        let r = Ray::infinite(Vec3::new(0.5, 2.0, 0.5), -Vec3::Y);
        assert_eq!(b.intersect(&r, f32::INFINITY), entered(2.0));
    }

    #[test]
    fn pair_test_equals_two_single_tests() {
        let mut hits = 0;
        let mut rng = crate::rng::Pcg32::new(1, 2);
        let mut v = |lo: f32, hi: f32| rng.range(lo, hi);
        for i in 0..20000 {
            let b0 = Aabb::new(
                Vec3::new(v(-2.0, 0.0), v(-2.0, 0.0), v(-2.0, 0.0)),
                Vec3::new(v(0.0, 2.0), v(0.0, 2.0), v(0.0, 2.0)),
            );
            let b1 = Aabb::new(
                Vec3::new(v(-1.0, 0.5), 0.0, v(-2.0, 0.0)),
                Vec3::new(v(0.5, 3.0), 0.0, v(0.0, 2.0)),
            );
            let mut d = Vec3::new(v(-1.0, 1.0), v(-1.0, 1.0), v(-1.0, 1.0));
            // Zero components of both signs, and origins on box planes.
            if i % 3 == 0 {
                d[i % 3] = if i % 2 == 0 { 0.0 } else { -0.0 };
            }
            let mut o = Vec3::new(v(-3.0, 3.0), v(-3.0, 3.0), v(-3.0, 3.0));
            if i % 5 == 0 {
                o.y = 0.0;
            }
            let r = Ray::new(o, d, v(0.0, 0.5), v(0.5, 4.0));
            let br = BoxRay::new(&r);
            let (a0, a1) = (b0.to_array(), b1.to_array());
            let mut soa = [0.0; 12];
            for a in 0..3 {
                soa[4 * a..4 * a + 4].copy_from_slice(&[a0[a], a1[a], a0[a + 3], a1[a + 3]]);
            }
            let pair = br.test_pair(&soa, r.tmin, r.tmax);
            let single = [br.test(&a0, r.tmin, r.tmax), br.test(&a1, r.tmin, r.tmax)];
            assert_eq!(pair.map(f32::to_bits), single.map(f32::to_bits), "{r:?}");
            // The mask form: the same hits, the same entries where hit.
            let (mask, t) = br.test_pair_mask(&soa, r.tmin, r.tmax);
            for (k, (entry, single)) in [t.x, t.y].into_iter().zip(single).enumerate() {
                let hit = mask >> k & 1 == 1;
                assert_eq!(hit, single != f32::INFINITY, "{r:?}");
                if hit {
                    assert_eq!(entry.to_bits(), single.to_bits(), "{r:?}");
                }
            }
            hits += mask.count_ones();
        }
        // Both outcomes occur often enough for the comparison to mean something.
        assert!(hits > 1000 && hits < 39000, "{hits}");
    }

    #[test]
    fn area_and_axis() {
        let b = Aabb::new(Vec3::ZERO, Vec3::new(1.0, 2.0, 3.0));
        assert_eq!(b.area(), 22.0);
        assert_eq!(b.largest_axis(), 2);
        assert_eq!(Aabb::EMPTY.area(), 0.0);
        assert!(Aabb::EMPTY.is_empty());
    }
}
