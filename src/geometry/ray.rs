use glam::Vec3;

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
    /// Watertight test: the axis of largest |direction| (kz) and the two others.
    pub(crate) k: [usize; 3],
    /// Watertight test: shear constants (Sx, Sy, Sz).
    pub(crate) shear: Vec3,
}

impl Ray {
    /// A ray over `[tmin, tmax]`. A zero direction component gets an infinite
    /// reciprocal of the same sign (`1/+0 = +inf`, `1/-0 = -inf`), so slab
    /// tests give ±inf, or NaN only for an origin exactly on the plane, which
    /// the box tests ignore (see [`crate::geometry::Aabb::intersect`]).
    pub fn new(origin: Vec3, direction: Vec3, tmin: f32, tmax: f32) -> Self {
        let inv_direction = Vec3::ONE / direction;
        let a = direction.abs();
        // First maximum, so that the choice is deterministic.
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
        let shear = Vec3::new(
            direction[kx] / direction[kz],
            direction[ky] / direction[kz],
            1.0 / direction[kz],
        );
        Ray {
            origin,
            direction,
            tmin,
            tmax,
            inv_direction,
            k: [kx, ky, kz],
            shear,
        }
    }

    /// A ray over `[0, +inf)`.
    pub fn infinite(origin: Vec3, direction: Vec3) -> Self {
        Self::new(origin, direction, 0.0, f32::INFINITY)
    }

    pub fn origin(&self) -> Vec3 {
        self.origin
    }

    pub fn direction(&self) -> Vec3 {
        self.direction
    }

    /// `1 / direction`, with ±inf for zero components (never NaN).
    pub fn inv_direction(&self) -> Vec3 {
        self.inv_direction
    }

    /// The point at parameter `t`.
    pub fn at(&self, t: f32) -> Vec3 {
        self.origin + self.direction * t
    }

    /// Whether the ray can be traced: finite origin and direction, a non-zero
    /// direction and an interval that is not NaN.
    pub fn is_valid(&self) -> bool {
        self.origin.is_finite()
            && self.direction.is_finite()
            && self.direction != Vec3::ZERO
            && !self.tmin.is_nan()
            && !self.tmax.is_nan()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn zero_components_give_signed_infinite_reciprocals() {
        let r = Ray::infinite(Vec3::ZERO, Vec3::new(0.0, -0.0, 2.0));
        assert_eq!(r.inv_direction().x, f32::INFINITY);
        assert_eq!(r.inv_direction().y, f32::NEG_INFINITY);
        assert_eq!(r.inv_direction().z, 0.5);
        assert!(!r.inv_direction().is_nan());
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
    }
}
