//! raytree: ray-tracing acceleration structures, built from one canonical BVH,
//! traversed by several algorithms and checked against one brute-force oracle.
//!
//! The data path: a [`scene::Scene`] (mesh + camera) gives triangles; a
//! [`bvh::Bvh`] is built over them; layouts in [`accel`] are derived from the
//! `Bvh`; every layout answers [`accel::Accel`] (closest hit, any hit, bytes),
//! counting work through a [`stats::Stats`] sink that costs nothing when off.
//!
//! ```
//! use raytree::prelude::*;
//! let scene = Scene::builtin("chess:2000").unwrap();
//! let bvh = Bvh::build(&scene.triangles, &BuildOptions::sah());
//! let layout = BinaryBvh::from_bvh(&bvh, scene.triangles.clone()).unwrap();
//! let ray = scene.camera.ray(0.5, 0.5, 1.0);
//! let hit = layout.closest_hit(&ray, &mut NoStats);
//! assert_eq!(hit, BruteForce::new(scene.triangles.clone()).closest_hit(&ray, &mut NoStats));
//! ```

pub mod accel;
pub mod bvh;
pub mod error;
pub mod fuzzing;
pub mod geometry;
pub mod names;
pub mod rayfile;
pub mod render;
pub mod rng;
pub mod scene;
pub mod stats;
pub mod traversal;

/// The names most programs need.
pub mod prelude {
    pub use crate::accel::{Accel, BinaryBvh, BruteForce};
    pub use crate::bvh::{BuildOptions, Builder, Bvh};
    pub use crate::error::Error;
    pub use crate::geometry::{Aabb, Hit, Ray, Triangle};
    pub use crate::scene::{Camera, Mesh, Scene};
    pub use crate::stats::{Counters, NoStats, Stats, VisitLog};
    pub use glam::Vec3;
}
