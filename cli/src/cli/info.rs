//! `raytree info`.

use super::common::{self, SceneArgs, SceneReport};
use super::out::say;
use clap::Args;
use raytree::bvh::BuildStats;
use raytree::error::Result;
use raytree::structures::{simd, Built, StructureInfo, StructureKind, TraversalKind};
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
    /// The SIMD path the wide kernels run on, and the ones this processor
    /// offers.
    simd: SimdReport,
    structures: Vec<StructureInfo>,
    /// Structures that cannot be built for this scene, with the limit that
    /// stops them.
    refused: Vec<Refused>,
}

#[derive(Serialize)]
pub struct SimdReport {
    pub active: &'static str,
    /// "chosen at run time" or "forced (RAYTREE_SIMD or set_active)".
    pub chosen: &'static str,
    pub supported: Vec<&'static str>,
}

impl SimdReport {
    pub fn detect() -> Self {
        SimdReport {
            active: simd::active().name(),
            chosen: simd::how_chosen(),
            supported: simd::supported().iter().map(|p| p.name()).collect(),
        }
    }

    /// One line: the path that runs and the ones this processor offers.
    pub fn describe(&self) -> String {
        format!(
            "{}, {} (this processor: {}; RAYTREE_SIMD forces one)",
            simd::active().describe(),
            self.chosen,
            self.supported.join(", ")
        )
    }
}

#[derive(Serialize)]
struct Refused {
    structure: StructureKind,
    error: String,
}

pub fn run(args: InfoArgs) -> Result<()> {
    let (scene, mut scene_report, saved) = common::load_scene(&args.scene)?;
    // A saved structure's BVH is the one every structure is derived from.
    let (bvh, bvh_stats) = common::bvh_for(
        &scene,
        &args.scene,
        saved.map(|s| s.bvh),
        &mut scene_report,
        false,
    )?;
    let mut structures = Vec::new();
    let mut refused = Vec::new();
    // One structure at a time, dropped before the next: a big scene needs
    // only one derived structure in memory beside the BVH.
    for &s in StructureKind::all() {
        match Built::new(s, TraversalKind::Stack, &bvh, scene.triangles.clone()) {
            Ok((_, info)) => structures.push(info),
            Err(e) => refused.push(Refused {
                structure: s,
                error: e.to_string(),
            }),
        }
    }
    let r = InfoReport {
        scene: scene_report,
        bvh: bvh_stats,
        simd: SimdReport::detect(),
        structures,
        refused,
    };
    let (lo, hi) = (r.scene.bounds_min, r.scene.bounds_max);
    say!("scene       {}", r.scene.scene);
    say!(
        "triangles   {} ({} vertices), loaded in {:.3} s",
        r.scene.triangles,
        r.scene.vertices,
        r.scene.load_seconds
    );
    say!("bounds      {lo:?} .. {hi:?}");
    if let Some(s) = &r.scene.saved {
        let h = &s.header;
        say!(
            "saved       {}: {}{} over the {} layout, format version {}, {} in {} sections, loaded in {:.3} s",
            s.file.display(),
            h.structure.name(),
            if h.structure == StructureKind::Bvh {
                format!("/{}", h.traversal.name())
            } else {
                String::new()
            },
            h.layout,
            h.version,
            common::mib(h.file_bytes as usize),
            h.sections.len(),
            s.load_seconds
        );
    }
    let geometries = &r.scene.geometries;
    say!("geometries  {}", geometries.len());
    // A glTF scene can hold thousands: the first few here, all in --json.
    const SHOWN: usize = 10;
    if geometries.len() > 1 {
        for g in geometries.iter().take(SHOWN) {
            say!(
                "  {:>4}  {}: {} triangles ({}..{})",
                g.id,
                g.name,
                g.triangles,
                g.first_triangle,
                u64::from(g.first_triangle) + u64::from(g.triangles)
            );
        }
        if geometries.len() > SHOWN {
            say!(
                "  ...   and {} more (--json lists them all)",
                geometries.len() - SHOWN
            );
        }
    }
    let b = &r.bvh;
    say!(
        "bvh         {} builder, leaves of at most {}{}: {} nodes ({} inner, {} leaves), {} triangle references, depth {}, SAH cost {:.3}, {} degenerate triangles left out, built in {:.3} s",
        b.builder, b.max_leaf_size,
        common::sah_block_note(b.sah_block),
        b.nodes, b.inner_nodes, b.leaves, b.references, b.depth, b.sah_cost, b.degenerate_triangles, b.build_seconds
    );
    if let Some(p) = b.peak_heap_bytes {
        say!(
            "            peak heap during the build: {} ({} bytes per triangle reference)",
            common::mib(p as usize),
            p / (b.references.max(1) as u64)
        );
    }
    if let Some(o) = &b.optimized {
        say!(
            "            optimized by reinsertion: SAH cost {:.3} -> {:.3} ({} reinsertions in {} rounds, {:.3} s)",
            o.sah_cost_before, o.sah_cost_after, o.reinsertions, o.rounds, o.seconds
        );
    }
    say!("simd        {}", r.simd.describe());
    say!();
    let bvh = r
        .structures
        .iter()
        .find(|s| s.structure == StructureKind::Bvh);
    let ratio = |bytes: usize, of: Option<usize>| {
        of.map_or("-".into(), |b| {
            format!("{:.1}%", 100.0 * bytes as f64 / b.max(1) as f64)
        })
    };
    // Against the BVH's nodes and index list, and (as the dual-split paper
    // counts storage) against its nodes alone.
    let vs_bvh = |bytes: usize| ratio(bytes, bvh.map(|b| b.bytes));
    let vs_bvh_nodes = |bytes: usize| ratio(bytes, bvh.map(|b| b.node_bytes));
    say!(
        "| structure | bytes | MiB | vs bvh | node bytes | vs bvh nodes | index bytes | inner nodes | leaves | conversion s |"
    );
    say!("|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|");
    for s in &r.structures {
        say!(
            "| {} | {} | {:.3} | {} | {} | {} | {} | {} | {} | {:.4} |",
            s.structure.name(),
            s.bytes,
            s.bytes as f64 / raytree::stats::MIB,
            vs_bvh(s.bytes),
            s.node_bytes,
            vs_bvh_nodes(s.node_bytes),
            s.index_bytes,
            s.inner_nodes,
            s.leaves,
            s.conversion_seconds
        );
    }
    for x in &r.refused {
        say!("| {} | refused: {} ||||||||", x.structure.name(), x.error);
    }
    let dsts: Vec<_> = r
        .structures
        .iter()
        .filter_map(|s| s.dst.as_ref().map(|d| (s.structure, d)))
        .collect();
    if !dsts.is_empty() {
        say!();
        say!("| two-plane tree (bih: clip nodes are 1-axis carving) | storage vs bvh | least identical vs bvh | nodes vs bvh nodes | least identical vs bvh nodes | split | carve 1-axis | carve 2-axis | carving leaves | plain leaves | 0 / 1 / 2 / 3 carving levels | 1-axis : 2-axis |");
        say!("|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---|---|");
        for (kind, d) in dsts {
            let levels = d.carving_levels;
            let all = levels.iter().sum::<usize>().max(1) as f64;
            let carves = (d.carve_single + d.carve_dual).max(1) as f64;
            say!(
                "| {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {:.0}% / {:.0}% / {:.0}% / {:.1}% | {:.0}% : {:.0}% |",
                kind.name(),
                vs_bvh(d.node_bytes + d.index_bytes),
                vs_bvh(d.least_identical_bytes),
                vs_bvh_nodes(d.node_bytes),
                vs_bvh_nodes(d.least_identical_bytes.saturating_sub(d.index_bytes)),
                d.split_nodes,
                d.carve_single,
                d.carve_dual,
                d.carving_leaves,
                d.plain_leaves,
                100.0 * levels[0] as f64 / all,
                100.0 * levels[1] as f64 / all,
                100.0 * levels[2] as f64 / all,
                100.0 * levels[3] as f64 / all,
                100.0 * d.carve_single as f64 / carves,
                100.0 * d.carve_dual as f64 / carves,
            );
        }
    }
    for s in &r.structures {
        if let Some(h) = &s.htree {
            say!();
            say!("| h-tree | split | bounding | leaves | bounding nodes storing 1 / 2 / 3 / 4 / 5 / 6 faces |");
            say!("|---|---:|---:|---:|---|");
            let f = h.bound_faces;
            say!(
                "| {} | {} | {} | {} | {} / {} / {} / {} / {} / {} |",
                s.structure.name(),
                h.split_nodes,
                h.bound_nodes,
                h.leaves,
                f[1],
                f[2],
                f[3],
                f[4],
                f[5],
                f[6]
            );
        }
    }
    if let Some(p) = &args.json {
        common::write_json(p, &r)?;
    }
    Ok(())
}
