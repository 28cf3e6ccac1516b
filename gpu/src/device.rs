//! The adapter and device.

use crate::{GpuError, Result};

/// The environment variable that makes a missing adapter a test failure
/// instead of a skip (CI sets it: `.ci/run`).
pub const REQUIRE_GPU_ENV: &str = "RAYTREE_REQUIRE_GPU";

/// An open GPU: the adapter's description, and the device and queue the
/// kernels run on.
pub struct Gpu {
    pub(crate) device: wgpu::Device,
    pub(crate) queue: wgpu::Queue,
    info: wgpu::AdapterInfo,
    limits: wgpu::Limits,
    f64: bool,
}

impl Gpu {
    /// Opens the best Vulkan adapter (a discrete GPU before an integrated
    /// one, a software one such as lavapipe last), with the largest buffer
    /// limits it offers. [`GpuError::NoAdapter`] when there is none.
    pub fn new() -> Result<Gpu> {
        pollster::block_on(Self::open())
    }

    async fn open() -> Result<Gpu> {
        let mut desc = wgpu::InstanceDescriptor::new_without_display_handle();
        desc.backends = wgpu::Backends::VULKAN;
        let instance = wgpu::Instance::new(desc);
        let mut adapters = instance.enumerate_adapters(wgpu::Backends::VULKAN).await;
        adapters.sort_by_key(|a| match a.get_info().device_type {
            wgpu::DeviceType::DiscreteGpu => 0,
            wgpu::DeviceType::IntegratedGpu => 1,
            wgpu::DeviceType::VirtualGpu => 2,
            wgpu::DeviceType::Other => 3,
            wgpu::DeviceType::Cpu => 4,
        });
        let Some(adapter) = adapters.into_iter().next() else {
            return Err(GpuError::NoAdapter(
                "no Vulkan device; without a GPU install Mesa's lavapipe (Debian: mesa-vulkan-drivers)"
                    .into(),
            ));
        };
        let info = adapter.get_info();
        let offered = adapter.limits();
        let limits = wgpu::Limits {
            max_storage_buffer_binding_size: offered.max_storage_buffer_binding_size,
            max_buffer_size: offered.max_buffer_size,
            max_compute_workgroups_per_dimension: offered.max_compute_workgroups_per_dimension,
            ..Default::default()
        };
        // f64 lets the triangle test redo its zero edge functions as the
        // CPU does; without it those rays go back to the CPU.
        let features = adapter.features() & wgpu::Features::SHADER_F64;
        let (device, queue) = adapter
            .request_device(&wgpu::DeviceDescriptor {
                label: Some("raytree"),
                required_features: features,
                required_limits: limits.clone(),
                ..Default::default()
            })
            .await
            .map_err(|e| GpuError::Device(e.to_string()))?;
        Ok(Gpu {
            f64: features.contains(wgpu::Features::SHADER_F64),
            device,
            queue,
            info,
            limits,
        })
    }

    /// The adapter's name, as its driver reports it.
    pub fn name(&self) -> &str {
        &self.info.name
    }

    /// The driver's name and version.
    pub fn driver(&self) -> String {
        format!("{} {}", self.info.driver, self.info.driver_info)
            .trim()
            .to_string()
    }

    /// The kind of adapter: discrete, integrated, virtual, CPU (software) or other.
    pub fn kind(&self) -> &'static str {
        match self.info.device_type {
            wgpu::DeviceType::DiscreteGpu => "discrete GPU",
            wgpu::DeviceType::IntegratedGpu => "integrated GPU",
            wgpu::DeviceType::VirtualGpu => "virtual GPU",
            wgpu::DeviceType::Cpu => "CPU (software rasterizer)",
            wgpu::DeviceType::Other => "other",
        }
    }

    /// Whether the adapter is a software one (lavapipe): figures from it
    /// say that the kernels are right, not how fast a GPU is.
    pub fn is_software(&self) -> bool {
        self.info.device_type == wgpu::DeviceType::Cpu
    }

    /// The device limits the kernels run under, as `name value` pairs.
    pub fn limits(&self) -> Vec<(&'static str, u64)> {
        let l = &self.limits;
        vec![
            (
                "max_storage_buffer_binding_size",
                l.max_storage_buffer_binding_size,
            ),
            ("max_buffer_size", l.max_buffer_size),
            (
                "max_compute_workgroups_per_dimension",
                l.max_compute_workgroups_per_dimension as u64,
            ),
            (
                "max_compute_invocations_per_workgroup",
                l.max_compute_invocations_per_workgroup as u64,
            ),
        ]
    }

    /// One line naming the adapter, its kind and driver.
    pub fn describe(&self) -> String {
        format!(
            "{} ({}, driver {}, {:?})",
            self.name(),
            self.kind(),
            self.driver(),
            self.info.backend
        )
    }

    /// Whether the kernels use f64 for the triangle test's exact edge
    /// functions (`SHADER_F64`); without it such rays finish on the CPU.
    pub fn has_f64(&self) -> bool {
        self.f64
    }

    pub(crate) fn max_binding(&self) -> u64 {
        self.limits
            .max_storage_buffer_binding_size
            .min(self.limits.max_buffer_size)
    }

    pub(crate) fn max_groups(&self) -> u32 {
        self.limits.max_compute_workgroups_per_dimension
    }
}
