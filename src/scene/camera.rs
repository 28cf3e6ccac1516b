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

    /// The ray through image point (`x`, `y`) in `[0,1]²`, `y` down, for an
    /// image of width/height `aspect`. Directions are normalized.
    pub fn ray(&self, x: f32, y: f32, aspect: f32) -> Ray {
        let forward = (self.target - self.eye).normalize();
        let right = forward.cross(self.up).normalize();
        let up = right.cross(forward);
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
    fn framing_sees_the_box() {
        let b = Aabb::new(Vec3::splat(-1.0), Vec3::splat(1.0));
        let c = Camera::framing(&b);
        let r = c.ray(0.5, 0.5, 1.0);
        assert!(b.intersect(&r, f32::INFINITY).is_some());
    }
}
