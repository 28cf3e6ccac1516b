use crate::error::{Error, Result};
use crate::geometry::{Aabb, Triangle};
use glam::Vec3;
use std::path::Path;

/// An indexed triangle mesh: f32 positions and u32 triangle indices.
/// Triangle `i` is `indices[i]`: faces in file order, polygons fan-triangulated.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Mesh {
    /// Vertex positions, in scene units.
    pub positions: Vec<Vec3>,
    /// One entry per triangle: indices into `positions` of its `a`, `b`, `c`.
    pub indices: Vec<[u32; 3]>,
}

impl Mesh {
    /// Loads an OBJ (`.obj`) or PLY (`.ply`) file and validates it:
    /// [`Error::Io`] when it cannot be read, [`Error::Parse`] otherwise.
    pub fn load(path: &Path) -> Result<Mesh> {
        let bytes = std::fs::read(path).map_err(|source| Error::Io {
            path: path.into(),
            source,
        })?;
        Self::parse(&bytes, path)
    }

    /// Parses the contents `bytes` of an OBJ or PLY file, the format chosen
    /// by `path`'s extension (`path` also names the file in errors), and
    /// validates the mesh. Any fault (an unknown extension, a malformed
    /// file, a mesh [`Self::validate`] refuses) is an [`Error::Parse`].
    pub fn parse(bytes: &[u8], path: &Path) -> Result<Mesh> {
        let ext = path
            .extension()
            .and_then(|e| e.to_str())
            .map(|e| e.to_ascii_lowercase());
        let mesh = match ext.as_deref() {
            Some("obj") => super::obj::parse(bytes, path)?,
            Some("ply") => super::ply::parse(bytes, path)?,
            _ => {
                return Err(Error::Parse {
                    path: path.into(),
                    line: None,
                    message: "unknown mesh format: expected a .obj or .ply file".into(),
                })
            }
        };
        mesh.validate().map_err(|message| Error::Parse {
            path: path.into(),
            line: None,
            message,
        })?;
        Ok(mesh)
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

    /// Checks what every structure assumes: at least one triangle of non-zero
    /// area, finite coordinates within ±[`crate::geometry::COORDINATE_LIMIT`], indices in range, and at most 2³¹ − 1
    /// triangles (layouts keep the sign bit of indices for themselves).
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
}
