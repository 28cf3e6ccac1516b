//! Acceleration structures: every one is derived from the canonical
//! [`crate::bvh::Bvh`] (or, for the oracle, from nothing) and answers
//! [`Accel`].

mod batch;
pub mod bih;
pub(crate) mod binary_bvh;
mod brute;
pub mod cbvh;
pub mod dst;
pub mod htree;
pub mod implicit_bvh;
pub(crate) mod own_box_node;
mod select;
pub mod sparse_bvh;

pub use batch::{tracer, Tracer};
pub use bih::Bih;
pub use binary_bvh::BinaryBvh;
pub use brute::BruteForce;
pub use cbvh::CompactBvh;
pub use dst::DualSplitTree;
pub use htree::HTree;
pub use implicit_bvh::ImplicitBvh;
pub use select::{
    check, Built, LayoutOptions, StructureInfo, StructureKind, TraversalKind, WithAccel,
};
pub use sparse_bvh::SparseBvh;

use crate::geometry::{Hit, Ray};
use crate::stats::Stats;

/// What every structure answers. The statistics sink is a generic parameter,
/// so that tracing with [`crate::stats::NoStats`] compiles the counting away.
pub trait Accel: Send + Sync {
    /// The structure's name as the command line spells it (`bvh`, `brute`).
    fn name(&self) -> &'static str;

    /// Bytes of the structure itself: nodes and triangle index lists, not the
    /// triangles, which every structure shares.
    fn bytes(&self) -> usize;

    /// The nearest hit within `[ray.tmin, ray.tmax]`; on equal distances, the
    /// smaller triangle index (see [`Hit::beats`]).
    fn closest_hit<S: Stats>(&self, ray: &Ray, stats: &mut S) -> Option<Hit>;

    /// Some hit within `[ray.tmin, ray.tmax]`; the first one found ends the
    /// search.
    fn any_hit<S: Stats>(&self, ray: &Ray, stats: &mut S) -> Option<Hit>;
}
