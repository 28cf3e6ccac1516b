//! The dual-split paper's Tables 1 to 3: storage, path-tracing frame time
//! and per-ray work (nodes, plane tests, triangle tests) of every structure
//! converted from one BVH, with node-type distributions and carving levels.
//!
//! The workload is the paper's: diffuse path tracing, 1 sample per pixel, 5
//! bounces without Russian roulette, every ray a closest-hit query, on all
//! cores. Every structure first renders one untimed frame that counts the
//! work and gives the image; it also warms the caches and pages that the
//! first timed frame would otherwise pay for (on plant:12M at 256×256 that
//! added 5–9% to the first structure's mean over 16 frames). The timed
//! frames then run with the counters compiled out, round-robin over the
//! structures (frame 1 of each, then frame 2 of each, ...) so that drift in
//! the machine's speed touches every structure alike; a structure's frame
//! time is the mean over its frames. Ratios are to the uncompressed BVH in
//! the same run.

use raytree::bvh::{BuildOptions, BuildStats, Bvh};
use raytree::error::Result;
use raytree::render::heatmap::Measure;
use raytree::render::{render, render_uncounted, Image, Integrator, PathSettings, Rendered};
use raytree::scene::Scene;
use raytree::stats::{PerRay, MIB};
use raytree::structures::dst::DstStats;
use raytree::structures::htree::HtreeStats;
use raytree::structures::{Accel, Built, StructureKind, TraversalKind, WithAccel};
use serde::Serialize;

/// The structures of Table 1, in the paper's order, then the wide BVHs beside
/// them (`bvh4`, `bvh8`, and `cwbvh`, the storage-lean wide layout).
pub const STRUCTURES: [StructureKind; 9] = [
    StructureKind::Bvh,
    StructureKind::Dst,
    StructureKind::DstSimilar,
    StructureKind::Bih,
    StructureKind::Htree,
    StructureKind::Cbvh,
    StructureKind::Bvh4,
    StructureKind::Bvh8,
    StructureKind::Cwbvh,
];

/// Image size and frame count of a run.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, clap::ValueEnum)]
#[serde(rename_all = "lowercase")]
pub enum Preset {
    /// 256×256, 2 frames.
    Quick,
    /// The paper's 1024×1024, averaged over 32 frames.
    Paper,
}

impl Preset {
    pub fn size(self) -> (usize, usize) {
        match self {
            Preset::Quick => (256, 256),
            Preset::Paper => (1024, 1024),
        }
    }

    pub fn frames(self) -> usize {
        match self {
            Preset::Quick => 2,
            Preset::Paper => 32,
        }
    }

    /// The scenes measured when none are named: the small built-ins, or
    /// the paper's analogues (Sponza, vegetation, Powerplant) with chess
    /// and hairball at 1M triangles.
    pub fn scenes(self) -> Vec<String> {
        let names: &[&str] = match self {
            Preset::Quick => &["chess", "hairball"],
            Preset::Paper => &["atrium", "forest", "plant:12M", "chess:1M", "hairball:1M"],
        };
        names.iter().map(|s| s.to_string()).collect()
    }
}

pub struct Options {
    pub build: BuildOptions,
    pub width: usize,
    pub height: usize,
    pub frames: usize,
    pub structures: Vec<StructureKind>,
}

/// One structure's row of Table 1.
#[derive(Clone, Debug, Serialize)]
pub struct Row {
    pub structure: StructureKind,
    pub bytes: usize,
    pub node_bytes: usize,
    pub index_bytes: usize,
    pub nodes: usize,
    pub conversion_seconds: f64,
    /// Mean frame time.
    pub frame_seconds: f64,
    pub fastest_frame_seconds: f64,
    pub rays: u64,
    pub mrays_per_second: f64,
    pub per_ray: PerRay,
    /// Ratios to the BVH's, when the BVH was among the structures measured.
    #[serde(flatten)]
    pub vs_bvh: Option<VsBvh>,
    /// Node kinds and carving levels (dual-split trees and the BIH).
    pub dst: Option<DstStats>,
    /// Node kinds (H-tree).
    pub htree: Option<HtreeStats>,
}

/// One structure against the uncompressed BVH of the same run.
#[derive(Clone, Copy, Debug, Serialize, PartialEq)]
pub struct VsBvh {
    /// `bytes` (nodes and triangle index list) over the BVH's.
    pub storage_ratio: f64,
    /// `node_bytes` over the BVH's: the paper's Table 1 storage, which
    /// counts nodes only (its 7.04 MB BVH of Crytek Sponza is 263,533 nodes
    /// at 52 and 4 bytes, in MiB, without the index list).
    pub node_storage_ratio: f64,
    /// `frame_seconds` over the BVH's.
    pub frame_ratio: f64,
    /// Per-ray work over the BVH's: nodes, plane tests, triangle tests.
    pub nodes_ratio: f64,
    pub planes_ratio: f64,
    pub triangles_ratio: f64,
    /// Whether the first frame equals the BVH's bit for bit.
    pub same_image: bool,
}

#[derive(Clone, Debug, Serialize)]
pub struct SceneResult {
    pub scene: String,
    pub triangles: usize,
    pub bvh: BuildStats,
    pub width: usize,
    pub height: usize,
    pub frames: usize,
    pub threads: usize,
    pub path: PathSettings,
    pub rows: Vec<Row>,
    /// The rendered frame and heat maps, for the HTML report.
    #[serde(skip)]
    pub pictures: Pictures,
}

/// Pictures of one scene, as PNG bytes.
#[derive(Clone, Debug, Default)]
pub struct Pictures {
    /// The first frame (every structure renders the same one; see the
    /// rows' `same_image`).
    pub frame: Vec<u8>,
    /// Heat maps of plane and triangle tests per pixel for the BVH and the
    /// dual-split tree, each measure on one scale (the paper's Figure 1).
    pub heatmaps: Vec<Heatmap>,
}

#[derive(Clone, Debug)]
pub struct Heatmap {
    pub structure: StructureKind,
    pub measure: Measure,
    /// The count drawn white.
    pub scale_top: u32,
    pub mean: f64,
    pub png: Vec<u8>,
}

struct Frame<'a> {
    scene: &'a Scene,
    integrator: &'a Integrator,
    size: (usize, usize),
    /// Count the traversal work (the untimed first frame) or not.
    counted: bool,
}

impl WithAccel for Frame<'_> {
    type Output = Rendered;
    fn run<A: Accel>(self, a: &A) -> Rendered {
        let (w, h) = self.size;
        if self.counted {
            render(a, self.scene, self.integrator, w, h, &|_| {})
        } else {
            render_uncounted(a, self.scene, self.integrator, w, h, &|_| {})
        }
    }
}

/// Measures every structure of `opts` on `scene`; `tick` is called after
/// each frame.
pub fn run_scene(scene: &Scene, opts: &Options, tick: &dyn Fn()) -> Result<SceneResult> {
    let bvh = Bvh::build(&scene.triangles, &opts.build);
    let mut built = Vec::new();
    for &s in &opts.structures {
        built.push(Built::new(
            s,
            TraversalKind::Stack,
            &bvh,
            scene.triangles.clone(),
        )?);
    }
    let path = PathSettings::default();
    let integrator = Integrator::Path(path.clone());
    let frames = opts.frames.max(1);
    let frame = |counted| Frame {
        scene,
        integrator: &integrator,
        size: (opts.width, opts.height),
        counted,
    };
    let firsts: Vec<Rendered> = built
        .iter()
        .map(|(b, _)| {
            let r = b.with(frame(true));
            tick();
            r
        })
        .collect();
    let mut times = vec![Vec::with_capacity(frames); built.len()];
    for _ in 0..frames {
        for (k, (b, _)) in built.iter().enumerate() {
            times[k].push(b.with(frame(false)).seconds);
            tick();
        }
    }
    let mut rows: Vec<Row> = Vec::new();
    for (k, (_, info)) in built.iter().enumerate() {
        let r = &firsts[k];
        let mean = times[k].iter().sum::<f64>() / times[k].len() as f64;
        rows.push(Row {
            structure: info.structure,
            bytes: info.bytes,
            node_bytes: info.node_bytes,
            index_bytes: info.index_bytes,
            nodes: info.inner_nodes + info.leaves,
            conversion_seconds: info.conversion_seconds,
            frame_seconds: mean,
            fastest_frame_seconds: times[k].iter().copied().fold(f64::INFINITY, f64::min),
            rays: r.counters.rays,
            mrays_per_second: r.counters.rays as f64 / mean.max(1e-12) / 1e6,
            per_ray: r.counters.per_ray(),
            vs_bvh: None,
            dst: info.dst.clone(),
            htree: info.htree.clone(),
        });
    }
    // Ratios to the BVH, when it was measured.
    let base = opts
        .structures
        .iter()
        .position(|&s| s == StructureKind::Bvh);
    if let Some(b) = base {
        let bvh = &rows[b];
        let (bytes, node_bytes, secs, per) =
            (bvh.bytes, bvh.node_bytes, bvh.frame_seconds, bvh.per_ray);
        let image: &Image = &firsts[b].image;
        let ratio = |x: f64, of: f64| x / of.max(1e-12);
        for (k, row) in rows.iter_mut().enumerate() {
            row.vs_bvh = Some(VsBvh {
                storage_ratio: ratio(row.bytes as f64, bytes as f64),
                node_storage_ratio: ratio(row.node_bytes as f64, node_bytes as f64),
                frame_ratio: ratio(row.frame_seconds, secs),
                nodes_ratio: ratio(row.per_ray.nodes, per.nodes),
                planes_ratio: ratio(row.per_ray.planes, per.planes),
                triangles_ratio: ratio(row.per_ray.triangles, per.triangles),
                same_image: firsts[k].image == *image,
            });
        }
    }
    let mut pictures = Pictures {
        frame: firsts.first().map(|r| r.image.to_png()).unwrap_or_default(),
        heatmaps: Vec::new(),
    };
    let mapped: Vec<(StructureKind, &Rendered)> = [StructureKind::Bvh, StructureKind::Dst]
        .into_iter()
        .filter_map(|k| {
            let i = opts.structures.iter().position(|&s| s == k)?;
            Some((k, &firsts[i]))
        })
        .collect();
    for m in [Measure::Planes, Measure::Triangles] {
        let top = mapped
            .iter()
            .map(|(_, r)| r.work.percentile_top(m))
            .max()
            .unwrap_or(0);
        for &(k, r) in &mapped {
            let (png, info) = r.work.png(m, Some(top));
            pictures.heatmaps.push(Heatmap {
                structure: k,
                measure: m,
                scale_top: top,
                mean: info.mean,
                png,
            });
        }
    }
    Ok(SceneResult {
        pictures,
        scene: scene.name.clone(),
        triangles: scene.mesh.triangle_count(),
        bvh: bvh.stats.clone(),
        width: opts.width,
        height: opts.height,
        frames,
        threads: rayon::current_num_threads(),
        path,
        rows,
    })
}

/// What a ratio cell shows when the BVH was not measured.
pub const NONE: &str = "–";

/// A ratio cell: `f` of the comparison in percent, or [`NONE`].
pub fn percent_cell(v: Option<VsBvh>, f: fn(&VsBvh) -> f64) -> String {
    v.map_or(NONE.into(), |v| format!("{:.1}%", 100.0 * f(&v)))
}

/// Whether the image is the BVH's: `yes`, `no`, or [`NONE`].
pub fn same_image_cell(v: Option<VsBvh>) -> &'static str {
    v.map_or(NONE, |v| if v.same_image { "yes" } else { "no" })
}

/// Table 1 of one scene, in Markdown.
pub fn markdown(r: &SceneResult) -> String {
    let mut s = format!(
        "### {} ({} triangles; {} BVH, leaves ≤ {}, built in {:.3} s; path tracing {}×{}, {} spp, {} bounces, {} timed frames, {} threads)\n\n",
        r.scene,
        r.triangles,
        r.bvh.builder,
        r.bvh.max_leaf_size,
        r.bvh.build_seconds,
        r.width,
        r.height,
        r.path.samples,
        r.path.bounces,
        r.frames,
        r.threads
    );
    s += "| structure | storage MB | vs bvh | nodes MiB | vs bvh | nodes | conversion s | frame s | vs bvh | Mrays/s | nodes/ray | vs bvh | plane tests/ray | vs bvh | triangle tests/ray | vs bvh | same image |\n";
    s += "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---|\n";
    for row in &r.rows {
        let v = row.vs_bvh;
        let pct = |f: fn(&VsBvh) -> f64| percent_cell(v, f);
        s += &format!(
            "| {} | {:.3} | {} | {:.3} | {} | {} | {:.3} | {:.4} | {} | {:.2} | {:.2} | {} | {:.1} | {} | {:.2} | {} | {} |\n",
            row.structure.name(),
            row.bytes as f64 / 1e6,
            pct(|v| v.storage_ratio),
            row.node_bytes as f64 / MIB,
            pct(|v| v.node_storage_ratio),
            row.nodes,
            row.conversion_seconds,
            row.frame_seconds,
            pct(|v| v.frame_ratio),
            row.mrays_per_second,
            row.per_ray.nodes,
            v.map_or(NONE.into(), |v| format!("{:.2}×", v.nodes_ratio)),
            row.per_ray.planes,
            pct(|v| v.planes_ratio),
            row.per_ray.triangles,
            v.map_or(NONE.into(), |v| format!("{:+.1}%", 100.0 * (v.triangles_ratio - 1.0))),
            same_image_cell(v),
        );
    }
    let two_plane: Vec<_> = r
        .rows
        .iter()
        .filter_map(|row| row.dst.as_ref().map(|d| (row.structure, d)))
        .collect();
    if !two_plane.is_empty() {
        s += "\n| Tables 2–3 | nodes | split | carve | leaf | 1-axis : 2-axis carving | 0 / 1 / 2 / 3 carving levels |\n";
        s += "|---|---:|---:|---:|---:|---|---|\n";
        for (kind, d) in two_plane {
            s += &dst_row(kind, d);
        }
    }
    for row in &r.rows {
        if let Some(h) = &row.htree {
            s += &format!(
                "\n{}: {} split nodes, {} bounding nodes (by faces stored, 1–6: {:?}), {} leaves\n",
                row.structure.name(),
                h.split_nodes,
                h.bound_nodes,
                &h.bound_faces[1..],
                h.leaves
            );
        }
    }
    s
}

/// The means over several scenes of every structure's ratios to the BVH
/// (arithmetic, as the paper averages), with their ranges, in Markdown;
/// `None` unless two or more scenes measured the BVH.
pub fn summary(results: &[SceneResult]) -> Option<String> {
    let measured: Vec<&SceneResult> = results
        .iter()
        .filter(|r| r.rows.iter().any(|row| row.vs_bvh.is_some()))
        .collect();
    if measured.len() < 2 {
        return None;
    }
    let mut s = format!(
        "### Over {} scenes: mean (least–most) of the ratios to the BVH\n\n",
        measured.len()
    );
    s += "| structure | storage | nodes only (paper's Table 1) | frame time | nodes/ray | plane tests/ray | triangle tests/ray |\n";
    s += "|---|---|---|---|---|---|---|\n";
    let kinds: Vec<StructureKind> = measured[0].rows.iter().map(|row| row.structure).collect();
    for kind in kinds {
        let of = |f: fn(&VsBvh) -> f64| -> Vec<f64> {
            measured
                .iter()
                .filter_map(|r| r.rows.iter().find(|row| row.structure == kind))
                .filter_map(|row| row.vs_bvh.as_ref().map(f))
                .collect()
        };
        let cell = |xs: Vec<f64>, show: &dyn Fn(f64) -> String| {
            let mean = xs.iter().sum::<f64>() / xs.len().max(1) as f64;
            let lo = xs.iter().copied().fold(f64::INFINITY, f64::min);
            let hi = xs.iter().copied().fold(f64::NEG_INFINITY, f64::max);
            format!("{} ({}–{})", show(mean), show(lo), show(hi))
        };
        let pct = |x: f64| format!("{:.1}%", 100.0 * x);
        let times = |x: f64| format!("{x:.2}×");
        let delta = |x: f64| format!("{:+.1}%", 100.0 * (x - 1.0));
        s += &format!(
            "| {} | {} | {} | {} | {} | {} | {} |\n",
            kind.name(),
            cell(of(|v| v.storage_ratio), &pct),
            cell(of(|v| v.node_storage_ratio), &pct),
            cell(of(|v| v.frame_ratio), &times),
            cell(of(|v| v.nodes_ratio), &times),
            cell(of(|v| v.planes_ratio), &pct),
            cell(of(|v| v.triangles_ratio), &delta),
        );
    }
    Some(s)
}

/// One row of the node-type table: counts and shares as the paper's
/// Tables 2 and 3 give them: carving leaves count as carving nodes, "leaf"
/// is the plain leaves (the paper's 4.5% of leaves on Crytek Sponza leaves
/// no other reading).
pub fn dst_row(kind: StructureKind, d: &DstStats) -> String {
    let nodes = d.nodes().max(1) as f64;
    let carve = d.carve_single + d.carve_dual;
    let carves = (d.carve_single + d.carve_dual).max(1) as f64;
    let levels = d.carving_levels;
    let children = levels.iter().sum::<usize>().max(1) as f64;
    let pct = |x: usize, of: f64| 100.0 * x as f64 / of;
    format!(
        "| {} | {} | {:.0}% | {:.0}% | {:.1}% | {:.0}% : {:.0}% | {:.0}% / {:.0}% / {:.0}% / {:.1}% |\n",
        kind.name(),
        d.nodes(),
        pct(d.split_nodes, nodes),
        pct(carve, nodes),
        pct(d.plain_leaves, nodes),
        pct(d.carve_single, carves),
        pct(d.carve_dual, carves),
        pct(levels[0], children),
        pct(levels[1], children),
        pct(levels[2], children),
        pct(levels[3], children),
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    fn row(structure: StructureKind, vs: Option<f64>) -> Row {
        Row {
            structure,
            bytes: 0,
            node_bytes: 0,
            index_bytes: 0,
            nodes: 0,
            conversion_seconds: 0.0,
            frame_seconds: 1.0,
            fastest_frame_seconds: 1.0,
            rays: 0,
            mrays_per_second: 0.0,
            per_ray: PerRay::default(),
            vs_bvh: vs.map(|x| VsBvh {
                storage_ratio: x,
                node_storage_ratio: x / 2.0,
                frame_ratio: 2.0 * x,
                nodes_ratio: 1.0,
                planes_ratio: 1.0,
                triangles_ratio: x,
                same_image: true,
            }),
            dst: None,
            htree: None,
        }
    }

    fn scene(dst: Option<f64>) -> SceneResult {
        SceneResult {
            scene: "s".into(),
            triangles: 0,
            bvh: BuildStats::default(),
            width: 1,
            height: 1,
            frames: 1,
            threads: 1,
            path: PathSettings::default(),
            rows: vec![
                row(StructureKind::Bvh, dst.map(|_| 1.0)),
                row(StructureKind::Dst, dst),
            ],
            pictures: Pictures::default(),
        }
    }

    #[test]
    fn summary_gives_the_mean_and_range_of_each_ratio() {
        let md = summary(&[scene(Some(0.5)), scene(Some(0.7)), scene(None)]).unwrap();
        assert!(md.starts_with("### Over 2 scenes"), "{md}");
        let dst = md.lines().find(|l| l.starts_with("| dst |")).unwrap();
        assert_eq!(
            dst,
            "| dst | 60.0% (50.0%–70.0%) | 30.0% (25.0%–35.0%) | 1.20× (1.00×–1.40×) | 1.00× (1.00×–1.00×) | 100.0% (100.0%–100.0%) | -40.0% (-50.0%–-30.0%) |"
        );
        // One scene with the BVH measured is not a summary.
        assert_eq!(summary(&[scene(Some(0.5)), scene(None)]), None);
    }
}
