//! `raytree build`: a structure built once and saved, with its BVH and
//! scene, to a file that `trace`, `render` and `info` load in place of the
//! scene (`-s file.rtree`).

use super::common::{self, SceneArgs, SceneReport, StructureArgs};
use super::out::say;
use clap::Args;
use raytree::bvh::BuildStats;
use raytree::error::{Error, Result};
use raytree::saved::Header;
use raytree::structures::StructureInfo;
use serde::Serialize;
use std::path::PathBuf;
use std::time::Instant;

#[derive(Args, Debug)]
pub struct BuildArgs {
    #[command(flatten)]
    scene: SceneArgs,
    #[command(flatten)]
    structure: StructureArgs,
    /// The file to write (by convention .rtree): a versioned binary file
    /// holding the scene, its canonical BVH and the structure, mapped into
    /// memory to load. Written atomically: a temporary file beside it,
    /// renamed when complete.
    #[arg(long, short = 'o')]
    out: PathBuf,
    /// Worker threads for the BVH build [default: all cores].
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..=1024))]
    threads: Option<u32>,
    /// Also write the report as JSON to this file.
    #[arg(long)]
    json: Option<PathBuf>,
}

#[derive(Serialize)]
struct BuildReport {
    #[serde(flatten)]
    scene: SceneReport,
    bvh: BuildStats,
    structure: StructureInfo,
    /// The file written.
    file: PathBuf,
    /// Its header.
    header: Header,
    /// Writing it, in seconds.
    write_seconds: f64,
}

pub fn run(args: BuildArgs) -> Result<()> {
    common::check_structure(&args.structure)?;
    if raytree::render::is_stdout(&args.out) || args.out.as_os_str().is_empty() {
        return Err(Error::Invalid(
            "raytree build writes a file (-o scene.rtree), not standard output".into(),
        ));
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

fn run_in_pool(args: &BuildArgs) -> Result<()> {
    let (scene, mut scene_report, saved) =
        common::load_scene_with(&args.scene, &args.structure.layout_options())?;
    // From a saved file: what the options ask for differently is built
    // (a structure derived from its BVH without building a new one).
    let (bvh, bvh_stats, built, info) = common::prepare(
        &scene,
        saved,
        &args.scene,
        &args.structure,
        &mut scene_report,
        true,
    )?;
    let start = Instant::now();
    let header = {
        let _stage = common::Stage::new(format!("writing {}", args.out.display()));
        raytree::saved::save(&args.out, &scene, &bvh, &built, &info)?
    };
    let report = BuildReport {
        scene: scene_report,
        bvh: bvh_stats,
        structure: info,
        file: args.out.clone(),
        header,
        write_seconds: start.elapsed().as_secs_f64(),
    };
    let (b, s, h) = (&report.bvh, &report.structure, &report.header);
    say!(
        "scene      {} ({} triangles, {} geometries), loaded in {:.3} s",
        report.scene.scene,
        report.scene.triangles,
        report.scene.geometries.len(),
        report.scene.load_seconds
    );
    common::say_saved(&report.scene);
    say!(
        "bvh        {} builder, leaves of at most {}{}: {} nodes, depth {}, SAH cost {:.2}, built in {:.3} s",
        b.builder,
        b.max_leaf_size,
        common::sah_block_note(b.sah_block),
        b.nodes,
        b.depth,
        b.sah_cost,
        b.build_seconds
    );
    say!(
        "structure  {}{} over the {} layout: {} (nodes {}, index {}), converted in {:.3} s",
        s.structure.name(),
        s.traversal
            .map(|t| format!("/{}", t.name()))
            .unwrap_or_default(),
        s.layout,
        common::mib(s.bytes),
        common::mib(s.node_bytes),
        common::mib(s.index_bytes),
        s.conversion_seconds
    );
    say!(
        "wrote      {}: {}, format version {}, {} sections, in {:.3} s",
        report.file.display(),
        common::mib(h.file_bytes as usize),
        h.version,
        h.sections.len(),
        report.write_seconds
    );
    if let Some(p) = &args.json {
        common::write_json(p, &report)?;
    }
    Ok(())
}
