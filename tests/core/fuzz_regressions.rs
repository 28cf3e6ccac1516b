//! Every input kept from fuzzing (`fuzz/`, see its README) replayed through
//! the same checks the fuzz targets run: files under
//! `tests/fuzz-regressions/<target>/`.

use raytree::structures::{StructureKind, TraversalKind};
use std::path::Path;

fn replay(target: &str, check: impl Fn(&[u8])) -> usize {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/fuzz-regressions")
        .join(target);
    let mut n = 0;
    for entry in std::fs::read_dir(&dir).unwrap() {
        let path = entry.unwrap().path();
        if path.is_file() {
            let data = std::fs::read(&path).unwrap();
            eprintln!("{target}: {}", path.display());
            check(&data);
            n += 1;
        }
    }
    n
}

#[test]
fn obj_inputs() {
    assert!(replay("obj", |d| raytree::fuzzing::mesh(d, "fuzz.obj")) > 0);
}

#[test]
fn ply_inputs() {
    assert!(replay("ply", |d| raytree::fuzzing::mesh(d, "fuzz.ply")) > 0);
}

#[test]
fn stl_inputs() {
    assert!(replay("stl", |d| raytree::fuzzing::mesh(d, "fuzz.stl")) > 0);
}

/// The `glb` and `gltf` targets' inputs: one loader, which tells GLB from
/// JSON by content, under either name.
#[test]
fn gltf_inputs() {
    assert!(
        replay("gltf", |d| {
            raytree::fuzzing::mesh(d, "fuzz.gltf");
            raytree::fuzzing::mesh(d, "fuzz.glb");
        }) > 0
    );
}

#[test]
fn rayfile_inputs() {
    assert!(replay("rayfile", raytree::fuzzing::rayfile) > 0);
}

#[test]
fn node_inputs() {
    assert!(replay("nodes", raytree::fuzzing::nodes) > 0);
}

#[test]
fn saved_inputs() {
    assert!(replay("saved", raytree::fuzzing::saved) > 0);
}

/// Writes the seeds of the `saved` target: a small file of every structure
/// and traversal over a soup of 40 triangles (leaves of at most 2 for a
/// deeper tree), and the same truncated, with a byte flipped, and from
/// another version. Run with `cargo test --test core write_saved_seeds --
/// --ignored` after a format change.
#[test]
#[ignore]
fn write_saved_seeds() {
    use raytree::prelude::*;
    use raytree::structures::Built;
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fuzz-regressions/saved");
    std::fs::create_dir_all(&dir).unwrap();
    let mut rng = raytree::rng::Pcg32::new(3, 7);
    let mut mesh = Mesh::default();
    for i in 0..40u32 {
        let c = Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) * 10.0;
        for _ in 0..3 {
            let d = Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32());
            mesh.positions.push(c + d);
        }
        mesh.indices.push([3 * i, 3 * i + 1, 3 * i + 2]);
    }
    let camera = Camera::framing(&mesh.bounds());
    let scene = Scene::new("soup", mesh, camera);
    for builder in raytree::bvh::Builder::ALL {
        let bvh = Bvh::build(
            &scene.triangles,
            &BuildOptions::new(builder).with_max_leaf_size(2),
        );
        for (s, t) in crate::common::configurations() {
            let (built, info) = Built::new(s, t, &bvh, scene.triangles.clone()).unwrap();
            let bytes = raytree::saved::encode(&scene, &bvh, &built, &info).unwrap();
            let name = format!("{}-{}-{}", builder.name(), s.name(), t.name());
            if builder == raytree::bvh::Builder::Hybrid && s != StructureKind::Bvh {
                continue;
            }
            std::fs::write(dir.join(format!("{name}.rtree")), &bytes).unwrap();
            if (s, t) == (StructureKind::Dst, TraversalKind::Stack) {
                std::fs::write(dir.join("cut.rtree"), &bytes[..bytes.len() / 2]).unwrap();
                let mut b = bytes.clone();
                let at = b.len() - 300;
                b[at] ^= 8;
                std::fs::write(dir.join("flipped.rtree"), &b).unwrap();
                b[8] = 2;
                raytree::saved::reseal(&mut b);
                std::fs::write(dir.join("version-2.rtree"), &b).unwrap();
            }
        }
    }
}
