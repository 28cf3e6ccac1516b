//! STL, ASCII and binary, read by a parser of our own so that every refusal
//! names its line (ASCII) or its triangle and byte offset (binary).
//!
//! - Binary: an 80-byte header (anything, even text starting with `solid`),
//!   a little-endian `u32` triangle count `n`, then `n` records of 50 bytes:
//!   a normal and three vertices (12 `f32`) and a 2-byte attribute. A file
//!   is binary when its size is exactly `84 + 50·n`, unless it starts with
//!   `solid` and is all text; a file of another size is refused with both
//!   sizes, unless it is an ASCII file (it starts with `solid` and is text).
//! - ASCII: `solid [name]`, facets `facet normal nx ny nz` / `outer loop` /
//!   `vertex x y z` (three, or more: a polygon is fan-triangulated) /
//!   `endloop` / `endfacet`, then `endsolid [name]`; several solids may
//!   follow one another. Keywords are read in any case, one statement per
//!   line. A file that ends before its `endsolid` is refused as truncated.
//! - Normals and attributes are ignored (normals may even be NaN, as some
//!   writers give degenerate facets); a non-finite vertex coordinate is
//!   refused.
//! - STL repeats each vertex in every triangle that uses it: vertices with
//!   exactly equal coordinates (`-0` equal to `0`) are welded into one, in
//!   order of first use, so that neighbouring triangles share their edges
//!   exactly as in an indexed mesh. Triangle `i` is the `i`-th facet.
//! - An ASCII file of several solids with triangles has one geometry per
//!   solid (`a.stl: solid 1 "wheel"`); otherwise the file is one geometry.

use super::mesh::{Geometry, Mesh};
use crate::error::{Error, Result};
use glam::Vec3;
use std::collections::HashMap;
use std::path::Path;

/// The binary header's size: 80 bytes of anything and the triangle count.
const HEADER: usize = 84;
/// One binary triangle record: normal, three vertices, attribute.
const RECORD: usize = 50;

/// Parses the STL file `bytes`; `path` names it in errors.
pub fn parse(bytes: &[u8], path: &Path) -> Result<Mesh> {
    let err = |line: Option<usize>, message: String| Error::Parse {
        path: path.into(),
        line,
        message,
    };
    let solid = starts_with_solid(bytes);
    if solid && is_text(bytes) {
        return parse_ascii(&String::from_utf8_lossy(bytes), path)
            .map_err(|(line, message)| err(Some(line), message));
    }
    if bytes.len() < HEADER {
        return Err(err(
            None,
            format!(
                "not an STL file: {} bytes, too short for a binary STL's {HEADER}-byte header, and it does not start with 'solid' as an ASCII STL does",
                bytes.len()
            ),
        ));
    }
    let count = u32::from_le_bytes([bytes[80], bytes[81], bytes[82], bytes[83]]);
    let need = HEADER as u64 + RECORD as u64 * u64::from(count);
    if need != bytes.len() as u64 {
        let what = if (bytes.len() as u64) < need {
            "the file is truncated"
        } else {
            "the file has bytes past its last triangle"
        };
        return Err(err(
            None,
            format!(
                "binary STL: its header counts {count} triangles, which take {need} bytes ({HEADER} + {RECORD} per triangle), but the file has {} bytes: {what}{}",
                bytes.len(),
                if solid {
                    " (it starts with 'solid' but is not text, so it is not an ASCII STL)"
                } else {
                    ""
                }
            ),
        ));
    }
    parse_binary(&bytes[HEADER..], count).map_err(|m| err(None, m))
}

/// Whether the file's first word is `solid` (any case), as in every ASCII
/// STL and in some binary headers.
fn starts_with_solid(bytes: &[u8]) -> bool {
    let start = bytes.trim_ascii_start();
    start.len() >= 5 && start[..5].eq_ignore_ascii_case(b"solid")
}

/// Whether `bytes` can be an ASCII STL: no control bytes but whitespace
/// (binary records hold zero bytes in their attributes and most floats).
fn is_text(bytes: &[u8]) -> bool {
    bytes
        .iter()
        .all(|&b| b >= 0x20 && b != 0x7f || matches!(b, b'\t' | b'\n' | b'\r' | 0x0b | 0x0c))
}

/// Gathers welded vertices and triangles.
struct Welder {
    mesh: Mesh,
    /// Position bits (with `-0` as `0`) to vertex index.
    seen: HashMap<[u32; 3], u32>,
}

impl Welder {
    fn new(triangles: usize) -> Welder {
        let reserve = triangles.min(1 << 20);
        Welder {
            mesh: Mesh {
                positions: Vec::with_capacity(reserve),
                indices: Vec::with_capacity(reserve),
                geometries: Vec::new(),
            },
            seen: HashMap::with_capacity(reserve),
        }
    }

    /// The index of the vertex at `p` (finite), a new one if none is there.
    fn vertex(&mut self, p: Vec3) -> std::result::Result<u32, String> {
        // Adding +0 turns -0 into +0: equal coordinates, equal keys.
        let key = (p + Vec3::ZERO).to_array().map(f32::to_bits);
        let next = self.mesh.positions.len();
        if let Some(&i) = self.seen.get(&key) {
            return Ok(i);
        }
        let i = u32::try_from(next)
            .ok()
            .filter(|&i| i != u32::MAX)
            .ok_or_else(|| "more than 2^32 - 1 distinct vertices".to_string())?;
        self.seen.insert(key, i);
        self.mesh.positions.push(p);
        Ok(i)
    }

    /// Adds the polygon `vertices` (at least 3), fan-triangulated.
    fn polygon(&mut self, vertices: &[Vec3]) -> std::result::Result<(), String> {
        let ids = vertices
            .iter()
            .map(|&p| self.vertex(p))
            .collect::<std::result::Result<Vec<u32>, String>>()?;
        for k in 1..ids.len().saturating_sub(1) {
            self.mesh.indices.push([ids[0], ids[k], ids[k + 1]]);
        }
        Ok(())
    }
}

/// The records after the header (exactly `count` of them).
fn parse_binary(records: &[u8], count: u32) -> std::result::Result<Mesh, String> {
    let mut welder = Welder::new(count as usize);
    for (i, record) in records.chunks_exact(RECORD).enumerate() {
        let f = |k: usize| {
            let at = 4 * k;
            f32::from_le_bytes([record[at], record[at + 1], record[at + 2], record[at + 3]])
        };
        let vertices: [Vec3; 3] = std::array::from_fn(|v| {
            let k = 3 + 3 * v;
            Vec3::new(f(k), f(k + 1), f(k + 2))
        });
        if let Some(v) = vertices.iter().position(|p| !p.is_finite()) {
            let p = vertices[v];
            return Err(format!(
                "binary STL: triangle {i} at byte {}: vertex {} has a non-finite coordinate ({}, {}, {})",
                HEADER + RECORD * i,
                v + 1,
                p.x,
                p.y,
                p.z
            ));
        }
        welder.polygon(&vertices)?;
    }
    Ok(welder.mesh)
}

/// Where the ASCII parser is.
#[derive(Clone, Copy, PartialEq, Eq)]
enum State {
    /// Before the first `solid`, or after an `endsolid`.
    Outside,
    /// Inside a solid, between facets.
    Solid,
    /// After `facet`, before `outer loop`.
    Facet,
    /// Inside `outer loop`.
    Loop,
    /// After `endloop`, before `endfacet`.
    LoopEnded,
}

/// A refusal: the 1-based line and the reason.
type Refusal = (usize, String);

fn parse_ascii(text: &str, path: &Path) -> std::result::Result<Mesh, Refusal> {
    let mut welder = Welder::new(text.len() / 200);
    let mut state = State::Outside;
    let mut polygon: Vec<Vec3> = Vec::with_capacity(3);
    // Each solid's name, first triangle and line.
    let mut solids: Vec<(String, usize, usize)> = Vec::new();
    let mut last_line = 0;
    for (i, raw) in text.split('\n').enumerate() {
        let number = i + 1;
        let line = raw.trim();
        let mut words = line.split_whitespace();
        let Some(keyword) = words.next() else {
            continue;
        };
        last_line = number;
        let is = |k: &str| keyword.eq_ignore_ascii_case(k);
        let refuse = |message: String| Err((number, message));
        // Nothing may follow a keyword that takes no values.
        let alone = |words: &mut std::str::SplitWhitespace| match words.next() {
            Some(w) => Err((number, format!("unexpected '{w}' after '{keyword}'"))),
            None => Ok(()),
        };
        match state {
            State::Outside if is("solid") => {
                solids.push((
                    line[keyword.len()..].trim().to_string(),
                    welder.mesh.indices.len(),
                    number,
                ));
                state = State::Solid;
            }
            State::Outside => {
                return refuse(if solids.is_empty() {
                    format!("expected 'solid' to start the ASCII STL, found '{keyword}'")
                } else {
                    format!("expected 'solid' or the end of the file after 'endsolid', found '{keyword}'")
                })
            }
            State::Solid if is("facet") => {
                match words.next() {
                    None => {}
                    Some(w) if w.eq_ignore_ascii_case("normal") => {
                        let values: Vec<&str> = words.by_ref().collect();
                        if values.len() != 3 || !values.iter().all(|v| is_normal_component(v)) {
                            return refuse(format!(
                                "malformed facet normal '{line}': expected three numbers"
                            ));
                        }
                    }
                    Some(w) => return refuse(format!("unexpected '{w}' after 'facet'")),
                }
                state = State::Facet;
            }
            State::Solid if is("endsolid") => state = State::Outside,
            State::Solid => {
                return refuse(format!("expected 'facet' or 'endsolid', found '{keyword}'"))
            }
            State::Facet if is("outer") => {
                match words.next() {
                    Some(w) if w.eq_ignore_ascii_case("loop") => alone(&mut words)?,
                    _ => return refuse(format!("expected 'outer loop', found '{line}'")),
                }
                polygon.clear();
                state = State::Loop;
            }
            State::Facet => return refuse(format!("expected 'outer loop', found '{keyword}'")),
            State::Loop if is("vertex") => {
                let values: Vec<&str> = words.collect();
                if values.len() != 3 {
                    return refuse(format!(
                        "malformed vertex '{line}': expected 3 numbers, found {}",
                        values.len()
                    ));
                }
                let mut p = [0f32; 3];
                for (k, v) in values.iter().enumerate() {
                    p[k] = v.parse().map_err(|_| {
                        (
                            number,
                            format!("malformed vertex '{line}': '{v}' is not a number"),
                        )
                    })?;
                }
                let p = Vec3::from_array(p);
                if !p.is_finite() {
                    return refuse(format!("non-finite vertex coordinate in '{line}'"));
                }
                polygon.push(p);
            }
            State::Loop if is("endloop") => {
                alone(&mut words)?;
                if polygon.len() < 3 {
                    return refuse(format!(
                        "a facet needs at least 3 vertices, this one has {}",
                        polygon.len()
                    ));
                }
                welder.polygon(&polygon).map_err(|m| (number, m))?;
                state = State::LoopEnded;
            }
            State::Loop => {
                return refuse(format!("expected 'vertex' or 'endloop', found '{keyword}'"))
            }
            State::LoopEnded if is("endfacet") => {
                alone(&mut words)?;
                state = State::Solid;
            }
            State::LoopEnded => return refuse(format!("expected 'endfacet', found '{keyword}'")),
        }
    }
    if state != State::Outside || solids.is_empty() {
        let inside = match solids.last() {
            Some((name, _, line)) if name.is_empty() => format!("inside the solid of line {line}"),
            Some((name, _, line)) => format!("inside solid '{name}' of line {line}"),
            None => "without any solid".into(),
        };
        return Err((
            last_line.max(1),
            format!("the file ends {inside}, before its 'endsolid': it is truncated"),
        ));
    }
    let mut mesh = welder.mesh;
    let total = mesh.indices.len();
    let filled: Vec<(usize, &(String, usize, usize))> = solids
        .iter()
        .enumerate()
        .filter(|(k, (_, first, _))| {
            let end = solids.get(k + 1).map_or(total, |s| s.1);
            end > *first
        })
        .collect();
    if filled.len() > 1 {
        for (n, &(k, (name, first, _))) in filled.iter().enumerate() {
            let end = filled.get(n + 1).map_or(total, |(_, s)| s.1);
            let label = if name.is_empty() {
                String::new()
            } else {
                format!(" \"{name}\"")
            };
            mesh.geometries.push(Geometry {
                name: format!("{}: solid {k}{label}", path.display()),
                first_triangle: *first as u32,
                triangle_count: (end - first) as u32,
            });
        }
    }
    Ok(mesh)
}

/// A normal's component: a number, or one of the spellings of NaN that
/// writers give degenerate facets (`nan`, `-nan`, `-nan(ind)`, `1.#QNAN`,
/// `-1.#IND`): normals are ignored.
fn is_normal_component(word: &str) -> bool {
    if word.parse::<f32>().is_ok() {
        return true;
    }
    let w = word.to_ascii_lowercase();
    w.contains("nan") || w.contains("#ind") || w.contains("inf")
}

#[cfg(test)]
mod tests {
    use super::*;

    fn refusal(bytes: &[u8]) -> String {
        parse(bytes, Path::new("m.stl")).unwrap_err().to_string()
    }

    fn binary(header: &[u8; 80], triangles: &[[f32; 9]]) -> Vec<u8> {
        let mut b = header.to_vec();
        b.extend((triangles.len() as u32).to_le_bytes());
        for t in triangles {
            for v in [0.0f32, 0.0, 1.0].iter().chain(t) {
                b.extend(v.to_le_bytes());
            }
            b.extend([0, 0]);
        }
        b
    }

    const QUAD: [[f32; 9]; 2] = [
        [0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 1.0, 1.0, 0.0],
        [0.0, 0.0, 0.0, 1.0, 1.0, 0.0, 0.0, 1.0, -0.0],
    ];

    #[test]
    fn binary_quad_welds_equal_vertices() {
        let mut header = [b' '; 80];
        header[..12].copy_from_slice(b"solid binary");
        let m = parse(&binary(&header, &QUAD), Path::new("q.stl")).unwrap();
        assert_eq!(m.indices, vec![[0, 1, 2], [0, 2, 3]]);
        assert_eq!(m.positions.len(), 4);
        assert_eq!(m.positions[3], Vec3::Y);
    }

    #[test]
    fn ascii_refusals_name_the_line() {
        let facet = "facet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\nvertex 0 1 0\nendloop\nendfacet\n";
        let ok = format!("solid a\n{facet}endsolid a\n");
        assert_eq!(
            parse(ok.as_bytes(), Path::new("a.stl"))
                .unwrap()
                .indices
                .len(),
            1
        );
        for (text, want) in [
            (
                format!("solid a\n{facet}"),
                "m.stl:8: the file ends inside solid 'a' of line 1, before its 'endsolid': it is truncated",
            ),
            (
                "solid a\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 nan 0\n".into(),
                "m.stl:5: non-finite vertex coordinate in 'vertex 1 nan 0'",
            ),
            (
                "solid a\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 x 0\n".into(),
                "m.stl:5: malformed vertex 'vertex 1 x 0': 'x' is not a number",
            ),
            (
                "solid a\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\nendloop\n".into(),
                "m.stl:6: a facet needs at least 3 vertices, this one has 2",
            ),
            (
                "solid\nfacet\nouter loop\nvertex 0 0 0\n".into(),
                "m.stl:4: the file ends inside the solid of line 1, before its 'endsolid': it is truncated",
            ),
            (
                "solid a\nfacet normal 0 0 1\nvertex 0 0 0\n".into(),
                "m.stl:3: expected 'outer loop', found 'vertex'",
            ),
            (
                format!("solid a\n{facet}endsolid\nfacet\n"),
                "m.stl:10: expected 'solid' or the end of the file after 'endsolid', found 'facet'",
            ),
        ] {
            assert_eq!(refusal(text.as_bytes()), want);
        }
        // NaN normals are ignored; keywords in any case; several solids.
        let text = format!(
            "SOLID one\nFACET NORMAL -nan -nan -nan\nOUTER LOOP\nVERTEX 0 0 0\nVERTEX 1 0 0\nVERTEX 0 1 0\nENDLOOP\nENDFACET\nENDSOLID\nsolid two\n{facet}endsolid two\n"
        );
        let m = parse(text.as_bytes(), Path::new("two.stl")).unwrap();
        assert_eq!(m.indices, vec![[0, 1, 2], [0, 1, 2]]);
        assert_eq!(m.geometries.len(), 2);
        assert_eq!(m.geometries[1].name, "two.stl: solid 1 \"two\"");
    }

    #[test]
    fn binary_refusals_name_the_triangle_and_byte() {
        let header = [0u8; 80];
        let mut bad = QUAD;
        bad[1][4] = f32::INFINITY;
        assert_eq!(
            refusal(&binary(&header, &bad)),
            "m.stl: binary STL: triangle 1 at byte 134: vertex 2 has a non-finite coordinate (1, inf, 0)"
        );
        let whole = binary(&header, &QUAD);
        let msg = refusal(&whole[..whole.len() - 1]);
        assert!(
            msg.contains("counts 2 triangles, which take 184 bytes")
                && msg.contains("has 183 bytes: the file is truncated"),
            "{msg}"
        );
        let mut longer = whole.clone();
        longer.push(0);
        assert!(refusal(&longer).contains("past its last triangle"));
        assert!(refusal(b"hello").contains("too short"));
        // A binary header that starts with "solid", cut short.
        let mut header = [0u8; 80];
        header[..5].copy_from_slice(b"solid");
        let msg = refusal(&binary(&header, &QUAD)[..150]);
        assert!(
            msg.contains("truncated") && msg.contains("not text"),
            "{msg}"
        );
    }
}
