//! Mesh files written by the tests: glTF (GLB, embedded and external
//! buffers) and STL (ASCII and binary). Shared by `tests/bad_input.rs` and
//! `cli/tests/cli.rs`.
#![allow(dead_code)]

use serde_json::{json, Value};

/// A glTF document being written: one binary buffer and the JSON arrays.
pub struct Gltf {
    pub bin: Vec<u8>,
    pub root: Value,
}

/// glTF component types.
pub const U8: u32 = 5121;
pub const U16: u32 = 5123;
pub const U32: u32 = 5125;
pub const FLOAT: u32 = 5126;

impl Default for Gltf {
    fn default() -> Self {
        Self::new()
    }
}

impl Gltf {
    pub fn new() -> Gltf {
        Gltf {
            bin: Vec::new(),
            root: json!({
                "asset": {"version": "2.0", "generator": "raytree tests"},
                "accessors": [], "bufferViews": [], "meshes": [], "nodes": [], "scenes": [],
            }),
        }
    }

    /// Appends `value` to the root's array `array`; its index.
    pub fn push(&mut self, array: &str, value: Value) -> usize {
        let a = self.root[array].as_array_mut().unwrap();
        a.push(value);
        a.len() - 1
    }

    /// A buffer view over `bytes`, appended to the buffer (4-aligned).
    pub fn view(&mut self, bytes: &[u8]) -> usize {
        while !self.bin.len().is_multiple_of(4) {
            self.bin.push(0);
        }
        let offset = self.bin.len();
        self.bin.extend_from_slice(bytes);
        self.push(
            "bufferViews",
            json!({"buffer": 0, "byteOffset": offset, "byteLength": bytes.len()}),
        )
    }

    /// A VEC3 FLOAT accessor of `points`, with its min and max.
    pub fn positions(&mut self, points: &[[f32; 3]]) -> usize {
        let bytes: Vec<u8> = points
            .iter()
            .flatten()
            .flat_map(|v| v.to_le_bytes())
            .collect();
        let view = self.view(&bytes);
        let (mut lo, mut hi) = ([f32::MAX; 3], [f32::MIN; 3]);
        for p in points {
            for k in 0..3 {
                lo[k] = lo[k].min(p[k]);
                hi[k] = hi[k].max(p[k]);
            }
        }
        self.push(
            "accessors",
            json!({"bufferView": view, "componentType": FLOAT, "count": points.len(),
                   "type": "VEC3", "min": lo, "max": hi}),
        )
    }

    /// A SCALAR accessor of `indices` as `kind` (U8, U16 or U32).
    pub fn indices(&mut self, indices: &[u32], kind: u32) -> usize {
        let bytes: Vec<u8> = indices
            .iter()
            .flat_map(|&i| match kind {
                U8 => vec![i as u8],
                U16 => (i as u16).to_le_bytes().to_vec(),
                _ => i.to_le_bytes().to_vec(),
            })
            .collect();
        let view = self.view(&bytes);
        self.push(
            "accessors",
            json!({"bufferView": view, "componentType": kind, "count": indices.len(), "type": "SCALAR"}),
        )
    }

    /// A mesh of `primitives` (JSON objects), named if `name` is given.
    pub fn mesh(&mut self, name: Option<&str>, primitives: Vec<Value>) -> usize {
        let mut m = json!({ "primitives": primitives });
        if let Some(n) = name {
            m["name"] = json!(n);
        }
        self.push("meshes", m)
    }

    /// A node (a JSON object: mesh, children, matrix or TRS, name).
    pub fn node(&mut self, node: Value) -> usize {
        self.push("nodes", node)
    }

    /// A scene of root nodes.
    pub fn scene(&mut self, nodes: &[usize]) -> usize {
        self.push("scenes", json!({ "nodes": nodes }))
    }

    fn with_buffer(&self, uri: Option<String>) -> Value {
        let mut root = self.root.clone();
        let mut buffer = json!({ "byteLength": self.bin.len() });
        if let Some(u) = uri {
            buffer["uri"] = json!(u);
        }
        root["buffers"] = json!([buffer]);
        root
    }

    /// The binary form: header, JSON chunk, BIN chunk.
    pub fn glb(&self) -> Vec<u8> {
        glb(
            serde_json::to_vec(&self.with_buffer(None)).unwrap(),
            Some(self.bin.clone()),
        )
    }

    /// JSON with the buffer in a base64 data URI.
    pub fn embedded(&self) -> Vec<u8> {
        let uri = format!("data:application/octet-stream;base64,{}", base64(&self.bin));
        serde_json::to_vec_pretty(&self.with_buffer(Some(uri))).unwrap()
    }

    /// JSON whose buffer is the file `uri` (relative), and that file's bytes.
    pub fn external(&self, uri: &str) -> (Vec<u8>, Vec<u8>) {
        (
            serde_json::to_vec_pretty(&self.with_buffer(Some(uri.into()))).unwrap(),
            self.bin.clone(),
        )
    }
}

/// A GLB file of `json` and an optional BIN chunk, padded as the format says.
pub fn glb(mut json: Vec<u8>, bin: Option<Vec<u8>>) -> Vec<u8> {
    while !json.len().is_multiple_of(4) {
        json.push(b' ');
    }
    let mut chunks = Vec::new();
    chunks.extend((json.len() as u32).to_le_bytes());
    chunks.extend(b"JSON");
    chunks.extend(&json);
    if let Some(mut bin) = bin {
        while !bin.len().is_multiple_of(4) {
            bin.push(0);
        }
        chunks.extend((bin.len() as u32).to_le_bytes());
        chunks.extend(b"BIN\0");
        chunks.extend(&bin);
    }
    let mut out = b"glTF".to_vec();
    out.extend(2u32.to_le_bytes());
    out.extend((12 + chunks.len() as u32).to_le_bytes());
    out.extend(chunks);
    out
}

/// Standard base64 with padding.
pub fn base64(bytes: &[u8]) -> String {
    const DIGITS: &[u8; 64] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    let mut out = String::new();
    for c in bytes.chunks(3) {
        let n = (u32::from(c[0]) << 16)
            | (u32::from(*c.get(1).unwrap_or(&0)) << 8)
            | u32::from(*c.get(2).unwrap_or(&0));
        for k in 0..4 {
            if k <= c.len() {
                out.push(DIGITS[(n >> (18 - 6 * k) & 63) as usize] as char);
            } else {
                out.push('=');
            }
        }
    }
    out
}

/// The unit cube's corners and its 12 triangles (two per face).
pub fn cube() -> (Vec<[f32; 3]>, Vec<u32>) {
    let corners = (0..8)
        .map(|i| [(i & 1) as f32, ((i >> 1) & 1) as f32, ((i >> 2) & 1) as f32])
        .collect();
    #[rustfmt::skip]
    let indices = vec![
        0, 2, 1, 1, 2, 3, // z = 0
        4, 5, 6, 5, 7, 6, // z = 1
        0, 1, 4, 1, 5, 4, // y = 0
        2, 6, 3, 3, 6, 7, // y = 1
        0, 4, 2, 2, 4, 6, // x = 0
        1, 3, 5, 3, 7, 5, // x = 1
    ];
    (corners, indices)
}

/// Triangles (three corners each) as ASCII STL text.
pub fn stl_ascii(name: &str, triangles: &[[[f32; 3]; 3]]) -> String {
    let mut s = format!("solid {name}\n");
    for t in triangles {
        s += "  facet normal 0 0 0\n    outer loop\n";
        for v in t {
            s += &format!("      vertex {:e} {:e} {:e}\n", v[0], v[1], v[2]);
        }
        s += "    endloop\n  endfacet\n";
    }
    s + &format!("endsolid {name}\n")
}

/// Triangles as a binary STL whose 80-byte header starts with `header`.
pub fn stl_binary(header: &[u8], triangles: &[[[f32; 3]; 3]]) -> Vec<u8> {
    let mut b = vec![b' '; 80];
    b[..header.len()].copy_from_slice(header);
    b.extend((triangles.len() as u32).to_le_bytes());
    for t in triangles {
        for v in [0.0f32; 3].iter().chain(t.iter().flatten()) {
            b.extend(v.to_le_bytes());
        }
        b.extend([0u8, 0]);
    }
    b
}
