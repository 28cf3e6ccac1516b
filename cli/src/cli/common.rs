//! Options and steps shared by the subcommands.

use crate::bench::machine::{Machine, Measured};
use clap::Args;
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use raytree::bvh::{BuildOptions, BuildStats, Builder, Bvh};
use raytree::error::Result;
use raytree::names::Named;
use raytree::prelude::Vec3;
use raytree::scene::{Camera, Fov, Scene};
use raytree::structures::{Built, LayoutOptions, StructureInfo, StructureKind, TraversalKind};
use serde::Serialize;
use std::path::Path;

/// Which scene, and how to build the canonical BVH.
#[derive(Args, Clone, Debug)]
pub struct SceneArgs {
    /// Scene: a built-in name with an optional size in triangles
    /// (chess, chess:200k, hairball, hairball:3M), a mesh file (.obj, .ply,
    /// .stl, .gltf, .glb), or mesh files separated by commas (a.obj,b.glb)
    /// loaded as one scene: one geometry per file, and per triangle
    /// primitive of each mesh instance of a glTF scene.
    #[arg(long, short = 's', default_value = "chess")]
    pub scene: String,
    /// BVH builder: binned SAH, or SAH for the top 8 levels and median
    /// splits below (the stackless paper's).
    #[arg(long, value_enum, default_value_t = BuilderArg::Sah)]
    pub builder: BuilderArg,
    /// Most triangles in a BVH leaf (1 to 255).
    #[arg(long, default_value_t = 8, value_parser = clap::value_parser!(u16).range(1..=255))]
    pub max_leaf: u16,
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
}

/// Which structure, and which traversal for `bvh`.
#[derive(Args, Clone, Debug)]
pub struct StructureArgs {
    /// Acceleration structure.
    #[arg(long, short = 'a', value_parser = named::<StructureKind>(), default_value_t = StructureKind::Bvh)]
    pub accel: StructureKind,
    /// Traversal algorithm (for --accel bvh). implicit-a and implicit-b run
    /// over the implicit heap layout; sparse, hapala and laine-k over the
    /// sparse layout with parent links; stack over the 52-byte binary layout.
    #[arg(long, short = 't', value_parser = named::<TraversalKind>(), default_value_t = TraversalKind::Stack)]
    pub traversal: TraversalKind,
    /// Most address space the implicit layout may reserve, in GiB (its gaps
    /// are reserved, not resident).
    #[arg(long, default_value_t = 64.0, value_parser = parse_gib)]
    pub implicit_limit: f64,
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

/// Loads the scene, saying on stderr what its loaders left out.
pub fn load_scene(args: &SceneArgs) -> Result<(Scene, SceneReport)> {
    let start = std::time::Instant::now();
    let scene = {
        let _stage = Stage::new(format!("loading {}", args.scene));
        load_spec(&args.scene)?
    };
    let report = SceneReport::new(&scene, start.elapsed().as_secs_f64());
    Ok((scene, report))
}

pub fn build_bvh(scene: &Scene, args: &SceneArgs) -> (Bvh, BuildStats) {
    let _stage = Stage::new(format!(
        "building the BVH over {} triangles",
        scene.triangles.len()
    ));
    let builder = match args.builder {
        BuilderArg::Sah => Builder::Sah,
        BuilderArg::Hybrid => Builder::Hybrid,
    };
    let opts = BuildOptions::new(builder).with_max_leaf_size(args.max_leaf as usize);
    let bvh = Bvh::build(&scene.triangles, &opts);
    let stats = bvh.stats.clone();
    (bvh, stats)
}

/// Checks the names before any work is done.
pub fn check_structure(s: &StructureArgs) -> Result<()> {
    raytree::structures::check(s.accel, s.traversal)
}

pub fn build_structure(
    scene: &Scene,
    bvh: &Bvh,
    s: &StructureArgs,
) -> Result<(Built, StructureInfo)> {
    let _stage = Stage::new(format!("converting the BVH to {}", s.accel.name()));
    let opts = LayoutOptions {
        implicit_reservation_limit: (s.implicit_limit * (1u64 << 30) as f64) as u64,
    };
    Built::with_options(s.accel, s.traversal, bvh, scene.triangles.clone(), &opts)
}

/// A clap parser for the names of a [`Named`] type, with their
/// descriptions in `--help`.
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
