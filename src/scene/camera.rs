use crate::geometry::{Aabb, Ray};
use glam::Vec3;

/// A pinhole camera.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Camera {
    pub eye: Vec3,
    pub target: Vec3,
    pub up: Vec3,
    /// Vertical field of view in degrees.
    pub fov_y: f32,
}

impl Camera {
    pub fn new(eye: Vec3, target: Vec3, up: Vec3, fov_y: f32) -> Self {
        Camera {
            eye,
            target,
            up,
            fov_y,
        }
    }

    /// A camera looking at the box's center from above and to one side,
    /// far enough that its bounding sphere fills the view.
    pub fn framing(bounds: &Aabb) -> Self {
        let center = bounds.center();
        let radius = (bounds.extent().length() * 0.5).max(1e-6);
        let fov_y: f32 = 45.0;
        let dist = radius / (fov_y.to_radians() * 0.5).sin();
        let dir = Vec3::new(0.55, 0.45, 0.7).normalize();
        Camera::new(center + dir * dist, center, Vec3::Y, fov_y)
    }

    /// The view's orthonormal basis `(forward, right, up)`. When the view
    /// runs along `up` (or `up` is zero), the image's up is taken from the
    /// world axis least aligned with the view instead (+Z when looking along
    /// ±Y with `up` = +Y, so a top view has +Z at the top of the image), so
    /// that every camera has a valid basis.
    pub fn basis(&self) -> (Vec3, Vec3, Vec3) {
        let forward = (self.target - self.eye).normalize();
        let mut right = forward.cross(self.up);
        // sin² of the angle between the view and up below ~1e-10.
        if !(right.length_squared() > 1e-10 * self.up.length_squared()) {
            let f = forward.abs();
            let axis = if f.z <= f.x && f.z <= f.y {
                Vec3::Z
            } else if f.x <= f.y {
                Vec3::X
            } else {
                Vec3::Y
            };
            right = forward.cross(axis);
        }
        let right = right.normalize();
        (forward, right, right.cross(forward))
    }

    /// The ray through image point (`x`, `y`) in `[0,1]²`, `y` down, for an
    /// image of width/height `aspect`. Directions are normalized.
    ///
    /// A camera whose `eye` equals its `target`, or with a non-finite
    /// component, gives rays that are not valid: every structure answers
    /// them with a miss (see [`Ray::new`]).
    pub fn ray(&self, x: f32, y: f32, aspect: f32) -> Ray {
        let (forward, right, up) = self.basis();
        let h = (self.fov_y.to_radians() * 0.5).tan();
        let px = (2.0 * x - 1.0) * h * aspect;
        let py = (1.0 - 2.0 * y) * h;
        Ray::infinite(self.eye, (forward + right * px + up * py).normalize())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn center_ray_looks_at_target() {
        let c = Camera::new(Vec3::new(0.0, 0.0, 5.0), Vec3::ZERO, Vec3::Y, 60.0);
        let r = c.ray(0.5, 0.5, 1.5);
        assert!((r.direction() - -Vec3::Z).length() < 1e-6);
        // Top of the image looks up.
        assert!(c.ray(0.5, 0.0, 1.0).direction().y > 0.0);
        assert!(c.ray(1.0, 0.5, 1.0).direction().x > 0.0);
    }

    #[test]
    fn a_view_along_up_gets_a_valid_basis() {
        for (eye, up) in [
            (Vec3::new(0.0, 500.0, 0.0), Vec3::Y),
            (Vec3::new(0.0, -500.0, 0.0), Vec3::Y),
            (Vec3::new(0.0, 0.0, 3.0), Vec3::Z),
            (Vec3::new(2.0, 0.0, 0.0), Vec3::ZERO),
        ] {
            let c = Camera::new(eye, Vec3::ZERO, up, 50.0);
            let (f, r, u) = c.basis();
            for v in [f, r, u] {
                assert!((v.length() - 1.0).abs() < 1e-6, "{eye} {up}: {v}");
            }
            assert!(f.dot(r).abs() < 1e-6 && f.dot(u).abs() < 1e-6 && r.dot(u).abs() < 1e-6);
            assert!((f + eye.normalize()).length() < 1e-6);
            for (x, y) in [(0.0, 0.0), (0.5, 0.5), (1.0, 0.3)] {
                let ray = c.ray(x, y, 1.5);
                assert!(ray.is_valid(), "{eye} {up} {x} {y}");
            }
        }
        // Looking straight down with +Y up: +Z at the top of the image.
        let c = Camera::new(Vec3::new(0.0, 500.0, 0.0), Vec3::ZERO, Vec3::Y, 50.0);
        assert!(c.basis().2.z > 0.99);
        // An ordinary view keeps its basis exactly as before.
        let c = Camera::new(Vec3::new(0.0, 0.0, 5.0), Vec3::ZERO, Vec3::Y, 60.0);
        assert_eq!(c.basis().2, Vec3::Y);
    }

    #[test]
    fn a_camera_at_its_target_gives_invalid_rays() {
        let c = Camera::new(Vec3::ONE, Vec3::ONE, Vec3::Y, 50.0);
        assert!(!c.ray(0.5, 0.5, 1.0).is_valid());
    }

    #[test]
    fn framing_sees_the_box() {
        let b = Aabb::new(Vec3::splat(-1.0), Vec3::splat(1.0));
        let c = Camera::framing(&b);
        let r = c.ray(0.5, 0.5, 1.0);
        assert!(b.intersect(&r, f32::INFINITY).is_some());
    }
}
