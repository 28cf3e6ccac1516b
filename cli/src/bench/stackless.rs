//! The stackless paper's Table 1 and Figure 5: AO rendering time of every
//! traversal over one BVH (the paper's hybrid build), eye and AO phases
//! timed apart, with the per-ray work and the traversal state size.
//!
//! Every algorithm renders the same image from the same BVH in one run, so
//! the ratios compare algorithms under the same conditions. Each row renders
//! once with its counters on, untimed: that gives the per-ray work and pays
//! the warm-up a first timed render would. Then every row renders `repeats`
//! times with the counters compiled out, timed, the rows taking turns; the
//! fastest counts.
//!
//! STACK runs over the uncompressed 52-byte layout (`stack`) and over the
//! 32-byte own-box nodes the stackless algorithms use (`stack-sparse`),
//! which is the reference of their ratios: the paper gave every algorithm
//! the same nodes. The paper's own tracer stored every algorithm's tree in
//! 64-byte nodes holding both children's boxes and a parent link; STACK,
//! SPARSE and LAINE-k also run over those (`*-paired`, [`Nodes::Paired`]),
//! their ratios taken to STACK on them (`stack-paired`).

use raytree::bvh::{BuildOptions, BuildStats, Bvh};
use raytree::error::Result;
use raytree::render::{AoQuery, AoSettings, Phase, PhasedAo, Sampling};
use raytree::scene::{Camera, Scene};
use raytree::stats::PerRay;
use raytree::structures::state_bytes;
use raytree::structures::{Built, SparseBvh, StructureKind, TraversalKind};
use serde::Serialize;
use std::sync::Arc;

/// The image sizes and ray counts of a run.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, clap::ValueEnum)]
#[serde(rename_all = "lowercase")]
pub enum Preset {
    /// 200×75 (chess) or 128×128, 4 eye rays per pixel, 4 AO rays per hit,
    /// in the default render's form (any-hit AO rays, independent samples)
    /// and each scene's own camera.
    Quick,
    /// The paper's (Section 4): 800×300 (chess) or 512×512, 16 eye rays per
    /// pixel and 16 AO rays per hit (256 per pixel), in its tracer's form:
    /// closest-hit AO rays from the hit point, 4×4 stratified eye jitter and
    /// AO directions; the CHESS scenes (built-in `chess`,
    /// `battlefield.obj`) seen through the paper's camera (50° horizontal,
    /// non-square pixels) with an AO radius of 32.
    Paper,
}

impl Preset {
    /// Image size for a scene: the chess scene has the paper's 8:3 frame.
    pub fn size(self, scene: &Scene) -> (usize, usize) {
        let chess = scene.is_stackless_chess();
        match (self, chess) {
            (Preset::Quick, true) => (200, 75),
            (Preset::Quick, false) => (128, 128),
            (Preset::Paper, true) => (800, 300),
            (Preset::Paper, false) => (512, 512),
        }
    }

    pub fn rays(self) -> (u32, u32) {
        match self {
            Preset::Quick => (4, 4),
            Preset::Paper => (16, 16),
        }
    }

    /// The preset's form of the AO workload: the query and the sampling.
    pub fn form(self) -> (AoQuery, Sampling) {
        match self {
            Preset::Quick => (AoQuery::Any, Sampling::Independent),
            Preset::Paper => (AoQuery::Closest, Sampling::Stratified),
        }
    }

    /// Sets the preset's view on `scene`: for [`Preset::Paper`], the paper's
    /// camera on its CHESS scenes. Returns whether the camera changed.
    pub fn apply_view(self, scene: &mut Scene) -> bool {
        self == Preset::Paper && scene.use_stackless_view()
    }
}

/// The nodes a row's traversal runs over.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Nodes {
    /// The traversal's own layout (binary for STACK, implicit for
    /// IMPLICIT-A/B).
    Own,
    /// The sparse layout's 32-byte own-box nodes.
    Sparse,
    /// The stackless paper tracer's 64-byte nodes with both children's
    /// boxes and a parent link (its supplemental `bvh.h`).
    Paired,
}

/// The rows of Table 1, in the paper's order, plus STACK on the sparse
/// nodes, then STACK, SPARSE and LAINE-k on the paper tracer's own 64-byte
/// nodes.
pub const ROWS: [(&str, TraversalKind, Nodes); 18] = [
    ("stack", TraversalKind::Stack, Nodes::Own),
    ("stack-sparse", TraversalKind::Stack, Nodes::Sparse),
    ("sparse", TraversalKind::Sparse, Nodes::Sparse),
    ("implicit-a", TraversalKind::ImplicitA, Nodes::Own),
    ("implicit-b", TraversalKind::ImplicitB, Nodes::Own),
    ("hapala", TraversalKind::Hapala, Nodes::Sparse),
    ("laine-0", TraversalKind::Laine0, Nodes::Sparse),
    ("laine-1", TraversalKind::Laine1, Nodes::Sparse),
    ("laine-2", TraversalKind::Laine2, Nodes::Sparse),
    ("laine-4", TraversalKind::Laine4, Nodes::Sparse),
    ("laine-8", TraversalKind::Laine8, Nodes::Sparse),
    ("stack-paired", TraversalKind::Stack, Nodes::Paired),
    ("sparse-paired", TraversalKind::Sparse, Nodes::Paired),
    ("laine-0-paired", TraversalKind::Laine0, Nodes::Paired),
    ("laine-1-paired", TraversalKind::Laine1, Nodes::Paired),
    ("laine-2-paired", TraversalKind::Laine2, Nodes::Paired),
    ("laine-4-paired", TraversalKind::Laine4, Nodes::Paired),
    ("laine-8-paired", TraversalKind::Laine8, Nodes::Paired),
];

/// The row the ratios of most rows are taken to: STACK on the sparse
/// layout's nodes.
pub const REFERENCE: &str = "stack-sparse";
/// The row the paired rows' ratios are taken to: STACK on the same 64-byte
/// nodes.
pub const PAIRED_REFERENCE: &str = "stack-paired";

/// The reference row of a row on `nodes`.
pub fn reference(nodes: Nodes) -> &'static str {
    match nodes {
        Nodes::Paired => PAIRED_REFERENCE,
        _ => REFERENCE,
    }
}

#[derive(Clone, Debug, Serialize)]
pub struct Row {
    pub algorithm: &'static str,
    pub layout: &'static str,
    pub state_bytes: usize,
    pub threads: usize,
    /// Eye plus AO phase, the best of the repeats.
    pub seconds: f64,
    /// `seconds` over the reference row's, same scene and thread count.
    pub ratio: f64,
    pub eye: Phase,
    pub ao: Phase,
    pub eye_per_ray: PerRay,
    pub ao_per_ray: PerRay,
    /// Whether the image equals the reference row's bit for bit, and the
    /// timed renders' image the counted one's.
    pub same_image: bool,
}

#[derive(Clone, Debug, Serialize)]
pub struct SceneResult {
    pub scene: String,
    pub triangles: usize,
    pub bvh: BuildStats,
    pub width: usize,
    pub height: usize,
    /// The camera the rows rendered through.
    pub camera: Camera,
    /// The AO workload, its form (`query`, `sampling`) included.
    pub ao: AoSettings,
    pub rows: Vec<Row>,
}

pub struct Options {
    pub preset: Preset,
    pub build: BuildOptions,
    /// Thread counts to measure (each in its own pool).
    pub threads: Vec<usize>,
    /// Timed renders per row, after one counted render; the fastest counts.
    pub repeats: usize,
    /// AO radius as a fraction of the scene diagonal (32 units on chess).
    pub radius_fraction: f32,
    /// An AO radius in scene units, overriding the fraction (and the
    /// paper preset's 32 on its CHESS scenes).
    pub radius: Option<f32>,
    /// How AO rays are traced [default: the preset's, [`Preset::form`]].
    pub query: Option<AoQuery>,
    /// How eye rays and AO directions are sampled [default: the preset's].
    pub sampling: Option<Sampling>,
}

/// One phased AO render: counted, or timed with the counters compiled out.
/// Measures every row on `scene`; `tick` is called after each render.
pub fn run_scene(scene: &Scene, opts: &Options, tick: &dyn Fn()) -> Result<SceneResult> {
    let bvh = Bvh::build(&scene.triangles, &opts.build);
    let (w, h) = opts.preset.size(scene);
    let (eye_rays, ao_rays) = opts.preset.rays();
    let (query, sampling) = opts.preset.form();
    let paper_chess = opts.preset == Preset::Paper && scene.is_stackless_chess();
    let radius = match (opts.radius, paper_chess) {
        (Some(r), _) => r,
        (None, true) => Scene::STACKLESS_CHESS_AO_RADIUS,
        (None, false) => opts.radius_fraction * scene.mesh.bounds().extent().length(),
    };
    let ao = AoSettings {
        query: opts.query.unwrap_or(query),
        sampling: opts.sampling.unwrap_or(sampling),
        ..AoSettings::plain(eye_rays, ao_rays, radius)
    };
    let sparse = Arc::new(SparseBvh::from_bvh(&bvh, scene.triangles.clone())?);
    let mut built = Vec::new();
    for (name, t, nodes) in ROWS {
        let (b, info) = match nodes {
            Nodes::Sparse => (Built::sparse(t, sparse.clone())?, "sparse"),
            Nodes::Paired => (Built::paired(t, sparse.clone())?, "paired"),
            Nodes::Own => {
                let (b, i) = Built::new(StructureKind::Bvh, t, &bvh, scene.triangles.clone())?;
                (b, i.layout)
            }
        };
        built.push((name, t, b, info));
    }
    let mut rows = Vec::new();
    for &threads in &opts.threads {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .map_err(|e| {
                raytree::error::Error::Invalid(format!("cannot start {threads} threads: {e}"))
            })?;
        // First one counted, untimed render per row: its per-ray work and
        // image, and the warm-up of what a first timed render would pay.
        let counted: Vec<PhasedAo> = built
            .iter()
            .map(|(_, _, b, _)| {
                let r = pool.install(|| b.render_ao_phased(scene, &ao, w, h, true));
                tick();
                r
            })
            .collect();
        // Then the timed renders, counters compiled out, the rows taking
        // turns so that a drift of the machine spreads over all of them.
        let mut best: Vec<Option<PhasedAo>> = vec![None; built.len()];
        for _ in 0..opts.repeats.max(1) {
            for ((_, _, b, _), best) in built.iter().zip(&mut best) {
                let r = pool.install(|| b.render_ao_phased(scene, &ao, w, h, false));
                tick();
                if best.as_ref().is_none_or(|b| r.seconds() < b.seconds()) {
                    *best = Some(r);
                }
            }
        }
        let (mut images, mut timed_same) = (Vec::new(), Vec::new());
        for ((name, t, _, layout), (c, timed)) in built.iter().zip(counted.into_iter().zip(best)) {
            let timed = timed.expect("at least one repeat");
            // The timed render must trace what the counted one did.
            timed_same.push(timed.image == c.image);
            let eye = Phase {
                seconds: timed.eye.seconds,
                counters: c.eye.counters,
            };
            let ao_phase = Phase {
                seconds: timed.ao.seconds,
                counters: c.ao.counters,
            };
            rows.push(Row {
                algorithm: name,
                layout,
                state_bytes: state_bytes(*t, bvh.stats.depth),
                threads,
                seconds: timed.seconds(),
                ratio: 0.0,
                eye,
                ao: ao_phase,
                eye_per_ray: c.eye.counters.per_ray(),
                ao_per_ray: c.ao.counters.per_ray(),
                same_image: false,
            });
            images.push(c.image);
        }
        let first = rows.len() - built.len();
        let times: Vec<f64> = rows[first..].iter().map(|r| r.seconds).collect();
        let position = |name: &str| {
            ROWS.iter()
                .position(|r| r.0 == name)
                .expect("reference row")
        };
        let stack = position(REFERENCE);
        for (k, row) in rows[first..].iter_mut().enumerate() {
            let reference = position(reference(ROWS[k].2));
            row.ratio = row.seconds / times[reference];
            row.same_image = images[k] == images[stack] && timed_same[k];
        }
    }
    Ok(SceneResult {
        scene: scene.name.clone(),
        triangles: scene.mesh.triangle_count(),
        bvh: bvh.stats.clone(),
        width: w,
        height: h,
        camera: scene.camera,
        ao,
        rows,
    })
}

/// The Markdown table of one scene.
pub fn markdown(r: &SceneResult) -> String {
    let mut s = format!(
        "### {} ({} triangles; {} BVH, depth {}, {} nodes; {}×{}, {} eye rays/pixel, {} AO rays/hit, radius {:.3}; {}; camera {})\n\n",
        r.scene, r.triangles, r.bvh.builder, r.bvh.depth, r.bvh.nodes, r.width, r.height, r.ao.eye_rays, r.ao.ao_rays, r.ao.radius, r.ao.form(), r.camera
    );
    s += "| algorithm | layout | state B | threads | time s | ratio | eye s | AO s | eye Mrays/s | AO Mrays/s | nodes/ray eye | nodes/ray AO | box tests/ray AO | tris/ray AO | same image |\n";
    s += "|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---|\n";
    for row in &r.rows {
        let mrays = |p: &Phase| p.counters.rays as f64 / p.seconds.max(1e-12) / 1e6;
        s += &format!(
            "| {} | {} | {} | {} | {:.3} | {:.2} | {:.3} | {:.3} | {:.2} | {:.2} | {:.2} | {:.2} | {:.2} | {:.2} | {} |\n",
            row.algorithm,
            row.layout,
            row.state_bytes,
            row.threads,
            row.seconds,
            row.ratio,
            row.eye.seconds,
            row.ao.seconds,
            mrays(&row.eye),
            mrays(&row.ao),
            row.eye_per_ray.nodes,
            row.ao_per_ray.nodes,
            row.ao_per_ray.planes / 6.0,
            row.ao_per_ray.triangles,
            if row.same_image { "yes" } else { "NO" }
        );
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_paper_preset_runs_the_papers_form_and_view() {
        assert_eq!(
            Preset::Paper.form(),
            (AoQuery::Closest, Sampling::Stratified)
        );
        assert_eq!(Preset::Quick.form(), (AoQuery::Any, Sampling::Independent));
        let mut chess = Scene::builtin("chess:2000").unwrap();
        let before = chess.camera;
        assert!(!Preset::Quick.apply_view(&mut chess));
        assert_eq!(chess.camera, before);
        assert!(Preset::Paper.apply_view(&mut chess));
        assert_eq!(chess.camera, Camera::stackless_chess());
        assert_eq!(Preset::Paper.size(&chess), (800, 300));
        let mut hair = Scene::builtin("hairball:2000").unwrap();
        assert!(!Preset::Paper.apply_view(&mut hair));
        assert_eq!(Preset::Paper.size(&hair), (512, 512));
    }
}
