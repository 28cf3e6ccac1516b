//! What the fuzz targets (`fuzz/`, run with `cargo +nightly fuzz`) check, as
//! plain functions, so that every input a fuzzer ever found is replayed by
//! the ordinary test suite (`tests/core/fuzz_regressions.rs`). Each panics, and
//! only panics, when raytree misbehaves on the input.

use crate::bvh::{BuildOptions, Builder, Bvh};
use crate::geometry::Ray;
use crate::rayfile;
use crate::scene::{Camera, Mesh, Scene};
use crate::stats::NoStats;
use crate::structures::{dst::node::DstNode, htree::node::HNode, WithAccel};
use crate::structures::{Accel, BruteForce, Built, LayoutOptions, StructureKind, TraversalKind};
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

/// A saved structure's bytes (the format of [`crate::saved`]): loading
/// gives a structure or an error naming the file, never a panic, both as
/// the bytes are and with their checksums recomputed
/// ([`crate::saved::reseal`]), so that alterations reach the checks behind
/// the checksums. A file that loads as it is (a genuine one: an altered
/// file fails its checksums) agrees with the oracle on rays through its
/// camera; one that loads only once resealed must trace them without a
/// panic.
pub fn saved(data: &[u8]) {
    let check = |bytes: &[u8], genuine: bool| {
        let opts = LayoutOptions {
            implicit_reservation_limit: 1 << 30,
        };
        match crate::saved::decode(bytes, Path::new("fuzz.rtree"), &opts) {
            Ok(s) => {
                if s.scene.triangles.len() > TRACE_LIMIT {
                    return;
                }
                let rays: Vec<Ray> = (0..64)
                    .map(|i| {
                        s.scene
                            .camera
                            .ray((i % 8) as f32 / 7.0, (i / 8) as f32 / 7.0, 1.0)
                    })
                    .collect();
                if genuine {
                    let oracle = BruteForce::new(s.scene.triangles.clone());
                    s.built.with(Agrees {
                        oracle: &oracle,
                        rays: &rays,
                    });
                } else {
                    s.built.with(Traces { rays: &rays });
                }
            }
            Err(e) => assert!(
                e.to_string().starts_with("fuzz.rtree: "),
                "error without the file: {e}"
            ),
        }
    };
    check(data, true);
    let mut resealed = data.to_vec();
    if crate::saved::reseal(&mut resealed) && resealed != data {
        check(&resealed, false);
    }
}

struct Traces<'a> {
    rays: &'a [Ray],
}

impl WithAccel for Traces<'_> {
    type Output = ();
    fn run<A: Accel>(self, a: &A) {
        for r in self.rays {
            a.closest_hit(r, &mut NoStats);
            a.any_hit(r, &mut NoStats);
            a.count_hits(r);
        }
    }
}
