use glam::{BVec4A, Vec3, Vec4};

/// The largest coordinate magnitude raytree accepts for a vertex or a ray
/// origin: 2¹²⁶ (about 8.5e37), so that the difference of two coordinates
/// (at most 2¹²⁷) never overflows f32.
pub const COORDINATE_LIMIT: f32 = (1u128 << 126) as f32;

/// The smallest largest-component magnitude of a ray direction: 2⁻¹⁰⁰
/// (about 7.9e-31). [`Ray::new`] reads a subnormal direction component
/// (below 2⁻¹²⁶, whose reciprocal overflows f32) as a zero of its sign;
/// with the largest component at least 2⁻¹⁰⁰ that turns the direction by
/// less than 2⁻²⁶, below the 2⁻²⁴ resolution of f32 itself.
pub const DIRECTION_MIN: f32 = 1.0 / (1u128 << 100) as f32;

/// The largest component magnitude of a ray direction: 2¹²⁶, so that its
/// reciprocal is a normal f32.
pub const DIRECTION_MAX: f32 = COORDINATE_LIMIT;

/// A ray `origin + t * direction` for `t` in `[tmin, tmax]`.
///
/// The direction may have any length (it is not normalized: `t` is measured in
/// units of it). The constructor precomputes what every traversal needs: the
/// reciprocal direction, and the shear of the watertight triangle test.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ray {
    origin: Vec3,
    direction: Vec3,
    /// Start of the valid interval.
    pub tmin: f32,
    /// End of the valid interval; hits beyond it are ignored.
    pub tmax: f32,
    inv_direction: Vec3,
    /// Watertight test: the axis of largest |direction| (kz) and the two
    /// others. Bytes, not `usize`: the ray is 60 bytes instead of 80, which
    /// a chunk of rays built before tracing stores and reads back.
    pub(crate) k: [u8; 3],
    /// Watertight test: shear constants (Sx, Sy, Sz).
    pub(crate) shear: Vec3,
}

/// The watertight test's axis `kz`: the first axis of the largest direction
/// magnitude (`x_largest`: |x| ≥ |y| and |x| ≥ |z|; `y_at_least_z`: |y| ≥
/// |z|), so that the choice is deterministic. Computed without branches:
/// random directions would mispredict them (a third of [`Ray::new`]'s time
/// on a batch of random rays).
#[inline(always)]
fn largest_axis(x_largest: bool, y_at_least_z: bool) -> usize {
    let not_x = !x_largest as usize;
    not_x + (not_x & !y_at_least_z as usize)
}

/// `[kx, ky, kz]`: `(kz + 1, kz + 2) mod 3`, swapped where the direction's
/// `kz` component is negative (so that the sheared triangle keeps its
/// winding), without branches.
#[inline(always)]
fn shear_axes(kz: usize, negative: bool) -> [usize; 3] {
    let (next, after) = ([1, 2, 0][kz], [2, 0, 1][kz]);
    let swap = (next ^ after) & (negative as usize).wrapping_neg();
    [next ^ swap, after ^ swap, kz]
}

impl Ray {
    /// A ray over `[tmin, tmax]`. A zero direction component gets an infinite
    /// reciprocal of the same sign (`1/+0 = +inf`, `1/-0 = -inf`), so slab
    /// tests give ±inf, or NaN only for an origin exactly on the plane, which
    /// the box tests ignore (see [`crate::geometry::Aabb::intersect`]).
    ///
    /// A ray that is not [`Self::is_valid`] (a NaN or infinite component, an
    /// origin beyond [`COORDINATE_LIMIT`], a direction outside
    /// [`DIRECTION_MIN`]..=[`DIRECTION_MAX`], a NaN bound, a negative `tmin`: the box tests rely on `tmin ≥ 0`, see
    /// [`crate::geometry::aabb::slab_reciprocals`]) gets the empty
    /// interval `[+inf, -inf]` and a finite stand-in for its direction's
    /// derived constants: every structure answers it with a miss at its root,
    /// in constant time.
    ///
    /// A subnormal direction component is read as a zero of its sign (see
    /// [`DIRECTION_MIN`]): [`Self::direction`] returns the direction traced.
    #[inline]
    pub fn new(origin: Vec3, direction: Vec3, tmin: f32, tmax: f32) -> Self {
        // Four lanes (the fourth a zero, read by no one): the subnormal
        // flush, the checks and the divisions each in one vector operation.
        // Division is correctly rounded lane by lane, so every constant is
        // the one three scalar divisions give, bit for bit.
        let d4 = Vec4::from((direction, 0.0));
        let tiny = d4.abs().cmplt(Vec4::splat(f32::MIN_POSITIVE));
        let d4 = Vec4::select(tiny, Vec4::ZERO.copysign(d4), d4);
        let direction = d4.truncate();
        // Without a branch: a ray that is not valid takes its derived
        // constants from the stand-in direction +z (selected lane by lane)
        // and the empty interval. One path keeps every field in registers
        // and each ray is stored once where the caller puts it; with an
        // early return the two paths met in a stack copy that was read
        // back at once (a failed store forward on every ray).
        let valid = Self::fast_valid(origin, d4, tmin, tmax);
        let dv = Vec4::select(BVec4A::splat(valid), d4, Vec4::new(0.0, 0.0, 1.0, 0.0));
        let inv_direction = (Vec4::ONE / dv).truncate();
        let a = dv.truncate().abs();
        let kz = largest_axis(a.x >= a.y && a.x >= a.z, a.y >= a.z);
        let d = dv.to_array();
        let [kx, ky, kz] = shear_axes(kz, d[kz] < 0.0);
        let shear = (Vec4::new(d[kx], d[ky], 1.0, 1.0) / Vec4::splat(d[kz])).truncate();
        Ray {
            origin,
            direction,
            tmin: if valid { tmin } else { f32::INFINITY },
            tmax: if valid { tmax } else { f32::NEG_INFINITY },
            inv_direction,
            k: [kx as u8, ky as u8, kz as u8],
            shear,
        }
    }

    /// Four rays from one `origin`, each [`Self::new`]`(origin, d[l], tmin,
    /// tmax)` bit for bit: [`Self::new4_lanes`] of the directions' lanes.
    #[inline]
    pub fn new4(origin: Vec3, d: [Vec3; 4], tmin: f32, tmax: f32) -> [Self; 4] {
        let axis = |a: usize| Vec4::from_array(d.map(|d| d[a]));
        Self::new4_lanes(origin, [axis(0), axis(1), axis(2)], tmin, tmax)
    }

    /// Four rays from one `origin` whose directions are given by axis, ray
    /// `l` pointing along `(d[0][l], d[1][l], d[2][l])`: each
    /// [`Self::new`] of that direction bit for bit, with the constants
    /// computed in four-lane vectors across the rays (three divisions for
    /// the reciprocals and two for the shears of all four; the third shear
    /// constant, `1/dz`, is the reciprocal on axis `kz`) and the shear's
    /// components chosen by lane masks rather than gathered through memory.
    /// Rays whose parts are not all valid are made one at a time by `new`.
    #[inline]
    pub fn new4_lanes(origin: Vec3, d: [Vec4; 3], tmin: f32, tmax: f32) -> [Self; 4] {
        // Subnormal components read as zeros of their sign, as in `new`.
        let flush = |v: Vec4| {
            let tiny = v.abs().cmplt(Vec4::splat(f32::MIN_POSITIVE));
            Vec4::select(tiny, Vec4::ZERO.copysign(v), v)
        };
        let [x, y, z] = d.map(flush);
        let (ax, ay, az) = (x.abs(), y.abs(), z.abs());
        let limit = Vec4::splat(DIRECTION_MAX);
        let valid = Vec4::from((origin, 0.0))
            .abs()
            .cmple(Vec4::splat(COORDINATE_LIMIT))
            .all()
            & (ax.cmple(limit) & ay.cmple(limit) & az.cmple(limit)).all()
            & ax.max(ay).max(az).cmpge(Vec4::splat(DIRECTION_MIN)).all()
            & (tmin >= 0.0)
            & !tmax.is_nan();
        let lanes = [x.to_array(), y.to_array(), z.to_array()];
        let dir = |l: usize| Vec3::new(lanes[0][l], lanes[1][l], lanes[2][l]);
        if !valid {
            // `new` flushes again, which changes nothing.
            return std::array::from_fn(|l| Self::new(origin, dir(l), tmin, tmax));
        }
        let inv4 = [Vec4::ONE / x, Vec4::ONE / y, Vec4::ONE / z];
        let inv = inv4.map(|v| v.to_array());
        // kz: the first axis of the largest magnitude, as in `new`.
        let kz0 = ax.cmpge(ay) & ax.cmpge(az);
        let kz1 = ay.cmpge(az);
        let dz = Vec4::select(kz0, x, Vec4::select(kz1, y, z));
        // 1/dz is the reciprocal on axis kz, already divided.
        let inv_dz = Vec4::select(kz0, inv4[0], Vec4::select(kz1, inv4[1], inv4[2]));
        let neg4 = dz.cmplt(Vec4::ZERO);
        // The shear's numerators d[kx], d[ky] (`shear_axes`): for kz = x
        // the pair (y, z), for kz = y (z, x), for kz = z (x, y), swapped
        // where d[kz] is negative.
        let by_kz = |on_x: Vec4, on_y: Vec4, on_z: Vec4| {
            Vec4::select(kz0, on_x, Vec4::select(kz1, on_y, on_z))
        };
        let next = by_kz(y, z, x);
        let after = by_kz(z, x, y);
        let sx = Vec4::select(neg4, after, next) / dz;
        let sy = Vec4::select(neg4, next, after) / dz;
        let (kz0, kz1, neg) = (kz0.bitmask(), kz1.bitmask(), neg4.bitmask());
        let shear = [sx, sy, inv_dz].map(|v| v.to_array());
        std::array::from_fn(|l| Ray {
            origin,
            direction: dir(l),
            tmin,
            tmax,
            inv_direction: Vec3::new(inv[0][l], inv[1][l], inv[2][l]),
            k: shear_axes(
                largest_axis(kz0 >> l & 1 != 0, kz1 >> l & 1 != 0),
                neg >> l & 1 != 0,
            )
            .map(|k| k as u8),
            shear: Vec3::new(shear[0][l], shear[1][l], shear[2][l]),
        })
    }

    /// [`Self::valid_parts`] of a flushed direction (`d4`, fourth lane
    /// zero) in a few vector comparisons: every origin coordinate within
    /// the limit (NaN and infinities fail), every direction component
    /// within [`DIRECTION_MAX`] and the largest at least [`DIRECTION_MIN`],
    /// and no NaN bound.
    #[inline(always)]
    fn fast_valid(origin: Vec3, d4: Vec4, tmin: f32, tmax: f32) -> bool {
        let o4 = Vec4::from((origin, 0.0));
        let ad = d4.abs();
        o4.abs().cmple(Vec4::splat(COORDINATE_LIMIT)).all()
            & ad.cmple(Vec4::splat(DIRECTION_MAX)).all()
            & (ad.max_element() >= DIRECTION_MIN)
            & (tmin >= 0.0)
            & !tmax.is_nan()
    }

    /// A ray over `[0, +inf)`.
    pub fn infinite(origin: Vec3, direction: Vec3) -> Self {
        Self::new(origin, direction, 0.0, f32::INFINITY)
    }

    /// The origin, in scene units.
    pub fn origin(&self) -> Vec3 {
        self.origin
    }

    /// The direction traced (not normalized; subnormal components read as
    /// zeros, see [`Self::new`]).
    pub fn direction(&self) -> Vec3 {
        self.direction
    }

    /// `1 / direction`, with ±inf for zero components (never NaN).
    pub fn inv_direction(&self) -> Vec3 {
        self.inv_direction
    }

    /// The watertight test's axes `[kx, ky, kz]`: `kz` the axis of the
    /// largest |direction| component, `kx`, `ky` the other two (swapped for
    /// a negative `kz` component, to keep the winding).
    pub fn shear_axes(&self) -> [usize; 3] {
        self.k.map(usize::from)
    }

    /// The watertight test's shear constants `(Sx, Sy, Sz)`.
    pub fn shear(&self) -> Vec3 {
        self.shear
    }

    /// The point at parameter `t`.
    pub fn at(&self, t: f32) -> Vec3 {
        self.origin + self.direction * t
    }

    /// Whether the ray can be traced: every origin coordinate within
    /// ±[`COORDINATE_LIMIT`], a finite direction whose largest component
    /// magnitude lies in [`DIRECTION_MIN`]..=[`DIRECTION_MAX`], and an
    /// interval that is not NaN and starts at `tmin ≥ 0`. Rays that are not
    /// valid are answered with a miss (see [`Self::new`]; a `tmin` made
    /// negative after `new` misses at every structure's root).
    pub fn is_valid(&self) -> bool {
        // [+inf, -inf] is the mark `new` leaves on a ray that is not valid.
        Self::valid_parts(self.origin, self.direction, self.tmin, self.tmax)
            && !(self.tmin == f32::INFINITY && self.tmax == f32::NEG_INFINITY)
    }

    /// Whether `tmin` is at least 0 (false for NaN). The box tests are
    /// conservative only from there (see
    /// [`crate::geometry::aabb::slab_reciprocals`]); [`Self::new`] refuses
    /// other rays, but `tmin` is a public field a caller can change
    /// afterwards, so every structure's root test asks this too and misses
    /// such a ray.
    #[inline(always)]
    pub fn has_traceable_tmin(&self) -> bool {
        self.tmin >= 0.0
    }

    /// Why a ray made of these parts is not valid, in a few words, or `None`.
    pub fn invalid_reason(origin: Vec3, direction: Vec3, tmin: f32, tmax: f32) -> Option<String> {
        Fault::of(origin, direction, tmin, tmax).map(|f| f.to_string())
    }

    fn valid_parts(origin: Vec3, direction: Vec3, tmin: f32, tmax: f32) -> bool {
        Fault::of(origin, direction, tmin, tmax).is_none()
    }
}

/// Why a ray cannot be traced: the one check behind [`Ray::is_valid`] and
/// [`Ray::invalid_reason`].
#[derive(Clone, Copy, Debug, PartialEq)]
enum Fault {
    NonFinite,
    OriginOutOfRange,
    ZeroDirection,
    DirectionOutOfRange(f32),
    NanBound,
    NegativeTmin(f32),
}

impl Fault {
    fn of(origin: Vec3, direction: Vec3, tmin: f32, tmax: f32) -> Option<Fault> {
        let largest = direction.abs().max_element();
        if !origin.is_finite() || !direction.is_finite() {
            Some(Fault::NonFinite)
        } else if origin.abs().max_element() > COORDINATE_LIMIT {
            Some(Fault::OriginOutOfRange)
        } else if direction == Vec3::ZERO {
            Some(Fault::ZeroDirection)
        } else if !(DIRECTION_MIN..=DIRECTION_MAX).contains(&largest) {
            Some(Fault::DirectionOutOfRange(largest))
        } else if tmin.is_nan() || tmax.is_nan() {
            Some(Fault::NanBound)
        } else if tmin < 0.0 {
            Some(Fault::NegativeTmin(tmin))
        } else {
            None
        }
    }
}

impl std::fmt::Display for Fault {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Fault::NonFinite => f.write_str("a NaN or infinite origin or direction"),
            Fault::OriginOutOfRange => write!(
                f,
                "an origin coordinate beyond ±{COORDINATE_LIMIT:e} (2^126)"
            ),
            Fault::ZeroDirection => f.write_str("a zero direction"),
            Fault::DirectionOutOfRange(largest) => write!(
                f,
                "a direction whose largest component {largest:e} is outside [2^-100, 2^126]"
            ),
            Fault::NanBound => f.write_str("a NaN tmin or tmax"),
            Fault::NegativeTmin(t) => write!(
                f,
                "a negative tmin ({t:e}): the interval must start at the origin or after it"
            ),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The constructor as three scalar divisions per constant and the
    /// validity check of `valid_parts`: what `new` computes in vectors.
    fn scalar_new(origin: Vec3, direction: Vec3, tmin: f32, tmax: f32) -> Ray {
        let direction = Vec3::from_array(direction.to_array().map(|c| {
            if c.abs() < f32::MIN_POSITIVE {
                0.0f32.copysign(c)
            } else {
                c
            }
        }));
        if !Ray::valid_parts(origin, direction, tmin, tmax) {
            let mut ray = scalar_new(Vec3::ZERO, Vec3::Z, f32::INFINITY, f32::NEG_INFINITY);
            ray.origin = origin;
            ray.direction = direction;
            return ray;
        }
        let a = direction.abs();
        let kz = if a.x >= a.y && a.x >= a.z {
            0
        } else if a.y >= a.z {
            1
        } else {
            2
        };
        let mut kx = (kz + 1) % 3;
        let mut ky = (kx + 1) % 3;
        if direction[kz] < 0.0 {
            std::mem::swap(&mut kx, &mut ky);
        }
        Ray {
            origin,
            direction,
            tmin,
            tmax,
            inv_direction: Vec3::new(1.0 / direction.x, 1.0 / direction.y, 1.0 / direction.z),
            k: [kx as u8, ky as u8, kz as u8],
            shear: Vec3::new(
                direction[kx] / direction[kz],
                direction[ky] / direction[kz],
                1.0 / direction[kz],
            ),
        }
    }

    fn bits(r: &Ray) -> Vec<u32> {
        let v = |v: Vec3| v.to_array().map(f32::to_bits);
        let mut b = Vec::new();
        b.extend(v(r.origin));
        b.extend(v(r.direction));
        b.extend([r.tmin.to_bits(), r.tmax.to_bits()]);
        b.extend(v(r.inv_direction));
        b.extend(r.k.map(|k| k as u32));
        b.extend(v(r.shear));
        b
    }

    /// Random rays of every scale and the edge values (zeros of both signs,
    /// subnormals, the limits and one step past them, infinities, NaN):
    /// the vector constructor's every field equals the scalar one's, bit
    /// for bit, and both agree on validity.
    #[test]
    fn vector_constructor_equals_the_scalar_one() {
        let mut rng = crate::rng::Pcg32::new(11, 5);
        let edge = [
            0.0,
            -0.0,
            1e-45,
            -1e-39,
            f32::MIN_POSITIVE,
            DIRECTION_MIN,
            DIRECTION_MIN * 0.5,
            DIRECTION_MAX,
            DIRECTION_MAX * 2.0,
            COORDINATE_LIMIT,
            -COORDINATE_LIMIT * 1.5,
            f32::INFINITY,
            f32::NEG_INFINITY,
            f32::NAN,
            1.0,
            -3.5,
        ];
        let mut valid = 0;
        for case in 0..20000 {
            let mut c = || {
                if rng.next_f32() < 0.15 {
                    edge[(rng.next_u32() as usize) % edge.len()]
                } else {
                    let e = (rng.next_f32() * 80.0 - 40.0) as i32;
                    (rng.next_f32() * 2.0 - 1.0) * 2f32.powi(e)
                }
            };
            let (o, d) = (Vec3::new(c(), c(), c()), Vec3::new(c(), c(), c()));
            let (t0, t1) = (c(), c());
            let (a, b) = (Ray::new(o, d, t0, t1), scalar_new(o, d, t0, t1));
            assert_eq!(bits(&a), bits(&b), "case {case}: {o} {d} {t0} {t1}");
            assert_eq!(a.is_valid(), b.is_valid());
            valid += a.is_valid() as u32;
        }
        assert!(valid > 5000 && valid < 19000, "{valid} valid rays");
    }

    /// Four rays at once equal four made one at a time, bit for bit: random
    /// directions of every scale, ties between component magnitudes (the
    /// first largest is kz), zeros of both signs, subnormals, and lanes
    /// that are not valid (the whole group then made one at a time).
    #[test]
    fn four_rays_at_once_equal_four_made_one_at_a_time() {
        let mut rng = crate::rng::Pcg32::new(3, 9);
        let edge = [
            0.0,
            -0.0,
            1e-40,
            -1e-39,
            1.0,
            -1.0,
            2.0,
            DIRECTION_MIN * 0.5,
            f32::NAN,
        ];
        let mut groups_valid = 0;
        for case in 0..20000 {
            let mut c = |k: u32| {
                let x = rng.next_f32();
                if x < 0.03 * k as f32 {
                    edge[(rng.next_u32() as usize) % edge.len()]
                } else {
                    let e = (rng.next_f32() * 40.0 - 20.0) as i32;
                    (rng.next_f32() * 2.0 - 1.0) * 2f32.powi(e)
                }
            };
            let k = case % 4;
            let o = Vec3::new(c(0), c(0), c(0)) * 100.0;
            let d: [Vec3; 4] = std::array::from_fn(|_| Vec3::new(c(k), c(k), c(k)));
            let (t0, t1) = if case % 97 == 0 {
                (f32::NAN, 1.0)
            } else {
                (1e-3, 32.0)
            };
            let four = Ray::new4(o, d, t0, t1);
            for l in 0..4 {
                let one = Ray::new(o, d[l], t0, t1);
                assert_eq!(
                    bits(&four[l]),
                    bits(&one),
                    "case {case} lane {l}: {o} {} ",
                    d[l]
                );
            }
            groups_valid += four.iter().all(Ray::is_valid) as u32;
        }
        assert!(
            groups_valid > 5000 && groups_valid < 19000,
            "{groups_valid}"
        );
    }

    #[test]
    fn zero_components_give_signed_infinite_reciprocals() {
        let r = Ray::infinite(Vec3::ZERO, Vec3::new(0.0, -0.0, 2.0));
        assert_eq!(r.inv_direction().x, f32::INFINITY);
        assert_eq!(r.inv_direction().y, f32::NEG_INFINITY);
        assert_eq!(r.inv_direction().z, 0.5);
        assert!(!r.inv_direction().is_nan());
    }

    #[test]
    fn a_ray_is_sixty_bytes() {
        // Fifteen 4-byte words' worth: eleven floats, three axis bytes and
        // a pad byte. Batches store rays before tracing them; a larger ray
        // is a measured cost there (Ray::k's comment).
        assert_eq!(std::mem::size_of::<Ray>(), 60);
    }

    #[test]
    fn shear_axis_is_the_largest_component() {
        let r = Ray::infinite(Vec3::ZERO, Vec3::new(0.1, -3.0, 2.0));
        assert_eq!(r.k[2], 1);
        // Negative kz swaps kx and ky to keep the winding.
        assert_eq!([r.k[0], r.k[1]], [0, 2]);
    }

    #[test]
    fn validity() {
        assert!(Ray::infinite(Vec3::ONE, Vec3::X).is_valid());
        assert!(!Ray::infinite(Vec3::ONE, Vec3::ZERO).is_valid());
        assert!(!Ray::infinite(Vec3::NAN, Vec3::X).is_valid());
        assert!(!Ray::infinite(Vec3::ONE, Vec3::new(1.0, f32::INFINITY, 0.0)).is_valid());
        assert!(!Ray::infinite(Vec3::X * 1e38, Vec3::X).is_valid());
        assert!(Ray::infinite(Vec3::X * 8e37, Vec3::X).is_valid());
        assert!(!Ray::infinite(Vec3::ONE, Vec3::X * 1e-31).is_valid());
        assert!(Ray::infinite(Vec3::ONE, Vec3::new(1e-30, 1e-45, 0.0)).is_valid());
        // Subnormal components are read as zeros of their sign.
        let r = Ray::infinite(Vec3::ONE, Vec3::new(1.0, 1e-39, -1e-45));
        assert_eq!(
            r.direction().to_array().map(f32::to_bits),
            [1.0f32, 0.0, -0.0].map(f32::to_bits)
        );
        assert_eq!(r.inv_direction().y, f32::INFINITY);
        assert!(!Ray::infinite(Vec3::ONE, Vec3::X * 1e38).is_valid());
        assert!(!Ray::new(Vec3::ONE, Vec3::X, f32::NAN, 1.0).is_valid());
        for (o, d) in [
            (Vec3::NAN, Vec3::X),
            (Vec3::ONE, Vec3::ZERO),
            (Vec3::ONE, Vec3::NAN),
        ] {
            let r = Ray::infinite(o, d);
            assert!(Ray::invalid_reason(o, d, 0.0, f32::INFINITY).is_some());
            // The empty interval, and finite derived constants.
            assert!(r.tmin > r.tmax);
            assert!(!r.inv_direction().is_nan() && r.shear.is_finite());
            assert!(r.origin().is_nan() == o.is_nan());
        }
        assert_eq!(Ray::invalid_reason(Vec3::ONE, Vec3::X, 0.0, 1.0), None);
    }
}
