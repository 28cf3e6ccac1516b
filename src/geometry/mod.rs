//! Rays, boxes and the watertight ray-triangle test.

pub(crate) mod aabb;
mod ray;
mod triangle;

pub use aabb::{Aabb, BoxRay};
pub use ray::Ray;
pub use triangle::{Hit, Triangle};
