use super::{Aabb, Ray};
use glam::{DVec3, Vec3};

/// A triangle whose sheared determinant (twice its projected area) is below
/// this fraction of the squared distance `m` of its vertex from the ray's
/// origin is tested on the precise path: it is smaller than about 2⁻¹⁸ of
/// `m` (or seen edge-on), while f32 shearing rounds by 2⁻²³ of `m`.
pub const ILL_CONDITIONED: f32 = 1.0 / (1u64 << 36) as f32;

/// Below this distance of a triangle's vertex from the ray's origin
/// (2⁻³², about 2.3e-10), f32 products of sheared coordinates may fall
/// into subnormals: the precise path.
pub const TINY_SCALE: f32 = 1.0 / (1u64 << 32) as f32;

/// Below this determinant (2⁻⁹⁰, about 8e-28) `1/det` and `T` lose
/// precision or overflow: the precise path.
pub const TINY_DETERMINANT: f32 = 1.0 / (1u128 << 90) as f32;

/// A triangle with vertices `a`, `b`, `c`.
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub struct Triangle {
    /// First vertex, in scene units; weighted by `1 - u - v`.
    pub a: Vec3,
    /// Second vertex; weighted by [`Hit::u`].
    pub b: Vec3,
    /// Third vertex; weighted by [`Hit::v`].
    pub c: Vec3,
}

/// A ray-triangle hit: the distance `t` along the ray (in units of its
/// direction), the triangle's index in the mesh, and the barycentrics `u`, `v`
/// of the hit point `(1-u-v)·a + u·b + v·c`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hit {
    /// Ray parameter of the hit point, within the ray's `[tmin, tmax]`.
    pub t: f32,
    /// Index of the triangle in the mesh (mesh order, not [`crate::bvh::Bvh::prims`] order).
    pub prim: u32,
    /// Barycentric weight of vertex `b`.
    pub u: f32,
    /// Barycentric weight of vertex `c`.
    pub v: f32,
}

impl Hit {
    /// Whether `self` should replace `best`: nearer, or as near with a smaller
    /// triangle index, so that the reported triangle does not depend on the
    /// order in which a structure visits triangles that tie (shared edges).
    #[inline(always)]
    pub fn beats(&self, best: &Option<Hit>) -> bool {
        match best {
            None => true,
            Some(b) => self.t < b.t || (self.t == b.t && self.prim < b.prim),
        }
    }
}

impl Triangle {
    /// The triangle `a`, `b`, `c`.
    pub fn new(a: Vec3, b: Vec3, c: Vec3) -> Self {
        Triangle { a, b, c }
    }

    /// The box of the three vertices.
    pub fn bounds(&self) -> Aabb {
        Aabb::from_points([self.a, self.b, self.c])
    }

    /// The mean of the three vertices.
    pub fn centroid(&self) -> Vec3 {
        (self.a + self.b + self.c) * (1.0 / 3.0)
    }

    /// The geometric normal `(b-a)×(c-a)`, not normalized.
    pub fn normal(&self) -> Vec3 {
        (self.b - self.a).cross(self.c - self.a)
    }

    /// Zero area, judged in f64 so that tiny but real triangles are kept,
    /// or a coordinate that is NaN or infinite (which scene loading
    /// refuses, but a program may pass to `Bvh::build` itself). Structures
    /// leave such triangles out: they can never be hit.
    pub fn is_degenerate(&self) -> bool {
        if !(self.a.is_finite() && self.b.is_finite() && self.c.is_finite()) {
            return true;
        }
        let (a, b, c) = (self.a.as_dvec3(), self.b.as_dvec3(), self.c.as_dvec3());
        (b - a).cross(c - a) == DVec3::ZERO
    }

    /// The watertight test of Woop, Benthin and Wald (JCGT 2013), without
    /// backface culling, over `[tmin, tmax]` (both inclusive). Returns
    /// `(t, u, v)`; `t` is always a finite f32 (a crossing farther than f32
    /// can say is a miss).
    ///
    /// The ray is sheared so that it runs along +z through the origin; the
    /// three 2D edge functions are computed from the sheared vertices, and
    /// redone in f64 when one is exactly zero, so their signs are exact. An
    /// edge shared by two triangles therefore gets edge functions of exactly
    /// opposite sign: no ray slips between them. No FMA is used on purpose.
    ///
    /// Where f32 cannot decide, the whole test is done again in
    /// double-double arithmetic on the ray itself (`precise.rs`, also
    /// watertight): a triangle smaller than about 2⁻¹⁸ of its distance from
    /// the ray's origin (see [`ILL_CONDITIONED`]: the sheared coordinates'
    /// rounding would approach its size), a configuration within
    /// [`TINY_SCALE`] of the origin or with a determinant below
    /// [`TINY_DETERMINANT`] (f32 products underflow), and products that
    /// overflow f32. So every triangle that is not degenerate is hit
    /// wherever the ray crosses its interior, at any magnitude inside
    /// [`crate::geometry::COORDINATE_LIMIT`].
    #[inline(always)]
    pub fn intersect(&self, ray: &Ray, tmin: f32, tmax: f32) -> Option<(f32, f32, f32)> {
        // `& 3` into 4-wide arrays: the compiler sees the indices in range.
        let [kx, ky, kz] = ray.k.map(|k| usize::from(k) & 3);
        let s = ray.shear;
        let o = ray.origin();
        let a = (self.a - o).extend(0.0).to_array();
        let b = (self.b - o).extend(0.0).to_array();
        let c = (self.c - o).extend(0.0).to_array();
        let ax = a[kx] - s.x * a[kz];
        let ay = a[ky] - s.y * a[kz];
        let bx = b[kx] - s.x * b[kz];
        let by = b[ky] - s.y * b[kz];
        let cx = c[kx] - s.x * c[kz];
        let cy = c[ky] - s.y * c[kz];
        let mut u = cx * by - cy * bx;
        let mut v = ax * cy - ay * cx;
        let mut w = bx * ay - by * ax;
        if u == 0.0 || v == 0.0 || w == 0.0 {
            let f =
                |p: f32, q: f32, r: f32, t: f32| (p as f64 * q as f64 - r as f64 * t as f64) as f32;
            u = f(cx, by, cy, bx);
            v = f(ax, cy, ay, cx);
            w = f(bx, ay, by, ax);
        }
        let det = u + v + w;
        // Conditioning: the sheared coordinates carry rounding errors of
        // about 2⁻²³ of vertex a's distance `m` from the origin (L1 over
        // the sheared axes and the ray's axis), and so do the edge
        // functions of its lever arms. The determinant, twice the sheared
        // triangle's area, is at most its extent squared: below
        // `m²·ILL_CONDITIONED` the triangle is smaller than about 2⁻¹⁸ of
        // `m` (or seen edge-on), and f32 cannot be trusted with the signs.
        // A vertex within TINY_SCALE of the origin may give subnormal
        // products. The negated comparison sends NaN there too.
        let m = ax.abs() + ay.abs() + a[kz].abs();
        if !(det.abs() >= m * m * ILL_CONDITIONED && m >= TINY_SCALE) {
            return self.intersect_precise(ray, tmin, tmax);
        }
        if (u < 0.0 || v < 0.0 || w < 0.0) && (u > 0.0 || v > 0.0 || w > 0.0) {
            return None;
        }
        if det == 0.0 {
            return None;
        }
        let az = s.z * a[kz];
        let bz = s.z * b[kz];
        let cz = s.z * c[kz];
        let t_scaled = u * az + v * bz + w * cz;
        // An edge function, the determinant or T overflowed f32 (inf or
        // NaN), the determinant is so small that 1/det loses precision or
        // overflows, or T is zero or subnormal (its products may have
        // underflowed, and with them the sign that says whether the plane
        // is before or behind the origin): the precise path, where they
        // cannot. (The test's own arithmetic makes T zero where the origin
        // lies in the triangle's plane.)
        if !(det.abs() >= TINY_DETERMINANT
            && det.is_finite()
            && t_scaled.abs() >= f32::MIN_POSITIVE
            && t_scaled.is_finite())
        {
            return self.intersect_precise(ray, tmin, tmax);
        }
        // Flip T by det's sign so that the comparisons need no division.
        let sign = det.to_bits() & 0x8000_0000;
        let t_abs = f32::from_bits(t_scaled.to_bits() ^ sign);
        let det_abs = det.abs();
        if t_abs < tmin * det_abs || t_abs > tmax * det_abs {
            return None;
        }
        let rcp = 1.0 / det;
        Some((t_scaled * rcp, v * rcp, w * rcp))
    }

    /// [`Self::intersect`] in double-double arithmetic (see `precise.rs`).
    #[cold]
    #[inline(never)]
    fn intersect_precise(&self, ray: &Ray, tmin: f32, tmax: f32) -> Option<(f32, f32, f32)> {
        super::precise::intersect(self.a, self.b, self.c, ray, tmin, tmax)
    }

    /// [`Self::intersect`] as a [`Hit`] for triangle `prim`.
    #[inline(always)]
    pub fn hit(&self, ray: &Ray, tmin: f32, tmax: f32, prim: u32) -> Option<Hit> {
        self.intersect(ray, tmin, tmax)
            .map(|(t, u, v)| Hit { t, prim, u, v })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tri() -> Triangle {
        Triangle::new(Vec3::ZERO, Vec3::X, Vec3::Y)
    }

    #[test]
    fn hit_from_both_sides_with_barycentrics() {
        for dz in [-1.0f32, 1.0] {
            let r = Ray::infinite(Vec3::new(0.25, 0.5, dz * -2.0), Vec3::new(0.0, 0.0, dz));
            let (t, u, v) = tri().intersect(&r, r.tmin, r.tmax).unwrap();
            assert_eq!(t, 2.0);
            assert!((u - 0.25).abs() < 1e-6 && (v - 0.5).abs() < 1e-6, "{u} {v}");
        }
    }

    #[test]
    fn unnormalized_direction_scales_t() {
        let r = Ray::infinite(Vec3::new(0.25, 0.25, -2.0), Vec3::new(0.0, 0.0, 4.0));
        assert_eq!(tri().intersect(&r, 0.0, f32::INFINITY).unwrap().0, 0.5);
    }

    #[test]
    fn interval_is_inclusive_and_respected() {
        let r = Ray::infinite(Vec3::new(0.25, 0.25, -2.0), Vec3::Z);
        assert!(tri().intersect(&r, 0.0, 2.0).is_some());
        assert!(tri().intersect(&r, 0.0, 1.999).is_none());
        assert!(tri().intersect(&r, 2.001, 5.0).is_none());
    }

    #[test]
    fn degenerate_triangles_are_never_hit() {
        let d = Triangle::new(Vec3::ZERO, Vec3::X, Vec3::X * 2.0);
        assert!(d.is_degenerate());
        let r = Ray::infinite(Vec3::new(0.5, 1.0, 0.0), -Vec3::Y);
        assert!(d.intersect(&r, 0.0, f32::INFINITY).is_none());
        let p = Triangle::new(Vec3::ONE, Vec3::ONE, Vec3::ONE);
        assert!(p.is_degenerate());
        assert!(!tri().is_degenerate());
    }

    #[test]
    fn shared_edge_is_hit_by_both_triangles() {
        let t1 = Triangle::new(Vec3::ZERO, Vec3::X, Vec3::Y);
        let t2 = Triangle::new(Vec3::X, Vec3::new(1.0, 1.0, 0.0), Vec3::Y);
        // A point on the diagonal edge, from an oblique direction.
        let p = Vec3::new(0.3, 0.7, 0.0);
        let r = Ray::infinite(p - Vec3::new(0.1, 0.3, 1.0), Vec3::new(0.1, 0.3, 1.0));
        let h1 = t1.intersect(&r, 0.0, f32::INFINITY);
        let h2 = t2.intersect(&r, 0.0, f32::INFINITY);
        assert!(h1.is_some() || h2.is_some());
    }

    #[test]
    fn huge_coordinates_give_finite_hits() {
        for scale in [1e15f32, 1e30, 1e37] {
            let t = Triangle::new(Vec3::ZERO, Vec3::X * scale, Vec3::Y * scale);
            let r = Ray::infinite(
                Vec3::new(0.25, 0.25, -2.0) * scale,
                Vec3::new(0.0, 0.0, 1.0) * scale,
            );
            let (t, u, v) = t.intersect(&r, 0.0, f32::INFINITY).unwrap();
            assert_eq!(t, 2.0, "scale {scale}");
            assert!(
                (u - 0.25).abs() < 1e-6 && (v - 0.25).abs() < 1e-6,
                "{u} {v}"
            );
            let miss = Ray::infinite(Vec3::new(0.75, 0.75, -2.0) * scale, Vec3::Z * scale);
            let tri = Triangle::new(Vec3::ZERO, Vec3::X * scale, Vec3::Y * scale);
            assert!(tri.intersect(&miss, 0.0, f32::INFINITY).is_none());
        }
    }

    #[test]
    fn tie_break_prefers_smaller_index() {
        let a = Hit {
            t: 1.0,
            prim: 3,
            u: 0.0,
            v: 0.0,
        };
        let b = Hit {
            t: 1.0,
            prim: 2,
            u: 0.0,
            v: 0.0,
        };
        assert!(b.beats(&Some(a)));
        assert!(!a.beats(&Some(b)));
        assert!(a.beats(&None));
    }
}
