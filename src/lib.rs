//! raytree: ray-tracing acceleration structures, built from one canonical BVH,
//! traversed by several algorithms and checked against one brute-force oracle.
//!
//! The data path: a [`scene::Scene`] (mesh + camera) gives triangles; a
//! [`bvh::Bvh`] is built over them; layouts in [`structures`] are derived from the
//! `Bvh`; every layout answers [`structures::Accel`] (closest hit, any hit, bytes),
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
//!
//! A structure chosen by name at run time traces batches in parallel
//! through [`structures::Tracer`] (see also `examples/batch.rs`):
//!
//! ```
//! use raytree::prelude::*;
//! let scene = Scene::from_spec("chess:2000").unwrap();
//! let bvh = Bvh::build(&scene.triangles, &BuildOptions::sah());
//! let tracer = raytree::structures::tracer("bvh/laine-4", &bvh, scene.triangles.clone()).unwrap();
//! let rays: Vec<Ray> = (0..1000).map(|i| scene.camera.ray(i as f32 / 1000.0, 0.6, 1.0)).collect();
//! let (mut hits, mut occluded) = (vec![None; rays.len()], vec![false; rays.len()]);
//! tracer.intersect(&rays, &mut hits, None).unwrap();
//! tracer.occluded(&rays, &mut occluded, None).unwrap();
//! assert!(hits.iter().zip(&occluded).all(|(h, &o)| h.is_some() == o));
//! ```

#![deny(missing_docs)]

pub mod bvh;
pub mod error;
pub mod fuzzing;
pub mod geometry;
pub mod meter;
pub mod names;
pub mod pages;
pub mod par;
pub mod rayfile;
pub mod render;
pub mod rng;
pub mod saved;
pub mod scene;
pub mod stats;
pub mod structures;

/// The names most programs need.
pub mod prelude {
    pub use crate::bvh::{BuildOptions, Builder, Bvh};
    pub use crate::error::Error;
    pub use crate::geometry::{Aabb, Hit, Ray, Triangle};
    pub use crate::scene::{Camera, Mesh, Scene};
    pub use crate::stats::{Counters, NoStats, Stats, VisitLog};
    pub use crate::structures::{tracer, Accel, BinaryBvh, BruteForce};
    pub use glam::Vec3;
}
