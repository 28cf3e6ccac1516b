//! Meshes, their loaders, built-in procedural scenes and cameras.

mod camera;
pub mod memory;
mod mesh;
mod obj;
mod ply;
pub mod procedural;

pub use camera::{Camera, Fov};
pub use mesh::Mesh;

use crate::error::{Error, Result};
use crate::geometry::Triangle;
use std::path::Path;
use std::sync::Arc;

/// A mesh, its expanded triangles (shared by every structure built over it)
/// and a camera.
#[derive(Clone, Debug)]
pub struct Scene {
    /// The built-in name with its size (`chess:64000`), or the file path.
    pub name: String,
    /// The mesh as loaded or generated.
    pub mesh: Mesh,
    /// `triangles[i]` is triangle `i` of the mesh, in file order.
    pub triangles: Arc<[Triangle]>,
    /// The view renders use: the file's framing, or the built-in scene's own.
    pub camera: Camera,
}

impl Scene {
    /// A scene named `name` over `mesh` seen by `camera`; expands the
    /// triangles (panics on an index out of range: validate the mesh first).
    pub fn new(name: impl Into<String>, mesh: Mesh, camera: Camera) -> Self {
        let triangles = mesh.triangles().into();
        Scene {
            name: name.into(),
            mesh,
            triangles,
            camera,
        }
    }

    /// A scene from an OBJ or PLY file, with a camera that frames its bounds.
    /// Errors as [`Mesh::load`]; [`Error::Limit`] when the scene would not
    /// fit in the memory available ([`memory::check_fits`]), [`Error::Invalid`]
    /// for a malformed [`memory::LIMIT_VARIABLE`].
    pub fn load(path: impl AsRef<Path>) -> Result<Scene> {
        let path = path.as_ref();
        let mesh = Mesh::load(path)?;
        memory::check_fits(
            &path.display().to_string(),
            mesh.triangle_count() as u64,
            memory::available_bytes()?,
        )?;
        let camera = Camera::framing(&mesh.bounds());
        Ok(Scene::new(path.display().to_string(), mesh, camera))
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

    /// A built-in scene name (`chess`, `hairball:300000`) or a path to an OBJ
    /// or PLY file; [`Error::Invalid`] when it is neither.
    pub fn from_spec(spec: &str) -> Result<Scene> {
        if procedural::is_builtin(spec) {
            Scene::builtin(spec)
        } else if Path::new(spec).extension().is_some() || Path::new(spec).exists() {
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
        }
    }
}
