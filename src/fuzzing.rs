//! What the fuzz targets (`fuzz/`, run with `cargo +nightly fuzz`) check, as
//! plain functions, so that every input a fuzzer ever found is replayed by
//! the ordinary test suite (`tests/fuzz_regressions.rs`). Each panics, and
//! only panics, when raytree misbehaves on the input.

use crate::bvh::{BuildOptions, Builder, Bvh};
use crate::geometry::Ray;
use crate::rayfile;
use crate::scene::{Camera, Mesh, Scene};
use crate::stats::NoStats;
use crate::structures::{dst::node::DstNode, htree::node::HNode, WithAccel};
use crate::structures::{Accel, BruteForce, Built, StructureKind, TraversalKind};
use std::path::Path;

/// Meshes larger than this are only parsed, not traced: the fuzzer's time
/// is better spent on more inputs.
const TRACE_LIMIT: usize = 2_000;

/// A mesh file (the format by `name`'s extension: `.obj`, `.ply`, `.stl`,
/// `.gltf`, `.glb`): parsing gives a mesh or an error naming the file,
/// never a panic; every triangle of a mesh it accepts maps to one geometry,
/// the mesh builds a valid BVH under both builders, and every structure
/// converted from it finds the oracle's closest and any hits for rays
/// through the camera.
pub fn mesh(data: &[u8], name: &str) {
    let mesh = match Mesh::parse(data, Path::new(name)) {
        Ok(m) => m,
        Err(e) => {
            assert!(e.to_string().contains(name), "error without the file: {e}");
            return;
        }
    };
    // Every triangle lies in exactly one geometry, found by the map.
    for t in 0..mesh.indices.len() as u32 {
        let (g, local) = mesh
            .geometry_of(t)
            .unwrap_or_else(|| panic!("triangle {t} in no geometry"));
        let geometry = &mesh.geometries[g as usize];
        assert_eq!(geometry.first_triangle + local, t, "{geometry:?}");
    }
    if mesh.indices.len() > TRACE_LIMIT {
        return;
    }
    let camera = Camera::framing(&mesh.bounds());
    let scene = Scene::new(name, mesh, camera);
    let oracle = BruteForce::new(scene.triangles.clone());
    let rays: Vec<Ray> = (0..64)
        .map(|i| {
            scene
                .camera
                .ray((i % 8) as f32 / 7.0, (i / 8) as f32 / 7.0, 1.0)
        })
        .collect();
    for builder in Builder::ALL {
        let bvh = Bvh::build(&scene.triangles, &BuildOptions::new(builder));
        if let Err(e) = bvh.validate(&scene.triangles) {
            panic!("invalid BVH: {e}");
        }
        for &s in StructureKind::all() {
            let (built, _) = Built::new(s, TraversalKind::Stack, &bvh, scene.triangles.clone())
                .unwrap_or_else(|e| panic!("{} refused a small mesh: {e}", s.name()));
            built.with(Agrees {
                oracle: &oracle,
                rays: &rays,
            });
        }
    }
}

struct Agrees<'a> {
    oracle: &'a BruteForce,
    rays: &'a [Ray],
}

impl WithAccel for Agrees<'_> {
    type Output = ();
    fn run<A: Accel>(self, a: &A) {
        for r in self.rays {
            let want = self.oracle.closest_hit(r, &mut NoStats);
            let got = a.closest_hit(r, &mut NoStats);
            assert!(
                self.oracle.confirms(got, want, r),
                "{}: closest {got:?}, oracle {want:?} for {r:?}",
                a.name()
            );
            let any = a.any_hit(r, &mut NoStats);
            assert_eq!(any.is_some(), want.is_some(), "{}: any hit", a.name());
        }
    }
}

/// A ray file and a hit file: parsing gives rays or an error, never a
/// panic; rays it accepts encode back to exactly the same bytes.
pub fn rayfile(data: &[u8]) {
    if let Ok(rays) = rayfile::parse_rays(data, Path::new("fuzz.rays")) {
        assert_eq!(rayfile::encode_rays(&rays), data, "ray file round trip");
    }
    let _ = rayfile::decode_hits(data);
    let _ = rayfile::decode_geometry_hits(data);
}

/// Node words of the dual-split tree and the H-tree: at every position, the
/// untrusted decoders give a node or `None`, never a panic, and a node they
/// give encodes back to exactly the words it came from.
pub fn nodes(data: &[u8]) {
    let words: Vec<u32> = data
        .chunks_exact(4)
        .map(|c| u32::from_le_bytes(c.try_into().expect("4 bytes")))
        .collect();
    for at in 0..words.len() {
        let w = &words[at..];
        if let Some(n) = DstNode::try_decode(w) {
            let mut out = Vec::new();
            n.encode(&mut out).expect("a decoded offset fits");
            assert_eq!(out[..], w[..n.words()], "dual-split node {n:?}");
        }
        if let Some(n) = HNode::try_decode(w) {
            let mut out = Vec::new();
            n.encode(&mut out).expect("a decoded offset fits");
            assert_eq!(out[..], w[..n.words()], "H-tree node {n:?}");
        }
    }
}
