//! Every input kept from fuzzing (`fuzz/`, see its README) replayed through
//! the same checks the fuzz targets run: files under
//! `tests/fuzz-regressions/<target>/`.

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
