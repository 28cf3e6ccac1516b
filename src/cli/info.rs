//! `raytree info`.

use super::common::{self, SceneArgs, SceneReport};
use clap::Args;
use raytree::accel::{Built, StructureInfo, StructureKind, TraversalKind};
use raytree::bvh::BuildStats;
use raytree::error::Result;
use serde::Serialize;
use std::path::PathBuf;

#[derive(Args, Debug)]
pub struct InfoArgs {
    #[command(flatten)]
    scene: SceneArgs,
    /// Also write the report as JSON to this file.
    #[arg(long)]
    json: Option<PathBuf>,
}

#[derive(Serialize)]
struct InfoReport {
    #[serde(flatten)]
    scene: SceneReport,
    bvh: BuildStats,
    structures: Vec<StructureInfo>,
}

pub fn run(args: InfoArgs) -> Result<()> {
    let (scene, scene_report) = common::load_scene(&args.scene)?;
    let (bvh, bvh_stats) = common::build_bvh(&scene, &args.scene);
    let mut structures = Vec::new();
    for &s in StructureKind::all().iter().filter(|s| s.is_available()) {
        let (_, info) = Built::new(s, TraversalKind::Stack, &bvh, scene.triangles.clone())?;
        structures.push(info);
    }
    let r = InfoReport {
        scene: scene_report,
        bvh: bvh_stats,
        structures,
    };
    let (lo, hi) = (r.scene.bounds_min, r.scene.bounds_max);
    println!("scene       {}", r.scene.scene);
    println!(
        "triangles   {} ({} vertices), loaded in {:.3} s",
        r.scene.triangles, r.scene.vertices, r.scene.load_seconds
    );
    println!("bounds      {lo:?} .. {hi:?}");
    let b = &r.bvh;
    println!(
        "bvh         {} builder, leaves of at most {}: {} nodes ({} inner, {} leaves), depth {}, SAH cost {:.3}, {} degenerate triangles left out, built in {:.3} s",
        b.builder, b.max_leaf_size, b.nodes, b.inner_nodes, b.leaves, b.depth, b.sah_cost, b.degenerate_triangles, b.build_seconds
    );
    println!();
    println!(
        "| structure | bytes | MiB | node bytes | index bytes | inner nodes | leaves | conversion s |"
    );
    println!("|---|---:|---:|---:|---:|---:|---:|---:|");
    for s in &r.structures {
        println!(
            "| {} | {} | {:.3} | {} | {} | {} | {} | {:.4} |",
            s.structure.name(),
            s.bytes,
            s.bytes as f64 / 1048576.0,
            s.node_bytes,
            s.index_bytes,
            s.inner_nodes,
            s.leaves,
            s.conversion_seconds
        );
    }
    if let Some(p) = &args.json {
        common::write_json(p, &r)?;
    }
    Ok(())
}
