//! `raytree trace`: rays from a file, hits to a file.

use super::common::{self, SceneArgs, SceneReport, StructureArgs};
use super::gpu::{self as gpu_cli, Device, GpuReport};
use super::out::say;
use crate::bench::machine::Machine;
use clap::{Args, ValueEnum};
use rayon::prelude::*;
use raytree::bvh::BuildStats;
use raytree::error::Result;
use raytree::geometry::{Hit, Ray};
use raytree::rayfile;
use raytree::stats::{Counters, PerRay};
use raytree::structures::{Accel, StructureInfo, WithAccel};
use serde::Serialize;
use std::path::PathBuf;
use std::time::Instant;

#[derive(Args, Debug)]
pub struct TraceArgs {
    #[command(flatten)]
    scene: SceneArgs,
    #[command(flatten)]
    structure: StructureArgs,
    /// Ray file: 32 bytes per ray, little-endian f32 origin xyz, direction
    /// xyz (any length), tmin, tmax; no header.
    #[arg(long)]
    rays: PathBuf,
    /// Hit file: 16 bytes per ray, f32 t (+inf on a miss), u32 triangle
    /// (the scene's order, 0xFFFFFFFF on a miss), f32 u, v; 24 bytes with
    /// --format bin-geometry; or CSV with --format csv. "-" writes them to
    /// standard output, and the report then goes to standard error.
    #[arg(long, short = 'o')]
    out: PathBuf,
    /// Any hit instead of the closest: t is some hit's distance in [tmin, tmax].
    #[arg(long)]
    any_hit: bool,
    /// Print the nodes, plane tests and triangle tests per ray (always in
    /// the JSON report).
    #[arg(long)]
    stats: bool,
    /// Hit file format.
    #[arg(long, value_enum, default_value_t = Format::Bin)]
    format: Format,
    /// Worker threads [default: all cores].
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..=1024))]
    threads: Option<u32>,
    /// Also write a JSON report (times, Mrays/s, counters) to this file.
    #[arg(long)]
    json: Option<PathBuf>,
    /// Where to trace: cpu, or gpu (wgpu compute shaders over Vulkan; the
    /// bvh with stack, sparse, implicit-b, hapala and laine-k, dst,
    /// dst-similar, bvh4 and bvh8).
    #[arg(long, value_enum, default_value_t = Device::Cpu)]
    device: Device,
}

#[derive(ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
enum Format {
    /// 16 bytes per ray: t, triangle, u, v.
    Bin,
    /// 24 bytes per ray: the 16 of bin, then u32 geometry id and u32
    /// triangle index within the geometry (0xFFFFFFFF on a miss).
    BinGeometry,
    /// Text: ray,t,triangle,u,v,geometry,primitive.
    Csv,
}

#[derive(Serialize)]
struct TraceReport {
    #[serde(flatten)]
    scene: SceneReport,
    bvh: BuildStats,
    structure: StructureInfo,
    any_hit: bool,
    rays: usize,
    hits: usize,
    threads: usize,
    /// What the timing ran on.
    machine: Machine,
    /// Tracing only: no file input or output.
    trace_seconds: f64,
    mrays_per_second: f64,
    counters: Counters,
    per_ray: PerRay,
    /// `cpu` or `gpu`.
    device: Device,
    /// The GPU adapter and the rays it handed back to the CPU (with
    /// --device gpu).
    #[serde(skip_serializing_if = "Option::is_none")]
    gpu: Option<GpuReport>,
}

struct TraceWith<'a> {
    rays: &'a [Ray],
    any: bool,
}

impl WithAccel for TraceWith<'_> {
    type Output = (Vec<Option<Hit>>, Counters, f64);
    fn run<A: Accel>(self, a: &A) -> Self::Output {
        let start = Instant::now();
        let parts: Vec<(Vec<Option<Hit>>, Counters)> = self
            .rays
            .par_chunks(1024)
            .map(|chunk| {
                let mut c = Counters::default();
                let hits: Vec<_> = chunk
                    .iter()
                    .map(|r| {
                        c.rays += 1;
                        if self.any {
                            a.any_hit(r, &mut c)
                        } else {
                            a.closest_hit(r, &mut c)
                        }
                    })
                    .collect();
                (hits, c)
            })
            .collect();
        let seconds = start.elapsed().as_secs_f64();
        let mut hits = Vec::with_capacity(self.rays.len());
        let mut total = Counters::default();
        for (h, c) in parts {
            hits.extend(h);
            total += c;
        }
        (hits, total, seconds)
    }
}

pub fn run(args: TraceArgs) -> Result<()> {
    common::check_structure(&args.structure)?;
    if raytree::render::is_stdout(&args.out) {
        super::out::report_to_stderr();
    }
    let rays = rayfile::read_rays(&args.rays)?;
    // No adapter: one line and exit 1, before any work.
    let gpu = gpu_cli::open(args.device)?;
    let go = || -> Result<()> {
        let (scene, mut scene_report, saved) =
            common::load_scene_with(&args.scene, &args.structure.layout_options())?;
        let (bvh, bvh_stats, built, info) = common::prepare(
            &scene,
            saved,
            &args.scene,
            &args.structure,
            &mut scene_report,
            false,
        )?;
        drop(bvh);
        let (hits, counters, seconds, gpu_report) = match &gpu {
            Some(g) => gpu_cli::trace(g, &built, &rays, args.any_hit)?,
            None => {
                let (h, c, s) = built.with(TraceWith {
                    rays: &rays,
                    any: args.any_hit,
                });
                (h, c, s, None)
            }
        };
        let write = |w: &mut dyn std::io::Write| match args.format {
            Format::Bin => w.write_all(&rayfile::encode_hits(&hits)),
            Format::BinGeometry => w.write_all(&rayfile::encode_geometry_hits(&hits, &scene.mesh)),
            Format::Csv => rayfile::write_hits_csv(&mut &mut *w, &hits, &scene.mesh),
        };
        if raytree::render::is_stdout(&args.out) {
            let mut out = std::io::stdout().lock();
            write(&mut out)
                .and_then(|()| std::io::Write::flush(&mut out))
                .map_err(|source| raytree::error::Error::Io {
                    path: "standard output".into(),
                    source,
                })?;
        } else {
            raytree::render::write_atomically(&args.out, |w| write(w))?;
        }
        let report = TraceReport {
            scene: scene_report,
            bvh: bvh_stats,
            structure: info,
            any_hit: args.any_hit,
            rays: rays.len(),
            hits: hits.iter().filter(|h| h.is_some()).count(),
            threads: rayon::current_num_threads(),
            machine: Machine::detect(&[rayon::current_num_threads()]),
            trace_seconds: seconds,
            mrays_per_second: rays.len() as f64 / seconds.max(1e-12) / 1e6,
            counters,
            per_ray: counters.per_ray(),
            device: args.device,
            gpu: gpu_report,
        };
        common::say_saved(&report.scene);
        match &report.gpu {
            Some(g) => {
                say!(
                    "traced     {} rays ({} hits) through {} in {:.3} s: {:.2} Mrays/s on the GPU",
                    report.rays,
                    report.hits,
                    report.structure.structure.name(),
                    report.trace_seconds,
                    report.mrays_per_second,
                );
                say!(
                    "gpu        {}; kernel {}; {} rays finished on the CPU",
                    g.adapter,
                    g.kernel,
                    g.deferred
                );
            }
            None => say!(
                "traced     {} rays ({} hits) through {} in {:.3} s: {:.2} Mrays/s on {} threads",
                report.rays,
                report.hits,
                report.structure.structure.name(),
                report.trace_seconds,
                report.mrays_per_second,
                report.threads
            ),
        }
        if args.stats {
            let p = report.per_ray;
            say!(
                "per ray    {:.2} nodes, {:.2} plane tests, {:.2} triangle tests",
                p.nodes,
                p.planes,
                p.triangles
            );
        }
        say!("wrote      {}", args.out.display());
        if let Some(p) = &args.json {
            common::write_json(p, &report)?;
        }
        Ok(())
    };
    match args.threads {
        Some(n) => rayon::ThreadPoolBuilder::new()
            .num_threads(n as usize)
            .build()
            .map_err(|e| raytree::error::Error::Invalid(format!("cannot start {n} threads: {e}")))?
            .install(go),
        None => go(),
    }
}
