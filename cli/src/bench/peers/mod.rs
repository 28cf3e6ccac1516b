//! raytree beside other ray tracers on the same rays: Embree 3 (cargo
//! feature `embree`, over the system library) and the `obvhs` crate
//! (feature `obvhs`, on by default). Three ray sets per scene, made once
//! with raytree's BVH and traced by every contender:
//!
//! - primary: one jittered eye ray per pixel, closest hit (coherent);
//! - ao: occlusion rays from each primary hit, any hit (incoherent, short);
//! - path: the bounce rays of one path-traced frame (5 diffuse bounces, the
//!   dual-split paper's workload), closest hit (incoherent, long).
//!
//! raytree runs as six contenders ([`RAYTREE`]: the binary BVH with STACK,
//! `bvh4`, `bvh8` and `cwbvh` from the same SAH tree, `bvh8` over an SBVH
//! build and over an LBVH build), Embree at its medium and high build qualities. Every contender
//! traces each set on all threads, the contenders taking turns, several
//! times; the median time gives Mrays/s, reported beside the ratio to
//! raytree's BVH with STACK, and a [`FASTEST`] row takes raytree's best per
//! workload. Each contender's answers are compared with raytree's ray by
//! ray, so a fast wrong answer shows. Each contender's configuration is
//! printed under its scene's table.

#[cfg(feature = "embree")]
pub mod embree;
#[cfg(feature = "obvhs")]
pub mod obvhs;
#[cfg(all(feature = "tinybvh", target_feature = "avx2"))]
pub mod tinybvh;

use rayon::prelude::*;
use raytree::bvh::{BuildOptions, Builder, Bvh};
use raytree::error::Result;
use raytree::geometry::Ray;
use raytree::render::rayset;
use raytree::scene::Scene;
use raytree::stats::NoStats;
use raytree::structures::{simd, Accel, BinaryBvh, Bvh4, Bvh8, CwBvh};
use serde::Serialize;
use std::time::Instant;

/// A ray tracer measured beside raytree.
pub trait Contender: Sync {
    /// The closest hit's distance along `ray`, within `[tmin, tmax]`.
    fn closest(&self, ray: &Ray) -> Option<f32>;
    /// Whether anything is hit within `[tmin, tmax]`.
    fn occluded(&self, ray: &Ray) -> bool;
}

impl<A: Accel + Sync> Contender for A {
    fn closest(&self, ray: &Ray) -> Option<f32> {
        self.closest_hit(ray, &mut NoStats).map(|h| h.t)
    }
    fn occluded(&self, ray: &Ray) -> bool {
        self.any_hit(ray, &mut NoStats).is_some()
    }
}

/// A built contender: its name, its build time in seconds, and itself.
pub type Entry<'a> = (String, f64, Box<dyn Contender + 'a>);

/// raytree's own contenders: the binary BVH with STACK (every ratio's
/// reference), the wide BVHs from the same SAH tree, and `bvh8` over an
/// SBVH build (spatial splits, the counterpart of Embree's high quality)
/// and over an LBVH build (the fast build for changing scenes).
pub const RAYTREE: [&str; 6] = [
    "raytree bvh stack",
    "raytree bvh4",
    "raytree bvh8",
    "raytree cwbvh",
    "raytree bvh8 sbvh",
    "raytree bvh8 lbvh",
];

/// The row that takes, per workload, the fastest of [`RAYTREE`].
pub const FASTEST: &str = "raytree fastest";

/// The contenders this build of raytree can run, by name.
pub fn available() -> Vec<&'static str> {
    let mut names = RAYTREE.to_vec();
    if cfg!(feature = "obvhs") {
        names.extend(["obvhs bvh2 same tree", "obvhs bvh2 ploc", "obvhs cwbvh"]);
    }
    #[cfg(all(feature = "tinybvh", target_feature = "avx2"))]
    names.extend(tinybvh::NAMES);
    if cfg!(feature = "embree") {
        names.extend(["embree medium", "embree high"]);
    }
    names
}

/// Why a contender this build was asked for is missing, if one is.
pub fn missing() -> Vec<&'static str> {
    let mut out = Vec::new();
    if !cfg!(feature = "embree") {
        out.push(
            "Embree is left out: build with --features embree, after apt install libembree-dev",
        );
    }
    if !cfg!(feature = "tinybvh") {
        out.push("tinybvh is left out: build with --features tinybvh and RUSTFLAGS=\"-C target-feature=+avx2,+fma\"");
    } else if !cfg!(target_feature = "avx2") {
        out.push("tinybvh is left out: tinybvh-rs exposes BVH8_CPU's traversal only to a build with RUSTFLAGS=\"-C target-feature=+avx2,+fma\"");
    }
    out
}

/// The three workloads.
pub const WORKLOADS: [&str; 3] = ["primary", "ao", "path"];

#[derive(Clone, Debug, Serialize)]
pub struct Options {
    /// raytree's BVH build (SAH, leaves of at most 8, as `bench dst`).
    #[serde(skip)]
    pub build: BuildOptions,
    pub width: usize,
    pub height: usize,
    /// Occlusion rays per primary hit.
    pub ao_per_hit: u32,
    /// AO ray length as a fraction of the scene's diagonal.
    pub ao_radius_fraction: f32,
    pub bounces: u32,
    /// Timed runs of each set by each contender; the median is reported.
    pub repeats: usize,
    /// Builds of each contender, taking turns; the fastest is reported.
    pub build_repeats: usize,
}

impl Options {
    pub fn quick() -> Self {
        Options {
            build: BuildOptions::sah().with_max_leaf_size(8),
            width: 256,
            height: 256,
            ao_per_hit: 4,
            ao_radius_fraction: 0.045,
            bounces: 5,
            repeats: 3,
            build_repeats: 3,
        }
    }

    pub fn paper() -> Self {
        Options {
            width: 1024,
            height: 1024,
            repeats: 5,
            ..Options::quick()
        }
    }
}

/// The rays every contender traces.
pub struct RaySets {
    pub primary: Vec<Ray>,
    pub ao: Vec<Ray>,
    pub path: Vec<Ray>,
}

impl RaySets {
    pub fn new(scene: &Scene, bvh: &BinaryBvh, o: &Options) -> Self {
        let primary = rayset::eye_rays(scene, o.width, o.height, 1);
        let radius = o.ao_radius_fraction * scene.mesh.bounds().extent().length();
        let ao = rayset::ao_rays(scene, bvh, &primary, o.ao_per_hit, radius);
        let path = rayset::path_rays(scene, bvh, o.width, o.height, o.bounces);
        RaySets { primary, ao, path }
    }

    fn get(&self, workload: &str) -> &[Ray] {
        match workload {
            "primary" => &self.primary,
            "ao" => &self.ao,
            _ => &self.path,
        }
    }
}

/// One contender's figures on one workload.
#[derive(Clone, Debug, Serialize)]
pub struct Measure {
    pub workload: String,
    pub rays: usize,
    /// Median seconds over the repeats.
    pub seconds: f64,
    pub mrays_per_s: f64,
    /// raytree STACK's median time over this one's (above 1: faster).
    pub speed_vs_stack: f64,
    /// Rays answered as raytree's BVH answers them: the same hit or miss,
    /// and for closest hits the same distance within a relative 1e-4.
    pub agreeing: f64,
}

#[derive(Clone, Debug, Serialize)]
pub struct Row {
    pub contender: String,
    /// For the [`FASTEST`] row: which raytree contender it took per
    /// workload.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub picked: Vec<String>,
    /// Time to build its structure from the triangles (raytree: the SAH BVH
    /// and its flat layout).
    pub build_s: f64,
    /// The most heap its build held at once (the `raytree` binary's meter):
    /// on `raytree bvh stack` the SAH build and the binary layout, on
    /// `raytree bvh8 sbvh` the SBVH build and its collapse; absent for the
    /// other rows (the wide rows share the SAH build; the peers allocate
    /// outside Rust's allocator, or inside their own crates).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub build_peak_heap_bytes: Option<u64>,
    pub measures: Vec<Measure>,
}

#[derive(Clone, Debug, Serialize)]
pub struct SceneResult {
    pub scene: String,
    pub triangles: usize,
    pub threads: usize,
    pub options: Options,
    /// How each contender was built and traced, one line each.
    pub configs: Vec<String>,
    pub rows: Vec<Row>,
}

/// Answers of one contender to one set: distances (closest) or 0/1 (any).
fn trace(c: &dyn Contender, rays: &[Ray], any: bool) -> Vec<f32> {
    let mut out = vec![0.0f32; rays.len()];
    out.par_chunks_mut(512)
        .zip(rays.par_chunks(512))
        .for_each(|(out, rays)| {
            for (o, r) in out.iter_mut().zip(rays) {
                *o = if any {
                    c.occluded(r) as u8 as f32
                } else {
                    c.closest(r).unwrap_or(f32::INFINITY)
                };
            }
        });
    out
}

fn agree(a: f32, b: f32) -> bool {
    a == b || (a - b).abs() <= 1e-4 * a.abs().max(b.abs())
}

/// One round of builds: every available contender built over `scene`
/// but raytree's binary BVH (built by [`Sah::build`]), raytree's wide rows
/// from the SAH tree, each with its build time.
struct Round<'b> {
    contenders: Vec<Entry<'b>>,
    configs: Vec<String>,
    /// The most heap the SBVH build and its collapse held.
    sbvh_peak: Option<u64>,
}

impl<'b> Round<'b> {
    fn build(scene: &Scene, o: &Options, sah: &'b Sah) -> Result<Self> {
        let (bvh, bvh_s) = (&sah.bvh, sah.bvh_s);
        let timed =
            |f: &dyn Fn() -> Result<Box<dyn Contender>>| -> Result<(f64, Box<dyn Contender>)> {
                let t = Instant::now();
                let c = f()?;
                Ok((bvh_s + t.elapsed().as_secs_f64(), c))
            };
        let tris = || scene.triangles.clone();
        let (b4_s, b4) = timed(&|| Ok(Box::new(Bvh4::from_bvh(bvh, tris())?)))?;
        let (b8_s, b8) = timed(&|| Ok(Box::new(Bvh8::from_bvh(bvh, tris())?)))?;
        let (cw_s, cw) = timed(&|| Ok(Box::new(CwBvh::from_bvh(bvh, tris())?)))?;
        let t = Instant::now();
        let (sb8, sbvh_peak) = crate::meter::peak_during(|| {
            let sbvh = Bvh::build(
                &scene.triangles,
                &BuildOptions::new(Builder::Sbvh)
                    .with_max_leaf_size(o.build.max_leaf_size)
                    .with_sah_block(o.build.sah_block),
            );
            Bvh8::from_bvh(&sbvh, tris())
        });
        let sb8: Box<dyn Contender> = Box::new(sb8?);
        let sb8_s = t.elapsed().as_secs_f64();
        let t = Instant::now();
        let lbvh = Bvh::build(
            &scene.triangles,
            &BuildOptions::new(Builder::Lbvh)
                .with_max_leaf_size(o.build.max_leaf_size)
                .with_sah_block(o.build.sah_block),
        );
        let lb8: Box<dyn Contender> = Box::new(Bvh8::from_bvh(&lbvh, tris())?);
        let lb8_s = t.elapsed().as_secs_f64();
        drop(lbvh);
        let mut configs = vec![format!(
            "raytree: {} builder, leaves of at most {} triangles, SAH leaf cost per {} (bvh8 sbvh / bvh8 lbvh: the SBVH / LBVH builder); bvh4/bvh8/cwbvh collapsed by SAH; wide kernels on the {} SIMD path; build times include the BVH build",
            o.build.builder.name(),
            o.build.max_leaf_size,
            match o.build.sah_block {
                1 => "triangle".to_string(),
                b => format!("block of {b}"),
            },
            simd::active().describe()
        )];
        let mut contenders: Vec<Entry<'b>> = vec![
            (RAYTREE[1].into(), b4_s, b4),
            (RAYTREE[2].into(), b8_s, b8),
            (RAYTREE[3].into(), cw_s, cw),
            (RAYTREE[4].into(), sb8_s, sb8),
            (RAYTREE[5].into(), lb8_s, lb8),
        ];
        #[cfg(feature = "obvhs")]
        {
            contenders.extend(obvhs::contenders(scene, bvh));
            configs.push("obvhs: its BVH2 over raytree's tree, its PLOC build (medium), its CWBVH; raytree's triangle test".into());
        }
        #[cfg(all(feature = "tinybvh", target_feature = "avx2"))]
        {
            let (peers, config) = tinybvh::contenders(scene)?;
            contenders.extend(peers);
            configs.push(config);
        }
        #[cfg(feature = "embree")]
        for q in [embree::Quality::Medium, embree::Quality::High] {
            let (peer, build_s) = embree::Peer::build(scene, q, rayon::current_num_threads())?;
            configs.push(peer.config.clone());
            contenders.push((q.contender().into(), build_s, Box::new(peer)));
        }
        Ok(Round {
            contenders,
            configs,
            sbvh_peak,
        })
    }
}

/// raytree's SAH tree, built with its binary layout (the `raytree bvh
/// stack` row, with which the rays are made).
struct Sah {
    bvh: Bvh,
    /// Seconds to build the tree.
    bvh_s: f64,
    /// Seconds to build the tree and the layout.
    layout_s: f64,
    /// The most heap both held at once.
    peak: Option<u64>,
}

impl Sah {
    fn build(scene: &Scene, o: &Options) -> Result<(Self, BinaryBvh)> {
        let start = Instant::now();
        let ((bvh, bvh_s, layout), peak) = crate::meter::peak_during(|| {
            let bvh = Bvh::build(&scene.triangles, &o.build);
            let bvh_s = start.elapsed().as_secs_f64();
            let layout = BinaryBvh::from_bvh(&bvh, scene.triangles.clone());
            (bvh, bvh_s, layout)
        });
        let layout = layout?;
        let sah = Sah {
            layout_s: start.elapsed().as_secs_f64(),
            bvh,
            bvh_s,
            peak,
        };
        Ok((sah, layout))
    }
}

/// Builds every available contender over `scene`, traces the three sets
/// through each (on the current rayon pool) and reports.
///
/// Every contender is built [`Options::build_repeats`] times, the
/// contenders taking turns, and its fastest build is reported: the first
/// use of fresh memory in a process is slow on some virtual machines
/// (the host backs each page as it is first touched), which would
/// otherwise be charged to whichever contender builds first.
pub fn run_scene(scene: &Scene, o: &Options, tick: &(dyn Fn() + Sync)) -> Result<SceneResult> {
    // The fastest build of each contender, in the rows' order (raytree's
    // binary BVH first).
    let mut fastest_build: Vec<f64> = Vec::new();
    let mut keep = |sah: &Sah, round: &Round| {
        let times = std::iter::once(sah.layout_s).chain(round.contenders.iter().map(|c| c.1));
        fastest_build.resize(round.contenders.len() + 1, f64::INFINITY);
        for (best, s) in fastest_build.iter_mut().zip(times) {
            *best = best.min(s);
        }
    };
    for _ in 1..o.build_repeats.max(1) {
        let (sah, _layout) = Sah::build(scene, o)?;
        keep(&sah, &Round::build(scene, o, &sah)?);
    }
    let (sah, layout) = Sah::build(scene, o)?;
    let round = Round::build(scene, o, &sah)?;
    keep(&sah, &round);
    let Round {
        mut contenders,
        configs,
        sbvh_peak,
    } = round;
    let sets = RaySets::new(scene, &layout, o);
    contenders.insert(0, (RAYTREE[0].into(), sah.layout_s, Box::new(layout)));
    let mut rows: Vec<Row> = contenders
        .iter()
        .zip(&fastest_build)
        .map(|((name, _, _), build_s)| Row {
            contender: name.clone(),
            picked: Vec::new(),
            build_s: *build_s,
            build_peak_heap_bytes: match name.as_str() {
                n if n == RAYTREE[0] => sah.peak,
                n if n == RAYTREE[4] => sbvh_peak,
                _ => None,
            },
            measures: Vec::new(),
        })
        .collect();
    for workload in WORKLOADS {
        let rays = sets.get(workload);
        let any = workload == "ao";
        let reference = trace(contenders[0].2.as_ref(), rays, any);
        let mut times = vec![Vec::with_capacity(o.repeats); contenders.len()];
        let mut agreeing = vec![0.0; contenders.len()];
        for rep in 0..o.repeats.max(1) {
            for (i, (_, _, c)) in contenders.iter().enumerate() {
                let t = Instant::now();
                let answers = trace(c.as_ref(), rays, any);
                times[i].push(t.elapsed().as_secs_f64());
                if rep == 0 {
                    let same = answers
                        .iter()
                        .zip(&reference)
                        .filter(|(a, b)| agree(**a, **b))
                        .count();
                    agreeing[i] = same as f64 / rays.len().max(1) as f64;
                }
                tick();
            }
        }
        let medians: Vec<f64> = times.iter_mut().map(|t| median(t)).collect();
        for (i, row) in rows.iter_mut().enumerate() {
            row.measures.push(Measure {
                workload: workload.into(),
                rays: rays.len(),
                seconds: medians[i],
                mrays_per_s: rays.len() as f64 / medians[i] / 1e6,
                speed_vs_stack: medians[0] / medians[i],
                agreeing: agreeing[i],
            });
        }
    }
    rows.insert(RAYTREE.len(), fastest(&rows[..RAYTREE.len()]));
    Ok(SceneResult {
        scene: scene.name.clone(),
        triangles: scene.triangles.len(),
        threads: rayon::current_num_threads(),
        options: o.clone(),
        configs,
        rows,
    })
}

/// The [`FASTEST`] row: per workload, the raytree row of least time.
fn fastest(rows: &[Row]) -> Row {
    let mut row = Row {
        contender: FASTEST.into(),
        picked: Vec::new(),
        build_s: f64::NAN,
        build_peak_heap_bytes: None,
        measures: Vec::new(),
    };
    for w in 0..rows[0].measures.len() {
        let best = rows
            .iter()
            .min_by(|a, b| a.measures[w].seconds.total_cmp(&b.measures[w].seconds))
            .expect("raytree rows");
        row.picked.push(best.contender.clone());
        row.measures.push(best.measures[w].clone());
    }
    row
}

fn median(v: &mut [f64]) -> f64 {
    v.sort_by(f64::total_cmp);
    let n = v.len();
    if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    }
}

/// The scene's table: Mrays/s per workload with the ratio to raytree STACK,
/// and how many answers agree with raytree's.
pub fn markdown(r: &SceneResult) -> String {
    use std::fmt::Write;
    let mut s = String::new();
    let m = &r.rows[0].measures;
    let _ = writeln!(
        s,
        "### {} ({} triangles, {} threads; {} primary, {} ao, {} path rays)\n",
        r.scene, r.triangles, r.threads, m[0].rays, m[1].rays, m[2].rays
    );
    let _ = writeln!(
        s,
        "| contender | build s (peak heap) | primary Mrays/s | ao Mrays/s | path Mrays/s | agreeing with raytree |"
    );
    let _ = writeln!(s, "|---|---:|---:|---:|---:|---|");
    for row in &r.rows {
        let name = if row.picked.is_empty() {
            row.contender.clone()
        } else {
            let picks: Vec<&str> = row
                .picked
                .iter()
                .map(|p| p.trim_start_matches("raytree "))
                .collect();
            format!("**{}** ({})", row.contender, picks.join(" / "))
        };
        let build = match (row.build_s.is_nan(), row.build_peak_heap_bytes) {
            (true, _) => "-".to_owned(),
            (false, None) => format!("{:.3}", row.build_s),
            (false, Some(b)) => format!(
                "{:.3} ({:.1} MiB)",
                row.build_s,
                b as f64 / (1 << 20) as f64
            ),
        };
        let cells: Vec<String> = row
            .measures
            .iter()
            .map(|m| format!("{:.2} ({:.2}×)", m.mrays_per_s, m.speed_vs_stack))
            .collect();
        let agreeing: Vec<String> = row
            .measures
            .iter()
            .map(|m| format!("{:.3}%", 100.0 * m.agreeing))
            .collect();
        let _ = writeln!(
            s,
            "| {name} | {build} | {} | {} |",
            cells.join(" | "),
            agreeing.join(" / ")
        );
    }
    // The target: raytree's fastest against Embree's best build.
    let row = |n: &str| r.rows.iter().find(|x| x.contender == n);
    if let (Some(f), Some(e)) = (row(FASTEST), row("embree high")) {
        let ratios: Vec<String> = f
            .measures
            .iter()
            .zip(&e.measures)
            .map(|(a, b)| format!("{} {:.2}×", a.workload, b.seconds / a.seconds))
            .collect();
        let _ = writeln!(
            s,
            "\nraytree fastest vs embree high (above 1: raytree faster): {}",
            ratios.join(", ")
        );
    }
    let _ = writeln!(s);
    for c in &r.configs {
        let _ = writeln!(s, "- {c}");
    }
    s
}

/// The geometric mean over `results` of contender `of`'s build time over
/// contender `to`'s (below 1: `of` builds faster), if both ran everywhere.
pub fn geomean_build_ratio(results: &[SceneResult], of: &str, to: &str) -> Option<f64> {
    let mut log = 0.0;
    for r in results {
        let a = r.rows.iter().find(|x| x.contender == of)?;
        let b = r.rows.iter().find(|x| x.contender == to)?;
        log += (a.build_s / b.build_s).ln();
    }
    Some((log / results.len().max(1) as f64).exp())
}

/// Geometric means over scenes of each contender's speed relative to
/// another's (`of` over `to`, per workload; above 1: `of` is faster), for
/// the contenders present in every scene.
pub fn geomean_ratios(results: &[SceneResult], of: &str, to: &str) -> Option<Vec<(String, f64)>> {
    let mut logs = vec![0.0; WORKLOADS.len()];
    for r in results {
        let a = r.rows.iter().find(|x| x.contender == of)?;
        let b = r.rows.iter().find(|x| x.contender == to)?;
        for (w, (ma, mb)) in a.measures.iter().zip(&b.measures).enumerate() {
            logs[w] += (mb.seconds / ma.seconds).ln();
        }
    }
    let n = results.len().max(1) as f64;
    Some(
        WORKLOADS
            .iter()
            .zip(logs)
            .map(|(w, l)| (w.to_string(), (l / n).exp()))
            .collect(),
    )
}
