//! Rays, boxes and the watertight ray-triangle test.

pub(crate) mod aabb;
mod precise;
mod ray;
mod triangle;

pub use aabb::{Aabb, BoxRay, ROBUST_WIDENING, WIDENING_STEP};
pub use ray::{Ray, COORDINATE_LIMIT, DIRECTION_MAX, DIRECTION_MIN};
pub use triangle::{Hit, Triangle, ILL_CONDITIONED, TINY_DETERMINANT, TINY_SCALE};
