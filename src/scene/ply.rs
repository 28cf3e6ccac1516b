//! PLY (ASCII, binary little- and big-endian) through `ply-rs-bw`: a `vertex`
//! element with `x`, `y`, `z`, and a `face` element with a `vertex_indices`
//! (or `vertex_index`) list. Polygons are fan-triangulated in order.

use super::Mesh;
use crate::error::{Error, Result};
use glam::Vec3;
use ply_rs_bw::parser::{ParseError, Parser, Reader};
use ply_rs_bw::ply::{DefaultElement, ElementDef, Encoding, Property, PropertyType, ScalarType};
use std::path::Path;

/// Parses the PLY file `bytes`; `path` names it in errors. Every refusal is
/// one line: the file, then the text line (ASCII) or the element and its
/// byte offset (binary).
pub fn parse(bytes: &[u8], path: &Path) -> Result<Mesh> {
    let err = |line: Option<usize>, message: String| Error::Parse {
        path: path.into(),
        line,
        message,
    };
    let parser = Parser::<DefaultElement>::new();
    let mut reader = Reader::new(bytes);
    let header = parser.read_header(&mut reader).map_err(|e| {
        err(
            e.line(),
            format!("not a valid PLY file: bad header ({})", reason(&e)),
        )
    })?;
    let body = *reader.get_ref();
    let header_len = bytes.len() - body.len();
    let ascii = header.encoding == Encoding::Ascii;
    let header_lines = bytes[..header_len].iter().filter(|&&b| b == b'\n').count();

    // Element by element, in header order, remembering where each starts
    // (its line for ASCII, its byte offset for binary).
    let mut payload: Vec<(String, Vec<DefaultElement>, Vec<usize>)> = Vec::new();
    let mut rest = body;
    let mut line = header_lines;
    for (name, def) in header.elements.iter() {
        // A header's count is not trusted with memory before the data is read.
        let reserve = def.count.min(rest.len()).min(1 << 16);
        let mut elements = Vec::with_capacity(reserve);
        let mut starts = Vec::with_capacity(reserve);
        for i in 0..def.count {
            let offset = bytes.len() - rest.len();
            if rest.is_empty() {
                let at = if ascii {
                    String::new()
                } else {
                    format!(" at byte {offset}")
                };
                return Err(err(
                    ascii.then_some(line + 1),
                    format!(
                        "not a valid PLY file: it ends{at} after {i} of its {} '{name}' elements",
                        def.count
                    ),
                ));
            }
            let element = if ascii {
                line += 1;
                let end = rest
                    .iter()
                    .position(|&b| b == b'\n')
                    .map_or(rest.len(), |k| k + 1);
                let text = String::from_utf8_lossy(&rest[..end]);
                rest = &rest[end..];
                starts.push(line);
                parser.read_ascii_element(&text, def).map_err(|e| {
                    err(
                        Some(line),
                        format!(
                            "not a valid PLY file: {name} {i} '{}': {}",
                            text.trim(),
                            ascii_reason(&text, def).unwrap_or_else(|| reason(&e))
                        ),
                    )
                })?
            } else {
                starts.push(offset);
                let read = match header.encoding {
                    Encoding::BinaryBigEndian => parser.read_big_endian_element(&mut rest, def),
                    _ => parser.read_little_endian_element(&mut rest, def),
                };
                read.map_err(|e| {
                    let why = if e.kind() == std::io::ErrorKind::UnexpectedEof {
                        "the file ends inside it".to_string()
                    } else {
                        reason(&e)
                    };
                    err(
                        None,
                        format!("not a valid PLY file: {name} {i} at byte {offset}: {why}"),
                    )
                })?
            };
            elements.push(element);
        }
        payload.push((name.clone(), elements, starts));
    }

    // Where element `i` of `element` starts: its line for ASCII files, its
    // byte offset (in the message) for binary ones.
    let place = |element: &str, i: usize| -> (Option<usize>, String) {
        let start = payload
            .iter()
            .find(|(n, _, _)| n == element)
            .and_then(|(_, _, s)| s.get(i).copied());
        match (ascii, start) {
            (true, Some(l)) => (Some(l), String::new()),
            (false, Some(b)) => (None, format!(" at byte {b}")),
            _ => (None, String::new()),
        }
    };
    let at = |element: &str, i: usize, what: String| -> Error {
        let (line, byte) = place(element, i);
        err(line, format!("{element} {i}{byte} {what}"))
    };

    let empty = Vec::new();
    let elements = |name: &str| {
        payload
            .iter()
            .find(|(n, _, _)| n == name)
            .map_or(&empty, |(_, e, _)| e)
    };
    let vertices = elements("vertex");
    let mut mesh = Mesh {
        positions: Vec::with_capacity(vertices.len()),
        indices: Vec::new(),
        geometries: Vec::new(),
    };
    for (i, v) in vertices.iter().enumerate() {
        let coord = |k: &str| v.get(k).and_then(Property::to_f32_lossy);
        let (Some(x), Some(y), Some(z)) = (coord("x"), coord("y"), coord("z")) else {
            return Err(at("vertex", i, "lacks a numeric x, y or z".into()));
        };
        let p = Vec3::new(x, y, z);
        if !p.is_finite() {
            return Err(at(
                "vertex",
                i,
                format!("has a non-finite coordinate ({}, {}, {})", p.x, p.y, p.z),
            ));
        }
        mesh.positions.push(p);
    }
    let n = mesh.positions.len();
    for (i, f) in elements("face").iter().enumerate() {
        let list = f
            .get("vertex_indices")
            .or_else(|| f.get("vertex_index"))
            .and_then(Property::to_u32_list);
        let Some(list) = list else {
            return Err(at(
                "face",
                i,
                "lacks a non-negative integer vertex_indices list".into(),
            ));
        };
        if list.len() < 3 {
            return Err(at("face", i, "has fewer than 3 vertices".into()));
        }
        if let Some(&bad) = list.iter().find(|&&k| k as usize >= n) {
            return Err(at(
                "face",
                i,
                format!("refers to vertex {bad}, but there are only {n} vertices"),
            ));
        }
        for k in 1..list.len() - 1 {
            mesh.indices.push([list[0], list[k], list[k + 1]]);
        }
    }
    Ok(mesh)
}

/// The parser's reason for `e`, cut to its first line, without its own
/// line number.
fn reason(e: &ParseError) -> String {
    let text = e.to_string();
    let first = text.lines().next().unwrap_or("").trim();
    let first = match first.strip_prefix("Line ") {
        Some(rest) => rest
            .split_once(": ")
            .filter(|(n, _)| n.bytes().all(|b| b.is_ascii_digit()))
            .map_or(first, |(_, r)| r),
        None => first,
    };
    first.trim_end_matches('.').to_string()
}

/// Why the ASCII element `text` does not match `def`, said plainly, where a
/// walk over its values finds it.
fn ascii_reason(text: &str, def: &ElementDef) -> Option<String> {
    let mut words = text.split_whitespace();
    let mut take = |name: &str, ty: &ScalarType| -> std::result::Result<f64, String> {
        let Some(w) = words.next() else {
            return Err(format!("too few values: '{name}' is missing"));
        };
        let (ok, kind) = match ty {
            ScalarType::Float | ScalarType::Double => (
                w.parse::<f64>().ok().filter(|x| x.is_finite()),
                "a finite number",
            ),
            ScalarType::Char => (w.parse::<i8>().ok().map(f64::from), "an 8-bit integer"),
            ScalarType::UChar => (
                w.parse::<u8>().ok().map(f64::from),
                "an 8-bit unsigned integer",
            ),
            ScalarType::Short => (w.parse::<i16>().ok().map(f64::from), "a 16-bit integer"),
            ScalarType::UShort => (
                w.parse::<u16>().ok().map(f64::from),
                "a 16-bit unsigned integer",
            ),
            ScalarType::Int => (w.parse::<i32>().ok().map(f64::from), "a 32-bit integer"),
            ScalarType::UInt => (
                w.parse::<u32>().ok().map(f64::from),
                "a 32-bit unsigned integer",
            ),
        };
        ok.ok_or_else(|| format!("'{w}' for '{name}' is not {kind}"))
    };
    let mut walk = || -> std::result::Result<(), String> {
        for (name, p) in def.properties.iter() {
            match &p.data_type {
                PropertyType::Scalar(ty) => {
                    take(name, ty)?;
                }
                PropertyType::List(count_ty, ty) => {
                    let count = take(name, count_ty)?;
                    for _ in 0..count.max(0.0) as usize {
                        take(name, ty)?;
                    }
                }
            }
        }
        Ok(())
    };
    walk().err()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn refusal(bytes: &[u8]) -> String {
        parse(bytes, Path::new("m.ply")).unwrap_err().to_string()
    }

    const HEAD: &str = "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n";

    #[test]
    fn ascii_refusals_are_one_clean_line_with_the_text_line() {
        for (body, want) in [
            ("0 0 0\n1 zero 0\n0 1 0\n3 0 1 2\n", "m.ply:11: not a valid PLY file: vertex 1 '1 zero 0': 'zero' for 'y' is not a finite number"),
            ("0 0 0\n1 1e39 0\n0 1 0\n3 0 1 2\n", "m.ply:11: vertex 1 has a non-finite coordinate (1, inf, 0)"),
            ("0 0 0\n1 0\n0 1 0\n3 0 1 2\n", "m.ply:11: not a valid PLY file: vertex 1 '1 0': too few values: 'z' is missing"),
            ("0 0 0\n1 0 0\n0 1 0\n3 0 1\n", "m.ply:13: not a valid PLY file: face 0 '3 0 1': too few values: 'vertex_indices' is missing"),
            ("0 0 0\n1 0 0\n0 1 0\n3 0 1 -2\n", "m.ply:13: face 0 lacks a non-negative integer vertex_indices list"),
            ("0 0 0\n1 0 0\n0 1 0\n300 0 1 2\n", "m.ply:13: not a valid PLY file: face 0 '300 0 1 2': '300' for 'vertex_indices' is not an 8-bit unsigned integer"),
            ("0 0 0\n1 0 0\n", "m.ply:12: not a valid PLY file: it ends after 2 of its 3 'vertex' elements"),
            ("0 0 0\n1 nan 0\n0 1 0\n3 0 1 2\n", "m.ply:11: not a valid PLY file: vertex 1 '1 nan 0': 'nan' for 'y' is not a finite number"),
        ] {
            let msg = refusal(format!("{HEAD}{body}").as_bytes());
            assert_eq!(msg, want);
            assert_eq!(msg.lines().count(), 1, "{msg}");
            assert!(!msg.contains("ParseError") && !msg.contains("Error:"), "{msg}");
        }
        let msg =
            refusal(b"ply\nformat ascii 1.0\nelement vertex 3\nproperty floot x\nend_header\n");
        assert!(
            msg.starts_with("m.ply:4: not a valid PLY file: bad header"),
            "{msg}"
        );
        assert_eq!(msg.lines().count(), 1, "{msg}");
    }

    #[test]
    fn binary_refusals_name_the_element_and_byte_offset() {
        let head = b"ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nelement face 1\nproperty list uchar uint vertex_indices\nend_header\n";
        let mut bytes = head.to_vec();
        for v in [0.0f32, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0] {
            bytes.extend(v.to_le_bytes());
        }
        let faces_at = bytes.len();
        bytes.push(3);
        bytes.extend(0u32.to_le_bytes());
        bytes.extend(1u32.to_le_bytes());
        // Cut inside the face's index list.
        let msg = refusal(&bytes);
        assert_eq!(
            msg,
            format!(
                "m.ply: not a valid PLY file: face 0 at byte {faces_at}: the file ends inside it"
            )
        );
        // Cut inside vertex 2.
        let msg = refusal(&bytes[..head.len() + 28]);
        assert_eq!(
            msg,
            format!(
                "m.ply: not a valid PLY file: vertex 2 at byte {}: the file ends inside it",
                head.len() + 24
            )
        );
        // A bad index names the face's offset.
        bytes.extend(9u32.to_le_bytes());
        let msg = refusal(&bytes);
        assert_eq!(
            msg,
            format!("m.ply: face 0 at byte {faces_at} refers to vertex 9, but there are only 3 vertices")
        );
    }
}
