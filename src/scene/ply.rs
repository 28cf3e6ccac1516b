//! PLY (ASCII, binary little- and big-endian) through `ply-rs-bw`: a `vertex`
//! element with `x`, `y`, `z`, and a `face` element with a `vertex_indices`
//! (or `vertex_index`) list. Polygons are fan-triangulated in order.

use super::Mesh;
use crate::error::{Error, Result};
use glam::Vec3;
use ply_rs_bw::parser::Parser;
use ply_rs_bw::ply::{DefaultElement, Encoding, Property};
use std::path::Path;

/// Parses the PLY file `bytes`; `path` names it in errors.
pub fn parse(bytes: &[u8], path: &Path) -> Result<Mesh> {
    let err = |line: Option<usize>, message: String| Error::Parse {
        path: path.into(),
        line,
        message,
    };
    let ply = Parser::<DefaultElement>::new()
        .read_ply(&mut &bytes[..])
        .map_err(|e| err(e.line(), format!("not a valid PLY file: {e}")))?;

    // The text line of element `i` of `element`, for ASCII files: one element
    // per line, elements in header order, after the header.
    let ascii = ply.header.encoding == Encoding::Ascii;
    let header_lines = if ascii {
        count_header_lines(bytes)
    } else {
        None
    };
    let line_of = |element: &str, i: usize| -> Option<usize> {
        let mut before = 0;
        for (name, def) in ply.header.elements.iter() {
            if name == element {
                return header_lines.map(|h| h + before + i + 1);
            }
            before += def.count;
        }
        None
    };

    let empty = Vec::new();
    let vertices = ply.payload.get("vertex").unwrap_or(&empty);
    let mut mesh = Mesh {
        positions: Vec::with_capacity(vertices.len()),
        indices: Vec::new(),
    };
    for (i, v) in vertices.iter().enumerate() {
        let coord = |k: &str| v.get(k).and_then(Property::to_f32_lossy);
        let (Some(x), Some(y), Some(z)) = (coord("x"), coord("y"), coord("z")) else {
            return Err(err(
                line_of("vertex", i),
                format!("vertex {i} lacks a numeric x, y or z"),
            ));
        };
        let p = Vec3::new(x, y, z);
        if !p.is_finite() {
            return Err(err(
                line_of("vertex", i),
                format!("vertex {i} has a non-finite coordinate {p:?}"),
            ));
        }
        mesh.positions.push(p);
    }
    let n = mesh.positions.len();
    for (i, f) in ply.payload.get("face").unwrap_or(&empty).iter().enumerate() {
        let list = f
            .get("vertex_indices")
            .or_else(|| f.get("vertex_index"))
            .and_then(Property::to_u32_list);
        let Some(list) = list else {
            return Err(err(
                line_of("face", i),
                format!("face {i} lacks a non-negative integer vertex_indices list"),
            ));
        };
        if list.len() < 3 {
            return Err(err(
                line_of("face", i),
                format!("face {i} has fewer than 3 vertices"),
            ));
        }
        if let Some(&bad) = list.iter().find(|&&k| k as usize >= n) {
            return Err(err(
                line_of("face", i),
                format!("face {i} refers to vertex {bad}, but there are only {n} vertices"),
            ));
        }
        for k in 1..list.len() - 1 {
            mesh.indices.push([list[0], list[k], list[k + 1]]);
        }
    }
    Ok(mesh)
}

/// Lines up to and including `end_header`.
fn count_header_lines(bytes: &[u8]) -> Option<usize> {
    bytes
        .split(|&b| b == b'\n')
        .position(|line| line.trim_ascii() == b"end_header")
        .map(|i| i + 1)
}
