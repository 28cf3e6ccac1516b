//! Meshes, their loaders, built-in procedural scenes and cameras.

mod camera;
mod gltf;
pub mod memory;
mod mesh;
mod obj;
mod ply;
pub mod procedural;
mod stl;

pub use camera::{Camera, Fov, Projection};
pub use mesh::{Geometry, LoadOptions, LoadReport, Mesh, EXTENSIONS};

use crate::error::{Error, Result};
use crate::geometry::Triangle;
use std::path::Path;
use std::sync::Arc;

/// A mesh, its expanded triangles (shared by every structure built over it)
/// and a camera.
#[derive(Clone, Debug)]
pub struct Scene {
    /// The built-in name with its size (`chess:64000`), the file path, or
    /// the file paths joined by commas.
    pub name: String,
    /// The triangles and their geometries (at least one).
    pub mesh: Mesh,
    /// `triangles[i]` is triangle `i` of the mesh, in file order.
    pub triangles: Arc<[Triangle]>,
    /// The view renders use: the file's framing, or the built-in scene's own.
    pub camera: Camera,
    /// What the loaders left out or did not apply, one line each, with the
    /// file (`a.gltf: skipped 2 primitives of mode LINES`).
    pub warnings: Vec<String>,
}

impl Scene {
    /// A scene of `mesh`. A mesh without listed geometries becomes one
    /// geometry named `name`. Expands the triangles (panics on an index out
    /// of range: validate the mesh first).
    pub fn new(name: impl Into<String>, mut mesh: Mesh, camera: Camera) -> Self {
        let name = name.into();
        if mesh.geometries.is_empty() && !mesh.indices.is_empty() {
            mesh.geometries.push(Geometry {
                name: name.clone(),
                first_triangle: 0,
                triangle_count: mesh.indices.len().try_into().unwrap_or(u32::MAX),
            });
        }
        let triangles = crate::pages::arc_from_fn(mesh.indices.len(), |i| mesh.triangle(i));
        Scene {
            name,
            mesh,
            triangles,
            camera,
            warnings: Vec::new(),
        }
    }

    /// A scene from a mesh file (OBJ, PLY, STL, glTF or GLB: see
    /// [`Mesh::parse`]), with a camera that frames its bounds.
    /// Errors as [`Mesh::load`]; [`Error::Limit`] when the scene would not
    /// fit in the memory available ([`memory::check_fits`]), [`Error::Invalid`]
    /// for a malformed [`memory::LIMIT_VARIABLE`].
    pub fn load(path: impl AsRef<Path>) -> Result<Scene> {
        Scene::load_many(&[path.as_ref()], &LoadOptions::default())
    }

    /// One scene of several mesh files, in order: file `k`'s triangles
    /// follow those of the files before it, and its geometries (one per
    /// OBJ, PLY or STL file, one per triangle primitive instance of a glTF
    /// scene) follow theirs. The camera frames the bounds of them all.
    pub fn load_many<P: AsRef<Path>>(paths: &[P], options: &LoadOptions) -> Result<Scene> {
        if paths.is_empty() {
            return Err(Error::Invalid("no scene files given".into()));
        }
        let name = paths
            .iter()
            .map(|p| p.as_ref().display().to_string())
            .collect::<Vec<_>>()
            .join(",");
        let available = memory::available_bytes()?;
        let mut mesh = Mesh::default();
        let mut warnings = Vec::new();
        for path in paths {
            let path = path.as_ref();
            let (part, report) = Mesh::load_with(path, options)?;
            warnings.extend(report.warnings(path));
            mesh.append(part, &path.display().to_string())
                .map_err(|message| Error::Parse {
                    path: path.into(),
                    line: None,
                    message: format!("with the files before it: {message}"),
                })?;
            memory::check_fits(&name, mesh.triangle_count() as u64, available)?;
        }
        if paths.len() > 1 {
            // Each file is valid; together they may pass the triangle limit.
            mesh.validate()
                .map_err(|message| Error::Invalid(format!("{name}: {message}")))?;
        }
        let camera = Camera::framing(&mesh.bounds());
        let mut scene = Scene::new(name, mesh, camera);
        scene.warnings = warnings;
        Ok(scene)
    }

    /// Whether this is the stackless paper's CHESS scene: the file
    /// `battlefield.obj` (the paper's own mesh, recognised by its file name)
    /// or the built-in `chess` (any size), whose board has the same
    /// coordinates.
    pub fn is_stackless_chess(&self) -> bool {
        self.name.split(':').next() == Some("chess")
            || Path::new(&self.name).file_name() == Some("battlefield.obj".as_ref())
    }

    /// Gives a stackless CHESS scene ([`Self::is_stackless_chess`]) the
    /// paper's camera, [`Camera::stackless_chess`]; returns whether it did.
    pub fn use_stackless_view(&mut self) -> bool {
        let chess = self.is_stackless_chess();
        if chess {
            self.camera = Camera::stackless_chess();
        }
        chess
    }

    /// The AO radius of the stackless paper's CHESS renders, in scene units
    /// (Section 4; supplemental `Tracer::sampleAO`).
    pub const STACKLESS_CHESS_AO_RADIUS: f32 = 32.0;

    /// A built-in scene by `name` or `name:size`, size being the approximate
    /// triangle count: see [`procedural::BUILTIN`]. Errors as [`procedural::build`].
    pub fn builtin(spec: &str) -> Result<Scene> {
        procedural::build(spec)
    }

    /// A built-in scene name (`chess`, `hairball:300000`), a path to a mesh
    /// file, or several paths separated by commas (`a.obj,b.stl`: one
    /// scene of them all, [`Scene::load_many`]). A path that exists is one
    /// file even if its name holds a comma.
    /// [`Error::Invalid`] when it is none of these.
    pub fn from_spec(spec: &str) -> Result<Scene> {
        if procedural::is_builtin(spec) {
            return Scene::builtin(spec);
        }
        let is_file = |s: &str| Path::new(s).extension().is_some() || Path::new(s).exists();
        if Path::new(spec).exists() || !spec.contains(',') {
            return if is_file(spec) {
                Scene::load(spec)
            } else {
                Err(Error::Invalid(format!(
                    "unknown scene '{spec}': not a file, nor a built-in scene ({})",
                    procedural::BUILTIN
                        .iter()
                        .map(|b| b.name)
                        .collect::<Vec<_>>()
                        .join(", ")
                )))
            };
        }
        let parts: Vec<&str> = spec.split(',').map(str::trim).collect();
        if let Some(bad) = parts
            .iter()
            .find(|p| p.is_empty() || procedural::is_builtin(p))
        {
            return Err(Error::Invalid(if bad.is_empty() {
                format!("scene list '{spec}' has an empty entry")
            } else {
                format!(
                    "scene list '{spec}': '{bad}' is a built-in scene; a list of scenes holds mesh files only"
                )
            }));
        }
        Scene::load_many(&parts, &LoadOptions::default())
    }
}
