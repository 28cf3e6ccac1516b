//! raytree's structures traversed on the GPU: `wgpu` compute shaders in
//! WGSL over the very node words the CPU traverses, uploaded once per
//! structure.
//!
//! [`Gpu::new`] opens the first adapter (a real GPU, or Mesa's lavapipe
//! where there is none); [`GpuAccel::new`] uploads a [`raytree::structures::Built`] structure
//! (its node words, its sign-terminated leaf list, the mesh's triangles) and
//! builds the closest-hit and any-hit pipelines of its traversal;
//! [`GpuAccel::trace`] answers a batch of rays with the hit and each ray's
//! counters (nodes, plane tests, triangle tests).
//!
//! Each kernel mirrors its CPU kernel (`src/structures/<name>/`) step for
//! step, so that it visits the same nodes in the same order and reports the
//! same counters. The triangle test is the f32 path of the CPU's watertight
//! test, operation for operation; where the CPU's test leaves f32 (an edge
//! function exactly zero, an ill-conditioned or tiny triangle, an overflow:
//! its f64 and double-double paths), the kernel stops and marks the ray
//! *deferred*, and [`GpuAccel::trace`] traces that ray again on the CPU with
//! the same structure. [`Traced::deferred`] says how many.
//!
//! The kernels live in `src/wgsl/`: `prelude.wgsl` (bindings, ray, triangle
//! and slab tests, leaf test, counters) is concatenated before each
//! traversal's own file.

#![deny(missing_docs)]

mod accel;
mod device;
mod kernel;

pub use accel::{supported, GpuAccel, GpuAnswer, Query, Traced};
pub use device::{Gpu, REQUIRE_GPU_ENV};
pub use kernel::Kernel;

/// What can go wrong on the GPU side.
#[derive(Debug)]
pub enum GpuError {
    /// No adapter: no GPU and no software Vulkan driver (lavapipe).
    NoAdapter(String),
    /// The adapter refused a device with the limits the kernels need.
    Device(String),
    /// The structure or traversal has no GPU kernel.
    Unsupported(String),
    /// A structure or ray batch larger than the adapter's buffers.
    TooLarge(String),
    /// The GPU reported an error while building pipelines or tracing.
    Failed(String),
}

impl std::fmt::Display for GpuError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            GpuError::NoAdapter(why) => write!(f, "no GPU adapter found ({why})"),
            GpuError::Device(why) => write!(f, "the GPU adapter refused a device: {why}"),
            GpuError::Unsupported(what) => write!(f, "no GPU kernel for {what}"),
            GpuError::TooLarge(what) => write!(f, "too large for the GPU adapter: {what}"),
            GpuError::Failed(what) => write!(f, "GPU error: {what}"),
        }
    }
}

impl std::error::Error for GpuError {}

/// A result with a [`GpuError`].
pub type Result<T> = std::result::Result<T, GpuError>;
