//! Wavefront OBJ: vertices (`v`) and faces (`f`, and the old `fo`), read by
//! a parser of our own so that every refusal names its file and line.
//!
//! - Faces are fan-triangulated in file order; triangle `i` of the mesh is
//!   the `i`-th triangle of the faces, whatever else the file holds.
//! - Lines (`l`), points (`p`), free-form curves and surfaces (`curv`,
//!   `curv2`, `surf` and their bodies), groups, objects, smoothing groups and
//!   materials contribute no triangles; unknown statements are skipped.
//! - `#` starts a comment anywhere on a line; a line ending with `\`
//!   continues on the next one (errors name the first line of the statement).
//! - `v x y z [w] [r g b ...]`: every value must be a number; a 4th value
//!   alone is a weight `w` that divides x, y and z; more values are colours
//!   and are ignored. A non-finite coordinate is refused.
//! - Face vertices are `v`, `v/vt`, `v//vn` or `v/vt/vn`, 1-based, or
//!   negative counted back from the last element defined before the face.
//!   Every index must name an existing element, and a face needs at least
//!   three vertices: anything else is refused with its line.
//!
//! The mesh keeps only the vertices that faces use, in order of first use.

use super::Mesh;
use crate::error::{Error, Result};
use glam::Vec3;
use std::borrow::Cow;
use std::path::Path;

/// Parses the OBJ text `bytes`; `path` names it in errors.
pub fn parse(bytes: &[u8], path: &Path) -> Result<Mesh> {
    let text = String::from_utf8_lossy(bytes);
    parse_text(&text).map_err(|(line, message)| Error::Parse {
        path: path.into(),
        line: Some(line),
        message,
    })
}

/// A refusal: the 1-based line and the reason.
type Refusal = (usize, String);

/// How many `v`, `vt` and `vn` statements the text holds, for positive
/// indices that refer forward.
#[derive(Default, Clone, Copy)]
struct Counts {
    v: usize,
    vt: usize,
    vn: usize,
}

fn parse_text(text: &str) -> std::result::Result<Mesh, Refusal> {
    let mut total = Counts::default();
    for (_, statement) in statements(text) {
        match statement.split_whitespace().next() {
            Some("v") => total.v += 1,
            Some("vt") => total.vt += 1,
            Some("vn") => total.vn += 1,
            _ => {}
        }
    }
    let mut seen = Counts::default();
    let mut positions: Vec<Vec3> = Vec::with_capacity(total.v);
    // Face vertices as 0-based position indices, checked at the end (they
    // may refer forward).
    let mut faces: Vec<(usize, usize, usize)> = Vec::new(); // (line, start, len)
    let mut refs: Vec<usize> = Vec::new();
    for (line, statement) in statements(text) {
        let mut words = statement.split_whitespace();
        match words.next() {
            Some("v") => {
                seen.v += 1;
                positions.push(vertex(words, &statement).map_err(|m| (line, m))?);
            }
            Some("vt") => {
                seen.vt += 1;
                numbers(words, 1, &statement, "texture coordinate").map_err(|m| (line, m))?;
            }
            Some("vn") => {
                seen.vn += 1;
                numbers(words, 3, &statement, "normal").map_err(|m| (line, m))?;
            }
            Some("f") | Some("fo") => {
                let start = refs.len();
                for word in words {
                    refs.push(face_vertex(word, seen, total).map_err(|m| (line, m))?);
                }
                let len = refs.len() - start;
                if len < 3 {
                    return Err((
                        line,
                        format!(
                            "a face needs at least 3 vertices, this one has {len}: '{}'",
                            statement.trim()
                        ),
                    ));
                }
                faces.push((line, start, len));
            }
            _ => {}
        }
    }

    // Keep the used vertices in order of first use.
    let mut mesh = Mesh::default();
    let mut new_index = vec![u32::MAX; positions.len()];
    for &(line, start, len) in &faces {
        let mut local = Vec::with_capacity(len);
        for &r in &refs[start..start + len] {
            if new_index[r] == u32::MAX {
                new_index[r] = u32::try_from(mesh.positions.len())
                    .ok()
                    .filter(|&k| k != u32::MAX)
                    .ok_or_else(|| (line, "more than 2^32 - 1 vertices".to_string()))?;
                mesh.positions.push(positions[r]);
            }
            local.push(new_index[r]);
        }
        for k in 1..len - 1 {
            mesh.indices.push([local[0], local[k], local[k + 1]]);
        }
    }
    Ok(mesh)
}

/// The statements of `text` with the 1-based line each starts on: comments
/// cut off, `\`-continued lines joined, a trailing `\r` removed.
fn statements(text: &str) -> impl Iterator<Item = (usize, Cow<'_, str>)> {
    let mut lines = text.split('\n').enumerate().peekable();
    std::iter::from_fn(move || {
        let (i, first) = lines.next()?;
        let mut statement = Cow::Borrowed(uncomment(first));
        while statement.trim_end().ends_with('\\') {
            let body = statement.trim_end();
            let mut joined = body[..body.len() - 1].to_string();
            joined.push(' ');
            if let Some((_, next)) = lines.next() {
                joined.push_str(uncomment(next));
            }
            statement = Cow::Owned(joined);
        }
        Some((i + 1, statement))
    })
}

/// A line without its comment and trailing `\r`.
fn uncomment(line: &str) -> &str {
    let line = line.strip_suffix('\r').unwrap_or(line);
    line.split('#').next().unwrap_or("")
}

/// `v`'s values: x, y, z, an optional weight, or colours.
fn vertex<'a>(
    words: impl Iterator<Item = &'a str>,
    statement: &str,
) -> std::result::Result<Vec3, String> {
    let values = numbers(words, 3, statement, "vertex")?;
    let mut p = Vec3::new(values[0], values[1], values[2]);
    if values.len() == 4 {
        let w = values[3];
        if w == 0.0 || !w.is_finite() {
            return Err(format!("vertex weight w = {w} in '{}'", statement.trim()));
        }
        p /= w;
    }
    if !p.is_finite() {
        return Err(format!(
            "non-finite vertex coordinate in '{}'",
            statement.trim()
        ));
    }
    Ok(p)
}

/// At least `min` values, every one a number.
fn numbers<'a>(
    words: impl Iterator<Item = &'a str>,
    min: usize,
    statement: &str,
    what: &str,
) -> std::result::Result<Vec<f32>, String> {
    let mut values = Vec::with_capacity(min);
    for word in words {
        match word.parse::<f32>() {
            Ok(x) => values.push(x),
            Err(_) => {
                return Err(format!(
                    "malformed {what} '{}': '{word}' is not a number",
                    statement.trim()
                ))
            }
        }
    }
    if values.len() < min {
        return Err(format!(
            "malformed {what} '{}': expected at least {min} numbers, found {}",
            statement.trim(),
            values.len()
        ));
    }
    Ok(values)
}

/// One face vertex `v[/vt[/vn]]` as a 0-based position index.
fn face_vertex(word: &str, seen: Counts, total: Counts) -> std::result::Result<usize, String> {
    let parts: Vec<&str> = word.split('/').collect();
    if parts.len() > 3 {
        return Err(format!("malformed face vertex '{word}'"));
    }
    let names = ["vertex", "texture coordinate", "normal"];
    let counts = [(seen.v, total.v), (seen.vt, total.vt), (seen.vn, total.vn)];
    let mut position = 0;
    for (slot, part) in parts.iter().enumerate() {
        if part.is_empty() {
            if slot == 0 {
                return Err(format!("malformed face vertex '{word}': no vertex index"));
            }
            continue;
        }
        let Ok(k) = part.parse::<i64>() else {
            return Err(format!("malformed face vertex '{word}'"));
        };
        let (before, all) = counts[slot];
        let resolved = if k < 0 { before as i64 + k } else { k - 1 };
        if k == 0 || resolved < 0 || resolved >= all as i64 {
            let name = names[slot];
            return Err(format!(
                "face refers to {name} {k}, which does not exist ({all} {name}s{})",
                if k < 0 {
                    format!(", {before} before this line")
                } else {
                    String::new()
                }
            ));
        }
        if slot == 0 {
            position = resolved as usize;
        }
    }
    Ok(position)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn line_of(text: &str) -> usize {
        parse_text(text).expect_err("must be refused").0
    }

    fn triangles(text: &str) -> Vec<[Vec3; 3]> {
        let m = parse_text(text).unwrap();
        m.indices
            .iter()
            .map(|t| t.map(|i| m.positions[i as usize]))
            .collect()
    }

    #[test]
    fn refusals_name_the_line() {
        assert!(parse_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n").is_ok());
        assert_eq!(line_of("v 0 0 0\nv 1 x 0\n"), 2);
        assert_eq!(line_of("v 0 0 0\nv nan 0 0\n"), 2);
        assert_eq!(line_of("v 0 0 0\n\nf 1 2 3\n"), 3);
        assert_eq!(line_of("v 0 0 0\nv 0 0 1\nf 1 -3 2\n"), 3);
        assert_eq!(line_of("v 0 0 0\nf 1 1\n"), 2);
        assert_eq!(line_of("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1/1 2/1 3/1\n"), 4);
        assert_eq!(
            line_of("v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 1\nf 1//1 2//1 3//2\n"),
            5
        );
        assert_eq!(line_of("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1/1/1/1 2 3\n"), 4);
        assert_eq!(line_of("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 0 2 3\n"), 4);
        assert_eq!(line_of("v 0 0 0\nv 1 0 0 0\n"), 2);
        assert_eq!(line_of("vn 0 0\n"), 1);
        assert_eq!(line_of("vt x\n"), 1);
        assert_eq!(line_of("v 1 2\n"), 1);
    }

    #[test]
    fn end_of_line_comments_continuations_and_weights() {
        let t = triangles(
            "v 0 0 0 # corner\r\nv 2 0 0 2\nv 0 1 0 0.5 0.5 0.5 # with a colour\n\
             f 1 2 \\\n 3 # tri\n",
        );
        assert_eq!(t, vec![[Vec3::ZERO, Vec3::X, Vec3::Y]]);
        // The line after a continued statement keeps its number.
        assert_eq!(line_of("v 0 0 0 \\\n 1\nv 0 1 0\nv 1 1 q\n"), 4);
    }

    #[test]
    fn forward_and_relative_indices() {
        let t = triangles("f 1 2 3\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf -1 -3 -2\n");
        assert_eq!(
            t,
            vec![
                [Vec3::ZERO, Vec3::X, Vec3::Y],
                [Vec3::Y, Vec3::ZERO, Vec3::X]
            ]
        );
        // The unused vertex is left out; the order is that of first use.
        let m = parse_text("v 9 9 9\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 4 2 3\n").unwrap();
        assert_eq!(m.positions, vec![Vec3::Y, Vec3::ZERO, Vec3::X]);
        assert_eq!(m.indices, vec![[0, 1, 2]]);
    }
}
