//! Built structures saved to a file and loaded back: the scene, its
//! canonical BVH and one structure derived from it (any structure and
//! traversal of [`crate::structures::registry`]), in one versioned binary
//! file that is memory-mapped to load (`raytree build`, then `-s
//! file.rtree` for `trace`, `render` and `info`).
//!
//! # Format (version 1)
//!
//! Little-endian throughout. A fixed header of 192 bytes, a table of
//! sections (64 bytes per entry), then the sections, each starting at a
//! multiple of 64 bytes and followed by zero padding to the next multiple
//! of 64; the file ends with the last section's padding.
//!
//! | offset | bytes | field |
//! |---:|---:|---|
//! | 0 | 8 | magic `RAYTREE\0` ([`MAGIC`]) |
//! | 8 | 4 | format version ([`VERSION`]) |
//! | 12 | 4 | byte-order mark `0x0A0B0C0D` ([`BYTE_ORDER`]) |
//! | 16 | 8 | file length in bytes |
//! | 24 | 4 | header length: 192 + 64 × sections |
//! | 28 | 4 | number of sections (at most 32) |
//! | 32 | 16 | structure name (`bvh`, `dst`, ...), ASCII, NUL padded |
//! | 48 | 16 | traversal name (`stack`, `laine-4`, ...) |
//! | 64 | 16 | layout (`binary`, `sparse`, `paired` (saved as the sparse arrays), `implicit`, `dual-split`, ...) |
//! | 80 | 16 | BVH builder (`sah`, `hybrid`) |
//! | 96 | 4 | the BVH's largest leaf size allowed |
//! | 100 | 4 | zero |
//! | 104 | 8 | triangles |
//! | 112 | 8 | vertices |
//! | 120 | 8 | geometries |
//! | 128 | 8 | canonical BVH nodes |
//! | 136 | 8 | the structure's bytes ([`StructureInfo::bytes`]) |
//! | 144 | 40 | zero |
//! | 184 | 8 | XXH3-64 of the header and table, these 8 bytes taken as zero |
//! | 192 | 64 × n | sections: name (24 bytes, ASCII, NUL padded), element size (u32), zero (u32), offset (u64), length in bytes (u64), XXH3-64 of the section's bytes (u64), zero (u64) |
//!
//! Sections, in file order: `scene.meta` (name, camera, warnings,
//! geometry names and ranges), `mesh.positions` (f32 × 3 per vertex),
//! `mesh.indices` (u32 × 3 per triangle), `bvh.meta`, `bvh.nodes`,
//! `bvh.prims` (the canonical BVH), `structure.meta` (the conversion
//! time), then the structure's own arrays, named after its layout
//! (`binary.words`, `sparse.nodes`, `dst.words`, ...) and written by its
//! folder, which alone knows what they mean. Triangles are not stored:
//! they are the mesh's, expanded on load.
//!
//! # Never trusted
//!
//! A file is refused, with an [`Error::Parse`] naming it and what is wrong,
//! when it is not a raytree file, when its version is not [`VERSION`],
//! when it is shorter or longer than its header says, when a checksum
//! fails, and when any array breaks an invariant that the code reading it
//! relies on: the mesh as [`Mesh::validate`] checks it, the canonical BVH
//! as [`Bvh::validate`] does, and every structure by a walk from its root
//! that checks every reference it follows is in range and reached once,
//! every leaf list ends inside its list and names real triangles, and the
//! tree's depth fits its traversal's stack. The checksums catch accidents;
//! the walks are what make a file safe to trace, even one whose checksums
//! were recomputed after it was altered (the reader is fuzzed so:
//! `fuzz/fuzz_targets/saved.rs`). A file that passes traces exactly as the
//! structure that was saved.
//!
//! Loading copies each array out of the mapping once (the structures own
//! their arrays) and checks it: no BVH is built and nothing is converted,
//! so a large scene loads in a small fraction of its build time.

mod format;

pub(crate) use format::{leaf_ids_match, leaf_run, Bits, RecordWriter, Sections, Source};

use crate::bvh::Bvh;
use crate::error::{Error, Result};
use crate::geometry::Triangle;
use crate::names::Named;
use crate::scene::{Camera, Fov, Geometry, Mesh, Scene};
use crate::structures::{Built, LayoutOptions, StructureInfo, StructureKind, TraversalKind};
use format::{align, checksum, Entry, ENTRY, FIXED, HEADER_CHECKSUM_AT, MAX_SECTIONS, NAME_BYTES};
use glam::Vec3;
use rayon::prelude::*;
use serde::Serialize;
use std::io::Write;
use std::path::Path;
use std::sync::Arc;
use std::time::Instant;

/// The first 8 bytes of every saved file.
pub const MAGIC: [u8; 8] = *b"RAYTREE\0";
/// The format version this raytree writes and reads; a file of any other
/// version is refused.
pub const VERSION: u32 = 1;
/// Written as a little-endian u32 at offset 12: a reader on a machine of
/// the other byte order reads `0x0D0C0B0A`.
pub const BYTE_ORDER: u32 = 0x0A0B_0C0D;
/// The extension `raytree build` suggests and the commands recognise.
pub const EXTENSION: &str = "rtree";

/// What a file's header says, checked against what the file holds.
#[derive(Clone, Debug, Serialize, PartialEq)]
pub struct Header {
    /// The format version ([`VERSION`]).
    pub version: u32,
    /// The structure saved.
    pub structure: StructureKind,
    /// Its traversal (STACK for every structure but `bvh`'s others).
    pub traversal: TraversalKind,
    /// The layout its arrays are in ([`StructureInfo::layout`]).
    pub layout: String,
    /// The canonical BVH's builder ([`crate::bvh::Builder::name`]).
    pub builder: String,
    /// The canonical BVH's largest leaf size allowed.
    pub max_leaf_size: u32,
    /// Triangles of the scene.
    pub triangles: u64,
    /// Vertices of the scene.
    pub vertices: u64,
    /// Geometries of the scene.
    pub geometries: u64,
    /// Nodes of the canonical BVH.
    pub bvh_nodes: u64,
    /// The structure's bytes ([`StructureInfo::bytes`]).
    pub structure_bytes: u64,
    /// The file's length in bytes.
    pub file_bytes: u64,
    /// The sections, in file order.
    pub sections: Vec<SectionInfo>,
}

/// One section of a file.
#[derive(Clone, Debug, Serialize, PartialEq)]
pub struct SectionInfo {
    /// Its name (`mesh.positions`, `dst.words`).
    pub name: String,
    /// Where it starts in the file, in bytes (a multiple of 64).
    pub offset: u64,
    /// Its length in bytes.
    pub bytes: u64,
    /// Bytes per element (1 for a record).
    pub element_bytes: u32,
}

/// A loaded file: everything a command needs to trace as if it had loaded
/// the scene, built the BVH and converted the structure.
pub struct Saved {
    /// The header.
    pub header: Header,
    /// The scene, its triangles expanded from the mesh.
    pub scene: Scene,
    /// The canonical BVH, from which other structures can be derived.
    pub bvh: Bvh,
    /// The structure, ready to trace.
    pub built: Built,
    /// What it reports; `conversion_seconds` is the time it took when it
    /// was built.
    pub info: StructureInfo,
    /// Where the time of the load went.
    pub times: LoadTimes,
}

/// Where the time of a load went, in seconds.
#[derive(Clone, Copy, Debug, Default, Serialize, PartialEq)]
pub struct LoadTimes {
    /// Opening and mapping the file (its pages read in).
    pub map: f64,
    /// Checking the header, the table, the padding and every section's
    /// checksum.
    pub checksums: f64,
    /// Copying and checking the mesh, expanding its triangles.
    pub scene: f64,
    /// Copying and checking the BVH and the structure (side by side).
    pub structure: f64,
}

impl LoadTimes {
    /// The whole load.
    pub fn total(&self) -> f64 {
        self.map + self.checksums + self.scene + self.structure
    }
}

/// Whether `path` names a saved structure rather than a scene: its
/// extension is `.rtree`, or it is a file that starts with [`MAGIC`].
pub fn is_saved(path: &Path) -> bool {
    if path.extension().is_some_and(|e| e == EXTENSION) {
        return true;
    }
    let mut magic = [0u8; 8];
    std::fs::File::open(path)
        .and_then(|mut f| std::io::Read::read_exact(&mut f, &mut magic))
        .is_ok_and(|()| magic == MAGIC)
}

/// Writes `built` (with `info`, as [`Built::with_options`] gave them),
/// derived from `bvh` over `scene`, to `path`, atomically (a temporary
/// file renamed). Returns the header written. [`Error::Io`] naming the
/// file when it cannot be written; [`Error::Invalid`] when `info` is not
/// `built`'s, `bvh` is not over `scene`'s triangles, or the structure
/// cannot be saved.
pub fn save(
    path: &Path,
    scene: &Scene,
    bvh: &Bvh,
    built: &Built,
    info: &StructureInfo,
) -> Result<Header> {
    let (header, sections) = prepare(scene, bvh, built, info)?;
    crate::render::write_atomically(path, |w| write(w, &header, &sections))?;
    Ok(header)
}

/// [`save`] into memory: the file's bytes.
pub fn encode(scene: &Scene, bvh: &Bvh, built: &Built, info: &StructureInfo) -> Result<Vec<u8>> {
    let (header, sections) = prepare(scene, bvh, built, info)?;
    let mut out = Vec::with_capacity(header.file_bytes as usize);
    write(&mut out, &header, &sections).expect("writing to memory");
    Ok(out)
}

/// Loads the file at `path`: maps it, checks it and copies its arrays out.
/// `opts` are the limits of the layouts that have them (the implicit
/// layout's reservation). [`Error::Io`] when it cannot be read;
/// [`Error::Parse`] naming the file for anything wrong in it (see the
/// module documentation).
pub fn load(path: &Path, opts: &LayoutOptions) -> Result<Saved> {
    let io = |source| Error::Io {
        path: path.into(),
        source,
    };
    let start = Instant::now();
    let file = std::fs::File::open(path).map_err(io)?;
    let len = file.metadata().map_err(io)?.len();
    if len == 0 {
        return decode(&[], path, opts);
    }
    // SAFETY: the mapping is read-only and private to this call; the file
    // is expected not to change while it is loaded (as for any file a
    // command reads). Everything is copied out before the map is dropped.
    let map = unsafe { memmap2::MmapOptions::new().populate().map(&file) }.map_err(io)?;
    let map_seconds = start.elapsed().as_secs_f64();
    let mut saved = decode(&map, path, opts)?;
    saved.times.map = map_seconds;
    Ok(saved)
}

/// [`load`] from the file's bytes; `path` names it in errors.
pub fn decode(bytes: &[u8], path: &Path, opts: &LayoutOptions) -> Result<Saved> {
    let err = |message: String| Error::Parse {
        path: path.into(),
        line: None,
        message,
    };
    let start = Instant::now();
    let (header, entries) = open(bytes).map_err(err)?;
    let checksums = start.elapsed().as_secs_f64();
    let source = Source { entries };
    let mut saved = read(header, &source, opts).map_err(err)?;
    saved.times.checksums = checksums;
    Ok(saved)
}

/// Reads and checks the header of the file at `path` only (its table and
/// the header's checksum, not the sections).
pub fn read_header(path: &Path) -> Result<Header> {
    let io = |source| Error::Io {
        path: path.into(),
        source,
    };
    let mut f = std::fs::File::open(path).map_err(io)?;
    let mut fixed = vec![0u8; FIXED];
    let got = read_up_to(&mut f, &mut fixed).map_err(io)?;
    fixed.truncate(got);
    let err = |message: String| Error::Parse {
        path: path.into(),
        line: None,
        message,
    };
    let n = header_bytes(&fixed).map_err(err)?;
    let mut all = fixed;
    all.resize(n, 0);
    let got = read_up_to(&mut f, &mut all[FIXED..]).map_err(io)?;
    all.truncate(FIXED + got);
    let len = f.metadata().map_err(io)?.len();
    parse_header(&all, len).map_err(err)
}

fn read_up_to(f: &mut std::fs::File, buf: &mut [u8]) -> std::io::Result<usize> {
    let mut n = 0;
    while n < buf.len() {
        match std::io::Read::read(f, &mut buf[n..])? {
            0 => break,
            k => n += k,
        }
    }
    Ok(n)
}

/// Recomputes the checksums of a file's bytes in place, after the header
/// and table: for tests and fuzzing, which alter files on purpose and want
/// them to reach the checks behind the checksums. Returns whether the
/// header and table were whole enough to do it.
pub fn reseal(bytes: &mut [u8]) -> bool {
    let Ok(n) = header_bytes(bytes) else {
        return false;
    };
    if bytes.len() < n {
        return false;
    }
    let count = u32_at(bytes, 28) as usize;
    for k in 0..count {
        let e = FIXED + k * ENTRY;
        let (off, len) = (u64_at(bytes, e + 32), u64_at(bytes, e + 40));
        let end = off.checked_add(len);
        if let Some(end) = end.filter(|&end| end <= bytes.len() as u64) {
            let c = checksum(&bytes[off as usize..end as usize]);
            bytes[e + 48..e + 56].copy_from_slice(&c.to_le_bytes());
        }
    }
    let c = header_checksum(&bytes[..n]);
    bytes[HEADER_CHECKSUM_AT..HEADER_CHECKSUM_AT + 8].copy_from_slice(&c.to_le_bytes());
    true
}

fn u32_at(b: &[u8], at: usize) -> u32 {
    u32::from_le_bytes(b[at..at + 4].try_into().unwrap())
}

fn u64_at(b: &[u8], at: usize) -> u64 {
    u64::from_le_bytes(b[at..at + 8].try_into().unwrap())
}

/// XXH3-64 of the header and table with the checksum field as zero.
fn header_checksum(header: &[u8]) -> u64 {
    let mut h = header.to_vec();
    h[HEADER_CHECKSUM_AT..HEADER_CHECKSUM_AT + 8].fill(0);
    checksum(&h)
}

/// The length of the header and table, from the fixed header: checks the
/// magic, the version and the byte order first.
fn header_bytes(b: &[u8]) -> std::result::Result<usize, String> {
    if b.is_empty() {
        return Err("empty (0 bytes): not a saved raytree structure".into());
    }
    let prefix = &b[..b.len().min(8)];
    if prefix != &MAGIC[..prefix.len()] {
        return Err(
            "not a saved raytree structure (a file written by raytree build): it does not start with the magic bytes \"RAYTREE\\0\"".into(),
        );
    }
    if b.len() < 16 {
        return Err(format!(
            "truncated: {} bytes, shorter than the {FIXED}-byte header",
            b.len()
        ));
    }
    let version = u32_at(b, 8);
    if version != VERSION {
        return Err(format!(
            "format version {version}, but this raytree reads version {VERSION} only: build the file again with this raytree (raytree build)"
        ));
    }
    let order = u32_at(b, 12);
    if order != BYTE_ORDER {
        return Err(format!(
            "byte-order mark {order:#010x} where {BYTE_ORDER:#010x} is expected: the file is little-endian{}",
            if order == BYTE_ORDER.swap_bytes() {
                ", and this machine reads it the other way"
            } else {
                " and this mark is corrupted"
            }
        ));
    }
    if b.len() < FIXED {
        return Err(format!(
            "truncated: {} bytes, shorter than the {FIXED}-byte header",
            b.len()
        ));
    }
    let count = u32_at(b, 28) as usize;
    if count > MAX_SECTIONS {
        return Err(format!(
            "the header lists {count} sections, more than the format's {MAX_SECTIONS}"
        ));
    }
    let n = FIXED + count * ENTRY;
    if u32_at(b, 24) as usize != n {
        return Err(format!(
            "the header says it is {} bytes long, but {count} sections make it {n}",
            u32_at(b, 24)
        ));
    }
    Ok(n)
}

fn field(b: &[u8], what: &str) -> std::result::Result<String, String> {
    let end = b.iter().position(|&c| c == 0).unwrap_or(b.len());
    let s = &b[..end];
    if s.is_empty() || !s.iter().all(|c| c.is_ascii_graphic()) || b[end..].iter().any(|&c| c != 0) {
        return Err(format!("the {what} field is not a name"));
    }
    Ok(String::from_utf8(s.to_vec()).expect("ASCII"))
}

fn put_field(out: &mut [u8], s: &str) {
    debug_assert!(s.len() < out.len());
    out[..s.len()].copy_from_slice(s.as_bytes());
}

/// Parses and checks the header and table of a file of `file_len` bytes
/// (`b` holds at least the header and table).
fn parse_header(b: &[u8], file_len: u64) -> std::result::Result<Header, String> {
    let n = header_bytes(b)?;
    if b.len() < n {
        return Err(format!(
            "truncated: {} bytes, shorter than its {n}-byte header and section table",
            file_len
        ));
    }
    let b = &b[..n];
    let stored = u64_at(b, HEADER_CHECKSUM_AT);
    let computed = header_checksum(b);
    if stored != computed {
        return Err(format!(
            "the header's checksum is {stored:#018x} but its bytes give {computed:#018x}: the header or section table is corrupted"
        ));
    }
    let file_bytes = u64_at(b, 16);
    if file_bytes != file_len {
        return Err(if file_len < file_bytes {
            format!("truncated: {file_len} bytes, but its header says {file_bytes}")
        } else {
            format!(
                "{file_len} bytes, but its header says {file_bytes}: {} bytes too many",
                file_len - file_bytes
            )
        });
    }
    if b[100..104].iter().chain(&b[144..184]).any(|&c| c != 0) {
        return Err("reserved header bytes are not zero".into());
    }
    let structure = field(&b[32..48], "structure")?;
    let traversal = field(&b[48..64], "traversal")?;
    let structure = StructureKind::from_name(&structure).map_err(|e| e.to_string())?;
    let traversal = TraversalKind::from_name(&traversal).map_err(|e| e.to_string())?;
    let count = u32_at(b, 28) as usize;
    let mut sections = Vec::with_capacity(count);
    let mut next = n as u64;
    for k in 0..count {
        let e = &b[FIXED + k * ENTRY..FIXED + (k + 1) * ENTRY];
        let name = field(&e[..NAME_BYTES], "section name")?;
        if sections.iter().any(|s: &SectionInfo| s.name == name) {
            return Err(format!("section '{name}' is listed twice"));
        }
        let elem = u32_at(e, 24);
        let (offset, bytes) = (u64_at(e, 32), u64_at(e, 40));
        if u32_at(e, 28) != 0 || u64_at(e, 56) != 0 {
            return Err(format!("section '{name}': reserved bytes are not zero"));
        }
        if elem == 0 || bytes % elem as u64 != 0 {
            return Err(format!(
                "section '{name}': {bytes} bytes are not a whole number of {elem}-byte elements"
            ));
        }
        if offset != next {
            return Err(format!(
                "section '{name}' starts at byte {offset}, where {next} is expected"
            ));
        }
        next = offset
            .checked_add(bytes)
            .map(|end| end.div_ceil(format::ALIGN as u64) * format::ALIGN as u64)
            .filter(|&end| end <= file_bytes)
            .ok_or_else(|| {
                format!(
                    "section '{name}' ({bytes} bytes at {offset}) runs past the end of the file ({file_bytes} bytes)"
                )
            })?;
        sections.push(SectionInfo {
            name,
            offset,
            bytes,
            element_bytes: elem,
        });
    }
    if next != file_bytes {
        return Err(format!(
            "the sections end at byte {next}, but the header says the file has {file_bytes}"
        ));
    }
    Ok(Header {
        version: VERSION,
        structure,
        traversal,
        layout: field(&b[64..80], "layout")?,
        builder: field(&b[80..96], "builder")?,
        max_leaf_size: u32_at(b, 96),
        triangles: u64_at(b, 104),
        vertices: u64_at(b, 112),
        geometries: u64_at(b, 120),
        bvh_nodes: u64_at(b, 128),
        structure_bytes: u64_at(b, 136),
        file_bytes,
        sections,
    })
}

/// Checks the container: header, table, padding and every section's
/// checksum (in parallel).
fn open(bytes: &[u8]) -> std::result::Result<(Header, Vec<Entry<'_>>), String> {
    let header = parse_header(bytes, bytes.len() as u64)?;
    let n = FIXED + header.sections.len() * ENTRY;
    let checks: Vec<std::result::Result<(), String>> = header
        .sections
        .par_iter()
        .enumerate()
        .map(|(k, s)| {
            let (off, len) = (s.offset as usize, s.bytes as usize);
            let stored = u64_at(bytes, FIXED + k * ENTRY + 48);
            let computed = checksum(&bytes[off..off + len]);
            if stored != computed {
                return Err(format!(
                    "section '{}' ({len} bytes at {off}): its checksum is {stored:#018x} but its bytes give {computed:#018x}: the file is corrupted",
                    s.name
                ));
            }
            let pad_end = align(off + len);
            if bytes[off + len..pad_end].iter().any(|&c| c != 0) {
                return Err(format!("section '{}': its padding is not zero", s.name));
            }
            Ok(())
        })
        .collect();
    checks
        .into_iter()
        .collect::<std::result::Result<Vec<()>, String>>()?;
    debug_assert!(header
        .sections
        .first()
        .is_none_or(|s| s.offset as usize == n));
    let entries = header
        .sections
        .iter()
        .map(|s| {
            let (off, len) = (s.offset as usize, s.bytes as usize);
            Entry::new(s.name.clone(), s.element_bytes, &bytes[off..off + len])
        })
        .collect();
    Ok((header, entries))
}

/// The header and sections of a file to write.
fn prepare<'a>(
    scene: &'a Scene,
    bvh: &'a Bvh,
    built: &'a Built,
    info: &StructureInfo,
) -> Result<(Header, Sections<'a>)> {
    let (structure, traversal, layout) = built.kind();
    if (
        structure,
        Some(traversal).filter(|_| structure == StructureKind::Bvh),
        layout,
    ) != (info.structure, info.traversal, info.layout)
    {
        return Err(Error::Invalid(format!(
            "the structure info given ({}, {}) is not the structure's ({}, {layout})",
            info.structure.name(),
            info.layout,
            structure.name()
        )));
    }
    if bvh
        .prims
        .iter()
        .any(|&p| p as usize >= scene.triangles.len())
    {
        return Err(Error::Invalid(
            "the BVH refers to triangles the scene does not have".into(),
        ));
    }
    let mut s = Sections::default();
    let mut meta = RecordWriter::default();
    meta.str(&scene.name);
    let c = &scene.camera;
    meta.f32s(&c.eye.to_array())
        .f32s(&c.target.to_array())
        .f32s(&c.up.to_array());
    let (kind, degrees) = match c.fov {
        Fov::Vertical(a) => (0, a),
        Fov::Horizontal(a) => (1, a),
        Fov::Paper(a) => (2, a),
    };
    meta.u32(kind).f32(degrees);
    meta.u32(scene.warnings.len() as u32);
    for w in &scene.warnings {
        meta.str(w);
    }
    meta.u32(scene.mesh.geometries.len() as u32);
    for g in &scene.mesh.geometries {
        meta.str(&g.name)
            .u32(g.first_triangle)
            .u32(g.triangle_count);
    }
    s.record("scene.meta", meta);
    s.slice("mesh.positions", &scene.mesh.positions);
    s.slice("mesh.indices", &scene.mesh.indices);
    bvh.save(&mut s);
    let mut meta = RecordWriter::default();
    meta.f64(info.conversion_seconds);
    s.record("structure.meta", meta);
    built.save(&mut s);

    let n = FIXED + s.list.len() * ENTRY;
    let mut at = n;
    let mut sections = Vec::with_capacity(s.list.len());
    for sec in &s.list {
        sections.push(SectionInfo {
            name: sec.name.into(),
            offset: at as u64,
            bytes: sec.bytes.len() as u64,
            element_bytes: sec.elem,
        });
        at = align(at + sec.bytes.len());
    }
    let header = Header {
        version: VERSION,
        structure,
        traversal,
        layout: layout.into(),
        builder: bvh.stats.builder.clone(),
        max_leaf_size: bvh.stats.max_leaf_size as u32,
        triangles: scene.triangles.len() as u64,
        vertices: scene.mesh.positions.len() as u64,
        geometries: scene.mesh.geometry_count() as u64,
        bvh_nodes: bvh.nodes.len() as u64,
        structure_bytes: info.bytes as u64,
        file_bytes: at as u64,
        sections,
    };
    Ok((header, s))
}

/// Writes the header, table and sections.
fn write(w: &mut impl Write, header: &Header, s: &Sections<'_>) -> std::io::Result<()> {
    let n = FIXED + s.list.len() * ENTRY;
    let mut h = vec![0u8; n];
    h[..8].copy_from_slice(&MAGIC);
    h[8..12].copy_from_slice(&VERSION.to_le_bytes());
    h[12..16].copy_from_slice(&BYTE_ORDER.to_le_bytes());
    h[16..24].copy_from_slice(&header.file_bytes.to_le_bytes());
    h[24..28].copy_from_slice(&(n as u32).to_le_bytes());
    h[28..32].copy_from_slice(&(s.list.len() as u32).to_le_bytes());
    put_field(&mut h[32..48], header.structure.name());
    put_field(&mut h[48..64], header.traversal.name());
    put_field(&mut h[64..80], &header.layout);
    put_field(&mut h[80..96], &header.builder);
    h[96..100].copy_from_slice(&header.max_leaf_size.to_le_bytes());
    for (at, v) in [
        (104, header.triangles),
        (112, header.vertices),
        (120, header.geometries),
        (128, header.bvh_nodes),
        (136, header.structure_bytes),
    ] {
        h[at..at + 8].copy_from_slice(&v.to_le_bytes());
    }
    let sums: Vec<u64> = s.list.par_iter().map(|sec| checksum(&sec.bytes)).collect();
    for (k, (sec, info)) in s.list.iter().zip(&header.sections).enumerate() {
        let e = &mut h[FIXED + k * ENTRY..FIXED + (k + 1) * ENTRY];
        put_field(&mut e[..NAME_BYTES], sec.name);
        e[24..28].copy_from_slice(&sec.elem.to_le_bytes());
        e[32..40].copy_from_slice(&info.offset.to_le_bytes());
        e[40..48].copy_from_slice(&info.bytes.to_le_bytes());
        e[48..56].copy_from_slice(&sums[k].to_le_bytes());
    }
    let c = header_checksum(&h);
    h[HEADER_CHECKSUM_AT..HEADER_CHECKSUM_AT + 8].copy_from_slice(&c.to_le_bytes());
    w.write_all(&h)?;
    let zeros = [0u8; format::ALIGN];
    for sec in &s.list {
        w.write_all(&sec.bytes)?;
        let pad = align(sec.bytes.len()) - sec.bytes.len();
        w.write_all(&zeros[..pad])?;
    }
    Ok(())
}

/// Loads the scene, the BVH and the structure from checked sections.
fn read(
    header: Header,
    s: &Source<'_>,
    opts: &LayoutOptions,
) -> std::result::Result<Saved, String> {
    let start = Instant::now();
    let scene = read_scene(s)?;
    let scene_seconds = start.elapsed().as_secs_f64();
    // The BVH and the structure are checked side by side: neither needs
    // the other until the structure's info is derived.
    let (bvh, built) = rayon::join(
        || Bvh::load(s, &scene.triangles),
        || {
            Built::load(
                header.structure,
                header.traversal,
                &header.layout,
                s,
                scene.triangles.clone(),
                opts,
            )
        },
    );
    let (bvh, built) = (bvh?, built?);
    let structure_seconds = start.elapsed().as_secs_f64() - scene_seconds;
    let mut info = built.info(&bvh);
    let conversion_seconds = {
        let mut r = s.record("structure.meta")?;
        let v = r.f64()?;
        r.finish()?;
        v
    };
    info.conversion_seconds = conversion_seconds;
    if let Some(name) = s.unused() {
        return Err(format!(
            "section '{name}' does not belong to a {} file of this version",
            header.layout
        ));
    }
    let counts = [
        ("triangles", header.triangles, scene.triangles.len() as u64),
        (
            "vertices",
            header.vertices,
            scene.mesh.positions.len() as u64,
        ),
        (
            "geometries",
            header.geometries,
            scene.mesh.geometry_count() as u64,
        ),
        ("BVH nodes", header.bvh_nodes, bvh.nodes.len() as u64),
        ("structure bytes", header.structure_bytes, info.bytes as u64),
        (
            "largest leaf size",
            header.max_leaf_size as u64,
            bvh.stats.max_leaf_size as u64,
        ),
    ];
    for (what, said, found) in counts {
        if said != found {
            return Err(format!(
                "the header says {said} {what}, the sections hold {found}"
            ));
        }
    }
    if header.builder != bvh.stats.builder {
        return Err(format!(
            "the header names builder '{}', the BVH's record '{}'",
            header.builder, bvh.stats.builder
        ));
    }
    Ok(Saved {
        header,
        scene,
        bvh,
        built,
        info,
        times: LoadTimes {
            scene: scene_seconds,
            structure: structure_seconds,
            ..LoadTimes::default()
        },
    })
}

fn read_scene(s: &Source<'_>) -> std::result::Result<Scene, String> {
    let mut r = s.record("scene.meta")?;
    let name = r.str()?;
    let eye = Vec3::from_array(r.f32s()?);
    let target = Vec3::from_array(r.f32s()?);
    let up = Vec3::from_array(r.f32s()?);
    let kind = r.u32()?;
    let degrees = r.f32()?;
    let fov = match kind {
        0 => Fov::Vertical(degrees),
        1 => Fov::Horizontal(degrees),
        2 => Fov::Paper(degrees),
        k => {
            return Err(format!(
                "section 'scene.meta': unknown field-of-view kind {k}"
            ))
        }
    };
    let camera = Camera {
        eye,
        target,
        up,
        fov,
    };
    if !(eye.is_finite() && target.is_finite() && up.is_finite())
        || eye == target
        || up == Vec3::ZERO
        || !(degrees > 0.0 && degrees < 180.0)
    {
        return Err(format!(
            "section 'scene.meta': an invalid camera ({camera:?})"
        ));
    }
    let warnings = (0..r.count(4)?)
        .map(|_| r.str())
        .collect::<std::result::Result<Vec<_>, _>>()?;
    let geometries = (0..r.count(12)?)
        .map(|_| {
            Ok(Geometry {
                name: r.str()?,
                first_triangle: r.u32()?,
                triangle_count: r.u32()?,
            })
        })
        .collect::<std::result::Result<Vec<_>, String>>()?;
    r.finish()?;
    let mesh = Mesh {
        positions: s.vec::<Vec3>("mesh.positions")?,
        indices: s.vec::<[u32; 3]>("mesh.indices")?,
        geometries,
    };
    mesh.validate().map_err(|m| format!("the mesh: {m}"))?;
    if mesh.geometries.is_empty() {
        return Err("the mesh lists no geometries".into());
    }
    let triangles: Vec<Triangle> = (0..mesh.indices.len())
        .into_par_iter()
        .map(|i| mesh.triangle(i))
        .collect();
    Ok(Scene {
        name,
        mesh,
        triangles: Arc::from(triangles),
        camera,
        warnings,
    })
}
