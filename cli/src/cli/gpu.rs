//! `--device gpu`: the GPU back end (crate `raytree-gpu`, feature `gpu`).
// Without the feature, only the options and the refusals remain.
#![cfg_attr(not(feature = "gpu"), allow(dead_code))]

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

/// A trace's hits, their counters summed, its seconds and, on the GPU, its
/// report.
pub type Traced = (Vec<Option<Hit>>, Counters, f64, Option<GpuReport>);

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
        Device::Gpu => open_gpu().map(Some),
        #[cfg(not(feature = "gpu"))]
        Device::Gpu => Err(Error::Invalid(
            "--device gpu: this raytree was built without the gpu feature".into(),
        )),
    }
}

/// Opens the adapter. On a machine without a display, Mesa's device-select
/// layer (which raytree does not need: it picks the adapter itself) would
/// print an error about the missing Wayland display; it is turned off
/// unless the user set it (`NODEVICE_SELECT`). Called before any thread
/// of raytree's own starts.
#[cfg(feature = "gpu")]
pub fn open_gpu() -> Result<Gpu> {
    if std::env::var_os("XDG_RUNTIME_DIR").is_none()
        && std::env::var_os("NODEVICE_SELECT").is_none()
    {
        std::env::set_var("NODEVICE_SELECT", "1");
    }
    Gpu::new().map_err(|e| Error::Invalid(e.to_string()))
}

/// Traces `rays` on the GPU: the hits, their counters summed, the GPU's
/// seconds and the report.
#[cfg(feature = "gpu")]
pub fn trace(gpu: &Gpu, built: &Built, rays: &[Ray], any: bool) -> Result<Traced> {
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
pub fn trace(gpu: &Gpu, _built: &Built, _rays: &[Ray], _any: bool) -> Result<Traced> {
    match *gpu {}
}

/// The workloads of `bench gpu`.
#[derive(ValueEnum, Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum GpuPreset {
    /// Table 1 on the closest-hit AO rays of one eye ray per pixel of a
    /// 256×256 image (4 per hit, radius 4.5% of the scene's diagonal), and
    /// the path bounce rays of the same image; scene: chess.
    Quick,
    /// The papers' workloads: Table 1 on the stackless paper's (as `bench
    /// stackless --preset paper`: 800×300 on its CHESS scenes through its
    /// camera, else 512×512; 16 stratified eye rays per pixel, 16
    /// closest-hit AO rays per hit, radius 32 on CHESS), eye and AO rays
    /// together; the frame-time column on the dual-split paper's (1024×1024,
    /// 1 sample per pixel, 5 bounces, each scene's own camera); scenes:
    /// chess and hairball:2.8M.
    Paper,
}

/// `raytree bench gpu`'s options.
#[derive(clap::Args, Debug)]
pub struct GpuBenchArgs {
    /// Scenes, repeatable: built-in names or mesh files [default: the preset's].
    #[arg(long = "scene", short = 's')]
    pub scenes: Vec<String>,
    /// The workload.
    #[arg(long, value_enum, default_value_t = GpuPreset::Quick)]
    pub preset: GpuPreset,
    /// Image width in pixels [default: the preset's].
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..=16384))]
    pub width: Option<u32>,
    /// Image height in pixels [default: the preset's].
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..=16384))]
    pub height: Option<u32>,
    /// Closest-hit AO rays per eye-ray hit [default: the preset's, 4 or 16].
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..=256))]
    pub ao_rays: Option<u32>,
    /// Timed runs of each ray set on each device; the fastest counts.
    #[arg(long, default_value_t = 3, value_parser = clap::value_parser!(u32).range(1..=100))]
    pub repeats: u32,
    /// Also write the results as JSON to this file.
    #[arg(long)]
    pub json: Option<std::path::PathBuf>,
}

/// One traversal's row of `bench gpu`.
#[derive(Serialize, Clone, Debug)]
pub struct GpuRow {
    /// The traversal or structure, with its layout.
    pub name: String,
    /// Fastest GPU dispatch over the ray set, seconds.
    pub gpu_seconds: f64,
    /// Rays per second on the GPU, millions.
    pub gpu_mrays: f64,
    /// GPU time relative to the row's reference (STACK on the sparse nodes,
    /// or the BVH).
    pub gpu_ratio: f64,
    /// Fastest CPU trace over the same rays, all threads, seconds.
    pub cpu_seconds: f64,
    /// Rays per second on the CPU, millions.
    pub cpu_mrays: f64,
    /// CPU time relative to the same reference.
    pub cpu_ratio: f64,
    /// Rays whose GPU answer differs from the CPU's (triangle, or t beyond
    /// a relative 1e-6); expected 0.
    pub disagree: usize,
    /// Rays the GPU finished on the CPU.
    pub deferred: usize,
}

/// One scene of `bench gpu`.
#[derive(Serialize, Clone, Debug)]
pub struct GpuScene {
    /// The scene.
    pub scene: String,
    /// Triangles.
    pub triangles: usize,
    /// The Table 1 workload in words: image, camera, rays per pixel and
    /// per hit, radius, form.
    pub ao_workload: String,
    /// Rays of the Table 1 workload (all closest-hit queries).
    pub ao_rays: usize,
    /// Table 1: each traversal over the hybrid BVH, ratios to STACK on the
    /// same (sparse) nodes.
    pub stackless: Vec<GpuRow>,
    /// Path-tracing bounce rays (the dual-split paper's frame-time workload).
    pub path_rays: usize,
    /// The BVH and the dual-split trees over one SAH BVH, ratios to the BVH.
    pub dst: Vec<GpuRow>,
}

/// The CPU's fastest time over `rays` (closest hit, all threads).
struct CpuTime<'r>(&'r [Ray], usize);

impl raytree::structures::WithAccel for CpuTime<'_> {
    type Output = f64;
    fn run<A: raytree::structures::Accel>(self, a: &A) -> f64 {
        use rayon::prelude::*;
        let mut best = f64::INFINITY;
        for _ in 0..self.1 {
            let start = std::time::Instant::now();
            let hits = self
                .0
                .par_chunks(1024)
                .map(|c| {
                    c.iter()
                        .filter(|r| a.closest_hit(r, &mut raytree::stats::NoStats).is_some())
                        .count()
                })
                .sum::<usize>();
            std::hint::black_box(hits);
            best = best.min(start.elapsed().as_secs_f64());
        }
        best
    }
}

/// `raytree bench gpu`: the stackless paper's Table 1 on AO rays and the
/// dual-split paper's frame-time ratio on path-tracing bounce rays, on the
/// GPU beside the CPU.
#[cfg(feature = "gpu")]
pub fn run_bench(a: GpuBenchArgs) -> Result<()> {
    use super::out::say;
    use raytree::bvh::{BuildOptions, Builder, Bvh};
    use raytree::render::{rayset, AoSettings};
    use raytree::structures::{SparseBvh, StructureKind, TraversalKind};
    use raytree_gpu::{GpuAccel, Query};
    use std::sync::Arc;
    let gpu = open_gpu()?;
    let paper = a.preset == GpuPreset::Paper;
    let specs = match (a.scenes.is_empty(), paper) {
        (false, _) => a.scenes.clone(),
        (true, false) => vec!["chess".to_string()],
        (true, true) => vec!["chess".to_string(), "hairball:2.8M".to_string()],
    };
    // Every scene loaded before any work, so that a bad name fails at once
    // rather than after the scenes before it were measured.
    let scenes = specs
        .iter()
        .map(|spec| super::common::load_spec(spec))
        .collect::<Result<Vec<_>>>()?;
    say!("adapter    {}", gpu.describe());
    say!(
        "limits     {}",
        gpu.limits()
            .iter()
            .map(|(k, v)| format!("{k} {v}"))
            .collect::<Vec<_>>()
            .join(", ")
    );
    say!(
        "f64        {}",
        if gpu.has_f64() {
            "yes: zero edge functions redone in f64 on the GPU, as on the CPU"
        } else {
            "no: rays with a zero edge function finish on the CPU"
        }
    );
    if gpu.is_software() {
        say!("note       a software adapter: these times check the kernels, they do not measure a GPU");
    }
    // The image size: the options', else the workload's.
    let size = |w: usize, h: usize| {
        (
            a.width.map_or(w, |w| w as usize),
            a.height.map_or(h, |h| h as usize),
        )
    };
    let repeats = a.repeats as usize;
    let err = |e: raytree_gpu::GpuError| Error::Invalid(e.to_string());
    let mut results = Vec::new();
    for scene in &scenes {
        let tris = scene.triangles.clone();
        // Measures one built structure on `rays` on both devices.
        let measure = |name: String, built: &Built, rays: &[Ray]| -> Result<GpuRow> {
            let accel = GpuAccel::new(&gpu, built).map_err(err)?;
            let gpu_seconds = accel.time(rays, Query::Closest, repeats).map_err(err)?;
            let traced = accel.trace(rays, Query::Closest).map_err(err)?;
            let cpu_hits = built.with(CpuHits(rays));
            let disagree = traced
                .answers
                .iter()
                .zip(&cpu_hits)
                .filter(|(g, c)| match (g.hit, c) {
                    (None, None) => false,
                    (Some(g), Some(c)) => g.prim != c.prim || (g.t - c.t).abs() > 1e-6 * c.t.abs(),
                    _ => true,
                })
                .count();
            let cpu_seconds = built.with(CpuTime(rays, repeats));
            let n = rays.len() as f64;
            Ok(GpuRow {
                name,
                gpu_seconds,
                gpu_mrays: n / gpu_seconds.max(1e-12) / 1e6,
                gpu_ratio: 1.0,
                cpu_seconds,
                cpu_mrays: n / cpu_seconds.max(1e-12) / 1e6,
                cpu_ratio: 1.0,
                disagree,
                deferred: traced.deferred,
            })
        };
        let ratios = |rows: &mut Vec<GpuRow>, reference: usize| {
            let (g, c) = (rows[reference].gpu_seconds, rows[reference].cpu_seconds);
            for r in rows.iter_mut() {
                r.gpu_ratio = r.gpu_seconds / g.max(1e-12);
                r.cpu_ratio = r.cpu_seconds / c.max(1e-12);
            }
        };
        // Table 1: AO rays over the hybrid BVH.
        let hybrid = Bvh::build(&tris, &BuildOptions::new(Builder::Hybrid));
        let binary = raytree::structures::BinaryBvh::from_bvh(&hybrid, tris.clone())?;
        let diagonal_radius = AoSettings::RADIUS_FRACTION * scene.mesh.bounds().extent().length();
        let (ao, ao_workload) = if paper {
            // The stackless paper's workload, as `bench stackless --preset paper`.
            let mut view = scene.clone();
            let preset = crate::bench::stackless::Preset::Paper;
            preset.apply_view(&mut view);
            let (pw, ph) = preset.size(&view);
            let (w, h) = size(pw, ph);
            let radius = if view.is_stackless_chess() {
                raytree::scene::Scene::STACKLESS_CHESS_AO_RADIUS
            } else {
                diagonal_radius
            };
            let (query, sampling) = preset.form();
            let (eye_n, ao_n) = preset.rays();
            let settings = AoSettings {
                query,
                sampling,
                ..AoSettings::plain(eye_n, a.ao_rays.unwrap_or(ao_n), radius)
            };
            let (eye, ao) = rayset::ao_workload(&view, &binary, &settings, w, h);
            let rays: Vec<Ray> = eye.into_iter().map(|(r, _)| r).chain(ao).collect();
            let words = format!(
                "{w}×{h}, camera {}, {} eye rays per pixel and {} AO rays per hit, radius {radius:.3}, {}; eye and AO rays",
                view.camera.fov,
                settings.eye_rays,
                settings.ao_rays,
                settings.form()
            );
            (rays, words)
        } else {
            let (w, h) = size(256, 256);
            let per_hit = a.ao_rays.unwrap_or(4);
            let eye = rayset::eye_rays(scene, w, h, 1);
            let ao = rayset::ao_rays(scene, &binary, &eye, per_hit, diagonal_radius);
            let words = format!(
                "{w}×{h} eye rays, {per_hit} per hit, radius {diagonal_radius:.3}, closest hit; AO rays"
            );
            (ao, words)
        };
        let mut stackless = Vec::new();
        let (b, _) = Built::new(
            StructureKind::Bvh,
            TraversalKind::Stack,
            &hybrid,
            tris.clone(),
        )?;
        stackless.push(measure("STACK, binary nodes".into(), &b, &ao)?);
        let sparse = Arc::new(SparseBvh::from_bvh(&hybrid, tris.clone())?);
        let on_sparse = [
            TraversalKind::Stack,
            TraversalKind::Sparse,
            TraversalKind::ImplicitB,
            TraversalKind::Hapala,
            TraversalKind::Laine0,
            TraversalKind::Laine1,
            TraversalKind::Laine2,
            TraversalKind::Laine4,
            TraversalKind::Laine8,
        ];
        for t in on_sparse {
            let built = if t == TraversalKind::ImplicitB {
                Built::new(StructureKind::Bvh, t, &hybrid, tris.clone())?.0
            } else {
                Built::sparse(t, sparse.clone())?
            };
            let name = match t {
                TraversalKind::Stack => "STACK, sparse nodes".to_string(),
                TraversalKind::ImplicitB => "IMPLICIT-B".to_string(),
                t => t.name().to_uppercase(),
            };
            stackless.push(measure(name, &built, &ao)?);
        }
        ratios(&mut stackless, 1);
        // The dual-split paper's frame time: path bounce rays, SAH BVH.
        let sah = Bvh::build(&tris, &BuildOptions::sah());
        let sah_binary = raytree::structures::BinaryBvh::from_bvh(&sah, tris.clone())?;
        // The dual-split paper's frame: 1024×1024 at 1 sample per pixel.
        let side = if paper { 1024 } else { 256 };
        let (pw, ph) = size(side, side);
        let bounces = raytree::render::PathSettings::default().bounces;
        let path = rayset::path_rays(scene, &sah_binary, pw, ph, bounces);
        let mut dst = Vec::new();
        for kind in [
            StructureKind::Bvh,
            StructureKind::Dst,
            StructureKind::DstSimilar,
            StructureKind::Bvh4,
            StructureKind::Bvh8,
        ] {
            let (built, _) = Built::new(kind, TraversalKind::Stack, &sah, tris.clone())?;
            dst.push(measure(kind.name().to_string(), &built, &path)?);
        }
        ratios(&mut dst, 0);
        let r = GpuScene {
            scene: scene.name.clone(),
            triangles: tris.len(),
            ao_workload,
            ao_rays: ao.len(),
            stackless,
            path_rays: path.len(),
            dst,
        };
        let table = |title: String, rows: &[GpuRow]| {
            say!("{title}");
            say!(
                "  {:<22} {:>10} {:>8} {:>6}   {:>10} {:>8} {:>6}   {:>8} {:>8}",
                "",
                "GPU s",
                "Mrays/s",
                "ratio",
                "CPU s",
                "Mrays/s",
                "ratio",
                "disagree",
                "deferred"
            );
            for x in rows {
                say!(
                    "  {:<22} {:>10.4} {:>8.2} {:>6.2}   {:>10.4} {:>8.2} {:>6.2}   {:>8} {:>8}",
                    x.name,
                    x.gpu_seconds,
                    x.gpu_mrays,
                    x.gpu_ratio,
                    x.cpu_seconds,
                    x.cpu_mrays,
                    x.cpu_ratio,
                    x.disagree,
                    x.deferred
                );
            }
        };
        say!("scene      {} ({} triangles)", r.scene, r.triangles);
        table(
            format!(
                "stackless Table 1: {} rays ({}), hybrid BVH; ratios to STACK on the sparse nodes",
                r.ao_rays, r.ao_workload
            ),
            &r.stackless,
        );
        table(
            format!(
                "dual-split frame time: {} path-tracing bounce rays ({pw}×{ph}, 1 sample per pixel, {bounces} bounces), SAH BVH; ratios to the BVH",
                r.path_rays
            ),
            &r.dst,
        );
        results.push(r);
    }
    if let Some(p) = &a.json {
        #[derive(Serialize)]
        struct Report<'a> {
            machine: crate::bench::machine::Machine,
            adapter: String,
            software: bool,
            preset: GpuPreset,
            scenes: &'a [GpuScene],
        }
        super::common::write_json(
            p,
            &Report {
                machine: crate::bench::machine::Machine::detect(&[rayon::current_num_threads()]),
                adapter: gpu.describe(),
                software: gpu.is_software(),
                preset: a.preset,
                scenes: &results,
            },
        )?;
    }
    Ok(())
}

/// Without the `gpu` feature, `bench gpu` says so.
#[cfg(not(feature = "gpu"))]
pub fn run_bench(_a: GpuBenchArgs) -> Result<()> {
    Err(Error::Invalid(
        "bench gpu: this raytree was built without the gpu feature".into(),
    ))
}

/// The CPU's closest hits.
struct CpuHits<'r>(&'r [Ray]);

impl raytree::structures::WithAccel for CpuHits<'_> {
    type Output = Vec<Option<Hit>>;
    fn run<A: raytree::structures::Accel>(self, a: &A) -> Self::Output {
        use rayon::prelude::*;
        self.0
            .par_iter()
            .map(|r| a.closest_hit(r, &mut raytree::stats::NoStats))
            .collect()
    }
}
