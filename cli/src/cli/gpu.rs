//! `--device gpu`: the GPU back end (crate `raytree-gpu`, feature `gpu`).

use clap::ValueEnum;
use raytree::error::{Error, Result};
use raytree::geometry::{Hit, Ray};
use raytree::stats::Counters;
use raytree::structures::Built;
use serde::Serialize;

/// Where rays are traced.
#[derive(ValueEnum, Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Device {
    /// The CPU, on rayon's threads.
    Cpu,
    /// The GPU: wgpu compute shaders over Vulkan (Mesa's lavapipe where
    /// there is no GPU).
    Gpu,
}

/// The GPU side of a trace report.
#[derive(Serialize, Clone, Debug)]
pub struct GpuReport {
    /// The adapter, its kind and driver.
    pub adapter: String,
    /// The WGSL kernel that ran.
    pub kernel: String,
    /// Rays whose triangle tests left f32, finished on the CPU.
    pub deferred: usize,
}

#[cfg(feature = "gpu")]
pub use raytree_gpu::Gpu;

/// Stands in for the GPU handle in a build without the `gpu` feature.
#[cfg(not(feature = "gpu"))]
pub enum Gpu {}

/// Opens the adapter for `--device gpu` (`None` for the CPU). No adapter is
/// an error of one line.
pub fn open(device: Device) -> Result<Option<Gpu>> {
    match device {
        Device::Cpu => Ok(None),
        #[cfg(feature = "gpu")]
        Device::Gpu => Gpu::new()
            .map(Some)
            .map_err(|e| Error::Invalid(e.to_string())),
        #[cfg(not(feature = "gpu"))]
        Device::Gpu => Err(Error::Invalid(
            "--device gpu: this raytree was built without the gpu feature".into(),
        )),
    }
}

/// Traces `rays` on the GPU: the hits, their counters summed, the GPU's
/// seconds and the report.
#[cfg(feature = "gpu")]
pub fn trace(
    gpu: &Gpu,
    built: &Built,
    rays: &[Ray],
    any: bool,
) -> Result<(Vec<Option<Hit>>, Counters, f64, Option<GpuReport>)> {
    use raytree_gpu::{GpuAccel, Query};
    let err = |e: raytree_gpu::GpuError| Error::Invalid(e.to_string());
    let accel = GpuAccel::new(gpu, built).map_err(err)?;
    let query = if any { Query::Any } else { Query::Closest };
    let traced = accel.trace(rays, query).map_err(err)?;
    let mut counters = Counters {
        rays: rays.len() as u64,
        ..Counters::default()
    };
    let hits = traced
        .answers
        .iter()
        .map(|a| {
            counters.nodes += a.tally.nodes as u64;
            counters.planes += a.tally.planes as u64;
            counters.triangles += a.tally.triangles as u64;
            a.hit
        })
        .collect();
    let report = GpuReport {
        adapter: gpu.describe(),
        kernel: accel.kernel().file().to_string(),
        deferred: traced.deferred,
    };
    Ok((hits, counters, traced.gpu_seconds, Some(report)))
}

/// Without the `gpu` feature there is no handle to trace with.
#[cfg(not(feature = "gpu"))]
pub fn trace(
    gpu: &Gpu,
    _built: &Built,
    _rays: &[Ray],
    _any: bool,
) -> Result<(Vec<Option<Hit>>, Counters, f64, Option<GpuReport>)> {
    match *gpu {}
}
