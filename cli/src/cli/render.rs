//! `raytree render`.

use super::common::{self, CameraArgs, SceneArgs, SceneReport, StructureArgs};
use super::out::say;
use crate::bench::machine::Machine;
use clap::{Args, ValueEnum};
use raytree::bvh::BuildStats;
use raytree::error::{Error, Result};
use raytree::render::heatmap::{HeatmapInfo, Measure};
use raytree::render::{self, AoQuery, AoSettings, Integrator, PathSettings, Sampling};
use raytree::scene::{Camera, Scene};
use raytree::stats::{Counters, PerRay};
use raytree::structures::StructureInfo;
use serde::Serialize;
use std::path::PathBuf;

#[derive(Args, Debug)]
pub struct RenderArgs {
    #[command(flatten)]
    scene: SceneArgs,
    #[command(flatten)]
    camera: CameraArgs,
    #[command(flatten)]
    structure: StructureArgs,
    /// Integrator: ambient occlusion or diffuse path tracing.
    #[arg(long, short = 'i', value_enum, default_value_t = IntegratorArg::Ao)]
    integrator: IntegratorArg,
    /// Use the papers' settings: for ao, the stackless paper's workload as
    /// its tracer ran it: 16 eye rays per pixel on a 4×4 stratified grid and
    /// 16 closest-hit AO rays at each eye-ray hit (256 AO rays per pixel),
    /// at 800×300 (chess) or 512×512; on its CHESS scenes (the built-in
    /// chess, a file named battlefield.obj) also its camera (eye
    /// 300,100,300 towards 0,10,0, 50° horizontal with its non-square
    /// pixels) and AO radius 32. For path, 1024×1024 at 1 sample per pixel.
    #[arg(long)]
    paper: bool,
    /// AO: how occlusion rays are traced. any: any-hit queries from the hit
    /// point moved off the surface; closest: the stackless paper's tracer's
    /// closest-hit queries from the hit point, t in [0.001, radius]
    /// [default: any; --paper: closest].
    #[arg(long, value_parser = common::named::<AoQuery>())]
    ao_query: Option<AoQuery>,
    /// AO: how eye rays are placed in the pixel and AO directions spread.
    /// stratified: one sample per cell of a k×k grid when the count is k²
    /// (independent otherwise) [default: independent; --paper: stratified].
    #[arg(long, value_parser = common::named::<Sampling>())]
    sampling: Option<Sampling>,
    /// Image width in pixels [default: ao 400 (chess) or 256, path 512;
    /// with --paper as above].
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..=16384))]
    width: Option<u32>,
    /// Image height in pixels [default: ao 150 (chess) or 256, path 512;
    /// with --paper as above].
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..=16384))]
    height: Option<u32>,
    /// AO: jittered eye rays per pixel [default: 4; --paper: 16].
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..=4096))]
    eye_rays: Option<u32>,
    /// AO: occlusion rays per eye-ray hit [default: 8; --paper: 16].
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..=65536))]
    ao_rays: Option<u32>,
    /// AO: length of the occlusion rays in scene units
    /// [default: 0.045 × the scene's diagonal, 32 on the chess board].
    #[arg(long)]
    ao_radius: Option<f32>,
    /// Path: samples per pixel.
    #[arg(long, default_value_t = 1, value_parser = clap::value_parser!(u32).range(1..=65536))]
    samples: u32,
    /// Path: diffuse bounces after the eye ray (no Russian roulette).
    #[arg(long, default_value_t = 5, value_parser = clap::value_parser!(u32).range(0..=64))]
    bounces: u32,
    /// Output image, its format chosen by the extension: .png (8-bit grey,
    /// sRGB), .jpg or .jpeg (the same, JPEG quality 95), .ppm (binary P6)
    /// or .exr (linear 32-bit float). "-" writes PNG to standard output,
    /// and the report then goes to standard error.
    #[arg(long, short = 'o', default_value = "raytree.png")]
    out: PathBuf,
    /// Worker threads [default: all cores].
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..=1024))]
    threads: Option<u32>,
    /// No progress bar.
    #[arg(long, short = 'q')]
    quiet: bool,
    /// Also write the report as JSON to this file.
    #[arg(long)]
    json: Option<PathBuf>,
    /// Also write heat maps of the work per pixel (all its rays), comma-
    /// separated: nodes, planes, triangles; each to OUT's name with
    /// "-nodes" (etc.) before the extension, as PNG with the colour scale
    /// (0 to the 99.5th percentile of the pixels' counts) beneath, labelled
    /// with 0, its middle and its top and the measure's name.
    #[arg(long, value_parser = common::named::<Measure>(), value_delimiter = ',')]
    heatmap: Vec<Measure>,
    /// The count drawn white in every heat map, instead of the 99.5th
    /// percentile: one scale for maps of several structures.
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..))]
    heatmap_top: Option<u32>,
}

#[derive(ValueEnum, Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum IntegratorArg {
    /// Ambient occlusion: eye rays, then occlusion rays at each hit
    /// (any-hit, or closest-hit as the stackless paper's tracer: --ao-query).
    Ao,
    /// Diffuse path tracing: closest-hit rays, up to --bounces bounces.
    Path,
}

#[derive(Serialize)]
struct RenderReport {
    #[serde(flatten)]
    scene: SceneReport,
    bvh: BuildStats,
    structure: StructureInfo,
    integrator: IntegratorArg,
    /// The AO workload, its form (`query`, `sampling`) included.
    ao: Option<AoSettings>,
    path: Option<PathSettings>,
    camera: Camera,
    width: usize,
    height: usize,
    threads: usize,
    /// What the timing ran on.
    machine: Machine,
    render_seconds: f64,
    rays: u64,
    mrays_per_second: f64,
    counters: Counters,
    per_ray: PerRay,
    image: PathBuf,
    heatmaps: Vec<Heatmap>,
}

#[derive(Serialize)]
struct Heatmap {
    #[serde(flatten)]
    info: HeatmapInfo,
    file: PathBuf,
}

/// `out` with `-suffix` before its extension, as PNG (`raytree-suffix.png`
/// when `out` is standard output).
fn beside(out: &std::path::Path, suffix: &str) -> PathBuf {
    if render::is_stdout(out) {
        return PathBuf::from(format!("raytree-{suffix}.png"));
    }
    let stem = out
        .file_stem()
        .map_or("raytree".into(), |s| s.to_string_lossy());
    out.with_file_name(format!("{stem}-{suffix}.png"))
}

pub fn run(args: RenderArgs) -> Result<()> {
    common::check_structure(&args.structure)?;
    // Before any work: an output name whose format is unknown.
    render::ImageFormat::of(&args.out)?;
    if render::is_stdout(&args.out) {
        super::out::report_to_stderr();
    }
    if let Some(r) = args.ao_radius {
        if !(r.is_finite() && r > 0.0) {
            return Err(Error::Invalid(format!(
                "--ao-radius {r}: must be a positive number"
            )));
        }
    }
    match args.threads {
        Some(n) => rayon::ThreadPoolBuilder::new()
            .num_threads(n as usize)
            .build()
            .map_err(|e| Error::Invalid(format!("cannot start {n} threads: {e}")))?
            .install(|| run_in_pool(&args)),
        None => run_in_pool(&args),
    }
}

fn run_in_pool(args: &RenderArgs) -> Result<()> {
    let (mut scene, mut scene_report, saved) =
        common::load_scene_with(&args.scene, &args.structure.layout_options())?;
    // The stackless paper's AO view of its CHESS scenes, before the options.
    let paper_chess =
        args.paper && args.integrator == IntegratorArg::Ao && scene.use_stackless_view();
    args.camera.apply(&mut scene.camera)?;

    let chess = scene.is_stackless_chess();
    let (w, h) = match (args.integrator, args.paper, chess) {
        (IntegratorArg::Ao, false, true) => (400, 150),
        (IntegratorArg::Ao, false, false) => (256, 256),
        (IntegratorArg::Ao, true, true) => (800, 300),
        (IntegratorArg::Ao, true, false) => (512, 512),
        (IntegratorArg::Path, false, _) => (512, 512),
        (IntegratorArg::Path, true, _) => (1024, 1024),
    };
    let width = args.width.map_or(w, |v| v as usize);
    let height = args.height.map_or(h, |v| v as usize);
    common::check_fov(&scene.camera, width, height)?;
    let diagonal = scene.mesh.bounds().extent().length();
    let (ao, path) = match args.integrator {
        IntegratorArg::Ao => {
            let radius = args.ao_radius.unwrap_or(if paper_chess {
                Scene::STACKLESS_CHESS_AO_RADIUS
            } else {
                AoSettings::RADIUS_FRACTION * diagonal
            });
            // A user's mesh (a file, not a built-in scene) gets the preview
            // settings unless --paper asks for the paper's: its silhouette
            // against a dark background and its shape by facing ratio.
            let file = !raytree::scene::procedural::is_builtin(&scene.name);
            let mut s = AoSettings::paper(radius);
            if !args.paper {
                if file {
                    s = AoSettings::preview(radius);
                } else {
                    s = AoSettings::plain(4, 8, radius);
                }
            }
            s.eye_rays = args.eye_rays.unwrap_or(s.eye_rays);
            s.ao_rays = args.ao_rays.unwrap_or(s.ao_rays);
            s.query = args.ao_query.unwrap_or(s.query);
            s.sampling = args.sampling.unwrap_or(s.sampling);
            (Some(s), None)
        }
        IntegratorArg::Path => {
            let s = PathSettings {
                samples: args.samples,
                bounces: args.bounces,
                ..PathSettings::default()
            };
            (None, Some(s))
        }
    };
    let integrator = match (&ao, &path) {
        (Some(s), _) => Integrator::Ao(s.clone()),
        (_, Some(s)) => Integrator::Path(s.clone()),
        _ => unreachable!(),
    };
    let (bvh, bvh_stats, built, info) = common::prepare(
        &scene,
        saved,
        &args.scene,
        &args.structure,
        &mut scene_report,
        false,
    )?;
    drop(bvh);
    let bar = common::progress(
        render::tile_count(width, height) as u64,
        "render",
        args.quiet,
    );
    let rendered = built.render(&scene, &integrator, width, height, &|n| bar.inc(n as u64));
    bar.finish_and_clear();
    rendered.image.save(&args.out)?;
    let mut heatmaps = Vec::new();
    for &m in &args.heatmap {
        let file = beside(&args.out, m.name());
        let info = rendered.work.save_scaled(m, &file, args.heatmap_top)?;
        heatmaps.push(Heatmap { info, file });
    }

    let c = rendered.counters;
    let report = RenderReport {
        scene: scene_report,
        bvh: bvh_stats,
        structure: info,
        integrator: args.integrator,
        ao,
        path,
        camera: scene.camera,
        width,
        height,
        threads: rayon::current_num_threads(),
        machine: Machine::detect(&[rayon::current_num_threads()]),
        render_seconds: rendered.seconds,
        rays: c.rays,
        mrays_per_second: c.rays as f64 / rendered.seconds / 1e6,
        counters: c,
        per_ray: c.per_ray(),
        image: args.out.clone(),
        heatmaps,
    };
    print_report(&report);
    if let Some(p) = &args.json {
        common::write_json(p, &report)?;
    }
    Ok(())
}

fn print_report(r: &RenderReport) {
    let b = &r.bvh;
    let s = &r.structure;
    say!(
        "scene      {} ({} triangles)",
        r.scene.scene,
        r.scene.triangles
    );
    common::say_saved(&r.scene);
    say!(
        "bvh        {} builder, {} nodes, depth {}, SAH cost {:.2}, built in {:.3} s",
        b.builder,
        b.nodes,
        b.depth,
        b.sah_cost,
        b.build_seconds
    );
    say!(
        "structure  {}{}: {} (nodes {}, index {}), converted in {:.3} s",
        s.structure.name(),
        s.traversal
            .map(|t| format!("/{}", t.name()))
            .unwrap_or_default(),
        common::mib(s.bytes),
        common::mib(s.node_bytes),
        common::mib(s.index_bytes),
        s.conversion_seconds
    );
    let what = match (&r.ao, &r.path) {
        (Some(a), _) => format!(
            "ao, {} eye rays per pixel, {} AO rays per hit, radius {} ({})",
            a.eye_rays,
            a.ao_rays,
            a.radius,
            a.form()
        ),
        (_, Some(p)) => format!("path, {} spp, {} bounces", p.samples, p.bounces),
        _ => String::new(),
    };
    say!(
        "render     {}×{} {what}: {:.3} s on {} threads",
        r.width,
        r.height,
        r.render_seconds,
        r.threads,
    );
    say!("camera     {}", r.camera);
    say!("rays       {} ({:.2} Mrays/s)", r.rays, r.mrays_per_second);
    say!(
        "per ray    {:.2} nodes, {:.2} plane tests, {:.2} triangle tests",
        r.per_ray.nodes,
        r.per_ray.planes,
        r.per_ray.triangles
    );
    if render::is_stdout(&r.image) {
        say!("wrote      standard output (PNG)");
    } else {
        say!("wrote      {}", r.image.display());
    }
    for h in &r.heatmaps {
        say!(
            "heat map   {} per pixel: mean {:.1}, largest {}; scale 0 (dark) to {} (white): {}",
            h.info.measure.name(),
            h.info.mean,
            h.info.max,
            h.info.scale_top,
            h.file.display()
        );
    }
}
