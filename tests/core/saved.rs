//! Saved structures (`raytree::saved`): every structure and traversal,
//! over both builders, saved and loaded, answers every ray exactly as
//! before (closest and any hit, the work counted, the nodes visited) and
//! reports the same; truncated, corrupted (with and without its checksums
//! recomputed), foreign and other-version files are refused with an error
//! naming the file, never a panic.

use crate::common::{configurations, mixed_rays};
use raytree::prelude::*;
use raytree::rng::Pcg32;
use raytree::saved::{self, Saved};
use raytree::structures::{Accel, WithAccel};
use raytree::structures::{
    Built, LayoutOptions, SparseBvh, StructureInfo, StructureKind, TraversalKind,
};
use std::path::Path;

/// Closest and any hit of every ray, the work counted, and the canonical
/// nodes visited by the first rays.
#[derive(Debug, PartialEq)]
struct Answers {
    closest: Vec<Option<Hit>>,
    any: Vec<Option<Hit>>,
    counters: Counters,
    visits: Vec<u32>,
}

struct Trace<'a>(&'a [Ray]);

impl WithAccel for Trace<'_> {
    type Output = Answers;
    fn run<A: Accel>(self, a: &A) -> Answers {
        let mut counters = Counters::default();
        let closest = self
            .0
            .iter()
            .map(|r| a.closest_hit(r, &mut counters))
            .collect();
        let any = self.0.iter().map(|r| a.any_hit(r, &mut counters)).collect();
        let mut log = VisitLog::default();
        for r in self.0.iter().take(40) {
            a.closest_hit(r, &mut log);
            a.any_hit(r, &mut log);
        }
        Answers {
            closest,
            any,
            counters,
            visits: log.visits,
        }
    }
}

fn json(info: &StructureInfo) -> serde_json::Value {
    serde_json::to_value(info).unwrap()
}

fn decode(bytes: &[u8]) -> raytree::error::Result<Saved> {
    saved::decode(bytes, Path::new("test.rtree"), &LayoutOptions::default())
}

/// Every configuration on `spec` under both builders: saved to memory and
/// decoded, the scene, the BVH, the structure's info and its answers are
/// exactly the originals'.
fn round_trip(spec: &str, rays: usize) {
    let scene = Scene::builtin(spec).unwrap();
    let rays = mixed_rays(&scene, rays, 17);
    for (builder, opts) in crate::common::build_variants() {
        let bvh = Bvh::build(&scene.triangles, &opts);
        for (s, t) in configurations() {
            let name = format!("{spec} {builder}/{}/{}", s.name(), t.name());
            let (built, info) = match Built::new(s, t, &bvh, scene.triangles.clone()) {
                Ok(b) => b,
                // A tree too deep for a traversal is refused when built, as
                // before.
                Err(raytree::error::Error::Limit(_)) => continue,
                Err(e) => panic!("{name}: {e}"),
            };
            answers_as_before(&name, &scene, &bvh, &built, &info, &rays);
        }
    }
}

/// `built` (with its `info`, over `bvh` and `scene`) saved to memory and
/// decoded: the scene, the BVH, the info and the answers to `rays` are
/// exactly the originals', and saving again gives the same bytes.
fn answers_as_before(
    name: &str,
    scene: &Scene,
    bvh: &Bvh,
    built: &Built,
    info: &StructureInfo,
    rays: &[Ray],
) {
    let bytes = saved::encode(scene, bvh, built, info).unwrap();
    let back = decode(&bytes).unwrap_or_else(|e| panic!("{name}: {e}"));
    assert_eq!(back.header.structure, built.kind().0, "{name}");
    assert_eq!(back.header.file_bytes, bytes.len() as u64, "{name}");
    assert_eq!(back.scene.name, scene.name, "{name}");
    assert_eq!(back.scene.mesh, scene.mesh, "{name}");
    assert_eq!(back.scene.triangles, scene.triangles, "{name}");
    assert_eq!(back.scene.camera, scene.camera, "{name}");
    assert_eq!(back.bvh.nodes, bvh.nodes, "{name}");
    assert_eq!(back.bvh.prims, bvh.prims, "{name}");
    assert_eq!(
        serde_json::to_value(&back.bvh.stats).unwrap(),
        serde_json::to_value(&bvh.stats).unwrap(),
        "{name}"
    );
    assert_eq!(json(&back.info), json(info), "{name}");
    assert_eq!(back.built.kind(), built.kind(), "{name}");
    let want = built.with(Trace(rays));
    let got = back.built.with(Trace(rays));
    assert!(want.closest.iter().any(|h| h.is_some()), "{name}: no hits");
    assert_eq!(got, want, "{name}");
    // Saved again, the same bytes.
    let again = saved::encode(&back.scene, &back.bvh, &back.built, &back.info).unwrap();
    assert!(again == bytes, "{name}: saved again, other bytes");
}

/// STACK, SPARSE and LAINE-k over the stackless paper tracer's 64-byte
/// nodes ([`Built::paired`]) are saved as their sparse layout and derive
/// the 64-byte nodes again when loaded: the same answers, visits and info.
#[test]
fn paired_layouts_answer_as_before_saving() {
    let scene = Scene::builtin("chess:6000").unwrap();
    let rays = mixed_rays(&scene, 2000, 17);
    let bvh = Bvh::build(&scene.triangles, &BuildOptions::hybrid());
    let sp = std::sync::Arc::new(SparseBvh::from_bvh(&bvh, scene.triangles.clone()).unwrap());
    for t in [
        TraversalKind::Stack,
        TraversalKind::Sparse,
        TraversalKind::Laine0,
        TraversalKind::Laine8,
    ] {
        let built = Built::paired(t, sp.clone()).unwrap();
        let info = built.info(&bvh);
        assert_eq!(info.layout, "paired");
        assert_eq!(info.node_bytes, 64 * bvh.nodes.len());
        answers_as_before(
            &format!("paired/{}", t.name()),
            &scene,
            &bvh,
            &built,
            &info,
            &rays,
        );
    }
}

#[test]
fn every_structure_answers_as_before_saving_chess() {
    round_trip("chess:6000", 3000);
}

#[test]
fn every_structure_answers_as_before_saving_hairball() {
    round_trip("hairball:4000", 2000);
}

#[test]
fn a_file_written_and_mapped_loads_and_names_itself_in_errors() {
    let scene = Scene::builtin("atrium:3000").unwrap();
    let bvh = Bvh::build(&scene.triangles, &BuildOptions::hybrid());
    let (built, info) = Built::new(
        StructureKind::Bvh,
        TraversalKind::ImplicitB,
        &bvh,
        scene.triangles.clone(),
    )
    .unwrap();
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("atrium.rtree");
    let header = saved::save(&path, &scene, &bvh, &built, &info).unwrap();
    assert_eq!(header.builder, "hybrid");
    assert_eq!(header.layout, "implicit");
    assert_eq!(std::fs::metadata(&path).unwrap().len(), header.file_bytes);
    assert!(saved::is_saved(&path));
    assert_eq!(saved::read_header(&path).unwrap(), header);
    let back = saved::load(&path, &LayoutOptions::default()).unwrap();
    let rays = mixed_rays(&scene, 1000, 3);
    assert_eq!(back.built.with(Trace(&rays)), built.with(Trace(&rays)));
    assert_eq!(json(&back.info), json(&info));

    // The reservation limit holds on load too.
    let small = LayoutOptions {
        implicit_reservation_limit: 4096,
    };
    let e = saved::load(&path, &small).err().unwrap().to_string();
    assert!(e.contains("atrium.rtree") && e.contains("limit"), "{e}");

    // Errors name the file.
    let mut bytes = std::fs::read(&path).unwrap();
    bytes.truncate(bytes.len() / 2);
    std::fs::write(&path, &bytes).unwrap();
    let e = saved::load(&path, &LayoutOptions::default())
        .err()
        .unwrap()
        .to_string();
    assert!(
        e.starts_with(&path.display().to_string()) && e.contains("truncated"),
        "{e}"
    );
    let e = saved::read_header(&path).err().unwrap().to_string();
    assert!(e.contains("truncated"), "{e}");
    let missing = dir.path().join("missing.rtree");
    let e = saved::load(&missing, &LayoutOptions::default())
        .err()
        .unwrap()
        .to_string();
    assert!(e.contains("missing.rtree"), "{e}");
    // A mesh file is not a saved structure.
    let obj = dir.path().join("tri.obj");
    std::fs::write(&obj, "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n").unwrap();
    assert!(!saved::is_saved(&obj));
    let e = saved::load(&obj, &LayoutOptions::default())
        .err()
        .unwrap()
        .to_string();
    assert!(
        e.contains("tri.obj") && e.contains("not a saved raytree structure"),
        "{e}"
    );
}

/// A small file of every configuration.
fn small_files() -> Vec<(String, Vec<u8>)> {
    let scene = Scene::builtin("chess:500").unwrap();
    let bvh = Bvh::build(&scene.triangles, &BuildOptions::sah().with_max_leaf_size(4));
    configurations()
        .into_iter()
        .map(|(s, t)| {
            let (built, info) = Built::new(s, t, &bvh, scene.triangles.clone()).unwrap();
            (
                format!("{}/{}", s.name(), t.name()),
                saved::encode(&scene, &bvh, &built, &info).unwrap(),
            )
        })
        .collect()
}

/// The error of a file that must be refused.
fn refused(bytes: &[u8], what: &str) -> String {
    match decode(bytes) {
        Ok(_) => panic!("{what}: accepted"),
        Err(e) => {
            let e = e.to_string();
            assert!(e.starts_with("test.rtree: "), "{what}: {e}");
            e
        }
    }
}

/// Traces a few rays through a file that loaded (after an alteration its
/// checks let through): no panic, no endless loop.
fn trace_some(s: &Saved) {
    let rays: Vec<Ray> = (0..16)
        .map(|i| {
            s.scene
                .camera
                .ray((i % 4) as f32 / 3.0, (i / 4) as f32 / 3.0, 1.0)
        })
        .collect();
    s.built.with(Trace(&rays));
}

#[test]
fn truncated_files_are_refused() {
    for (what, bytes) in small_files() {
        let n = bytes.len();
        let mut lengths: Vec<usize> = (0..300).collect();
        lengths.extend((300..n).step_by(n / 97 + 1));
        lengths.extend([n - 64, n - 1]);
        for len in lengths {
            let e = refused(&bytes[..len], &format!("{what} cut to {len}"));
            assert!(
                e.contains("truncated") || e.contains("empty"),
                "{what} cut to {len}: {e}"
            );
        }
        // A byte too many.
        let mut longer = bytes.clone();
        longer.push(0);
        let e = refused(&longer, &what);
        assert!(e.contains("1 bytes too many"), "{e}");
    }
}

#[test]
fn flipped_bytes_are_refused_by_the_checksums() {
    let mut rng = Pcg32::new(5, 1);
    for (what, bytes) in small_files() {
        let header = 192 + 64 * bytes[28] as usize;
        let mut offsets: Vec<usize> = (0..header).collect();
        offsets
            .extend((0..200).map(|_| header + rng.below((bytes.len() - header) as u32) as usize));
        for at in offsets {
            let mut b = bytes.clone();
            b[at] ^= 1 << rng.below(8);
            let e = refused(&b, &format!("{what}, byte {at} flipped"));
            assert!(
                e.contains("checksum")
                    || e.contains("magic")
                    || e.contains("version")
                    || e.contains("byte-order")
                    || e.contains("sections")
                    || e.contains("header")
                    || e.contains("padding")
                    || e.contains("bytes"),
                "{what}, byte {at}: {e}"
            );
        }
    }
}

/// Bytes altered and the checksums recomputed, as an attacker would: the
/// checks behind the checksums refuse what would break a traversal, and
/// whatever they let through traces without a panic.
#[test]
fn altered_files_with_recomputed_checksums_never_panic() {
    let mut rng = Pcg32::new(9, 4);
    let (mut accepted, mut refused_count) = (0, 0);
    for (what, bytes) in small_files() {
        let header = 192 + 64 * bytes[28] as usize;
        for k in 0..400 {
            let mut b = bytes.clone();
            // One to four changes: a flipped bit, a byte set, a word set to
            // a small number or to all ones.
            for _ in 0..=rng.below(4) {
                let at = header + rng.below((b.len() - header) as u32) as usize;
                match k % 4 {
                    0 => b[at] ^= 1 << rng.below(8),
                    1 => b[at] = rng.below(256) as u8,
                    2 => {
                        let at = at & !3;
                        let v = rng.below(64).to_le_bytes();
                        b[at..at + 4].copy_from_slice(&v);
                    }
                    _ => {
                        let at = at & !3;
                        b[at..at + 4].fill(0xff);
                    }
                }
            }
            assert!(saved::reseal(&mut b));
            match decode(&b) {
                Ok(s) => {
                    accepted += 1;
                    trace_some(&s);
                }
                Err(e) => {
                    refused_count += 1;
                    assert!(e.to_string().starts_with("test.rtree: "), "{what}: {e}");
                }
            }
        }
    }
    // Most alterations hit an array that is checked.
    assert!(
        refused_count > accepted,
        "{refused_count} refused, {accepted} accepted"
    );
}

#[test]
fn foreign_and_other_version_files_are_refused() {
    let (_, bytes) = small_files().swap_remove(0);
    let mut b = bytes.clone();
    b[0] = b'X';
    let e = refused(&b, "magic");
    assert!(e.contains("not a saved raytree structure"), "{e}");
    let e = refused(b"ply\nformat ascii 1.0\n", "ply");
    assert!(e.contains("not a saved raytree structure"), "{e}");
    for version in [0u32, 2, 7] {
        let mut b = bytes.clone();
        b[8..12].copy_from_slice(&version.to_le_bytes());
        saved::reseal(&mut b);
        let e = refused(&b, "version");
        assert!(
            e.contains(&format!("format version {version}")) && e.contains("reads version 1"),
            "{e}"
        );
    }
    let mut b = bytes.clone();
    b[12..16].copy_from_slice(&saved::BYTE_ORDER.to_be_bytes());
    let e = refused(&b, "byte order");
    assert!(e.contains("byte-order"), "{e}");
    // A structure name this raytree does not know.
    let mut b = bytes.clone();
    b[32..35].copy_from_slice(b"xyz");
    saved::reseal(&mut b);
    let e = refused(&b, "structure name");
    assert!(e.contains("unknown structure"), "{e}");
    // An unknown section is not ignored.
    let mut b = bytes;
    let at = b.windows(9).position(|w| w == b"bvh.prims").unwrap();
    b[at..at + 9].copy_from_slice(b"bvh.xxxxx");
    saved::reseal(&mut b);
    let e = refused(&b, "section name");
    assert!(e.contains("bvh.prims"), "{e}");
}
