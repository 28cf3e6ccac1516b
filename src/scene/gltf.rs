//! glTF 2.0, JSON (`.gltf`) or binary (`.glb`), through the `gltf` crate's
//! document model (`gltf::json`), with every reference, offset and length
//! checked here so that a malformed file is refused with the element it
//! names, never trusted.
//!
//! - The scene: the one asked for, else the file's default scene
//!   (`"scene"`), else its first scene. Its nodes are walked depth first,
//!   in the order of the scene's list and of each node's children; every
//!   node's transform (its `matrix`, or translation · rotation · scale, the
//!   rotation quaternion normalized) is composed with its parents' in f64,
//!   and each vertex is transformed in f64 and then rounded to f32. A node
//!   reached twice (a node with two parents, a cycle) is refused.
//! - Every primitive of every mesh instance (a node with a `mesh`) of mode
//!   TRIANGLES, TRIANGLE_STRIP or TRIANGLE_FAN becomes one geometry, its
//!   triangles in index order (strips and fans as the glTF specification
//!   numbers them); other modes (POINTS, LINES, LINE_LOOP, LINE_STRIP) and
//!   triangle primitives of fewer than three vertices are skipped and
//!   counted in the [`LoadReport`]. A primitive with `indices` reads them
//!   (unsigned 8-, 16- or 32-bit), one without reads its positions in order.
//! - POSITION is a VEC3 of floats, or of 8- or 16-bit integers, normalized
//!   or not (`KHR_mesh_quantization`); sparse accessors and accessors
//!   without a buffer view (zeros) are read as the specification says. A
//!   non-finite position (of a vertex that a triangle uses) is refused.
//! - Buffers: the GLB's BIN chunk, base64 `data:` URIs, or files relative
//!   to the glTF file's directory (percent-encoded names decoded); only the
//!   buffers that the scene's triangle primitives use are read.
//! - Ignored: materials, textures, normals and every other attribute,
//!   cameras, animations, skins (a skinned mesh is placed by its node's
//!   transform, in its bind pose) and morph targets (the base positions).
//!   A file that requires an extension that could change its geometry
//!   (anything but `KHR_mesh_quantization` and material, texture and light
//!   extensions) is refused.
//! - The mesh keeps, per instance, the vertices its triangles use, in order
//!   of their index in the POSITION accessor.

use super::memory;
use super::mesh::{Geometry, LoadReport, Mesh};
use crate::error::{Error, Result};
use crate::geometry::COORDINATE_LIMIT;
use ::gltf::json;
use glam::{DMat4, DQuat, DVec3, DVec4, Vec3};
use json::accessor::{ComponentType, Type};
use json::mesh::{Mode, Semantic};
use json::validation::Checked;
use std::borrow::Cow;
use std::collections::hash_map::Entry;
use std::collections::{BTreeSet, HashMap};
use std::io::Read;
use std::path::Path;

/// A refusal's message (the file is added by [`parse`]).
type Refusal = String;
type Out<T> = std::result::Result<T, Refusal>;

/// Parses the glTF or GLB file `bytes` (binary when it starts with the GLB
/// magic `glTF`, JSON otherwise), loading scene `scene` (see the module
/// documentation for the default); `path` names the file in errors and is
/// where relative buffer URIs are resolved. What is skipped goes to
/// `report`.
pub fn parse(
    bytes: &[u8],
    path: &Path,
    scene: Option<usize>,
    report: &mut LoadReport,
) -> Result<Mesh> {
    let err = |message: String| Error::Parse {
        path: path.into(),
        line: None,
        message,
    };
    let (json_bytes, bin) = if bytes.starts_with(b"glTF") {
        split_glb(bytes).map_err(err)?
    } else {
        (bytes, None)
    };
    let json_bytes = json_bytes
        .strip_prefix(b"\xEF\xBB\xBF")
        .unwrap_or(json_bytes);
    let root =
        json::Root::from_slice(json_bytes).map_err(|e| err(format!("not valid glTF JSON: {e}")))?;
    let loader = Loader {
        root: &root,
        path,
        bin,
    };
    let instances = loader.instances(scene).map_err(err)?;
    // Refuse what would not fit before reading it: a small file can
    // instance a large mesh many times.
    let estimate: u64 = instances
        .iter()
        .map(|i| loader.triangle_estimate(i.mesh))
        .sum();
    memory::check_fits(
        &path.display().to_string(),
        estimate,
        memory::available_bytes()?,
    )?;
    let buffers = loader.load_buffers(&instances)?;
    loader.assemble(&instances, &buffers, report).map_err(err)
}

/// A mesh placed by a node: the node, its mesh and its world transform.
struct Instance {
    node: usize,
    mesh: usize,
    world: DMat4,
}

/// The GLB container's JSON chunk and BIN chunk (if any).
fn split_glb(bytes: &[u8]) -> Out<(&[u8], Option<&[u8]>)> {
    let word =
        |at: usize| u32::from_le_bytes([bytes[at], bytes[at + 1], bytes[at + 2], bytes[at + 3]]);
    if bytes.len() < 12 {
        return Err(format!(
            "GLB: {} bytes, fewer than its 12-byte header",
            bytes.len()
        ));
    }
    let version = word(4);
    if version != 2 {
        return Err(format!("GLB version {version}: only version 2 is read"));
    }
    let length = word(8) as usize;
    if length > bytes.len() {
        return Err(format!(
            "GLB: its header gives a length of {length} bytes, but the file has {}: it is truncated",
            bytes.len()
        ));
    }
    if length < 12 {
        return Err(format!(
            "GLB: its header gives a length of {length} bytes, less than the header itself"
        ));
    }
    let mut json = None;
    let mut bin = None;
    let mut at = 12;
    let mut chunk = 0;
    while at < length {
        if length - at < 8 {
            return Err(format!(
                "GLB chunk {chunk} at byte {at}: {} bytes left, fewer than a chunk's 8-byte header",
                length - at
            ));
        }
        let size = word(at) as usize;
        let kind = [bytes[at + 4], bytes[at + 5], bytes[at + 6], bytes[at + 7]];
        let name = chunk_name(kind);
        let start = at + 8;
        if size > length - start {
            return Err(format!(
                "GLB chunk {chunk} ({name}) at byte {at}: its length of {size} bytes runs past the end of the file ({length} bytes)"
            ));
        }
        let data = &bytes[start..start + size];
        match (&kind, chunk) {
            (b"JSON", 0) => json = Some(data),
            (_, 0) => {
                return Err(format!(
                    "GLB chunk 0 is {name}, but the first chunk must be JSON"
                ))
            }
            (b"BIN\0", 1) => bin = Some(data),
            (b"JSON" | b"BIN\0", _) => {
                return Err(format!(
                    "GLB chunk {chunk} at byte {at} is a second {name} chunk, or a BIN chunk that is not the second chunk"
                ))
            }
            // Chunks of other types are to be ignored.
            _ => {}
        }
        at = start + size;
        chunk += 1;
    }
    match json {
        Some(json) => Ok((json, bin)),
        None => Err("GLB: no JSON chunk".into()),
    }
}

/// A chunk type for messages: its text, or its bytes in hex.
fn chunk_name(kind: [u8; 4]) -> String {
    let text = kind.iter().all(|b| b.is_ascii_graphic() || *b == 0);
    if text {
        String::from_utf8_lossy(&kind)
            .trim_end_matches('\0')
            .to_string()
    } else {
        format!("0x{:08x}", u32::from_be_bytes(kind))
    }
}

/// Whether a required extension leaves the geometry as raytree reads it:
/// mesh quantization (read here) and appearance only (materials, textures,
/// lights).
fn extension_is_harmless(name: &str) -> bool {
    name == "KHR_mesh_quantization"
        || [
            "KHR_materials_",
            "KHR_texture_",
            "EXT_texture_",
            "MSFT_texture_",
            "KHR_lights_",
            "KHR_xmp",
        ]
        .iter()
        .any(|p| name.starts_with(p))
}

/// The name of a primitive mode that gives no triangles, as in the glTF
/// specification.
fn mode_name(mode: Mode) -> &'static str {
    match mode {
        Mode::Points => "POINTS",
        Mode::Lines => "LINES",
        Mode::LineLoop => "LINE_LOOP",
        Mode::LineStrip => "LINE_STRIP",
        Mode::Triangles => "TRIANGLES",
        Mode::TriangleStrip => "TRIANGLE_STRIP",
        Mode::TriangleFan => "TRIANGLE_FAN",
    }
}

fn is_triangles(mode: Mode) -> bool {
    matches!(
        mode,
        Mode::Triangles | Mode::TriangleStrip | Mode::TriangleFan
    )
}

/// ` "name"` for a named element, nothing otherwise.
fn label(name: &Option<String>) -> String {
    match name {
        Some(n) if !n.is_empty() => format!(" \"{n}\""),
        _ => String::new(),
    }
}

struct Loader<'a> {
    root: &'a json::Root,
    path: &'a Path,
    bin: Option<&'a [u8]>,
}

/// The buffers' bytes (those that are read), by buffer index.
type Buffers<'a> = Vec<Option<Cow<'a, [u8]>>>;

impl<'a> Loader<'a> {
    /// The scene's mesh instances in walking order, after the checks that
    /// need no buffer: version, required extensions, the scene, the node
    /// hierarchy and transforms.
    fn instances(&self, scene: Option<usize>) -> Out<Vec<Instance>> {
        let root = self.root;
        let version = &root.asset.version;
        if version.split('.').next() != Some("2") {
            return Err(format!("glTF version {version}: only glTF 2.0 is read"));
        }
        if let Some(ext) = root
            .extensions_required
            .iter()
            .find(|e| !extension_is_harmless(e))
        {
            return Err(format!(
                "the file requires the extension {ext}, which raytree does not read"
            ));
        }
        if root.scenes.is_empty() {
            return Err(
                "the file has no scenes (raytree places meshes by the nodes of a scene)".into(),
            );
        }
        let index = match (scene, root.scene) {
            (Some(s), _) => s,
            (None, Some(s)) => s.value(),
            (None, None) => 0,
        };
        let Some(chosen) = root.scenes.get(index) else {
            let which = if scene.is_some() { "" } else { "default " };
            return Err(format!(
                "the {which}scene {index} does not exist: the file has {} scene{}",
                root.scenes.len(),
                if root.scenes.len() == 1 { "" } else { "s" }
            ));
        };
        let mut seen = vec![false; root.nodes.len()];
        let mut instances = Vec::new();
        // Depth first, in list order: children pushed in reverse.
        let mut stack: Vec<(usize, DMat4)> = chosen
            .nodes
            .iter()
            .rev()
            .map(|n| (n.value(), DMat4::IDENTITY))
            .collect();
        while let Some((n, parent)) = stack.pop() {
            let Some(node) = root.nodes.get(n) else {
                return Err(format!(
                    "scene {index} refers to node {n}, but the file has {} nodes",
                    root.nodes.len()
                ));
            };
            if std::mem::replace(&mut seen[n], true) {
                return Err(format!(
                    "node {n} is reached twice in scene {index}: a node may have only one parent, and the hierarchy no cycle"
                ));
            }
            let world = parent * local_transform(node, n)?;
            if !world.is_finite() {
                return Err(format!(
                    "node {n}: its transform composed with its parents' is not finite"
                ));
            }
            if let Some(m) = node.mesh {
                let m = m.value();
                if m >= root.meshes.len() {
                    return Err(format!(
                        "node {n} refers to mesh {m}, but the file has {} meshes",
                        root.meshes.len()
                    ));
                }
                instances.push(Instance {
                    node: n,
                    mesh: m,
                    world,
                });
            }
            for child in node.children.iter().flatten().rev() {
                let c = child.value();
                if c >= root.nodes.len() {
                    return Err(format!(
                        "node {n} refers to child node {c}, but the file has {} nodes",
                        root.nodes.len()
                    ));
                }
                stack.push((c, world));
            }
        }
        Ok(instances)
    }

    /// An upper estimate of mesh `m`'s triangles from its accessors'
    /// counts, before any data is read.
    fn triangle_estimate(&self, m: usize) -> u64 {
        let root = self.root;
        let Some(mesh) = root.meshes.get(m) else {
            return 0;
        };
        mesh.primitives
            .iter()
            .map(|p| {
                let Checked::Valid(mode) = p.mode else {
                    return 0;
                };
                let vertices = p
                    .indices
                    .or_else(|| {
                        p.attributes
                            .get(&Checked::Valid(Semantic::Positions))
                            .copied()
                    })
                    .and_then(|a| root.accessors.get(a.value()))
                    .map_or(0, |a| a.count.0);
                match mode {
                    Mode::Triangles => vertices / 3,
                    Mode::TriangleStrip | Mode::TriangleFan => vertices.saturating_sub(2),
                    _ => 0,
                }
            })
            .sum()
    }

    /// Reads the buffers that the instances' triangle primitives use.
    fn load_buffers(&self, instances: &[Instance]) -> Result<Buffers<'a>> {
        let root = self.root;
        let mut needed = BTreeSet::new();
        let mut view = |v: usize| {
            if let Some(view) = root.buffer_views.get(v) {
                needed.insert(view.buffer.value());
            }
        };
        let meshes: BTreeSet<usize> = instances.iter().map(|i| i.mesh).collect();
        for &m in &meshes {
            for p in &root.meshes[m].primitives {
                if !matches!(p.mode, Checked::Valid(mode) if is_triangles(mode)) {
                    continue;
                }
                let position = p.attributes.get(&Checked::Valid(Semantic::Positions));
                for a in position.into_iter().chain(&p.indices) {
                    let Some(accessor) = root.accessors.get(a.value()) else {
                        continue;
                    };
                    if let Some(v) = accessor.buffer_view {
                        view(v.value());
                    }
                    if let Some(sparse) = &accessor.sparse {
                        view(sparse.indices.buffer_view.value());
                        view(sparse.values.buffer_view.value());
                    }
                }
            }
        }
        let mut buffers: Buffers<'a> = vec![None; root.buffers.len()];
        for b in needed {
            if let Some(buffer) = root.buffers.get(b) {
                buffers[b] = Some(self.load_buffer(b, buffer)?);
            }
        }
        Ok(buffers)
    }

    /// Buffer `b`'s bytes, at least its `byteLength` of them.
    fn load_buffer(&self, b: usize, buffer: &json::Buffer) -> Result<Cow<'a, [u8]>> {
        let err = |message: String| Error::Parse {
            path: self.path.into(),
            line: None,
            message: format!("buffer {b}{}: {message}", label(&buffer.name)),
        };
        let length = buffer.byte_length.0;
        let data: Cow<'a, [u8]> = match &buffer.uri {
            None => match self.bin {
                Some(bin) => Cow::Borrowed(bin),
                None => {
                    return Err(err(
                        "it has no uri, and the file is not a GLB with a BIN chunk".into(),
                    ))
                }
            },
            Some(uri) if uri.starts_with("data:") => Cow::Owned(data_uri(uri).map_err(err)?),
            Some(uri) if has_scheme(uri) => {
                return Err(err(format!(
                    "its uri '{uri}' is not a file name relative to the glTF file (nor a data: URI)"
                )))
            }
            Some(uri) => {
                let name = percent_decode(uri);
                let file = self.path.parent().unwrap_or(Path::new("")).join(&name);
                let read = || -> std::io::Result<Vec<u8>> {
                    let f = std::fs::File::open(&file)?;
                    let meta = f.metadata()?;
                    if !meta.is_file() {
                        return Err(std::io::Error::other("not a regular file"));
                    }
                    if meta.len() < length {
                        return Err(std::io::Error::other(format!(
                            "it has {} bytes, fewer than the buffer's byteLength of {length}",
                            meta.len()
                        )));
                    }
                    // Never more than the buffer's length, whatever the file
                    // is (nor from a file that claims no size, as in /proc).
                    let mut data = Vec::new();
                    f.take(length).read_to_end(&mut data)?;
                    Ok(data)
                };
                Cow::Owned(
                    read().map_err(|e| err(format!("cannot read '{}': {e}", file.display())))?,
                )
            }
        };
        if (data.len() as u64) < length {
            return Err(err(format!(
                "it has {} bytes, fewer than its byteLength of {length}",
                data.len()
            )));
        }
        Ok(match data {
            Cow::Borrowed(d) => Cow::Borrowed(&d[..length as usize]),
            Cow::Owned(mut d) => {
                d.truncate(length as usize);
                Cow::Owned(d)
            }
        })
    }

    /// The mesh: every instance's triangle primitives, in order.
    fn assemble(
        &self,
        instances: &[Instance],
        buffers: &Buffers<'a>,
        report: &mut LoadReport,
    ) -> Out<Mesh> {
        let root = self.root;
        let mut mesh = Mesh::default();
        if root
            .extensions_used
            .iter()
            .any(|e| e == "EXT_mesh_gpu_instancing")
        {
            report.note(
                "it uses EXT_mesh_gpu_instancing, which raytree does not apply: each instanced mesh appears once, at its node".into(),
            );
        }
        let mut prepared: HashMap<(usize, usize), Prepared> = HashMap::new();
        for instance in instances {
            let m = instance.mesh;
            let json_mesh = &root.meshes[m];
            for p in 0..json_mesh.primitives.len() {
                let here = || format!("mesh {m} primitive {p}");
                if let Entry::Vacant(slot) = prepared.entry((m, p)) {
                    slot.insert(
                        self.prepare(m, p, buffers)
                            .map_err(|e| format!("{}: {e}", here()))?,
                    );
                }
                let (positions, indices) = match &prepared[&(m, p)] {
                    Prepared::Skipped(kind) => {
                        report.skip(kind);
                        continue;
                    }
                    Prepared::Triangles {
                        positions,
                        indices,
                        sources,
                    } => (
                        positions
                            .iter()
                            .zip(sources)
                            .map(|(q, &s)| {
                                transform(&instance.world, *q).ok_or_else(|| {
                                    format!(
                                        "node {} ({}): POSITION {s} ({}, {}, {}) transformed lies beyond the coordinate limit of ±{COORDINATE_LIMIT:e} (2^126)",
                                        instance.node,
                                        here(),
                                        q.x,
                                        q.y,
                                        q.z
                                    )
                                })
                            })
                            .collect::<Out<Vec<Vec3>>>()?,
                        indices,
                    ),
                };
                let base = mesh.positions.len();
                if base + positions.len() >= u32::MAX as usize {
                    return Err("more than 2^32 - 1 vertices in the scene".into());
                }
                let (Ok(first), Ok(count)) = (
                    u32::try_from(mesh.indices.len()),
                    u32::try_from(indices.len()),
                ) else {
                    return Err("more than 2^32 - 1 triangles in the scene".into());
                };
                if first.checked_add(count).is_none() {
                    return Err("more than 2^32 - 1 triangles in the scene".into());
                }
                let node = &root.nodes[instance.node];
                mesh.geometries.push(Geometry {
                    name: format!(
                        "{}: node {}{}, mesh {m}{}, primitive {p}",
                        self.path.display(),
                        instance.node,
                        label(&node.name),
                        label(&json_mesh.name)
                    ),
                    first_triangle: first,
                    triangle_count: count,
                });
                mesh.positions.extend(positions);
                let base = base as u32;
                mesh.indices
                    .extend(indices.iter().map(|t| t.map(|i| i + base)));
            }
        }
        Ok(mesh)
    }

    /// Primitive `p` of mesh `m` in its own space: the positions its
    /// triangles use, and the triangles over them.
    fn prepare(&self, m: usize, p: usize, buffers: &Buffers<'a>) -> Out<Prepared> {
        let root = self.root;
        let primitive = &root.meshes[m].primitives[p];
        let mode = match primitive.mode {
            Checked::Valid(mode) => mode,
            Checked::Invalid => return Err("its mode is not one of glTF's (0 to 6)".into()),
        };
        if !is_triangles(mode) {
            return Ok(Prepared::Skipped(mode_name(mode)));
        }
        let Some(&position) = primitive
            .attributes
            .get(&Checked::Valid(Semantic::Positions))
        else {
            return Err("it has no POSITION attribute".into());
        };
        let positions = self.accessor(position.value(), buffers, "POSITION")?;
        if positions.dimensions != 3 || positions.kind == ComponentType::U32 {
            return Err(format!(
                "its POSITION accessor {} is {}: positions are VEC3 of floats, or of 8- or 16-bit integers",
                position.value(),
                positions.describe()
            ));
        }
        let count = positions.count;
        // The vertex sequence: the indices, or 0..count.
        let sequence: Vec<u32> = match primitive.indices {
            Some(a) => {
                let indices = self.accessor(a.value(), buffers, "indices")?;
                if indices.dimensions != 1
                    || !matches!(
                        indices.kind,
                        ComponentType::U8 | ComponentType::U16 | ComponentType::U32
                    )
                {
                    return Err(format!(
                        "its indices accessor {} is {}: indices are unsigned 8-, 16- or 32-bit SCALAR",
                        a.value(),
                        indices.describe()
                    ));
                }
                (0..indices.count).map(|i| indices.unsigned(i)).collect()
            }
            None => {
                let n = u32::try_from(count)
                    .ok()
                    .filter(|&n| n < u32::MAX)
                    .ok_or_else(|| {
                        format!("{count} vertices without indices: more than 2^32 - 1")
                    })?;
                (0..n).collect()
            }
        };
        let n = sequence.len();
        let mut triangles: Vec<[u32; 3]> = match mode {
            Mode::Triangles => {
                if !n.is_multiple_of(3) {
                    return Err(format!(
                        "{n} {} for TRIANGLES, not a multiple of 3",
                        if primitive.indices.is_some() {
                            "indices"
                        } else {
                            "vertices"
                        }
                    ));
                }
                sequence
                    .chunks_exact(3)
                    .map(|t| [t[0], t[1], t[2]])
                    .collect()
            }
            // The specification's numbering: p_i = {v_i, v_(i+1+i%2), v_(i+2-i%2)}.
            Mode::TriangleStrip => (0..n.saturating_sub(2))
                .map(|i| {
                    let odd = i % 2;
                    [sequence[i], sequence[i + 1 + odd], sequence[i + 2 - odd]]
                })
                .collect(),
            // p_i = {v_(i+1), v_(i+2), v_0}.
            _ => (0..n.saturating_sub(2))
                .map(|i| [sequence[i + 1], sequence[i + 2], sequence[0]])
                .collect(),
        };
        if triangles.is_empty() {
            return Ok(Prepared::Skipped("empty"));
        }
        if let Some(k) = sequence.iter().position(|&v| v as usize >= count) {
            return Err(format!(
                "index {} (at position {k} of its indices) is out of range of {count} positions",
                sequence[k]
            ));
        }
        // The vertices used, in order of their index, numbered anew: by a
        // table over the accessor when it is not much larger than the
        // index list (the usual case), else by sorting the index list (an
        // accessor of zeros and sparse values can be huge).
        let (used, table) = if count <= 2 * n + 1024 {
            let mut table = vec![u32::MAX; count];
            for &v in &sequence {
                table[v as usize] = 0;
            }
            let mut used = Vec::new();
            for (v, slot) in table.iter_mut().enumerate() {
                if *slot != u32::MAX {
                    *slot = used.len() as u32;
                    used.push(v as u32);
                }
            }
            (used, Some(table))
        } else {
            let mut used = sequence;
            used.sort_unstable();
            used.dedup();
            (used, None)
        };
        let mut local = Vec::with_capacity(used.len());
        for &v in &used {
            let q = positions.vec3(v as usize);
            if !q.is_finite() {
                return Err(format!(
                    "POSITION {v} is not finite ({}, {}, {})",
                    q.x, q.y, q.z
                ));
            }
            local.push(q);
        }
        let renumber = |v: u32| match &table {
            Some(table) => table[v as usize],
            None => used.binary_search(&v).unwrap_or(0) as u32,
        };
        for t in &mut triangles {
            *t = t.map(renumber);
        }
        Ok(Prepared::Triangles {
            positions: local,
            indices: triangles,
            sources: used,
        })
    }

    /// Accessor `a`, checked against its buffer view and buffer: `what`
    /// names its use in errors.
    fn accessor<'b>(&self, a: usize, buffers: &'b Buffers<'a>, what: &str) -> Out<Accessor<'b>> {
        let root = self.root;
        let Some(accessor) = root.accessors.get(a) else {
            return Err(format!(
                "its {what} accessor {a} does not exist: the file has {} accessors",
                root.accessors.len()
            ));
        };
        let here = |m: String| format!("{what} accessor {a}: {m}");
        let kind = match accessor.component_type {
            Checked::Valid(t) => t.0,
            Checked::Invalid => return Err(here("its componentType is not one of glTF's".into())),
        };
        let dimensions = match accessor.type_ {
            Checked::Valid(Type::Scalar) => 1,
            Checked::Valid(Type::Vec2) => 2,
            Checked::Valid(Type::Vec3) => 3,
            Checked::Valid(Type::Vec4 | Type::Mat2) => 4,
            Checked::Valid(Type::Mat3) => 9,
            Checked::Valid(Type::Mat4) => 16,
            Checked::Invalid => return Err(here("its type is not one of glTF's".into())),
        };
        let count = usize::try_from(accessor.count.0)
            .map_err(|_| here(format!("{} elements: too many", accessor.count.0)))?;
        let element = component_size(kind) * dimensions;
        let dense = match accessor.buffer_view {
            Some(v) => Some(
                self.strided(
                    v.value(),
                    accessor.byte_offset.map_or(0, |o| o.0),
                    count,
                    element,
                    buffers,
                    true,
                )
                .map_err(here)?,
            ),
            None => None,
        };
        let sparse = match &accessor.sparse {
            None => None,
            Some(s) => {
                let n = usize::try_from(s.count.0)
                    .ok()
                    .filter(|&n| n <= count)
                    .ok_or_else(|| {
                        here(format!(
                            "its sparse count {} exceeds its count {count}",
                            s.count.0
                        ))
                    })?;
                let index_kind = match s.indices.component_type {
                    Checked::Valid(t)
                        if matches!(
                            t.0,
                            ComponentType::U8 | ComponentType::U16 | ComponentType::U32
                        ) =>
                    {
                        t.0
                    }
                    _ => {
                        return Err(here(
                            "its sparse indices are not unsigned 8-, 16- or 32-bit".into(),
                        ))
                    }
                };
                let (index_bytes, _) = self
                    .strided(
                        s.indices.buffer_view.value(),
                        s.indices.byte_offset.0,
                        n,
                        component_size(index_kind),
                        buffers,
                        false,
                    )
                    .map_err(|m| here(format!("sparse indices: {m}")))?;
                let (value_bytes, _) = self
                    .strided(
                        s.values.buffer_view.value(),
                        s.values.byte_offset.0,
                        n,
                        element,
                        buffers,
                        false,
                    )
                    .map_err(|m| here(format!("sparse values: {m}")))?;
                let indices: Vec<u32> = (0..n)
                    .map(|i| read_unsigned(index_bytes, i * component_size(index_kind), index_kind))
                    .collect();
                if let Some(k) = (0..n).find(|&k| {
                    indices[k] as usize >= count || (k > 0 && indices[k] <= indices[k - 1])
                }) {
                    return Err(here(format!(
                        "sparse index {} (at position {k}) is out of range of {count} elements, or not above the one before it",
                        indices[k]
                    )));
                }
                Some((indices, value_bytes))
            }
        };
        Ok(Accessor {
            kind,
            dimensions,
            normalized: accessor.normalized,
            count,
            dense,
            sparse,
        })
    }

    /// `count` elements of `element` bytes at `offset` in buffer view `v`,
    /// checked to lie inside it: the bytes from the first element to the
    /// end of the view, and the stride (`strided`: the view's byteStride if
    /// it has one; otherwise tightly packed).
    fn strided<'b>(
        &self,
        v: usize,
        offset: u64,
        count: usize,
        element: usize,
        buffers: &'b Buffers<'a>,
        strided: bool,
    ) -> Out<(&'b [u8], usize)> {
        let root = self.root;
        let Some(view) = root.buffer_views.get(v) else {
            return Err(format!(
                "buffer view {v} does not exist: the file has {} buffer views",
                root.buffer_views.len()
            ));
        };
        let b = view.buffer.value();
        let Some(Some(buffer)) = buffers.get(b) else {
            return Err(format!(
                "buffer view {v} refers to buffer {b}, but the file has {} buffers",
                root.buffers.len()
            ));
        };
        let start = view.byte_offset.map_or(0, |o| o.0);
        let length = view.byte_length.0;
        let end = start.checked_add(length);
        if end.is_none_or(|e| e > buffer.len() as u64) {
            return Err(format!(
                "buffer view {v} (bytes {start} to {start} + {length}) runs past the end of buffer {b} ({} bytes)",
                buffer.len()
            ));
        }
        let stride = match view.byte_stride {
            Some(s) if strided => s.0,
            _ => element,
        };
        if stride < element {
            return Err(format!(
                "buffer view {v}'s byteStride of {stride} is less than an element's {element} bytes"
            ));
        }
        let need = match count {
            0 => Some(offset),
            n => (n as u64 - 1)
                .checked_mul(stride as u64)
                .and_then(|x| x.checked_add(element as u64))
                .and_then(|x| x.checked_add(offset)),
        };
        if need.is_none_or(|n| n > length) {
            return Err(format!(
                "{count} elements of {element} bytes, {stride} bytes apart, from byte {offset} do not fit in buffer view {v} ({length} bytes)"
            ));
        }
        // Both fit in the buffer's length, which is a usize.
        let from = (start + offset) as usize;
        let to = (start + length) as usize;
        Ok((&buffer[from..to], stride))
    }
}

/// Node `n`'s own transform: its matrix, or T · R · S (the rotation
/// normalized), in f64.
fn local_transform(node: &json::Node, n: usize) -> Out<DMat4> {
    let f = |a: &[f32]| a.iter().all(|x| x.is_finite());
    if let Some(m) = &node.matrix {
        if !f(m) {
            return Err(format!("node {n}: its matrix has a non-finite value"));
        }
        let m = DMat4::from_cols_array(&m.map(f64::from));
        let last = m.row(3);
        if last != DVec4::W {
            return Err(format!(
                "node {n}: its matrix's last row is ({}, {}, {}, {}), not (0, 0, 0, 1)",
                last.x, last.y, last.z, last.w
            ));
        }
        return Ok(m);
    }
    let t = node.translation.unwrap_or([0.0; 3]);
    let r = node.rotation.map_or([0.0, 0.0, 0.0, 1.0], |q| q.0);
    let s = node.scale.unwrap_or([1.0; 3]);
    if !f(&t) || !f(&r) || !f(&s) {
        return Err(format!(
            "node {n}: its translation, rotation or scale has a non-finite value"
        ));
    }
    let q = DQuat::from_xyzw(r[0].into(), r[1].into(), r[2].into(), r[3].into());
    let length = q.length();
    if !(length > 0.0 && length.is_finite()) {
        return Err(format!(
            "node {n}: its rotation ({}, {}, {}, {}) is not a unit quaternion",
            r[0], r[1], r[2], r[3]
        ));
    }
    Ok(DMat4::from_scale_rotation_translation(
        DVec3::from_array(s.map(f64::from)),
        q / length,
        DVec3::from_array(t.map(f64::from)),
    ))
}

/// `p` transformed by `world` in f64 and rounded to f32, if it lies
/// within the coordinate limit.
fn transform(world: &DMat4, p: Vec3) -> Option<Vec3> {
    let q = world.transform_point3(p.as_dvec3()).as_vec3();
    (q.is_finite() && q.abs().max_element() <= COORDINATE_LIMIT).then_some(q)
}

/// A triangle primitive read once and placed by every instance.
enum Prepared {
    /// Not triangles: its kind for the report.
    Skipped(&'static str),
    Triangles {
        /// The positions its triangles use, in its own space.
        positions: Vec<Vec3>,
        /// Triangles over `positions`.
        indices: Vec<[u32; 3]>,
        /// Each position's index in the POSITION accessor.
        sources: Vec<u32>,
    },
}

/// An accessor whose every element lies inside its buffer view.
struct Accessor<'b> {
    kind: ComponentType,
    dimensions: usize,
    normalized: bool,
    count: usize,
    /// Element `i` starts at byte `i · stride`; `None`: zeros.
    dense: Option<(&'b [u8], usize)>,
    /// Sparse replacements: strictly increasing indices, tightly packed
    /// values.
    sparse: Option<(Vec<u32>, &'b [u8])>,
}

impl Accessor<'_> {
    fn describe(&self) -> String {
        let t = match self.dimensions {
            1 => "SCALAR".to_string(),
            d => format!("{d} components"),
        };
        format!(
            "{t} of {:?}{}",
            self.kind,
            if self.normalized { " (normalized)" } else { "" }
        )
    }

    /// Where element `i` is: its bytes' slice and offset.
    fn locate(&self, i: usize) -> Option<(&[u8], usize)> {
        if let Some((indices, values)) = &self.sparse {
            if let Ok(k) = indices.binary_search(&(i as u32)) {
                return Some((values, k * component_size(self.kind) * self.dimensions));
            }
        }
        self.dense.map(|(bytes, stride)| (bytes, i * stride))
    }

    /// Element `i` (below `count`) of an unsigned integer SCALAR accessor.
    fn unsigned(&self, i: usize) -> u32 {
        self.locate(i)
            .map_or(0, |(bytes, at)| read_unsigned(bytes, at, self.kind))
    }

    /// Element `i` (below `count`) of a VEC3 accessor, as floats.
    fn vec3(&self, i: usize) -> Vec3 {
        let Some((bytes, at)) = self.locate(i) else {
            return Vec3::ZERO;
        };
        let size = component_size(self.kind);
        let c = |k: usize| read_float(bytes, at + k * size, self.kind, self.normalized);
        Vec3::new(c(0), c(1), c(2))
    }
}

fn component_size(kind: ComponentType) -> usize {
    match kind {
        ComponentType::I8 | ComponentType::U8 => 1,
        ComponentType::I16 | ComponentType::U16 => 2,
        ComponentType::U32 | ComponentType::F32 => 4,
    }
}

/// An unsigned integer component at `at` (inside `bytes`, checked before).
fn read_unsigned(bytes: &[u8], at: usize, kind: ComponentType) -> u32 {
    match kind {
        ComponentType::U8 => u32::from(bytes[at]),
        ComponentType::U16 => u32::from(u16::from_le_bytes([bytes[at], bytes[at + 1]])),
        _ => u32::from_le_bytes([bytes[at], bytes[at + 1], bytes[at + 2], bytes[at + 3]]),
    }
}

/// A component at `at` as a float: integers as they are, or normalized as
/// the glTF specification says (`max(c / 127, -1)` for signed bytes).
fn read_float(bytes: &[u8], at: usize, kind: ComponentType, normalized: bool) -> f32 {
    let four = || [bytes[at], bytes[at + 1], bytes[at + 2], bytes[at + 3]];
    let two = || [bytes[at], bytes[at + 1]];
    match (kind, normalized) {
        (ComponentType::F32, _) => f32::from_le_bytes(four()),
        (ComponentType::I8, false) => f32::from(bytes[at] as i8),
        (ComponentType::U8, false) => f32::from(bytes[at]),
        (ComponentType::I16, false) => f32::from(i16::from_le_bytes(two())),
        (ComponentType::U16, false) => f32::from(u16::from_le_bytes(two())),
        (ComponentType::I8, true) => (f32::from(bytes[at] as i8) / 127.0).max(-1.0),
        (ComponentType::U8, true) => f32::from(bytes[at]) / 255.0,
        (ComponentType::I16, true) => (f32::from(i16::from_le_bytes(two())) / 32767.0).max(-1.0),
        (ComponentType::U16, true) => f32::from(u16::from_le_bytes(two())) / 65535.0,
        (ComponentType::U32, _) => u32::from_le_bytes(four()) as f32,
    }
}

/// Whether `uri` starts with a scheme of two or more letters (`http:`,
/// `file:`); a drive letter (`C:`) is not one.
fn has_scheme(uri: &str) -> bool {
    let Some((scheme, _)) = uri.split_once(':') else {
        return false;
    };
    scheme.len() >= 2
        && scheme.starts_with(|c: char| c.is_ascii_alphabetic())
        && scheme
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || matches!(c, '+' | '-' | '.'))
}

/// `%XX` escapes decoded (a malformed one is kept as it is).
fn percent_decode(uri: &str) -> String {
    let bytes = uri.as_bytes();
    let mut out = Vec::with_capacity(bytes.len());
    let mut i = 0;
    while i < bytes.len() {
        let hex = |b: u8| (b as char).to_digit(16);
        if bytes[i] == b'%' && i + 2 < bytes.len() {
            if let (Some(h), Some(l)) = (hex(bytes[i + 1]), hex(bytes[i + 2])) {
                out.push((h * 16 + l) as u8);
                i += 3;
                continue;
            }
        }
        out.push(bytes[i]);
        i += 1;
    }
    String::from_utf8_lossy(&out).into_owned()
}

/// The bytes of a base64 `data:` URI.
fn data_uri(uri: &str) -> Out<Vec<u8>> {
    let Some((header, data)) = uri.split_once(',') else {
        return Err("its data: URI has no ',' before its data".into());
    };
    if !header.ends_with(";base64") {
        return Err(format!(
            "its data: URI ('{header},...') is not base64, the only encoding read"
        ));
    }
    base64(data).map_err(|m| format!("its data: URI: {m}"))
}

/// Standard base64 (`=` padding optional).
fn base64(text: &str) -> Out<Vec<u8>> {
    let digits = text.trim_end_matches('=');
    if text.len() - digits.len() > 2 {
        return Err("more than two '=' at the end of its base64 data".into());
    }
    let mut out = Vec::with_capacity(digits.len() / 4 * 3 + 3);
    let mut acc: u32 = 0;
    let mut bits = 0;
    for (i, c) in digits.bytes().enumerate() {
        let v = match c {
            b'A'..=b'Z' => c - b'A',
            b'a'..=b'z' => c - b'a' + 26,
            b'0'..=b'9' => c - b'0' + 52,
            b'+' => 62,
            b'/' => 63,
            _ => {
                return Err(format!(
                    "'{}' at position {i} of its base64 data is not a base64 digit",
                    c.escape_ascii()
                ))
            }
        };
        acc = (acc << 6) | u32::from(v);
        bits += 6;
        if bits >= 8 {
            bits -= 8;
            out.push((acc >> bits) as u8);
            acc &= (1 << bits) - 1;
        }
    }
    if bits >= 6 {
        return Err("its base64 data has a stray last digit".into());
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn base64_decodes_and_refuses() {
        assert_eq!(base64("").unwrap(), b"");
        assert_eq!(base64("TWFu").unwrap(), b"Man");
        assert_eq!(base64("TWE=").unwrap(), b"Ma");
        assert_eq!(base64("TWE").unwrap(), b"Ma");
        assert_eq!(base64("TQ==").unwrap(), b"M");
        assert_eq!(base64("AAECAwQFBgc=").unwrap(), [0, 1, 2, 3, 4, 5, 6, 7]);
        assert!(base64("TQ===").is_err());
        assert!(base64("T").is_err());
        assert!(base64("TW!u").unwrap_err().contains("position 2"));
    }

    #[test]
    fn uris() {
        assert!(has_scheme("http://x/y.bin"));
        assert!(has_scheme("file:///y.bin"));
        assert!(!has_scheme("C:/y.bin"));
        assert!(!has_scheme("y.bin"));
        assert_eq!(percent_decode("my%20mesh.bin"), "my mesh.bin");
        assert_eq!(percent_decode("100%"), "100%");
        assert_eq!(percent_decode("a%2"), "a%2");
        assert_eq!(percent_decode("%zz"), "%zz");
    }

    #[test]
    fn glb_container_refusals() {
        let mut glb = b"glTF".to_vec();
        glb.extend(2u32.to_le_bytes());
        glb.extend(28u32.to_le_bytes());
        glb.extend(8u32.to_le_bytes());
        glb.extend(b"JSON");
        glb.extend(b"{}      ");
        assert!(split_glb(&glb).is_ok());
        assert!(split_glb(&glb[..20]).unwrap_err().contains("truncated"));
        let mut bad = glb.clone();
        bad[12] = 200;
        assert_eq!(
            split_glb(&bad).unwrap_err(),
            "GLB chunk 0 (JSON) at byte 12: its length of 200 bytes runs past the end of the file (28 bytes)"
        );
        let mut bad = glb.clone();
        bad[8] = 4;
        assert!(split_glb(&bad)
            .unwrap_err()
            .contains("less than the header"));
        let mut bad = glb.clone();
        bad[4] = 1;
        assert!(split_glb(&bad).unwrap_err().contains("version 1"));
        let mut bad = glb.clone();
        bad[16..20].copy_from_slice(b"BIN\0");
        assert!(split_glb(&bad).unwrap_err().contains("must be JSON"));
        assert!(split_glb(b"glTF\x02\0\0").unwrap_err().contains("12-byte"));
    }
}
