use crate::geometry::{Aabb, Ray};
use glam::Vec3;

/// The camera's field of view: which angle it gives, and how the image's
/// other extent follows from it.
///
/// The image plane lies at distance 1 along the view; its half extents are
/// `ex` across and `ey` down, and image point (`x`, `y`) in `[0,1]²` looks
/// along `forward + right·ex·(2x−1) + up·ey·(1−2y)`.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
#[serde(tag = "kind", content = "degrees", rename_all = "kebab-case")]
pub enum Fov {
    /// The vertical angle in degrees, square pixels:
    /// `ey = tan(angle/2)`, `ex = ey · width/height`.
    Vertical(f32),
    /// The horizontal angle in degrees, square pixels:
    /// `ex = tan(angle/2)`, `ey = ex · height/width`.
    Horizontal(f32),
    /// The stackless paper's tracer (Barringer & Akenine-Möller 2013,
    /// Section 4 and its supplemental code, `Camera::lookAt`): the angle in
    /// degrees is horizontal, and the vertical extent scales the *angle* by
    /// the image's height/width, so pixels are not square unless the image
    /// is: `ex = tan(angle/2)`, `ey = tan(angle/2 · height/width)`. Its
    /// 50° at 800×300 gives 50° across and about 18.75° down.
    Paper(f32),
}

impl Fov {
    /// The angle in degrees, whichever way it is measured.
    pub fn degrees(self) -> f32 {
        match self {
            Fov::Vertical(a) | Fov::Horizontal(a) | Fov::Paper(a) => a,
        }
    }

    /// The image plane's half extents `(ex, ey)` at distance 1 (tangents of
    /// the half angles across and down) for an image of width/height
    /// `aspect`.
    pub fn extents(self, aspect: f32) -> (f32, f32) {
        match self {
            Fov::Vertical(a) => {
                let h = (a.to_radians() * 0.5).tan();
                (h * aspect, h)
            }
            Fov::Horizontal(a) => {
                let w = (a.to_radians() * 0.5).tan();
                (w, w / aspect)
            }
            Fov::Paper(a) => {
                // As the original: the half angle scaled by height/width in
                // single precision, the tangent taken in double precision.
                let rad = std::f64::consts::PI / 180.0;
                let ex = ((0.5 * a) as f64 * rad).tan() as f32;
                let ey = ((0.5 * a * (1.0 / aspect)) as f64 * rad).tan() as f32;
                (ex, ey)
            }
        }
    }

    /// Whether a camera can have this angle on an image of width/height
    /// `aspect`: the angle finite and in (0, 180) degrees, and both extents
    /// finite and positive (a [`Fov::Paper`] angle scaled by a tall image's
    /// height/width can reach 180°).
    pub fn is_valid(self, aspect: f32) -> bool {
        let a = self.degrees();
        let (ex, ey) = self.extents(aspect);
        let scaled = match self {
            Fov::Paper(a) => a / aspect,
            _ => a,
        };
        a.is_finite()
            && a > 0.0
            && a < 180.0
            && scaled < 180.0
            && ex.is_finite()
            && ey.is_finite()
            && ex > 0.0
            && ey > 0.0
    }
}

/// A pinhole camera.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Camera {
    /// Position, in scene units.
    pub eye: Vec3,
    /// The point the view's centre passes through, in scene units.
    pub target: Vec3,
    /// The image's up direction (any length but zero).
    pub up: Vec3,
    /// The field of view and how it maps to the image.
    pub fov: Fov,
}

impl serde::Serialize for Camera {
    fn serialize<S: serde::Serializer>(&self, ser: S) -> Result<S::Ok, S::Error> {
        #[derive(serde::Serialize)]
        struct View {
            eye: [f32; 3],
            target: [f32; 3],
            up: [f32; 3],
            fov: Fov,
        }
        View {
            eye: self.eye.to_array(),
            target: self.target.to_array(),
            up: self.up.to_array(),
            fov: self.fov,
        }
        .serialize(ser)
    }
}

impl std::fmt::Display for Fov {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Fov::Vertical(a) => write!(f, "{a}° vertical, square pixels"),
            Fov::Horizontal(a) => write!(f, "{a}° horizontal, square pixels"),
            Fov::Paper(a) => write!(
                f,
                "{a}° horizontal, the stackless paper's non-square pixels"
            ),
        }
    }
}

impl std::fmt::Display for Camera {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let v = |v: Vec3| format!("({}, {}, {})", v.x, v.y, v.z);
        write!(
            f,
            "eye {} towards {}, up {}, {}",
            v(self.eye),
            v(self.target),
            v(self.up),
            self.fov
        )
    }
}

impl Camera {
    /// A camera with square pixels and a vertical field of view of `fov_y`
    /// degrees.
    pub fn new(eye: Vec3, target: Vec3, up: Vec3, fov_y: f32) -> Self {
        Camera {
            eye,
            target,
            up,
            fov: Fov::Vertical(fov_y),
        }
    }

    /// The stackless paper's camera for its CHESS scene (Barringer &
    /// Akenine-Möller 2013, Section 4; the supplemental tracer's `main.cpp`):
    /// eye (300, 100, 300) towards (0, 10, 0), up +Y, [`Fov::Paper`] of 50°
    /// (horizontal, non-square pixels; 800×300 in the paper).
    pub fn stackless_chess() -> Self {
        Camera {
            eye: Vec3::new(300.0, 100.0, 300.0),
            target: Vec3::new(0.0, 10.0, 0.0),
            up: Vec3::Y,
            fov: Fov::Paper(50.0),
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
        // Not greater, or NaN: the fallback.
        let valid = matches!(
            right
                .length_squared()
                .partial_cmp(&(1e-10 * self.up.length_squared())),
            Some(std::cmp::Ordering::Greater)
        );
        if !valid {
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
    /// image of width/height `aspect`: the direction
    /// `forward + right·ex·(2x−1) + up·ey·(1−2y)` normalized, with `(ex, ey)`
    /// from [`Fov::extents`]. Pixel `(i, j)` of a `w`×`h` image covers
    /// `x` in `[i/w, (i+1)/w)` and `y` in `[j/h, (j+1)/h)`, as in the stackless
    /// paper's tracer (its pixel `px` in `[0, w)` is `x·w`).
    ///
    /// A camera whose `eye` equals its `target`, or with a non-finite
    /// component, gives rays that are not valid: every structure answers
    /// them with a miss (see [`Ray::new`]).
    pub fn ray(&self, x: f32, y: f32, aspect: f32) -> Ray {
        self.projection(aspect).ray(x, y)
    }

    /// What [`Self::ray`] derives from the camera for an image of
    /// width/height `aspect` (the basis, the extents), computed once, for
    /// renders that make many rays: [`Projection::ray`] gives the same rays
    /// bit for bit.
    pub fn projection(&self, aspect: f32) -> Projection {
        let (forward, right, up) = self.basis();
        // `ex · ex_scale` in that order: the vertical angle's form, `h·aspect`
        // applied after the pixel coordinate, as before the other kinds
        // existed, so that images stay bit-identical (times 1 for the others).
        let (ex, ex_scale, ey) = match self.fov {
            Fov::Vertical(a) => {
                let h = (a.to_radians() * 0.5).tan();
                (h, aspect, h)
            }
            fov => {
                let (ex, ey) = fov.extents(aspect);
                (ex, 1.0, ey)
            }
        };
        Projection {
            eye: self.eye,
            forward,
            right,
            up,
            ex,
            ex_scale,
            ey,
        }
    }
}

/// A camera's rays for one image shape ([`Camera::projection`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Projection {
    eye: Vec3,
    forward: Vec3,
    right: Vec3,
    up: Vec3,
    ex: f32,
    ex_scale: f32,
    ey: f32,
}

impl Projection {
    /// [`Camera::ray`] through image point (`x`, `y`) in `[0,1]²`, `y` down.
    #[inline]
    pub fn ray(&self, x: f32, y: f32) -> Ray {
        self.ray_over(x, y, 0.0, f32::INFINITY)
    }

    /// [`Self::ray`] over `[tmin, tmax]` rather than `[0, +inf)`.
    #[inline]
    pub fn ray_over(&self, x: f32, y: f32, tmin: f32, tmax: f32) -> Ray {
        let px = (2.0 * x - 1.0) * self.ex * self.ex_scale;
        let py = (1.0 - 2.0 * y) * self.ey;
        let d = (self.forward + self.right * px + self.up * py).normalize();
        Ray::new(self.eye, d, tmin, tmax)
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
