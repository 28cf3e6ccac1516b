//! Rays, boxes and the watertight ray-triangle test.

mod aabb;
mod ray;
mod triangle;

pub use aabb::{Aabb, BoxRay};
pub use ray::Ray;
pub use triangle::{Hit, Triangle};
