//! A structure uploaded to the GPU, and ray batches traced over it.

use crate::{Gpu, GpuError, Kernel, Result};
use raytree::geometry::{Hit, Ray, Triangle};
use raytree::stats::{Counters, Tally};
use raytree::structures::shared::own_box::OwnBoxNode;
use raytree::structures::{stack_capacity, Accel, Built, WithAccel};
use std::borrow::Cow;
use std::time::Instant;
use wgpu::util::DeviceExt;

/// Bytes of one ray on the GPU (`GpuRay` in the prelude).
const RAY_BYTES: u64 = 64;
/// Bytes of one answer on the GPU (`Answer` in the prelude).
const ANSWER_BYTES: u64 = 32;
/// Invocations per workgroup (`@workgroup_size` of every kernel).
const GROUP: u32 = 64;
/// Rays per dispatch at most (buffers of 64 MiB of rays).
const BATCH: usize = 1 << 20;

/// The query a batch answers.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Query {
    /// The closest hit, ties to the smaller triangle index.
    Closest,
    /// Any hit: the first one the traversal finds.
    Any,
}

/// One ray's answer from the GPU.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GpuAnswer {
    /// The hit, or `None` for a miss.
    pub hit: Option<Hit>,
    /// The ray's work: nodes visited, plane tests, triangle tests.
    pub tally: Tally,
    /// The GPU handed this ray to the CPU (its triangle test left f32);
    /// `hit` and `tally` are then the CPU's.
    pub deferred: bool,
}

/// A traced batch.
#[derive(Clone, Debug)]
pub struct Traced {
    /// One answer per ray, in order.
    pub answers: Vec<GpuAnswer>,
    /// Rays traced again on the CPU (see [`GpuAnswer::deferred`]).
    pub deferred: usize,
    /// Seconds from submitting the dispatches to their completion (upload
    /// of the rays and read-back excluded).
    pub gpu_seconds: f64,
}

/// A [`Built`] structure uploaded to the GPU, with its traversal's
/// closest-hit and any-hit pipelines.
pub struct GpuAccel<'a> {
    gpu: &'a Gpu,
    built: &'a Built,
    kernel: Kernel,
    triangles: wgpu::Buffer,
    index: wgpu::Buffer,
    nodes: wgpu::Buffer,
    root: u32,
    bounds: [f32; 6],
    empty: bool,
    layout: wgpu::BindGroupLayout,
    closest: wgpu::ComputePipeline,
    any: wgpu::ComputePipeline,
    bytes: usize,
}

/// The kernel and buffers of a built structure.
struct Upload<'b> {
    kernel: Kernel,
    nodes: Cow<'b, [u32]>,
    /// The leaf list, or the wide layouts' triangle blocks.
    index: &'b [u32],
    /// The mesh (none for the wide layouts, whose blocks hold the vertices).
    triangles: &'b [Triangle],
    root: u32,
    bounds: [f32; 6],
    empty: bool,
    /// Entries of the private stack.
    stack: usize,
}

/// A wide BVH's nodes as the words of their `WideNode` records: six plane
/// rows of `W` floats, `W` child references, zeros in the padding to 64
/// bytes.
fn wide_words<const W: usize>(w: &raytree::structures::WideBvh<W>) -> Vec<u32> {
    let stride = crate::kernel::wide_node_words(W as u32);
    let mut words = Vec::with_capacity(w.nodes().len() * stride);
    for n in w.nodes() {
        let start = words.len();
        words.extend(n.planes.iter().flatten().map(|p| p.to_bits()));
        words.extend(n.plain_children());
        words.resize(start + stride, 0);
    }
    words
}

fn wide<const W: usize>(w: &raytree::structures::WideBvh<W>) -> Upload<'_> {
    Upload {
        kernel: Kernel::Wide(W as u32),
        nodes: Cow::Owned(wide_words(w)),
        index: bytemuck::cast_slice(w.blocks()),
        triangles: &[],
        root: w.root(),
        bounds: [0.0; 6],
        empty: w.is_empty(),
        // `W − 1` pending children per level below the root, and the node
        // being visited.
        stack: w.depth() as usize * (W - 1) + 1,
    }
}

fn upload_of(built: &Built) -> Result<Upload<'_>> {
    use raytree::structures::Built as B;
    fn sparse(kernel: Kernel, l: &raytree::structures::SparseBvh) -> Upload<'_> {
        Upload {
            kernel,
            nodes: Cow::Borrowed(bytemuck::cast_slice(l.nodes())),
            index: l.index(),
            triangles: l.triangles(),
            root: 0,
            bounds: l.bounds().to_array(),
            empty: l.is_empty(),
            stack: stack_capacity(l.depth()),
        }
    }
    Ok(match built {
        B::Bvh(b) => Upload {
            kernel: Kernel::BvhStack,
            nodes: Cow::Borrowed(b.words()),
            index: b.index(),
            triangles: b.triangles(),
            root: b.root(),
            bounds: b.root_bounds().to_array(),
            empty: b.is_empty(),
            stack: stack_capacity(b.depth()),
        },
        B::StackOnSparse(s) => sparse(Kernel::SparseStack, &s.layout),
        B::Sparse(s) => sparse(Kernel::Sparse, &s.layout),
        B::Hapala(s) => sparse(Kernel::Hapala, &s.layout),
        B::Laine0(s) => sparse(Kernel::Laine(0), &s.layout),
        B::Laine1(s) => sparse(Kernel::Laine(1), &s.layout),
        B::Laine2(s) => sparse(Kernel::Laine(2), &s.layout),
        B::Laine4(s) => sparse(Kernel::Laine(4), &s.layout),
        B::Laine8(s) => sparse(Kernel::Laine(8), &s.layout),
        B::Dst(d) => Upload {
            kernel: Kernel::Dst,
            nodes: Cow::Borrowed(d.words()),
            index: d.index_list(),
            triangles: d.triangles(),
            root: 0,
            bounds: d.root_bounds().to_array(),
            empty: d.is_empty(),
            stack: stack_capacity(d.depth()),
        },
        B::ImplicitB(s) => {
            let l = &s.layout;
            let slots = l.slots();
            Upload {
                kernel: Kernel::ImplicitB,
                nodes: Cow::Borrowed(bytemuck::cast_slice(
                    &slots[..implicit_used(slots, l.is_empty())],
                )),
                index: l.index(),
                triangles: l.triangles(),
                root: 1,
                bounds: l.bounds().to_array(),
                empty: l.is_empty(),
                stack: stack_capacity(0),
            }
        }
        B::Bvh4(w) => wide(w),
        B::Bvh8(w) => wide(w),
        other => {
            let (structure, traversal, _) = other.kind();
            return Err(GpuError::Unsupported(format!(
                "the {} structure with the {} traversal ({})",
                structure.name(),
                traversal.name(),
                "GPU kernels exist for bvh with stack, sparse, implicit-b, hapala and laine-k, for dst and dst-similar, and for bvh4 and bvh8"
            )));
        }
    })
}

/// The slots of the implicit layout up to its last node (the gaps before it
/// included, as zeros), found by a walk over the nodes alone: the mapping
/// reserves far more.
fn implicit_used(slots: &[OwnBoxNode], empty: bool) -> usize {
    if empty || slots.len() < 2 {
        return slots.len().min(2);
    }
    let mut last = 1;
    let mut todo = vec![1usize];
    while let Some(s) = todo.pop() {
        last = last.max(s);
        if !slots[s].is_leaf() {
            todo.extend([2 * s, 2 * s + 1]);
        }
    }
    // Whole sibling pairs.
    (last | 1) + 1
}

/// Whether `built` has a GPU kernel.
pub fn supported(built: &Built) -> bool {
    upload_of(built).is_ok()
}

impl<'a> GpuAccel<'a> {
    /// Uploads `built` (node words, leaf list, triangles) and builds its
    /// pipelines. [`GpuError::Unsupported`] for a structure or traversal
    /// without a kernel, [`GpuError::TooLarge`] for one past the adapter's
    /// buffer limits.
    pub fn new(gpu: &'a Gpu, built: &'a Built) -> Result<Self> {
        let up = upload_of(built)?;
        let tris: Vec<f32> = up
            .triangles
            .iter()
            .flat_map(|t| [t.a.to_array(), t.b.to_array(), t.c.to_array()])
            .flatten()
            .collect();
        let device = &gpu.device;
        let max = gpu.max_binding();
        let buffer = |label: &str, bytes: &[u8]| -> Result<wgpu::Buffer> {
            if bytes.len() as u64 > max {
                return Err(GpuError::TooLarge(format!(
                    "{label}: {} bytes, the adapter binds at most {max}",
                    bytes.len()
                )));
            }
            // Bindings may not be empty: pad to one 16-byte word.
            let mut padded;
            let contents = if bytes.len() < 16 {
                padded = bytes.to_vec();
                padded.resize(16, 0);
                &padded[..]
            } else {
                bytes
            };
            Ok(
                device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                    label: Some(label),
                    contents,
                    usage: wgpu::BufferUsages::STORAGE,
                }),
            )
        };
        let bytes = tris.len() * 4 + up.index.len() * 4 + up.nodes.len() * 4;
        let triangles = buffer("triangles", bytemuck::cast_slice(&tris))?;
        let index = buffer("index", bytemuck::cast_slice(up.index))?;
        let nodes = buffer("nodes", bytemuck::cast_slice(&up.nodes))?;
        let entry = |binding, ty| wgpu::BindGroupLayoutEntry {
            binding,
            visibility: wgpu::ShaderStages::COMPUTE,
            ty,
            count: None,
        };
        let storage = |read_only| wgpu::BindingType::Buffer {
            ty: wgpu::BufferBindingType::Storage { read_only },
            has_dynamic_offset: false,
            min_binding_size: None,
        };
        let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("raytree"),
            entries: &[
                entry(
                    0,
                    wgpu::BindingType::Buffer {
                        ty: wgpu::BufferBindingType::Uniform,
                        has_dynamic_offset: false,
                        min_binding_size: None,
                    },
                ),
                entry(1, storage(true)),
                entry(2, storage(false)),
                entry(3, storage(true)),
                entry(4, storage(true)),
                entry(5, storage(true)),
            ],
        });
        let pipeline_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("raytree"),
            bind_group_layouts: &[Some(&layout)],
            immediate_size: 0,
        });
        let scope = device.push_error_scope(wgpu::ErrorFilter::Validation);
        let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some(up.kernel.file()),
            source: wgpu::ShaderSource::Wgsl(up.kernel.source(up.stack, gpu.has_f64()).into()),
        });
        let pipeline = |any: bool| {
            device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
                label: Some(up.kernel.file()),
                layout: Some(&pipeline_layout),
                module: &module,
                entry_point: Some("main"),
                compilation_options: wgpu::PipelineCompilationOptions {
                    constants: &[("ANY", if any { 1.0 } else { 0.0 })],
                    zero_initialize_workgroup_memory: false,
                },
                cache: None,
            })
        };
        let closest = pipeline(false);
        let any = pipeline(true);
        if let Some(e) = pollster::block_on(scope.pop()) {
            return Err(GpuError::Failed(format!("{}: {e}", up.kernel.file())));
        }
        Ok(GpuAccel {
            gpu,
            built,
            kernel: up.kernel,
            triangles,
            index,
            nodes,
            root: up.root,
            bounds: up.bounds,
            empty: up.empty,
            layout,
            closest,
            any,
            bytes,
        })
    }

    /// The kernel this structure's traversal runs.
    pub fn kernel(&self) -> Kernel {
        self.kernel
    }

    /// Bytes uploaded: triangles, leaf list and node words.
    pub fn bytes(&self) -> usize {
        self.bytes
    }

    /// Traces `rays`, answering `query`, with each ray's counters. Rays the
    /// GPU defers are traced again on the CPU over the same structure.
    pub fn trace(&self, rays: &[Ray], query: Query) -> Result<Traced> {
        let mut answers = Vec::with_capacity(rays.len());
        let mut gpu_seconds = 0.0;
        for chunk in rays.chunks(self.batch_rays()) {
            let (raw, secs) = self.dispatch(chunk, query, 1)?;
            gpu_seconds += secs;
            answers.extend(raw.iter().map(decode));
        }
        let deferred: Vec<usize> = answers
            .iter()
            .enumerate()
            .filter(|(_, a)| a.deferred)
            .map(|(i, _)| i)
            .collect();
        if !deferred.is_empty() {
            let picked: Vec<Ray> = deferred.iter().map(|&i| rays[i]).collect();
            let cpu = self.built.with(OnCpu {
                rays: &picked,
                query,
            });
            for (&i, (hit, tally)) in deferred.iter().zip(cpu) {
                answers[i] = GpuAnswer {
                    hit,
                    tally,
                    deferred: true,
                };
            }
        }
        Ok(Traced {
            answers,
            deferred: deferred.len(),
            gpu_seconds,
        })
    }

    /// The GPU time of tracing `rays` (uploaded once), the fastest of
    /// `repeats` dispatches, in seconds; deferred rays are not traced again.
    pub fn time(&self, rays: &[Ray], query: Query, repeats: usize) -> Result<f64> {
        let mut total = 0.0;
        for chunk in rays.chunks(self.batch_rays()) {
            total += self.dispatch(chunk, query, repeats.max(1))?.1;
        }
        Ok(total)
    }

    fn batch_rays(&self) -> usize {
        let by_limit = (self.gpu.max_binding() / RAY_BYTES) as usize;
        BATCH.min(by_limit).max(GROUP as usize)
    }

    /// Runs one batch `repeats` times; the raw answers and the fastest
    /// dispatch's seconds.
    fn dispatch(
        &self,
        rays: &[Ray],
        query: Query,
        repeats: usize,
    ) -> Result<(Vec<RawAnswer>, f64)> {
        let device = &self.gpu.device;
        let n = rays.len();
        if n == 0 {
            return Ok((Vec::new(), 0.0));
        }
        let groups = (n as u32).div_ceil(GROUP);
        let x = groups.min(self.gpu.max_groups());
        let y = groups.div_ceil(x);
        if y > self.gpu.max_groups() {
            return Err(GpuError::TooLarge(format!("{n} rays in one dispatch")));
        }
        let params = Params {
            count: n as u32,
            root: self.root,
            row: x * GROUP,
            empty: self.empty as u32,
            lo: [self.bounds[0], self.bounds[1], self.bounds[2], 0.0],
            hi: [self.bounds[3], self.bounds[4], self.bounds[5], 0.0],
        };
        let gpu_rays: Vec<GpuRay> = rays.iter().map(GpuRay::of).collect();
        let params = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("params"),
            contents: bytemuck::bytes_of(&params),
            usage: wgpu::BufferUsages::UNIFORM,
        });
        let ray_buf = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("rays"),
            contents: bytemuck::cast_slice(&gpu_rays),
            usage: wgpu::BufferUsages::STORAGE,
        });
        let size = n as u64 * ANSWER_BYTES;
        let out = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("answers"),
            size,
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
            mapped_at_creation: false,
        });
        let back = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("read-back"),
            size,
            usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let bind = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("raytree"),
            layout: &self.layout,
            entries: &[
                (0, &params),
                (1, &ray_buf),
                (2, &out),
                (3, &self.triangles),
                (4, &self.index),
                (5, &self.nodes),
            ]
            .map(|(binding, b)| wgpu::BindGroupEntry {
                binding,
                resource: b.as_entire_binding(),
            }),
        });
        let pipeline = match query {
            Query::Closest => &self.closest,
            Query::Any => &self.any,
        };
        let mut best = f64::INFINITY;
        for _ in 0..repeats {
            let mut enc = device.create_command_encoder(&Default::default());
            {
                let mut pass = enc.begin_compute_pass(&Default::default());
                pass.set_pipeline(pipeline);
                pass.set_bind_group(0, &bind, &[]);
                pass.dispatch_workgroups(x, y, 1);
            }
            let start = Instant::now();
            self.gpu.queue.submit([enc.finish()]);
            self.wait()?;
            best = best.min(start.elapsed().as_secs_f64());
        }
        let mut enc = device.create_command_encoder(&Default::default());
        enc.copy_buffer_to_buffer(&out, 0, &back, 0, size);
        self.gpu.queue.submit([enc.finish()]);
        let slice = back.slice(..);
        slice.map_async(wgpu::MapMode::Read, |_| {});
        self.wait()?;
        let raw = {
            let view = slice
                .get_mapped_range()
                .map_err(|e| GpuError::Failed(e.to_string()))?;
            bytemuck::cast_slice::<u8, RawAnswer>(&view).to_vec()
        };
        back.unmap();
        Ok((raw, best))
    }

    fn wait(&self) -> Result<()> {
        self.gpu
            .device
            .poll(wgpu::PollType::wait_indefinitely())
            .map(|_| ())
            .map_err(|e| GpuError::Failed(e.to_string()))
    }
}

#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct Params {
    count: u32,
    root: u32,
    row: u32,
    empty: u32,
    lo: [f32; 4],
    hi: [f32; 4],
}

#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct GpuRay {
    o: [f32; 3],
    tmin: f32,
    d: [f32; 3],
    tmax: f32,
    inv: [f32; 3],
    k: u32,
    shear: [f32; 3],
    pad: u32,
}

impl GpuRay {
    fn of(r: &Ray) -> Self {
        let [kx, ky, kz] = r.shear_axes();
        GpuRay {
            o: r.origin().to_array(),
            tmin: r.tmin,
            d: r.direction().to_array(),
            tmax: r.tmax,
            inv: r.inv_direction().to_array(),
            k: (kx | ky << 2 | kz << 4) as u32,
            shear: r.shear().to_array(),
            pad: 0,
        }
    }
}

#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct RawAnswer {
    t: u32,
    prim: u32,
    u: u32,
    v: u32,
    nodes: u32,
    planes: u32,
    triangles: u32,
    status: u32,
}

fn decode(a: &RawAnswer) -> GpuAnswer {
    GpuAnswer {
        hit: (a.prim != u32::MAX).then(|| Hit {
            t: f32::from_bits(a.t),
            prim: a.prim,
            u: f32::from_bits(a.u),
            v: f32::from_bits(a.v),
        }),
        tally: Tally {
            nodes: a.nodes,
            planes: a.planes,
            triangles: a.triangles,
        },
        deferred: a.status != 0,
    }
}

/// Deferred rays, traced on the CPU with their counters.
struct OnCpu<'r> {
    rays: &'r [Ray],
    query: Query,
}

impl WithAccel for OnCpu<'_> {
    type Output = Vec<(Option<Hit>, Tally)>;
    fn run<A: Accel>(self, a: &A) -> Self::Output {
        self.rays
            .iter()
            .map(|r| {
                let mut c = Counters::default();
                let hit = match self.query {
                    Query::Closest => a.closest_hit(r, &mut c),
                    Query::Any => a.any_hit(r, &mut c),
                };
                (
                    hit,
                    Tally {
                        nodes: c.nodes as u32,
                        planes: c.planes as u32,
                        triangles: c.triangles as u32,
                    },
                )
            })
            .collect()
    }
}
