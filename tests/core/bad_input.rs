//! Bad input gets a clear error naming the file (and line, for text
//! formats), never a panic.

use raytree::prelude::*;
use std::io::Write;

fn load(name: &str, bytes: &[u8]) -> String {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join(name);
    std::fs::File::create(&path)
        .unwrap()
        .write_all(bytes)
        .unwrap();
    let err = Scene::load(&path).expect_err("bad input must be refused");
    let msg = err.to_string();
    assert!(msg.contains(name), "error does not name the file: {msg}");
    msg
}

#[test]
fn obj_malformed_vertex_names_the_line() {
    let msg = load("a.obj", b"v 0 0 0\nv 1 0 0\nv 0 one 0\nf 1 2 3\n");
    assert!(msg.contains("a.obj:3"), "{msg}");
}

#[test]
fn obj_nan_and_infinite_vertices_name_the_line() {
    for bad in ["nan", "inf", "-inf", "NaN"] {
        let text = format!("v 0 0 0\nv 1 0 0\n# comment\nv 0 {bad} 0\nf 1 2 3\n");
        let msg = load("b.obj", text.as_bytes());
        assert!(
            msg.contains("b.obj:4") && msg.contains("non-finite"),
            "{msg}"
        );
    }
}

#[test]
fn obj_out_of_range_index_names_the_line() {
    let msg = load("c.obj", b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\nf 1 2 4\n");
    assert!(msg.contains("c.obj:5"), "{msg}");
    let msg = load("c2.obj", b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 -4\n");
    assert!(msg.contains("c2.obj:4"), "{msg}");
}

#[test]
fn empty_and_degenerate_meshes_are_refused() {
    let msg = load("empty.obj", b"");
    assert!(msg.contains("no triangles"), "{msg}");
    let msg = load("points.obj", b"v 0 0 0\nv 1 0 0\n");
    assert!(msg.contains("no triangles"), "{msg}");
    let msg = load("flat.obj", b"v 0 0 0\nv 1 0 0\nv 2 0 0\nf 1 2 3\n");
    assert!(msg.contains("degenerate"), "{msg}");
}

#[test]
fn missing_file_and_unknown_format() {
    let err = Scene::load("/nonexistent/x.obj").unwrap_err().to_string();
    assert!(err.contains("/nonexistent/x.obj"), "{err}");
    let msg = load("mesh.3ds", b"solid x\n");
    assert!(
        msg.contains(
            "unknown mesh format: expected a file ending in .obj, .ply, .stl, .gltf, .glb"
        ),
        "{msg}"
    );
    let err = Scene::from_spec("no-such-scene").unwrap_err().to_string();
    assert!(err.contains("chess") && err.contains("hairball"), "{err}");
}

const PLY_HEAD: &str = "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n";

#[test]
fn ply_ascii_loads_and_fans_polygons() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("quad.ply");
    let text = "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\nproperty float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n1 1 0\n0 1 0\n4 0 1 2 3\n";
    std::fs::write(&path, text).unwrap();
    let s = Scene::load(&path).unwrap();
    assert_eq!(s.mesh.indices, vec![[0, 1, 2], [0, 2, 3]]);
}

#[test]
fn ply_binary_little_endian_loads() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("bin.ply");
    let mut bytes = b"ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nelement face 1\nproperty list uchar uint vertex_indices\nend_header\n".to_vec();
    for v in [0.0f32, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0] {
        bytes.extend(v.to_le_bytes());
    }
    bytes.push(3);
    for i in [0u32, 1, 2] {
        bytes.extend(i.to_le_bytes());
    }
    std::fs::write(&path, bytes).unwrap();
    let s = Scene::load(&path).unwrap();
    assert_eq!(s.mesh.positions[1], Vec3::X);
    assert_eq!(s.mesh.indices, vec![[0, 1, 2]]);
}

#[test]
fn ply_bad_inputs_name_the_line() {
    let msg = load(
        "nan.ply",
        format!("{PLY_HEAD}0 0 0\n1 nan 0\n0 1 0\n3 0 1 2\n").as_bytes(),
    );
    assert!(msg.contains("nan.ply:11"), "{msg}");
    let msg = load(
        "inf.ply",
        format!("{PLY_HEAD}0 0 0\n1 1e39 0\n0 1 0\n3 0 1 2\n").as_bytes(),
    );
    assert!(msg.contains("inf.ply:11"), "{msg}");
    let msg = load(
        "idx.ply",
        format!("{PLY_HEAD}0 0 0\n1 0 0\n0 1 0\n3 0 1 7\n").as_bytes(),
    );
    assert!(
        msg.contains("idx.ply:13") && msg.contains("vertex 7"),
        "{msg}"
    );
    let msg = load("trunc.ply", format!("{PLY_HEAD}0 0 0\n1 0 0\n").as_bytes());
    assert!(msg.contains("not a valid PLY"), "{msg}");
    let msg = load("junk.ply", b"this is not a ply file\n");
    assert!(msg.contains("not a valid PLY"), "{msg}");
    let msg = load(
        "word.ply",
        format!("{PLY_HEAD}0 0 0\n1 zero 0\n0 1 0\n3 0 1 2\n").as_bytes(),
    );
    assert!(msg.contains("word.ply"), "{msg}");
}

#[test]
fn ply_binary_nan_is_refused() {
    let mut bytes = b"ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nelement face 1\nproperty list uchar uint vertex_indices\nend_header\n".to_vec();
    for v in [0.0f32, 0.0, 0.0, 1.0, f32::NAN, 0.0, 0.0, 1.0, 0.0] {
        bytes.extend(v.to_le_bytes());
    }
    bytes.push(3);
    for i in [0u32, 1, 2] {
        bytes.extend(i.to_le_bytes());
    }
    let msg = load("binnan.ply", &bytes);
    assert!(
        msg.contains("vertex 1") && msg.contains("non-finite"),
        "{msg}"
    );
}

#[test]
fn obj_with_polygons_fans_in_file_order() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("poly.obj");
    std::fs::write(
        &path,
        "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0 0 1\nf 1 2 3 4\nf 1 2 5\n",
    )
    .unwrap();
    let s = Scene::load(&path).unwrap();
    let t: Vec<Triangle> = s.mesh.triangles();
    assert_eq!(t.len(), 3);
    assert_eq!(
        (t[0].a, t[0].b, t[0].c),
        (Vec3::ZERO, Vec3::X, Vec3::new(1.0, 1.0, 0.0))
    );
    assert_eq!(
        (t[1].a, t[1].b, t[1].c),
        (Vec3::ZERO, Vec3::new(1.0, 1.0, 0.0), Vec3::Y)
    );
    assert_eq!(t[2].c, Vec3::Z);
}

fn load_ok(name: &str, text: &str) -> Scene {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join(name);
    std::fs::write(&path, text).unwrap();
    Scene::load(&path).unwrap()
}

const QUAD: &str = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0 0 1\nv 1 0 1\nv 1 1 1\nv 0 1 1\n";

#[test]
fn obj_lines_points_and_curves_make_no_triangles() {
    // A quad face, then a closed polyline over other vertices, points and a
    // curve: the quad's two triangles only.
    let extras = "l 5 6 7 8 5\nl 1 2\np 5 6 7\ncstype bspline\ndeg 3\ncurv 0 1 5 6 7 8\nparm u 0 0 0 0 1 1 1 1\nend\nsurf 0 1 0 1 5 6 7 8\nend\n";
    let face = "f 1 2 3 4\n";
    let want = [
        [Vec3::ZERO, Vec3::X, Vec3::new(1.0, 1.0, 0.0)],
        [Vec3::ZERO, Vec3::new(1.0, 1.0, 0.0), Vec3::Y],
    ];
    for text in [
        format!("{QUAD}{face}{extras}"),
        format!("{QUAD}{extras}{face}"),
    ] {
        let s = load_ok("wire.obj", &text);
        let got: Vec<[Vec3; 3]> = s.triangles.iter().map(|t| [t.a, t.b, t.c]).collect();
        assert_eq!(got, want, "{text}");
        assert_eq!(s.mesh.indices, vec![[0, 1, 2], [0, 2, 3]]);
    }
}

#[test]
fn obj_end_of_line_comments_are_accepted() {
    let s = load_ok(
        "comments.obj",
        "v 0 0 0 # corner\nv 1 0 0#x\nv 0 1 0\t# y\nvn 0 0 1 # up\nf 1//1 2//1 3//1 # tri\n",
    );
    assert_eq!(s.mesh.indices, vec![[0, 1, 2]]);
    assert_eq!(s.mesh.positions, vec![Vec3::ZERO, Vec3::X, Vec3::Y]);
}

#[test]
fn obj_every_refusal_names_file_and_line() {
    let head = "v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nvn 0 0 1\n";
    for (bad, why) in [
        ("f 1//1 2//1 3//2", "normal 2"),
        ("f 1/2 2/1 3/1", "texture coordinate 2"),
        ("f 1 2 4", "vertex 4"),
        ("f 1 2 -4", "vertex -4"),
        ("f 1 2 x", "malformed face vertex 'x'"),
        ("f 1/1/1/1 2 3", "malformed face vertex"),
        ("v 1 2 3 4 five", "'five' is not a number"),
        ("v 1 2", "at least 3 numbers"),
        ("v 1 2 3 0", "weight"),
        ("vn 0 1", "malformed normal"),
        ("vt u", "malformed texture coordinate"),
    ] {
        let text = format!("{head}# a comment\n{bad} # the culprit\nf 1 2 3\n");
        let msg = load("where.obj", text.as_bytes());
        assert!(
            msg.contains("where.obj:7: ") && msg.contains(why),
            "{bad}: {msg}"
        );
    }
}

#[test]
fn obj_faces_with_fewer_than_3_vertices_are_refused() {
    for (bad, n) in [("f 5", 1), ("f 1 2", 2), ("f", 0), ("f 1/1", 1)] {
        let text = format!("{QUAD}vt 0 0\nf 1 2 3\n{bad}\nf 1 3 4\n");
        let msg = load("short.obj", text.as_bytes());
        assert!(
            msg.contains("short.obj:11: ")
                && msg.contains(&format!("at least 3 vertices, this one has {n}")),
            "{bad}: {msg}"
        );
    }
}
