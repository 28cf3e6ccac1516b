//! Options and steps shared by the subcommands.

use crate::bench::machine::{Machine, Measured};
use clap::Args;
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use raytree::bvh::{BuildOptions, BuildStats, Builder, Bvh};
use raytree::error::Result;
use raytree::names::Named;
use raytree::prelude::Vec3;
use raytree::saved::{Header, LoadTimes};
use raytree::scene::{Camera, Fov, Scene};
use raytree::structures::{Built, LayoutOptions, StructureInfo, StructureKind, TraversalKind};
use serde::Serialize;
use std::path::{Path, PathBuf};

/// Which scene, and how to build the canonical BVH.
#[derive(Args, Clone, Debug)]
pub struct SceneArgs {
    /// Scene: a built-in name with an optional size in triangles
    /// (chess, chess:200k, hairball, hairball:3M), a mesh file (.obj, .ply,
    /// .stl, .gltf, .glb), or mesh files separated by commas (a.obj,b.glb)
    /// loaded as one scene: one geometry per file, and per triangle
    /// primitive of each mesh instance of a glTF scene. Or a structure
    /// saved by `raytree build` (.rtree): its scene, BVH and structure are
    /// loaded instead of built.
    #[arg(long, short = 's', default_value = "chess")]
    pub scene: String,
    /// BVH builder: binned SAH, SAH for the top 8 levels and median
    /// splits below (the stackless paper's), or binned SAH with spatial
    /// splits (sbvh: a triangle may sit in several leaves) [default: sah; a
    /// saved structure's own].
    #[arg(long, value_enum)]
    pub builder: Option<BuilderArg>,
    /// Most triangles in a BVH leaf (1 to 255) [default: 8; a saved
    /// structure's own].
    #[arg(long, value_parser = clap::value_parser!(u16).range(1..=255))]
    pub max_leaf: Option<u16>,
    /// SAH leaf cost in blocks of this many triangles (1, 2, 4, 8 or 16),
    /// Embree's sahBlockSize: a leaf of n triangles costs ceil(n/b)
    /// triangle tests and no node is split below b triangles. Fewer,
    /// fuller leaves for wide BVHs' grouped leaf tests; sah and sbvh
    /// builders [default: 1; a saved structure's own].
    #[arg(long, value_parser = sah_block_parser())]
    pub sah_block: Option<usize>,
    /// Improve the built BVH by reinsertion (Bittner, Hapala and Havran
    /// 2013): the same leaves, a lower SAH cost; the costs before and after
    /// are reported.
    #[arg(long)]
    pub optimize: bool,
    /// With a saved structure (-s file.rtree): build what the options ask
    /// for differently from the file (a BVH of another builder or leaf
    /// size over the file's scene; another structure or traversal, derived
    /// from the file's BVH) instead of refusing them.
    #[arg(long)]
    pub rebuild: bool,
}

impl SceneArgs {
    /// The builder asked for, or the default one.
    pub fn builder(&self) -> Builder {
        self.builder.map_or(Builder::Sah, Builder::from)
    }

    /// The leaf size asked for, or the default one.
    pub fn max_leaf(&self) -> usize {
        self.max_leaf.map_or(8, usize::from)
    }

    /// The SAH block size asked for, or 1.
    pub fn sah_block(&self) -> usize {
        self.sah_block.unwrap_or(1)
    }
}

/// The camera, for the commands that render.
#[derive(Args, Clone, Debug)]
pub struct CameraArgs {
    /// Camera position "x,y,z" in scene units [default: the scene's camera;
    /// a file's camera frames its bounds].
    #[arg(long, value_parser = parse_vec3, allow_hyphen_values = true)]
    pub eye: Option<Vec3>,
    /// Point the camera looks at, "x,y,z".
    #[arg(long, value_parser = parse_vec3, allow_hyphen_values = true)]
    pub look_at: Option<Vec3>,
    /// The camera's up direction "x,y,z", not zero [default: the scene's,
    /// +y for files].
    #[arg(long, value_parser = parse_up, allow_hyphen_values = true)]
    pub up: Option<Vec3>,
    /// VERTICAL field of view in degrees, in (0, 180), with square pixels
    /// [default: the scene's camera's; with render --paper on the stackless
    /// paper's CHESS scenes, its camera: 50° horizontal, non-square pixels].
    #[arg(long, value_parser = parse_fov, conflicts_with = "hfov")]
    pub fov: Option<f32>,
    /// HORIZONTAL field of view in degrees, in (0, 180), with square pixels.
    #[arg(long, value_parser = parse_fov)]
    pub hfov: Option<f32>,
}

impl CameraArgs {
    /// Sets the options given on `cam`.
    pub fn apply(&self, cam: &mut Camera) -> Result<()> {
        cam.eye = self.eye.unwrap_or(cam.eye);
        cam.target = self.look_at.unwrap_or(cam.target);
        cam.up = self.up.unwrap_or(cam.up);
        if let Some(a) = self.fov {
            cam.fov = Fov::Vertical(a);
        }
        if let Some(a) = self.hfov {
            cam.fov = Fov::Horizontal(a);
        }
        if cam.eye == cam.target {
            return Err(raytree::error::Error::Invalid(
                "--eye and --look-at are the same point".into(),
            ));
        }
        Ok(())
    }
}

/// Checks that `cam`'s field of view works on a `width`×`height` image: a
/// stackless-paper angle scaled by a tall image's height/width can reach
/// 180°.
pub fn check_fov(cam: &Camera, width: usize, height: usize) -> Result<()> {
    if cam.fov.is_valid(width as f32 / height as f32) {
        Ok(())
    } else {
        Err(raytree::error::Error::Invalid(format!(
            "the field of view ({}) does not fit a {width}×{height} image: \
             its angles must lie in (0, 180) degrees",
            cam.fov
        )))
    }
}

pub fn parse_vec3(s: &str) -> std::result::Result<Vec3, String> {
    let v: Vec<f32> = s
        .split(',')
        .map(|c| c.trim().parse::<f32>().map_err(|e| format!("'{c}': {e}")))
        .collect::<std::result::Result<_, _>>()?;
    match v[..] {
        [x, y, z] if v.iter().all(|c| c.is_finite()) => Ok(Vec3::new(x, y, z)),
        _ => Err(format!(
            "expected three finite numbers \"x,y,z\", got '{s}'"
        )),
    }
}

/// A vector "x,y,z" that is not zero.
pub fn parse_up(s: &str) -> std::result::Result<Vec3, String> {
    let v = parse_vec3(s)?;
    if v == Vec3::ZERO {
        Err("the up direction must not be zero".into())
    } else {
        Ok(v)
    }
}

/// An angle in degrees in (0, 180): not NaN, not infinite.
pub fn parse_fov(s: &str) -> std::result::Result<f32, String> {
    let f: f32 = s.trim().parse().map_err(|e| format!("'{s}': {e}"))?;
    if f > 0.0 && f < 180.0 {
        Ok(f)
    } else {
        Err(format!("{f} is not an angle in (0, 180) degrees"))
    }
}

#[derive(clap::ValueEnum, Clone, Copy, Debug)]
pub enum BuilderArg {
    /// Binned SAH at every level.
    Sah,
    /// SAH for the top 8 levels, median splits below.
    Hybrid,
    /// Binned SAH with spatial splits (Stich, Friedrich and Dietrich 2009).
    Sbvh,
    /// Linear BVH: Morton order, split at the highest differing bit, leaves
    /// by SAH (the fast build).
    Lbvh,
}

impl From<BuilderArg> for Builder {
    fn from(b: BuilderArg) -> Builder {
        match b {
            BuilderArg::Sah => Builder::Sah,
            BuilderArg::Hybrid => Builder::Hybrid,
            BuilderArg::Sbvh => Builder::Sbvh,
            BuilderArg::Lbvh => Builder::Lbvh,
        }
    }
}

/// Which structure, and which traversal for `bvh`.
#[derive(Args, Clone, Debug)]
pub struct StructureArgs {
    /// Acceleration structure [default: bvh; a saved structure's own].
    #[arg(long, short = 'a', visible_alias = "structure", value_parser = named::<StructureKind>())]
    pub accel: Option<StructureKind>,
    /// Traversal algorithm (for --accel bvh). implicit-a and implicit-b run
    /// over the implicit heap layout; sparse, hapala and laine-k over the
    /// sparse layout with parent links; stack over the 52-byte binary
    /// layout [default: stack; a saved structure's own].
    #[arg(long, short = 't', value_parser = named::<TraversalKind>())]
    pub traversal: Option<TraversalKind>,
    /// Most address space the implicit layout may reserve, in GiB (its gaps
    /// are reserved, not resident).
    #[arg(long, default_value_t = 64.0, value_parser = parse_gib)]
    pub implicit_limit: f64,
}

impl StructureArgs {
    /// The structure and traversal asked for; what is not given is
    /// `saved`'s (a saved structure's), or the default.
    pub fn kinds(
        &self,
        saved: Option<(StructureKind, TraversalKind)>,
    ) -> (StructureKind, TraversalKind) {
        let (s, t) = saved.unwrap_or((StructureKind::Bvh, TraversalKind::Stack));
        match (self.accel, self.traversal) {
            (Some(a), Some(t)) => (a, t),
            // Another structure than the file's: its own traversal.
            (Some(a), None) if a != s => (a, TraversalKind::Stack),
            (Some(a), None) => (a, t),
            (None, Some(t)) => (s, t),
            (None, None) => (s, t),
        }
    }

    /// The layouts' limits.
    pub fn layout_options(&self) -> LayoutOptions {
        LayoutOptions {
            implicit_reservation_limit: (self.implicit_limit * (1u64 << 30) as f64) as u64,
        }
    }
}

fn parse_gib(s: &str) -> std::result::Result<f64, String> {
    match s.parse::<f64>() {
        Ok(v) if v > 0.0 && v.is_finite() => Ok(v),
        _ => Err(format!("'{s}' is not a positive number of GiB")),
    }
}

#[derive(Serialize)]
pub struct SceneReport {
    pub scene: String,
    pub triangles: usize,
    pub vertices: usize,
    pub bounds_min: [f32; 3],
    pub bounds_max: [f32; 3],
    pub load_seconds: f64,
    /// The scene's geometries: each file, and each triangle primitive
    /// instance of a glTF scene; hits name them by id.
    pub geometries: Vec<GeometryReport>,
    /// What the loaders left out or did not apply.
    pub warnings: Vec<String>,
    /// The saved structure the scene came from, if it did.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub saved: Option<SavedReport>,
}

/// One geometry of a scene.
#[derive(Serialize)]
pub struct GeometryReport {
    /// Its id: hit files and CSV give it beside the triangle.
    pub id: usize,
    pub name: String,
    /// Its first triangle's index in the scene.
    pub first_triangle: u32,
    pub triangles: u32,
}

impl SceneReport {
    /// What `scene` holds, loaded in `load_seconds`.
    pub fn new(scene: &Scene, load_seconds: f64) -> SceneReport {
        let b = scene.mesh.bounds();
        SceneReport {
            scene: scene.name.clone(),
            triangles: scene.mesh.triangle_count(),
            vertices: scene.mesh.positions.len(),
            bounds_min: b.min.to_array(),
            bounds_max: b.max.to_array(),
            load_seconds,
            geometries: scene
                .mesh
                .geometries
                .iter()
                .enumerate()
                .map(|(id, g)| GeometryReport {
                    id,
                    name: g.name.clone(),
                    first_triangle: g.first_triangle,
                    triangles: g.triangle_count,
                })
                .collect(),
            warnings: scene.warnings.clone(),
            saved: None,
        }
    }
}

/// Loads the scene `spec`, saying on stderr what its loaders left out.
pub fn load_spec(spec: &str) -> Result<Scene> {
    let scene = Scene::from_spec(spec)?;
    for w in &scene.warnings {
        eprintln!("raytree: warning: {w}");
    }
    Ok(scene)
}

/// A structure saved by `raytree build`, loaded in place of a scene.
pub struct SavedParts {
    pub header: Header,
    pub bvh: Bvh,
    pub built: Built,
    pub info: StructureInfo,
}

/// What a report says about a saved structure it loaded.
#[derive(Serialize)]
pub struct SavedReport {
    /// The file.
    pub file: PathBuf,
    /// Its header: version, structure, traversal, builder, counts, sections.
    pub header: Header,
    /// Mapping, checking and copying it out, in seconds.
    pub load_seconds: f64,
    /// Where that time went: mapping, checksums, scene, BVH and structure.
    pub load_times: LoadTimes,
    /// What was built anew because the options asked for something the
    /// file does not hold (--rebuild): "bvh", "structure", or nothing.
    pub rebuilt: Vec<&'static str>,
}

/// Loads the scene (or the saved structure) `args` name, saying on
/// stderr what its loaders left out. `opts` are the limits a saved
/// structure's layout loads under.
pub fn load_scene_with(
    args: &SceneArgs,
    opts: &LayoutOptions,
) -> Result<(Scene, SceneReport, Option<SavedParts>)> {
    let start = std::time::Instant::now();
    let path = Path::new(&args.scene);
    if !raytree::saved::is_saved(path) {
        let scene = {
            let _stage = Stage::new(format!("loading {}", args.scene));
            load_spec(&args.scene)?
        };
        let report = SceneReport::new(&scene, start.elapsed().as_secs_f64());
        return Ok((scene, report, None));
    }
    let s = {
        let _stage = Stage::new(format!("loading the saved structure {}", args.scene));
        raytree::saved::load(path, opts)?
    };
    for w in &s.scene.warnings {
        eprintln!("raytree: warning: {w}");
    }
    let seconds = start.elapsed().as_secs_f64();
    let mut report = SceneReport::new(&s.scene, seconds);
    report.saved = Some(SavedReport {
        file: path.into(),
        header: s.header.clone(),
        load_seconds: seconds,
        load_times: s.times,
        rebuilt: Vec::new(),
    });
    let parts = SavedParts {
        header: s.header,
        bvh: s.bvh,
        built: s.built,
        info: s.info,
    };
    Ok((s.scene, report, Some(parts)))
}

/// [`load_scene_with`] under the default layout limits.
pub fn load_scene(args: &SceneArgs) -> Result<(Scene, SceneReport, Option<SavedParts>)> {
    load_scene_with(args, &LayoutOptions::default())
}

/// The canonical BVH: a saved structure's, or built over `scene` as
/// `args` ask. A saved structure whose BVH is not what `args` ask for
/// (another builder or leaf size) is refused unless --rebuild (or
/// `rebuild`) asks for a new one.
pub fn bvh_for(
    scene: &Scene,
    args: &SceneArgs,
    saved: Option<Bvh>,
    report: &mut SceneReport,
    rebuild: bool,
) -> Result<(Bvh, BuildStats)> {
    let Some(bvh) = saved else {
        return Ok(build_bvh(scene, args));
    };
    let mut differs = Vec::new();
    if args.builder.is_some() && args.builder().name() != bvh.stats.builder {
        differs.push(format!(
            "--builder {} (the file's BVH: {})",
            args.builder().name(),
            bvh.stats.builder
        ));
    }
    if args.optimize {
        differs.push("--optimize (the file's BVH is used as it was saved)".to_string());
    }
    if args.max_leaf.is_some() && args.max_leaf() != bvh.stats.max_leaf_size {
        differs.push(format!(
            "--max-leaf {} (the file's BVH: {})",
            args.max_leaf(),
            bvh.stats.max_leaf_size
        ));
    }
    if args.sah_block.is_some() && args.sah_block() != bvh.stats.sah_block {
        differs.push(format!(
            "--sah-block {} (the file's BVH: {})",
            args.sah_block(),
            bvh.stats.sah_block
        ));
    }
    if differs.is_empty() {
        let stats = bvh.stats.clone();
        return Ok((bvh, stats));
    }
    if !(rebuild || args.rebuild) {
        return Err(raytree::error::Error::Invalid(format!(
            "{} holds a saved BVH that {} does not match: build a new file (raytree build), drop the option, or add --rebuild to build a new BVH over its scene",
            args.scene,
            differs.join(" and ")
        )));
    }
    if let Some(s) = &mut report.saved {
        s.rebuilt.push("bvh");
    }
    Ok(build_bvh(scene, args))
}

/// The canonical BVH and the structure `st` asks for: a saved
/// structure's own, or built (the BVH over `scene`, then converted). With
/// a saved structure, options that ask for another BVH, structure or
/// traversal are refused unless --rebuild (or `rebuild`) asks to build
/// them, the structure from the file's BVH where that one is kept.
pub fn prepare(
    scene: &Scene,
    saved: Option<SavedParts>,
    sa: &SceneArgs,
    st: &StructureArgs,
    report: &mut SceneReport,
    rebuild: bool,
) -> Result<(Bvh, BuildStats, Built, StructureInfo)> {
    let Some(parts) = saved else {
        let (bvh, stats) = build_bvh(scene, sa);
        let (s, t) = st.kinds(None);
        let (built, info) = build_structure(scene, &bvh, s, t, st)?;
        return Ok((bvh, stats, built, info));
    };
    let have = (parts.header.structure, parts.header.traversal);
    let (s, t) = st.kinds(Some(have));
    raytree::structures::check(s, t)?;
    let saved_bvh_kept = {
        let b = &parts.bvh.stats;
        (sa.builder.is_none() || sa.builder().name() == b.builder)
            && (sa.max_leaf.is_none() || sa.max_leaf() == b.max_leaf_size)
            && (sa.sah_block.is_none() || sa.sah_block() == b.sah_block)
            && !sa.optimize
    };
    if (s, t) != have && !(rebuild || sa.rebuild) {
        let name = |(s, t): (StructureKind, TraversalKind)| {
            if s == StructureKind::Bvh {
                format!("{}/{}", s.name(), t.name())
            } else {
                s.name().to_string()
            }
        };
        return Err(raytree::error::Error::Invalid(format!(
            "{} holds a saved {}, but the options ask for {}: build a file for it (raytree build), drop --accel/--traversal, or add --rebuild to derive it from the file's BVH",
            sa.scene,
            name(have),
            name((s, t)),
        )));
    }
    let (bvh, stats) = bvh_for(scene, sa, Some(parts.bvh), report, rebuild)?;
    if (s, t) == have && saved_bvh_kept {
        return Ok((bvh, stats, parts.built, parts.info));
    }
    drop(parts.built);
    if let Some(r) = &mut report.saved {
        r.rebuilt.push("structure");
    }
    let (built, info) = build_structure(scene, &bvh, s, t, st)?;
    Ok((bvh, stats, built, info))
}

pub fn build_bvh(scene: &Scene, args: &SceneArgs) -> (Bvh, BuildStats) {
    let _stage = Stage::new(format!(
        "building the BVH over {} triangles",
        scene.triangles.len()
    ));
    let opts = BuildOptions::new(args.builder())
        .with_max_leaf_size(args.max_leaf())
        .with_sah_block(args.sah_block());
    let (mut bvh, peak) = crate::meter::peak_during(|| {
        let bvh = Bvh::build(&scene.triangles, &opts);
        if args.optimize {
            bvh.optimize(&raytree::bvh::OptimizeOptions::default())
        } else {
            bvh
        }
    });
    bvh.stats.peak_heap_bytes = peak;
    let stats = bvh.stats.clone();
    (bvh, stats)
}

/// Checks the names before any work is done.
pub fn check_structure(s: &StructureArgs) -> Result<()> {
    let (a, t) = s.kinds(None);
    raytree::structures::check(a, t)
}

pub fn build_structure(
    scene: &Scene,
    bvh: &Bvh,
    structure: StructureKind,
    traversal: TraversalKind,
    s: &StructureArgs,
) -> Result<(Built, StructureInfo)> {
    let _stage = Stage::new(format!("converting the BVH to {}", structure.name()));
    Built::with_options(
        structure,
        traversal,
        bvh,
        scene.triangles.clone(),
        &s.layout_options(),
    )
}

/// The "saved" line of a report.
pub fn say_saved(r: &SceneReport) {
    if let Some(s) = &r.saved {
        let h = &s.header;
        super::out::say!(
            "saved      {}: {}{} over the {} layout, {} BVH, format version {}, {}, loaded in {:.3} s{}",
            s.file.display(),
            h.structure.name(),
            if h.structure == StructureKind::Bvh {
                format!("/{}", h.traversal.name())
            } else {
                String::new()
            },
            h.layout,
            h.builder,
            h.version,
            mib(h.file_bytes as usize),
            s.load_seconds,
            if s.rebuilt.is_empty() {
                String::new()
            } else {
                format!("; rebuilt: {}", s.rebuilt.join(", "))
            }
        );
    }
}

/// A clap parser for the names of a [`Named`] type, with their
/// descriptions in `--help`.
/// `--sah-block`'s parser: one of [`BuildOptions::SAH_BLOCKS`], listed in
/// `--help` and in the error.
pub fn sah_block_parser() -> impl clap::builder::TypedValueParser<Value = usize> {
    use clap::builder::{PossibleValuesParser, TypedValueParser};
    PossibleValuesParser::new(["1", "2", "4", "8", "16"])
        .map(|s| s.parse().expect("the possible values are numbers"))
}

/// What `info` and `build` add to the BVH's line for a build with SAH
/// blocks (nothing for blocks of one).
pub fn sah_block_note(block: usize) -> String {
    if block > 1 {
        format!(", SAH leaf cost per block of {block}")
    } else {
        String::new()
    }
}

pub fn named<T: Named + Send + Sync>() -> impl clap::builder::TypedValueParser<Value = T> {
    use clap::builder::{PossibleValue, PossibleValuesParser, TypedValueParser};
    PossibleValuesParser::new(
        T::TABLE
            .iter()
            .map(|&(_, name, help)| PossibleValue::new(name).help(help)),
    )
    .map(|s| T::from_name(&s).expect("clap checked the name"))
}

/// A step without a count (loading, building, converting) shown as a
/// spinner with its elapsed time on stderr while it lasts, drawn only when
/// stderr is a terminal; cleared when dropped.
pub struct Stage(ProgressBar);

impl Stage {
    pub fn new(what: String) -> Stage {
        let bar = ProgressBar::with_draw_target(None, ProgressDrawTarget::stderr());
        bar.set_style(
            ProgressStyle::with_template("{spinner} {msg} {elapsed_precise}")
                .expect("valid template"),
        );
        bar.set_message(what);
        bar.enable_steady_tick(std::time::Duration::from_millis(100));
        Stage(bar)
    }
}

impl Drop for Stage {
    fn drop(&mut self) {
        self.0.finish_and_clear();
    }
}

/// A progress bar on stderr, drawn only when stderr is a terminal.
pub fn progress(len: u64, what: &str, quiet: bool) -> ProgressBar {
    let target = if quiet {
        ProgressDrawTarget::hidden()
    } else {
        ProgressDrawTarget::stderr()
    };
    let bar = ProgressBar::with_draw_target(Some(len), target);
    bar.set_style(
        ProgressStyle::with_template("{msg} [{bar:40}] {pos}/{len} {elapsed_precise} eta {eta}")
            .expect("valid template")
            .progress_chars("=> "),
    );
    bar.set_message(what.to_owned());
    bar
}

/// Writes `value` as pretty JSON to `path`, atomically.
pub fn write_json(path: &Path, value: &impl Serialize) -> Result<()> {
    raytree::render::write_atomically(path, |w| {
        serde_json::to_writer_pretty(&mut *w, value).map_err(std::io::Error::other)?;
        use std::io::Write;
        writeln!(w)
    })
}

/// A benchmark's results as JSON beside the machine they were measured on.
pub fn write_bench_json<T: Serialize>(path: &Path, machine: &Machine, scenes: &[T]) -> Result<()> {
    write_json(path, &Measured { machine, scenes })
}

pub fn mib(bytes: usize) -> String {
    format!("{:.2} MiB", bytes as f64 / raytree::stats::MIB)
}
