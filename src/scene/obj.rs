//! Wavefront OBJ through `tobj`. Materials are not read. When tobj refuses a
//! file, or the mesh has a non-finite coordinate or a bad index, a second pass
//! over the text finds the line to blame.

use super::Mesh;
use crate::error::{Error, Result};
use glam::Vec3;
use std::path::Path;

/// Parses the OBJ text `bytes`; `path` names it in errors.
pub fn parse(bytes: &[u8], path: &Path) -> Result<Mesh> {
    let opts = tobj::LoadOptions {
        triangulate: true,
        single_index: false,
        ignore_points: true,
        ignore_lines: true,
    };
    let loaded = tobj::load_obj_buf(&mut &bytes[..], &opts, |_| Ok(Default::default()));
    let models = match loaded {
        Ok((models, _)) => models,
        Err(e) => return Err(locate(bytes, path, &format!("not a valid OBJ file ({e})"))),
    };
    let mut mesh = Mesh::default();
    for m in &models {
        let base = mesh.positions.len() as u32;
        mesh.positions.extend(
            m.mesh
                .positions
                .chunks_exact(3)
                .map(|p| Vec3::new(p[0], p[1], p[2])),
        );
        mesh.indices.extend(
            m.mesh
                .indices
                .chunks_exact(3)
                .map(|t| [t[0] + base, t[1] + base, t[2] + base]),
        );
    }
    if mesh.positions.iter().any(|p| !p.is_finite()) {
        return Err(locate(bytes, path, "a vertex has a non-finite coordinate"));
    }
    Ok(mesh)
}

/// An error for `path`, with the first offending line of its text `bytes`
/// if a scan finds one.
fn locate(bytes: &[u8], path: &Path, fallback: &str) -> Error {
    let found = first_bad_line(&String::from_utf8_lossy(bytes));
    match found {
        Some((line, message)) => Error::Parse {
            path: path.into(),
            line: Some(line),
            message,
        },
        None => Error::Parse {
            path: path.into(),
            line: None,
            message: fallback.into(),
        },
    }
}

/// The first line (1-based) that is a malformed vertex or face, or refers to
/// a vertex that does not exist, with the reason.
fn first_bad_line(text: &str) -> Option<(usize, String)> {
    let total_vertices = text
        .lines()
        .filter(|l| l.split_whitespace().next() == Some("v"))
        .count() as i64;
    let mut seen = 0i64;
    for (i, line) in text.lines().enumerate() {
        let mut words = line.split_whitespace();
        match words.next() {
            Some("v") => {
                seen += 1;
                let coords: Vec<_> = words.take(3).map(str::parse::<f32>).collect();
                if coords.len() < 3 || coords.iter().any(|c| c.is_err()) {
                    return Some((i + 1, format!("malformed vertex '{}'", line.trim())));
                }
                if coords.iter().any(|c| !c.as_ref().unwrap().is_finite()) {
                    return Some((
                        i + 1,
                        format!("non-finite vertex coordinate in '{}'", line.trim()),
                    ));
                }
            }
            Some("f") => {
                let refs: Vec<&str> = words.collect();
                if refs.len() < 3 {
                    return Some((
                        i + 1,
                        format!("face with fewer than 3 vertices: '{}'", line.trim()),
                    ));
                }
                for r in refs {
                    let index = r.split('/').next().unwrap_or("");
                    let Ok(k) = index.parse::<i64>() else {
                        return Some((i + 1, format!("malformed face vertex '{r}'")));
                    };
                    let resolved = if k < 0 { seen + k + 1 } else { k };
                    if k == 0 || resolved < 1 || resolved > total_vertices {
                        return Some((
                            i + 1,
                            format!(
                                "face refers to vertex {k}, which does not exist ({total_vertices} vertices)"
                            ),
                        ));
                    }
                }
            }
            _ => {}
        }
    }
    None
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn scan_finds_the_line() {
        assert_eq!(first_bad_line("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n"), None);
        assert_eq!(first_bad_line("v 0 0 0\nv 1 x 0\n").unwrap().0, 2);
        assert_eq!(first_bad_line("v 0 0 0\nv nan 0 0\n").unwrap().0, 2);
        assert_eq!(first_bad_line("v 0 0 0\n\nf 1 2 3\n").unwrap().0, 3);
        assert_eq!(first_bad_line("v 0 0 0\nv 0 0 1\nf 1 -3 2\n").unwrap().0, 3);
        assert_eq!(first_bad_line("v 0 0 0\nf 1 1\n").unwrap().0, 2);
    }
}
