use crate::error::{Error, Result};
use crate::geometry::{Aabb, Triangle};
use glam::Vec3;
use std::collections::BTreeMap;
use std::ops::Range;
use std::path::Path;

/// An indexed triangle mesh: f32 positions and u32 triangle indices, split
/// into geometries.
///
/// Triangle `i` is `indices[i]`: faces in file order, polygons
/// fan-triangulated. Its triangles are numbered globally (`0..`), which is
/// what hits report ([`crate::geometry::Hit::prim`]); [`Mesh::geometry_of`]
/// maps a global index to its geometry and its index within it.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Mesh {
    /// Vertex positions, in scene units.
    pub positions: Vec<Vec3>,
    /// One entry per triangle: indices into `positions` of its `a`, `b`, `c`.
    pub indices: Vec<[u32; 3]>,
    /// The geometries: consecutive, non-empty ranges of the triangles that
    /// together cover them all, in order (geometry `g` is `geometries[g]`).
    /// Empty means the whole mesh is one geometry (id 0), as for a mesh
    /// built by hand; loaders and [`crate::scene::Scene::new`] fill it in.
    pub geometries: Vec<Geometry>,
}

/// One geometry of a mesh: a loaded file (OBJ, PLY, STL), one solid of a
/// multi-solid ASCII STL file, or one triangle primitive of one mesh
/// instance of a glTF scene. Its triangles are consecutive in the mesh.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Geometry {
    /// What it is, for people: the file name, and for glTF the node, mesh
    /// and primitive (`scene.glb: node 2 "Wheel", mesh 1 "Tyre", primitive 0`).
    pub name: String,
    /// Its first triangle's global index.
    pub first_triangle: u32,
    /// How many triangles it has (at least one).
    pub triangle_count: u32,
}

impl Geometry {
    /// Its triangles' global indices.
    pub fn triangles(&self) -> Range<usize> {
        let first = self.first_triangle as usize;
        first..first + self.triangle_count as usize
    }
}

/// Options of the loaders.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct LoadOptions {
    /// The glTF scene to load, by index: `None` loads the file's default
    /// scene (`"scene"`), or its first scene when it names none. Other
    /// formats ignore it.
    pub gltf_scene: Option<usize>,
}

/// What a loader left out of a file, for the user to hear about: glTF
/// primitives that are not triangles (points, lines), triangle primitives
/// with no triangles, and what it did not apply.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct LoadReport {
    /// Primitives left out, by kind (`POINTS`, `LINES`, `LINE_LOOP`,
    /// `LINE_STRIP`, and `empty` for triangle primitives of fewer than 3
    /// vertices), counted per mesh instance.
    pub skipped_primitives: BTreeMap<String, usize>,
    /// Other things the user should know, one sentence each.
    pub notes: Vec<String>,
}

impl LoadReport {
    /// One warning per kind of primitive left out of `path`
    /// (`a.gltf: skipped 2 primitives of mode LINES`), then the notes.
    pub fn warnings(&self, path: &Path) -> Vec<String> {
        self.skipped_primitives
            .iter()
            .map(|(kind, &n)| {
                let s = if n == 1 { "" } else { "s" };
                if kind == "empty" {
                    format!(
                        "{}: skipped {n} triangle primitive{s} with no triangles",
                        path.display()
                    )
                } else {
                    format!(
                        "{}: skipped {n} primitive{s} of mode {kind}",
                        path.display()
                    )
                }
            })
            .chain(
                self.notes
                    .iter()
                    .map(|n| format!("{}: {n}", path.display())),
            )
            .collect()
    }

    /// Adds a note.
    pub(crate) fn note(&mut self, note: String) {
        self.notes.push(note);
    }

    /// Counts one more primitive of `kind` left out.
    pub(crate) fn skip(&mut self, kind: &str) {
        *self.skipped_primitives.entry(kind.to_string()).or_default() += 1;
    }
}

/// The mesh formats, by file name extension (any case): `obj`, `ply`,
/// `stl`, `gltf` and `glb`.
pub const EXTENSIONS: [&str; 5] = ["obj", "ply", "stl", "gltf", "glb"];

impl Mesh {
    /// Loads a mesh file (the format by its extension: see
    /// [`Mesh::parse`]) and validates it:
    /// [`Error::Io`] when it cannot be read, [`Error::Parse`] otherwise.
    pub fn load(path: &Path) -> Result<Mesh> {
        Self::load_with(path, &LoadOptions::default()).map(|(mesh, _)| mesh)
    }

    /// [`Mesh::load`] with options, also saying what was left out.
    pub fn load_with(path: &Path, options: &LoadOptions) -> Result<(Mesh, LoadReport)> {
        let bytes = std::fs::read(path).map_err(|source| Error::Io {
            path: path.into(),
            source,
        })?;
        Self::parse_with(&bytes, path, options)
    }

    /// Parses the contents `bytes` of a mesh file and validates the mesh.
    /// The format is chosen by `path`'s extension: OBJ (`.obj`), PLY
    /// (`.ply`), STL (`.stl`, ASCII or binary) or glTF 2.0 (`.gltf` or
    /// `.glb`, JSON or binary whatever the extension). `path` names the
    /// file in errors, and a glTF file's external buffers are read relative
    /// to its directory. Any fault (an unknown extension, a malformed file,
    /// a mesh [`Self::validate`] refuses) is an [`Error::Parse`].
    pub fn parse(bytes: &[u8], path: &Path) -> Result<Mesh> {
        Self::parse_with(bytes, path, &LoadOptions::default()).map(|(mesh, _)| mesh)
    }

    /// [`Mesh::parse`] with options, also saying what was left out.
    pub fn parse_with(
        bytes: &[u8],
        path: &Path,
        options: &LoadOptions,
    ) -> Result<(Mesh, LoadReport)> {
        let ext = path
            .extension()
            .and_then(|e| e.to_str())
            .map(|e| e.to_ascii_lowercase());
        let mut report = LoadReport::default();
        let mut mesh = match ext.as_deref() {
            Some("obj") => super::obj::parse(bytes, path)?,
            Some("ply") => super::ply::parse(bytes, path)?,
            Some("stl") => super::stl::parse(bytes, path)?,
            Some("gltf" | "glb") => {
                super::gltf::parse(bytes, path, options.gltf_scene, &mut report)?
            }
            _ if bytes.starts_with(&crate::saved::MAGIC) => {
                return Err(Error::Parse {
                    path: path.into(),
                    line: None,
                    message: "a saved structure (raytree build), not a mesh: trace, render and info take it with -s in place of a scene; other commands need the scene itself".into(),
                })
            }
            _ => {
                return Err(Error::Parse {
                    path: path.into(),
                    line: None,
                    message: format!(
                        "unknown mesh format: expected a file ending in .{}",
                        EXTENSIONS.join(", .")
                    ),
                })
            }
        };
        if mesh.geometries.is_empty() && !mesh.indices.is_empty() {
            mesh.geometries = vec![Geometry {
                name: path.display().to_string(),
                first_triangle: 0,
                triangle_count: mesh.indices.len().try_into().unwrap_or(u32::MAX),
            }];
        }
        mesh.validate().map_err(|message| Error::Parse {
            path: path.into(),
            line: None,
            message,
        })?;
        Ok((mesh, report))
    }

    /// Number of triangles: `indices.len()`.
    pub fn triangle_count(&self) -> usize {
        self.indices.len()
    }

    /// Triangle `i`; panics if `i` or one of its indices is out of range.
    pub fn triangle(&self, i: usize) -> Triangle {
        let [a, b, c] = self.indices[i];
        Triangle::new(
            self.positions[a as usize],
            self.positions[b as usize],
            self.positions[c as usize],
        )
    }

    /// Every triangle, in mesh order.
    pub fn triangles(&self) -> Vec<Triangle> {
        (0..self.indices.len()).map(|i| self.triangle(i)).collect()
    }

    /// The box of every position, used or not.
    pub fn bounds(&self) -> Aabb {
        Aabb::from_points(self.positions.iter().copied())
    }

    /// How many geometries it has: at least one for a mesh with triangles
    /// (an empty [`Mesh::geometries`] is one geometry).
    pub fn geometry_count(&self) -> usize {
        match self.geometries.len() {
            0 => usize::from(!self.indices.is_empty()),
            n => n,
        }
    }

    /// The geometry of the global triangle index `triangle` (a hit's
    /// [`crate::geometry::Hit::prim`]) and the triangle's index within it:
    /// `(geometry id, local index)`, by binary search over the geometries'
    /// first triangles; `None` for an index past the last triangle (such
    /// as [`crate::rayfile::MISS`]).
    pub fn geometry_of(&self, triangle: u32) -> Option<(u32, u32)> {
        if triangle as usize >= self.indices.len() {
            return None;
        }
        if self.geometries.is_empty() {
            return Some((0, triangle));
        }
        let after = self
            .geometries
            .partition_point(|g| g.first_triangle <= triangle);
        let id = after.checked_sub(1)?;
        let g = &self.geometries[id];
        let local = triangle - g.first_triangle;
        (local < g.triangle_count).then_some((id as u32, local))
    }

    /// Appends `other`'s vertices, triangles and geometries after this
    /// mesh's: its triangle `i` becomes triangle `self.triangle_count() + i`
    /// and its geometry `g` becomes geometry `self.geometry_count() + g`.
    /// `name` names `other`'s geometry where it has none listed. Fails when
    /// the vertices or triangles would overflow their 32-bit indices.
    pub fn append(&mut self, other: Mesh, name: &str) -> std::result::Result<(), String> {
        let vertices = self.positions.len() + other.positions.len();
        if vertices > u32::MAX as usize {
            return Err(format!("{vertices} vertices: more than 2^32 - 1"));
        }
        let triangles = self.indices.len() + other.indices.len();
        if triangles > u32::MAX as usize {
            return Err(format!("{triangles} triangles: more than 2^32 - 1"));
        }
        let (base, first) = (self.positions.len() as u32, self.indices.len() as u32);
        if self.geometries.is_empty() && !self.indices.is_empty() {
            self.geometries.push(Geometry {
                name: String::new(),
                first_triangle: 0,
                triangle_count: first,
            });
        }
        let mut geometries = other.geometries;
        if geometries.is_empty() && !other.indices.is_empty() {
            geometries.push(Geometry {
                name: name.to_string(),
                first_triangle: 0,
                triangle_count: other.indices.len() as u32,
            });
        }
        self.geometries
            .extend(geometries.into_iter().map(|g| Geometry {
                first_triangle: g.first_triangle + first,
                ..g
            }));
        self.positions.extend(other.positions);
        self.indices.extend(
            other
                .indices
                .iter()
                .map(|t| t.map(|i| i.saturating_add(base))),
        );
        Ok(())
    }

    /// Checks what every structure assumes: at least one triangle of non-zero
    /// area, finite coordinates within ±[`crate::geometry::COORDINATE_LIMIT`], indices in range, and at most 2³¹ − 1
    /// triangles (layouts keep the sign bit of indices for themselves); and
    /// that the geometries, if listed, are consecutive, non-empty and cover
    /// every triangle.
    pub fn validate(&self) -> std::result::Result<(), String> {
        if self.indices.is_empty() {
            return Err("the mesh has no triangles".into());
        }
        if self.indices.len() > i32::MAX as usize {
            return Err(format!(
                "{} triangles: more than the limit of {} (2^31 - 1)",
                self.indices.len(),
                i32::MAX
            ));
        }
        if let Some(i) = self.positions.iter().position(|p| !p.is_finite()) {
            return Err(format!(
                "vertex {} has a non-finite coordinate {:?}",
                i + 1,
                self.positions[i]
            ));
        }
        let limit = crate::geometry::COORDINATE_LIMIT;
        if let Some(i) = self
            .positions
            .iter()
            .position(|p| p.abs().max_element() > limit)
        {
            return Err(format!(
                "vertex {} has a coordinate beyond the limit of ±{limit:e} (2^126) {:?}",
                i + 1,
                self.positions[i]
            ));
        }
        let n = self.positions.len();
        for (t, tri) in self.indices.iter().enumerate() {
            if let Some(&i) = tri.iter().find(|&&i| i as usize >= n) {
                return Err(format!(
                    "triangle {t} refers to vertex index {i}, but there are only {n} vertices"
                ));
            }
        }
        if (0..self.indices.len()).all(|i| self.triangle(i).is_degenerate()) {
            return Err("every triangle of the mesh is degenerate (zero area)".into());
        }
        self.validate_geometries()
    }

    /// The geometries, if listed, are consecutive, non-empty and cover
    /// every triangle.
    fn validate_geometries(&self) -> std::result::Result<(), String> {
        if self.geometries.is_empty() {
            return Ok(());
        }
        let mut next = 0u64;
        for (g, geometry) in self.geometries.iter().enumerate() {
            if geometry.triangle_count == 0 {
                return Err(format!("geometry {g} ({}) has no triangles", geometry.name));
            }
            if u64::from(geometry.first_triangle) != next {
                return Err(format!(
                    "geometry {g} ({}) starts at triangle {}, not {next} where the one before it ends",
                    geometry.name, geometry.first_triangle
                ));
            }
            next += u64::from(geometry.triangle_count);
        }
        if next != self.indices.len() as u64 {
            return Err(format!(
                "the geometries cover {next} triangles, but the mesh has {}",
                self.indices.len()
            ));
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn quad() -> Mesh {
        Mesh {
            positions: vec![Vec3::ZERO, Vec3::X, Vec3::new(1.0, 1.0, 0.0), Vec3::Y],
            indices: vec![[0, 1, 2], [0, 2, 3]],
            geometries: Vec::new(),
        }
    }

    #[test]
    fn valid_mesh() {
        assert_eq!(quad().validate(), Ok(()));
        assert_eq!(quad().triangles()[1].c, Vec3::Y);
    }

    #[test]
    fn invalid_meshes_say_why() {
        let mut m = quad();
        m.positions[2].y = f32::NAN;
        assert!(m.validate().unwrap_err().contains("vertex 3"));
        let mut m = quad();
        m.positions[1].y = 1e38;
        assert!(m
            .validate()
            .unwrap_err()
            .contains("vertex 2 has a coordinate beyond"));
        m.positions[1].y = -8e37;
        assert_eq!(m.validate(), Ok(()));
        let mut m = quad();
        m.indices[1][2] = 9;
        assert!(m.validate().unwrap_err().contains("vertex index 9"));
        assert!(Mesh::default()
            .validate()
            .unwrap_err()
            .contains("no triangles"));
        let mut m = quad();
        m.indices = vec![[0, 1, 1]];
        assert!(m.validate().unwrap_err().contains("degenerate"));
    }

    fn geometry(name: &str, first_triangle: u32, triangle_count: u32) -> Geometry {
        Geometry {
            name: name.into(),
            first_triangle,
            triangle_count,
        }
    }

    #[test]
    fn geometries_map_global_triangles_to_local_ones() {
        let mut m = quad();
        assert_eq!(m.geometry_count(), 1);
        assert_eq!(m.geometry_of(1), Some((0, 1)));
        assert_eq!(m.geometry_of(2), None);
        assert_eq!(m.geometry_of(u32::MAX), None);
        let other = quad();
        m.append(other.clone(), "b").unwrap();
        m.append(other, "c").unwrap();
        assert_eq!(m.triangle_count(), 6);
        assert_eq!(m.positions.len(), 12);
        assert_eq!(m.indices[5], [8, 10, 11]);
        assert_eq!(
            m.geometries,
            vec![geometry("", 0, 2), geometry("b", 2, 2), geometry("c", 4, 2)]
        );
        assert_eq!(m.validate(), Ok(()));
        let got: Vec<_> = (0..7).map(|t| m.geometry_of(t)).collect();
        assert_eq!(
            got,
            [
                Some((0, 0)),
                Some((0, 1)),
                Some((1, 0)),
                Some((1, 1)),
                Some((2, 0)),
                Some((2, 1)),
                None
            ]
        );
        assert_eq!(m.geometries[2].triangles(), 4..6);
        // A mesh with listed geometries keeps them, renumbered.
        let mut n = quad();
        n.append(m.clone(), "ignored").unwrap();
        assert_eq!(n.geometry_count(), 4);
        assert_eq!(n.geometries[3], geometry("c", 6, 2));
    }

    #[test]
    fn geometries_that_do_not_tile_the_triangles_are_refused() {
        let mut m = quad();
        m.geometries = vec![geometry("a", 0, 1), geometry("b", 2, 1)];
        assert!(m
            .validate()
            .unwrap_err()
            .contains("starts at triangle 2, not 1"));
        m.geometries = vec![geometry("a", 0, 1), geometry("b", 1, 0)];
        assert!(m
            .validate()
            .unwrap_err()
            .contains("geometry 1 (b) has no triangles"));
        m.geometries = vec![geometry("a", 0, 1)];
        assert!(m.validate().unwrap_err().contains("cover 1 triangles"));
    }
}
