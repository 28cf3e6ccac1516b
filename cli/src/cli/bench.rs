//! `raytree bench`: the papers' measurements.

use super::common::{self, BuilderArg};
use super::out::say;
use crate::bench::machine::Machine;
use crate::bench::stackless::{self, Preset};
use crate::bench::svg::{stacked_bars, Bar};
use crate::bench::{dst, peers, report};
use clap::{Args, Subcommand};
use raytree::bvh::{BuildOptions, Builder};
use raytree::error::Result;
use raytree::render::{AoQuery, AoSettings, Sampling};
use raytree::structures::StructureKind;
use std::path::PathBuf;

#[derive(Subcommand, Debug)]
pub enum BenchCommand {
    /// The stackless paper's Table 1 and Figure 5: AO render time of every
    /// traversal (eye and AO phases), ratios to STACK on the same nodes,
    /// per-ray work, state sizes; STACK, SPARSE and LAINE-k also on the
    /// paper tracer's own 64-byte nodes (the `*-paired` rows).
    Stackless(StacklessArgs),
    /// The dual-split paper's Tables 1 to 3: storage, path-tracing frame
    /// time and per-ray nodes, plane tests and triangle tests of every
    /// structure converted from one BVH, with node-type distributions.
    Dst(DstArgs),
    /// raytree (binary BVH, bvh4, bvh8, cwbvh, bvh8 over SBVH, and its
    /// fastest per ray kind) beside Embree 3 at medium and high quality
    /// (feature `embree`), tinybvh's BVH8_CPU (feature `tinybvh`, in an
    /// AVX2 build) and obvhs (feature `obvhs`) on the same primary, AO and
    /// path rays: Mrays/s and ratios to raytree's BVH with STACK.
    Peers(PeersArgs),
    /// The GPU back end (feature `gpu`): the stackless paper's Table 1 on
    /// AO rays and the dual-split paper's frame-time ratio on path-tracing
    /// bounce rays, on the GPU beside the CPU, with the adapter, its driver
    /// and limits.
    Gpu(super::gpu::GpuBenchArgs),
}

#[derive(Args, Debug)]
pub struct PeersArgs {
    /// Scenes, repeatable: built-in names or mesh files (.obj, .ply, .stl,
    /// .gltf, .glb; several files joined by commas make one scene) [default: chess
    /// and hairball; with --preset paper, atrium, forest, plant:12M,
    /// chess:1M and hairball:1M].
    #[arg(long = "scene", short = 's')]
    scenes: Vec<String>,
    /// quick: 256×256 rays per set, 3 timed runs; paper: 1024×1024, 5 runs.
    #[arg(long, value_enum, default_value_t = dst::Preset::Quick)]
    preset: dst::Preset,
    /// Image width in pixels (primary rays per row), overriding the preset's.
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..=16384))]
    width: Option<u32>,
    /// Image height in pixels, overriding the preset's.
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..=16384))]
    height: Option<u32>,
    /// Timed runs of each ray set by each contender (the median counts).
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..=100))]
    repeats: Option<u32>,
    /// Builds of each contender, taking turns (the fastest counts).
    #[arg(long, default_value_t = 3, value_parser = clap::value_parser!(u32).range(1..=100))]
    build_repeats: u32,
    /// raytree's SAH leaf cost in blocks of this many triangles (1, 2, 4,
    /// 8, 16; Embree's sahBlockSize), for the SAH and the SBVH builds.
    /// Default 4: Embree's own for the four-triangle leaf blocks that its
    /// BVH8 and raytree's wide layouts both test in one pass (the papers'
    /// benchmarks and the other commands keep 1).
    #[arg(long, default_value = "4", value_parser = common::sah_block_parser())]
    sah_block: usize,
    /// Worker threads [default: all cores].
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..=1024))]
    threads: Option<u32>,
    /// Also write the results as JSON to this file.
    #[arg(long)]
    json: Option<PathBuf>,
    /// No progress bar.
    #[arg(long, short = 'q')]
    quiet: bool,
}

#[derive(Args, Debug)]
pub struct DstArgs {
    /// Scenes, repeatable: built-in names or mesh files (.obj, .ply, .stl,
    /// .gltf, .glb; several files joined by commas make one scene) [default: chess
    /// and hairball; with --preset paper, the paper's analogues atrium
    /// (Sponza), forest (vegetation), plant:12M (Powerplant), chess:1M and
    /// hairball:1M].
    #[arg(long = "scene", short = 's')]
    scenes: Vec<String>,
    /// quick: 256×256, 2 frames; paper: 1024×1024, 32 frames (as the paper).
    #[arg(long, value_enum, default_value_t = dst::Preset::Quick)]
    preset: dst::Preset,
    /// Frames per structure, overriding the preset's.
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..=10000))]
    frames: Option<u32>,
    /// Image width in pixels, overriding the preset's.
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..=16384))]
    width: Option<u32>,
    /// Image height in pixels, overriding the preset's.
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..=16384))]
    height: Option<u32>,
    /// Structures to measure, comma-separated [default: bvh, dst,
    /// dst-similar, bih, htree, cbvh]; ratios are to bvh when it is among them.
    #[arg(long, short = 'a', value_parser = common::named::<StructureKind>(), value_delimiter = ',')]
    accel: Vec<StructureKind>,
    /// BVH builder [default: binned SAH, as the paper's Embree build].
    #[arg(long, value_enum, default_value_t = BuilderArg::Sah)]
    builder: BuilderArg,
    /// Most triangles in a BVH leaf (the paper: 8).
    #[arg(long, default_value_t = 8, value_parser = clap::value_parser!(u16).range(1..=255))]
    max_leaf: u16,
    /// Worker threads [default: all cores].
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..=1024))]
    threads: Option<u32>,
    /// Also write the results as JSON to this file.
    #[arg(long)]
    json: Option<PathBuf>,
    /// Write report.html (tables, bar charts, frames and heat maps, self-
    /// contained), dst.csv and dst.json into this directory.
    #[arg(long)]
    report: Option<PathBuf>,
    /// No progress bar.
    #[arg(long, short = 'q')]
    quiet: bool,
    /// The camera of every scene [default: each scene's own].
    #[command(flatten)]
    camera: common::CameraArgs,
}

#[derive(Args, Debug)]
pub struct StacklessArgs {
    /// Scenes, repeatable: built-in names or mesh files (.obj, .ply, .stl,
    /// .gltf, .glb; several files joined by commas make one scene)
    /// [default: chess and hairball; with --preset paper, hairball:2.8M as in the paper].
    #[arg(long = "scene", short = 's')]
    scenes: Vec<String>,
    /// quick: small images, 4 eye rays per pixel and 4 AO rays per hit,
    /// any-hit AO rays, independent samples, each scene's camera;
    /// paper: the stackless paper's workload as its tracer ran it: 800×300
    /// (chess) or 512×512, 16 eye rays per pixel on a 4×4 stratified grid,
    /// 16 closest-hit AO rays per hit, and on its CHESS scenes (chess,
    /// battlefield.obj) its camera (50° horizontal, non-square pixels) and
    /// AO radius 32.
    #[arg(long, value_enum, default_value_t = Preset::Quick)]
    preset: Preset,
    /// How AO rays are traced: any-hit, or closest-hit from the hit point as
    /// the stackless paper's tracer [default: quick any, paper closest].
    #[arg(long, value_parser = common::named::<AoQuery>())]
    ao_query: Option<AoQuery>,
    /// How eye rays and AO directions are sampled [default: quick
    /// independent, paper stratified].
    #[arg(long, value_parser = common::named::<Sampling>())]
    sampling: Option<Sampling>,
    /// BVH builder [default: the paper's hybrid, SAH for 8 levels then median].
    #[arg(long, value_enum, default_value_t = BuilderArg::Hybrid)]
    builder: BuilderArg,
    /// Most triangles in a BVH leaf.
    #[arg(long, default_value_t = 8, value_parser = clap::value_parser!(u16).range(1..=255))]
    max_leaf: u16,
    /// Thread counts to measure, comma-separated [default: 1 and all cores].
    #[arg(long, value_delimiter = ',', value_parser = clap::value_parser!(u32).range(1..=1024))]
    threads: Vec<u32>,
    /// Timed renders per measurement, after one counted, untimed render;
    /// the fastest counts.
    #[arg(long, default_value_t = 1, value_parser = clap::value_parser!(u32).range(1..=100))]
    repeats: u32,
    /// Also write the results as JSON to this file.
    #[arg(long)]
    json: Option<PathBuf>,
    /// Write one SVG bar chart (eye and AO time per algorithm, like Figure 5)
    /// per scene and thread count into this directory.
    #[arg(long)]
    charts: Option<PathBuf>,
    /// No progress bar.
    #[arg(long, short = 'q')]
    quiet: bool,
    /// The camera of every scene [default: each scene's own].
    #[command(flatten)]
    camera: common::CameraArgs,
    /// AO ray length in scene units [default: 0.045 × each scene's diagonal].
    #[arg(long)]
    ao_radius: Option<f32>,
}

pub fn run(cmd: BenchCommand) -> Result<()> {
    match cmd {
        BenchCommand::Stackless(a) => run_stackless(a),
        BenchCommand::Dst(a) => run_dst(a),
        BenchCommand::Peers(a) => run_peers(a),
        BenchCommand::Gpu(a) => super::gpu::run_bench(a),
    }
}

fn thread_pool(threads: Option<u32>) -> Result<rayon::ThreadPool> {
    let threads = threads.map_or(rayon::current_num_threads(), |t| t as usize);
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .map_err(|e| raytree::error::Error::Invalid(format!("cannot start {threads} threads: {e}")))
}

fn run_peers(a: PeersArgs) -> Result<()> {
    let scenes = if a.scenes.is_empty() {
        a.preset.scenes()
    } else {
        a.scenes.clone()
    };
    let mut opts = match a.preset {
        dst::Preset::Quick => peers::Options::quick(),
        dst::Preset::Paper => peers::Options::paper(),
    };
    opts.width = a.width.map_or(opts.width, |v| v as usize);
    opts.height = a.height.map_or(opts.height, |v| v as usize);
    opts.repeats = a.repeats.map_or(opts.repeats, |v| v as usize);
    opts.build_repeats = a.build_repeats as usize;
    opts.build = opts.build.with_sah_block(a.sah_block);
    let pool = thread_pool(a.threads)?;
    let machine = Machine::detect(&[pool.current_num_threads()]);
    say!("{}", machine.describe());
    let contenders = peers::available();
    say!("contenders: {}", contenders.join(", "));
    for m in peers::missing() {
        say!("({m})");
    }
    let runs = scenes.len() * peers::WORKLOADS.len() * opts.repeats * contenders.len();
    let bar = common::progress(runs as u64, "bench peers", a.quiet);
    let mut results = Vec::new();
    for spec in &scenes {
        bar.set_message(format!("bench peers: {spec}"));
        let scene = bar.suspend(|| common::load_spec(spec))?;
        let r = pool.install(|| peers::run_scene(&scene, &opts, &|| bar.inc(1)))?;
        let md = peers::markdown(&r);
        bar.suspend(|| say!("{md}"));
        results.push(r);
    }
    bar.finish_and_clear();
    say!("Mrays/s from the median of {} runs on {} threads; (×) is the speed over raytree's BVH with STACK, same run. primary and path: closest hit; ao: any hit. Build times: the fastest of {} builds, the contenders taking turns.", opts.repeats, pool.current_num_threads(), opts.build_repeats);
    for peer in ["embree high", "embree medium", "obvhs cwbvh"] {
        if let Some(g) = peers::geomean_ratios(&results, peers::FASTEST, peer) {
            let cells: Vec<String> = g.iter().map(|(w, r)| format!("{w} {r:.2}×")).collect();
            say!(
                "geometric mean over {} scenes, raytree fastest vs {peer} (above 1: raytree faster): {}",
                results.len(),
                cells.join(", ")
            );
        }
    }
    for (of, to) in [
        (peers::RAYTREE[0], "embree medium"),
        (peers::RAYTREE[2], "embree medium"),
        (peers::RAYTREE[4], "embree high"),
        (peers::RAYTREE[5], "embree medium"),
    ] {
        if let Some(g) = peers::geomean_build_ratio(&results, of, to) {
            say!(
                "geometric mean over {} scenes, build time of {of} over {to}'s (below 1: raytree builds faster): {g:.2}×",
                results.len()
            );
        }
    }
    if let Some(p) = &a.json {
        common::write_bench_json(p, &machine, &results)?;
    }
    Ok(())
}

fn run_dst(a: DstArgs) -> Result<()> {
    let scenes = if a.scenes.is_empty() {
        a.preset.scenes()
    } else {
        a.scenes.clone()
    };
    let (w, h) = a.preset.size();
    let width = a.width.map_or(w, |v| v as usize);
    let height = a.height.map_or(h, |v| v as usize);
    let builder = Builder::from(a.builder);
    let opts = dst::Options {
        build: BuildOptions::new(builder).with_max_leaf_size(a.max_leaf as usize),
        width,
        height,
        frames: a.frames.map_or(a.preset.frames(), |f| f as usize),
        structures: if a.accel.is_empty() {
            dst::STRUCTURES.to_vec()
        } else {
            a.accel.clone()
        },
    };
    let pool = thread_pool(a.threads)?;
    let machine = Machine::detect(&[pool.current_num_threads()]);
    say!("{}", machine.describe());
    // One untimed counting frame per structure, then the timed ones.
    let frames = scenes.len() * (opts.frames.max(1) + 1) * opts.structures.len();
    let bar = common::progress(frames as u64, "bench dst", a.quiet);
    let mut results = Vec::new();
    let mut tables = Vec::new();
    for spec in &scenes {
        bar.set_message(format!("bench dst: {spec}"));
        let mut scene = bar.suspend(|| common::load_spec(spec))?;
        a.camera.apply(&mut scene.camera)?;
        let r = pool.install(|| dst::run_scene(&scene, &opts, &|| bar.inc(1)))?;
        let md = dst::markdown(&r);
        bar.suspend(|| say!("{md}"));
        tables.push(md);
        results.push(r);
    }
    bar.finish_and_clear();
    if let Some(md) = dst::summary(&results) {
        say!("{md}");
    }
    say!("vs bvh: storage (nodes and triangle index list), node storage alone (in MiB, as the paper's Table 1 counts it), mean frame time and per-ray work over the uncompressed BVH's (52-byte inner nodes, 4-byte leaves), same run; plane tests count 6 per box and 2 per two-plane node; {} where the BVH was not measured.", dst::NONE);
    if let Some(p) = &a.json {
        common::write_bench_json(p, &machine, &results)?;
    }
    if let Some(dir) = &a.report {
        std::fs::create_dir_all(dir).map_err(|source| raytree::error::Error::Io {
            path: dir.into(),
            source,
        })?;
        let write = |name: &str, text: String| {
            raytree::render::write_atomically(&dir.join(name), |w| {
                use std::io::Write;
                w.write_all(text.as_bytes())
            })
        };
        write("report.html", report::html(&results, &tables, &machine))?;
        write("dst.csv", report::csv(&results))?;
        common::write_bench_json(&dir.join("dst.json"), &machine, &results)?;
        say!("report: {}", dir.join("report.html").display());
    }
    Ok(())
}

fn run_stackless(a: StacklessArgs) -> Result<()> {
    let scenes = if a.scenes.is_empty() {
        match a.preset {
            Preset::Quick => vec!["chess".to_owned(), "hairball".to_owned()],
            Preset::Paper => vec!["chess".to_owned(), "hairball:2.8M".to_owned()],
        }
    } else {
        a.scenes.clone()
    };
    let threads: Vec<usize> = if a.threads.is_empty() {
        let all = rayon::current_num_threads();
        if all > 1 {
            vec![1, all]
        } else {
            vec![1]
        }
    } else {
        a.threads.iter().map(|&t| t as usize).collect()
    };
    let builder = Builder::from(a.builder);
    let opts = stackless::Options {
        preset: a.preset,
        build: BuildOptions::new(builder).with_max_leaf_size(a.max_leaf as usize),
        threads: threads.clone(),
        repeats: a.repeats as usize,
        radius_fraction: AoSettings::RADIUS_FRACTION,
        radius: a.ao_radius,
        query: a.ao_query,
        sampling: a.sampling,
    };
    if let Some(r) = a.ao_radius {
        if !(r.is_finite() && r > 0.0) {
            return Err(raytree::error::Error::Invalid(format!(
                "--ao-radius {r}: must be a positive number"
            )));
        }
    }
    let machine = Machine::detect(&threads);
    say!("{}", machine.describe());
    // Per row: one counted render, then the timed ones.
    let renders = scenes.len() * threads.len() * stackless::ROWS.len() * (1 + a.repeats as usize);
    let bar = common::progress(renders as u64, "bench stackless", a.quiet);
    let mut results = Vec::new();
    for spec in &scenes {
        bar.set_message(format!("bench stackless: {spec}"));
        let mut scene = bar.suspend(|| common::load_spec(spec))?;
        a.preset.apply_view(&mut scene);
        a.camera.apply(&mut scene.camera)?;
        let (w, h) = a.preset.size(&scene);
        common::check_fov(&scene.camera, w, h)?;
        let r = stackless::run_scene(&scene, &opts, &|| bar.inc(1))?;
        bar.suspend(|| say!("{}", stackless::markdown(&r)));
        if let Some(dir) = &a.charts {
            write_charts(dir, &r)?;
        }
        results.push(r);
    }
    bar.finish_and_clear();
    say!(
        "ratio: time over STACK's on the same nodes, same scene and threads: {}'s (the 32-byte own-box nodes) for the binary, implicit and sparse rows, {}'s for the rows on the paper tracer's 64-byte nodes; state B counts 4 bytes per 32-bit state variable (8 per 64-bit), a stack adds its head and 4 bytes per entry.",
        stackless::REFERENCE,
        stackless::PAIRED_REFERENCE
    );
    if let Some(p) = &a.json {
        common::write_bench_json(p, &machine, &results)?;
    }
    Ok(())
}

fn write_charts(dir: &std::path::Path, r: &stackless::SceneResult) -> Result<()> {
    std::fs::create_dir_all(dir).map_err(|source| raytree::error::Error::Io {
        path: dir.into(),
        source,
    })?;
    let mut threads: Vec<usize> = r.rows.iter().map(|row| row.threads).collect();
    threads.dedup();
    for t in threads {
        let bars: Vec<Bar> = r
            .rows
            .iter()
            .filter(|row| row.threads == t)
            .map(|row| Bar {
                label: row.algorithm.to_owned(),
                segments: vec![row.eye.seconds, row.ao.seconds],
                note: format!("×{:.2}  {} B state", row.ratio, row.state_bytes),
            })
            .collect();
        let svg = stacked_bars(
            &format!("{}: AO render time, {} thread(s)", r.scene, t),
            &["eye rays", "AO rays"],
            "s",
            &bars,
        );
        let name: String = r
            .scene
            .chars()
            .map(|c| if c.is_ascii_alphanumeric() { c } else { '-' })
            .collect();
        let path = dir.join(format!("stackless-{name}-{t}t.svg"));
        raytree::render::write_atomically(&path, |w| {
            use std::io::Write;
            w.write_all(svg.as_bytes())
        })?;
    }
    Ok(())
}
