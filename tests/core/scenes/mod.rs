//! glTF, GLB and STL files written here load to exactly the triangles they
//! hold; scenes of several files keep each file's geometries; hits map to
//! their geometry and local triangle; bad files are refused with the file
//! and the element. (Part of the `bad_input` test binary.)

pub mod files;

use files::{cube, stl_ascii, stl_binary, Gltf, U16, U32, U8};
use raytree::prelude::*;
use raytree::scene::{LoadOptions, LoadReport};
use serde_json::json;
use std::path::{Path, PathBuf};

/// Writes `bytes` to `name` in `dir`.
fn write(dir: &Path, name: &str, bytes: &[u8]) -> PathBuf {
    let path = dir.join(name);
    std::fs::write(&path, bytes).unwrap();
    path
}

/// The mesh's triangles as corner arrays.
fn corners(mesh: &Mesh) -> Vec<[[f32; 3]; 3]> {
    (0..mesh.triangle_count())
        .map(|i| {
            let t = mesh.triangle(i);
            [t.a.to_array(), t.b.to_array(), t.c.to_array()]
        })
        .collect()
}

/// The cube's triangles with `f` applied to every corner.
fn cube_triangles(f: impl Fn([f32; 3]) -> [f32; 3]) -> Vec<[[f32; 3]; 3]> {
    let (points, indices) = cube();
    indices
        .chunks(3)
        .map(|t| [0, 1, 2].map(|k| f(points[t[k] as usize])))
        .collect()
}

/// A glTF of the unit cube placed three times: node 0 as it is, node 1
/// (translated, turned 180° about y, scaled) under a translated parent, and
/// node 3 by a matrix.
fn cube_scene() -> Gltf {
    let mut g = Gltf::new();
    let (points, indices) = cube();
    let pos = g.positions(&points);
    let idx = g.indices(&indices, U16);
    g.mesh(
        Some("Cube"),
        vec![json!({"attributes": {"POSITION": pos}, "indices": idx})],
    );
    g.node(json!({"name": "A", "mesh": 0}));
    g.node(
        json!({"name": "B", "mesh": 0, "translation": [10.0, 0.0, 0.0],
                  "rotation": [0.0, 1.0, 0.0, 0.0], "scale": [2.0, 3.0, 4.0]}),
    );
    g.node(json!({"name": "Parent", "translation": [0.0, 5.0, 0.0], "children": [1]}));
    g.node(
        json!({"mesh": 0, "matrix": [0.5, 0.0, 0.0, 0.0, 0.0, 0.5, 0.0, 0.0,
                                         0.0, 0.0, 0.5, 0.0, -4.0, 0.0, 0.25, 1.0]}),
    );
    g.scene(&[0, 2, 3]);
    g
}

#[test]
fn gltf_cube_and_its_transformed_instances_load_exactly_from_every_container() {
    let dir = tempfile::tempdir().unwrap();
    let g = cube_scene();
    let (json, bin) = g.external("my%20cube.bin");
    write(dir.path(), "my cube.bin", &bin);
    let files = [
        write(dir.path(), "cube.glb", &g.glb()),
        write(dir.path(), "embedded.gltf", &g.embedded()),
        write(dir.path(), "external.gltf", &json),
        // The format follows the content: a GLB named .gltf loads too.
        write(dir.path(), "binary.gltf", &g.glb()),
    ];
    let mut want = cube_triangles(|p| p);
    // T(0,5,0) · T(10,0,0) · R_y(180°) · S(2,3,4), exact in f32.
    want.extend(cube_triangles(|[x, y, z]| {
        [10.0 - 2.0 * x, 5.0 + 3.0 * y, -4.0 * z]
    }));
    want.extend(cube_triangles(|[x, y, z]| {
        [0.5 * x - 4.0, 0.5 * y, 0.5 * z + 0.25]
    }));
    for path in &files {
        let (mesh, report) = Mesh::load_with(path, &LoadOptions::default()).unwrap();
        assert_eq!(report, LoadReport::default());
        assert_eq!(corners(&mesh), want, "{}", path.display());
        // Each instance keeps the 8 corners it uses.
        assert_eq!(mesh.positions.len(), 24);
        let p = path.display();
        let names: Vec<&str> = mesh.geometries.iter().map(|g| g.name.as_str()).collect();
        assert_eq!(
            names,
            [
                format!("{p}: node 0 \"A\", mesh 0 \"Cube\", primitive 0"),
                format!("{p}: node 1 \"B\", mesh 0 \"Cube\", primitive 0"),
                format!("{p}: node 3, mesh 0 \"Cube\", primitive 0"),
            ]
        );
        let ranges: Vec<_> = mesh.geometries.iter().map(|g| g.triangles()).collect();
        assert_eq!(ranges, [0..12, 12..24, 24..36]);
        assert_eq!(mesh.geometry_of(13), Some((1, 1)));
        assert_eq!(mesh.geometry_of(35), Some((2, 11)));
    }
}

#[test]
fn gltf_rotations_turn_as_the_specification_says() {
    // 90° about +z (right-handed): x goes to y; and about +x: y goes to z.
    let h = std::f32::consts::FRAC_1_SQRT_2;
    for (rotation, to) in [
        ([0.0, 0.0, h, h], [[0.0, 1.0, 0.0], [-1.0, 0.0, 0.0]]),
        ([h, 0.0, 0.0, h], [[1.0, 0.0, 0.0], [0.0, 0.0, 1.0]]),
    ] {
        let mut g = Gltf::new();
        let pos = g.positions(&[[0.0; 3], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]);
        g.mesh(None, vec![json!({"attributes": {"POSITION": pos}})]);
        g.node(json!({"mesh": 0, "rotation": rotation}));
        g.scene(&[0]);
        let mesh = Mesh::parse(&g.glb(), Path::new("r.glb")).unwrap();
        let t = mesh.triangle(0);
        assert_eq!(t.a, Vec3::ZERO);
        for (got, want) in [t.b, t.c].iter().zip(to) {
            assert!(
                (*got - Vec3::from_array(want)).abs().max_element() < 1e-7,
                "{rotation:?}: {got:?}, want {want:?}"
            );
        }
    }
}

/// A mesh of six primitives over one quad: indexed triangles (8-bit),
/// LINES, non-indexed triangles, a non-indexed strip, an indexed fan
/// (32-bit) and POINTS; instanced by two nodes, the second translated.
fn mixed_primitives() -> Gltf {
    let mut g = Gltf::new();
    let quad = [
        [0.0, 0.0, 0.0],
        [1.0, 0.0, 0.0],
        [1.0, 1.0, 0.0],
        [0.0, 1.0, 0.0],
    ];
    let a = g.positions(&quad);
    let soup: Vec<[f32; 3]> = [0, 1, 2, 0, 2, 3]
        .iter()
        .map(|&i| {
            let [x, y, _] = quad[i];
            [x, y, 1.0]
        })
        .collect();
    let b = g.positions(&soup);
    let strip: Vec<[f32; 3]> = quad.iter().map(|&[x, y, _]| [x, y, 2.0]).collect();
    let c = g.positions(&strip);
    let tri = g.indices(&[0, 1, 2, 0, 2, 3], U8);
    let lines = g.indices(&[0, 1, 1, 2], U16);
    let fan = g.indices(&[0, 1, 2, 3], U32);
    g.mesh(
        Some("Mixed"),
        vec![
            json!({"attributes": {"POSITION": a}, "indices": tri}),
            json!({"attributes": {"POSITION": a}, "indices": lines, "mode": 1}),
            json!({"attributes": {"POSITION": b}}),
            json!({"attributes": {"POSITION": c}, "mode": 5}),
            json!({"attributes": {"POSITION": a}, "indices": fan, "mode": 6}),
            json!({"attributes": {"POSITION": a}, "mode": 0}),
        ],
    );
    g.node(json!({"mesh": 0}));
    g.node(json!({"mesh": 0, "translation": [0.0, 0.0, 8.0]}));
    g.scene(&[0, 1]);
    g
}

#[test]
fn gltf_primitives_each_become_a_geometry_and_lines_and_points_are_counted() {
    let dir = tempfile::tempdir().unwrap();
    let path = write(dir.path(), "mixed.glb", &mixed_primitives().glb());
    let (mesh, report) = Mesh::load_with(&path, &LoadOptions::default()).unwrap();
    let q = |x: f32, y: f32, z: f32| [x, y, z];
    let one = |dz: f32| {
        vec![
            // Indexed triangles.
            [q(0.0, 0.0, dz), q(1.0, 0.0, dz), q(1.0, 1.0, dz)],
            [q(0.0, 0.0, dz), q(1.0, 1.0, dz), q(0.0, 1.0, dz)],
            // Non-indexed: vertices in order.
            [
                q(0.0, 0.0, 1.0 + dz),
                q(1.0, 0.0, 1.0 + dz),
                q(1.0, 1.0, 1.0 + dz),
            ],
            [
                q(0.0, 0.0, 1.0 + dz),
                q(1.0, 1.0, 1.0 + dz),
                q(0.0, 1.0, 1.0 + dz),
            ],
            // Strip: (0, 1, 2), then (1, 3, 2).
            [
                q(0.0, 0.0, 2.0 + dz),
                q(1.0, 0.0, 2.0 + dz),
                q(1.0, 1.0, 2.0 + dz),
            ],
            [
                q(1.0, 0.0, 2.0 + dz),
                q(0.0, 1.0, 2.0 + dz),
                q(1.0, 1.0, 2.0 + dz),
            ],
            // Fan: (1, 2, 0), then (2, 3, 0).
            [q(1.0, 0.0, dz), q(1.0, 1.0, dz), q(0.0, 0.0, dz)],
            [q(1.0, 1.0, dz), q(0.0, 1.0, dz), q(0.0, 0.0, dz)],
        ]
    };
    let mut want = one(0.0);
    want.extend(one(8.0));
    assert_eq!(corners(&mesh), want);
    let names: Vec<String> = mesh.geometries.iter().map(|g| g.name.clone()).collect();
    let p = path.display();
    let mut expected = Vec::new();
    for node in 0..2 {
        for prim in [0, 2, 3, 4] {
            expected.push(format!(
                "{p}: node {node}, mesh 0 \"Mixed\", primitive {prim}"
            ));
        }
    }
    assert_eq!(names, expected);
    assert!(mesh.geometries.iter().all(|g| g.triangle_count == 2));
    assert_eq!(mesh.geometry_of(5), Some((2, 1)));
    // One LINES and one POINTS primitive per instance.
    assert_eq!(
        report.skipped_primitives,
        [("LINES".to_string(), 2), ("POINTS".to_string(), 2)].into()
    );
    assert_eq!(
        report.warnings(&path),
        [
            format!("{p}: skipped 2 primitives of mode LINES"),
            format!("{p}: skipped 2 primitives of mode POINTS"),
        ]
    );
    // The scene carries the warnings.
    let scene = Scene::load(&path).unwrap();
    assert_eq!(scene.warnings, report.warnings(&path));
}

#[test]
fn gltf_scenes_by_default_and_by_index() {
    let mut g = Gltf::new();
    let (points, indices) = cube();
    let pos = g.positions(&points);
    let idx = g.indices(&indices, U32);
    let tri = g.indices(&[0, 1, 3], U8);
    g.mesh(
        None,
        vec![json!({"attributes": {"POSITION": pos}, "indices": idx})],
    );
    g.mesh(
        None,
        vec![json!({"attributes": {"POSITION": pos}, "indices": tri})],
    );
    g.node(json!({"mesh": 0}));
    g.node(json!({"mesh": 1}));
    g.scene(&[1]);
    g.scene(&[0]);
    let count = |g: &Gltf, scene: Option<usize>| {
        Mesh::parse_with(
            &g.glb(),
            Path::new("s.glb"),
            &LoadOptions { gltf_scene: scene },
        )
        .map(|(m, _)| m.triangle_count())
        .map_err(|e| e.to_string())
    };
    // No default: the first scene.
    assert_eq!(count(&g, None), Ok(1));
    assert_eq!(count(&g, Some(1)), Ok(12));
    g.root["scene"] = json!(1);
    assert_eq!(count(&g, None), Ok(12));
    assert_eq!(count(&g, Some(0)), Ok(1));
    assert_eq!(
        count(&g, Some(2)),
        Err("s.glb: the scene 2 does not exist: the file has 2 scenes".into())
    );
    g.root["scene"] = json!(5);
    assert_eq!(
        count(&g, None),
        Err("s.glb: the default scene 5 does not exist: the file has 2 scenes".into())
    );
}

#[test]
fn gltf_sparse_zero_filled_and_quantized_positions() {
    // Four positions with no buffer view (zeros), three replaced sparsely.
    let mut g = Gltf::new();
    let sparse_indices = g.view(&[1, 2, 3]);
    let values: Vec<u8> = [1.0f32, 0.0, 0.0, 1.0, 1.0, 0.0, 0.0, 1.0, 0.0]
        .iter()
        .flat_map(|v| v.to_le_bytes())
        .collect();
    let sparse_values = g.view(&values);
    let pos = g.push(
        "accessors",
        json!({"componentType": 5126, "count": 4, "type": "VEC3",
               "min": [0, 0, 0], "max": [1, 1, 0],
               "sparse": {"count": 3,
                          "indices": {"bufferView": sparse_indices, "componentType": 5121},
                          "values": {"bufferView": sparse_values}}}),
    );
    // Normalized 16-bit integers (KHR_mesh_quantization), with a stride.
    let mut shorts = Vec::new();
    for p in [[0i16, 0, 0], [32767, 0, 0], [0, -32768, 0]] {
        for c in p {
            shorts.extend(c.to_le_bytes());
        }
        shorts.extend([0xAB, 0xCD]); // padding to the stride of 8
    }
    let view = g.view(&shorts);
    g.root["bufferViews"][view]["byteStride"] = json!(8);
    let quantized = g.push(
        "accessors",
        json!({"bufferView": view, "componentType": 5122, "normalized": true, "count": 3,
               "type": "VEC3", "min": [0, -1, 0], "max": [1, 0, 0]}),
    );
    // A million zeros, two of them replaced, three of them used: the
    // loader reads only those.
    let far_indices = g.view(&[5u32, 999_999].map(u32::to_le_bytes).concat());
    let far_values: Vec<u8> = [1.0f32, 0.0, 0.0, 0.0, 1.0, 0.0]
        .iter()
        .flat_map(|v| v.to_le_bytes())
        .collect();
    let far_values = g.view(&far_values);
    let far = g.push(
        "accessors",
        json!({"componentType": 5126, "count": 1_000_000, "type": "VEC3",
               "min": [0, 0, 0], "max": [1, 1, 0],
               "sparse": {"count": 2,
                          "indices": {"bufferView": far_indices, "componentType": 5125},
                          "values": {"bufferView": far_values}}}),
    );
    let idx = g.indices(&[0, 1, 2, 0, 2, 3], U8);
    let far_idx = g.indices(&[999_999, 0, 5], U32);
    g.mesh(
        None,
        vec![
            json!({"attributes": {"POSITION": pos}, "indices": idx}),
            json!({"attributes": {"POSITION": quantized}}),
            json!({"attributes": {"POSITION": far}, "indices": far_idx}),
        ],
    );
    g.node(json!({"mesh": 0}));
    g.scene(&[0]);
    g.root["extensionsUsed"] = json!(["KHR_mesh_quantization"]);
    g.root["extensionsRequired"] = json!(["KHR_mesh_quantization"]);
    let mesh = Mesh::parse(&g.embedded(), Path::new("sparse.gltf")).unwrap();
    assert_eq!(
        corners(&mesh),
        [
            [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [1.0, 1.0, 0.0]],
            [[0.0, 0.0, 0.0], [1.0, 1.0, 0.0], [0.0, 1.0, 0.0]],
            [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, -1.0, 0.0]],
            [[0.0, 1.0, 0.0], [0.0, 0.0, 0.0], [1.0, 0.0, 0.0]],
        ]
    );
    // Only the vertices used are kept, in the order of their index.
    assert_eq!(mesh.positions.len(), 4 + 3 + 3);
    assert_eq!(&mesh.positions[7..], [Vec3::ZERO, Vec3::X, Vec3::Y]);
}

/// The cube's triangles with every corner scaled by 0.1 and moved, which
/// ASCII must write and read back exactly.
fn odd_cube() -> Vec<[[f32; 3]; 3]> {
    cube_triangles(|p| p.map(|c| c * 0.1 - 1.0e-3))
}

#[test]
fn stl_ascii_and_binary_load_to_the_same_welded_triangles() {
    let dir = tempfile::tempdir().unwrap();
    let want = odd_cube();
    let files = [
        write(dir.path(), "cube.stl", stl_ascii("cube", &want).as_bytes()),
        // A binary file whose header starts with "solid", as many do.
        write(
            dir.path(),
            "solid.stl",
            &stl_binary(b"solid cube exported", &want),
        ),
        write(dir.path(), "plain.STL", &stl_binary(b"binary", &want)),
        write(
            dir.path(),
            "crlf.stl",
            stl_ascii("cube", &want).replace('\n', "\r\n").as_bytes(),
        ),
    ];
    for path in &files {
        let mesh = Mesh::load(path).unwrap();
        assert_eq!(corners(&mesh), want, "{}", path.display());
        // Equal corners are welded: the cube's 8.
        assert_eq!(mesh.positions.len(), 8, "{}", path.display());
        assert_eq!(mesh.geometry_count(), 1);
        assert_eq!(mesh.geometries[0].name, path.display().to_string());
    }
}

#[test]
fn several_files_make_one_scene_and_hits_name_their_geometry() {
    let dir = tempfile::tempdir().unwrap();
    // Geometry 0: a quad at x in [0, 1] (OBJ); 1: a quad at x in [2, 3]
    // (binary STL); 2 and 3: the cube at x = 4 and x = 6 (GLB, two nodes).
    let obj = write(
        dir.path(),
        "a.obj",
        b"v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3 4\n",
    );
    let stl = write(
        dir.path(),
        "b.stl",
        &stl_binary(
            b"solid",
            &[
                [[2.0, 0.0, 0.0], [3.0, 0.0, 0.0], [3.0, 1.0, 0.0]],
                [[2.0, 0.0, 0.0], [3.0, 1.0, 0.0], [2.0, 1.0, 0.0]],
            ],
        ),
    );
    let mut g = Gltf::new();
    let (points, indices) = cube();
    let pos = g.positions(&points);
    let idx = g.indices(&indices, U16);
    g.mesh(
        Some("Cube"),
        vec![json!({"attributes": {"POSITION": pos}, "indices": idx})],
    );
    g.node(json!({"mesh": 0, "translation": [4.0, 0.0, 0.0]}));
    g.node(json!({"mesh": 0, "translation": [6.0, 0.0, 0.0]}));
    g.scene(&[0, 1]);
    let glb = write(dir.path(), "c.glb", &g.glb());
    let scene = Scene::load_many(&[&obj, &stl, &glb], &LoadOptions::default()).unwrap();
    assert_eq!(scene.mesh.triangle_count(), 2 + 2 + 12 + 12);
    assert_eq!(scene.mesh.geometry_count(), 4);
    assert_eq!(scene.mesh.geometries[0].name, obj.display().to_string());
    assert_eq!(scene.mesh.geometries[1].name, stl.display().to_string());
    assert!(scene.mesh.geometries[3]
        .name
        .ends_with("c.glb: node 1, mesh 0 \"Cube\", primitive 0"));
    // Straight down at points inside known triangles: (x, y) -> (geometry,
    // triangle within it). The cube's top is its triangles 2 (x + y < 1)
    // and 3.
    let cases = [
        ((0.75, 0.25), Some((0, 0))),
        ((0.25, 0.75), Some((0, 1))),
        ((2.75, 0.25), Some((1, 0))),
        ((2.25, 0.75), Some((1, 1))),
        ((4.25, 0.25), Some((2, 2))),
        ((4.75, 0.75), Some((2, 3))),
        ((6.25, 0.25), Some((3, 2))),
        ((6.75, 0.75), Some((3, 3))),
        ((5.5, 0.5), None),
    ];
    let bvh = Bvh::build(&scene.triangles, &BuildOptions::sah());
    let layout = BinaryBvh::from_bvh(&bvh, scene.triangles.clone()).unwrap();
    let oracle = BruteForce::new(scene.triangles.clone());
    for ((x, y), want) in cases {
        let ray = Ray::infinite(Vec3::new(x, y, 10.0), Vec3::NEG_Z);
        let hit = layout.closest_hit(&ray, &mut NoStats);
        assert_eq!(hit, oracle.closest_hit(&ray, &mut NoStats));
        assert_eq!(
            hit.and_then(|h| scene.mesh.geometry_of(h.prim)),
            want,
            "({x}, {y})"
        );
    }
    // The same scene from a comma list.
    let spec = format!("{},{},{}", obj.display(), stl.display(), glb.display());
    let again = Scene::from_spec(&spec).unwrap();
    assert_eq!(again.name, spec);
    assert_eq!(again.mesh, scene.mesh);
    for bad in [
        format!("{},", obj.display()),
        format!("chess,{}", obj.display()),
    ] {
        let e = Scene::from_spec(&bad).unwrap_err().to_string();
        assert!(
            e.contains("empty entry") || e.contains("'chess' is a built-in"),
            "{e}"
        );
    }
}

/// Loads `bytes` as `name` and returns the error, which must name the file.
fn refusal(name: &str, bytes: &[u8]) -> String {
    let dir = tempfile::tempdir().unwrap();
    let path = write(dir.path(), name, bytes);
    let msg = Scene::load(&path)
        .expect_err("bad input must be refused")
        .to_string();
    assert!(msg.contains(name), "error does not name the file: {msg}");
    assert_eq!(msg.lines().count(), 1, "{msg}");
    msg
}

/// A one-triangle glTF with `edit` applied to its JSON.
fn triangle_gltf(edit: impl Fn(&mut Gltf)) -> Gltf {
    let mut g = Gltf::new();
    let pos = g.positions(&[[0.0; 3], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [1.0, 1.0, 0.0]]);
    let idx = g.indices(&[0, 1, 2], U16);
    g.mesh(
        None,
        vec![json!({"attributes": {"POSITION": pos}, "indices": idx})],
    );
    g.node(json!({"mesh": 0}));
    g.scene(&[0]);
    edit(&mut g);
    g
}

#[test]
fn gltf_bad_files_name_the_file_and_the_element() {
    assert!(Mesh::parse(&triangle_gltf(|_| {}).glb(), Path::new("t.glb")).is_ok());
    let cases: Vec<(&str, Gltf, &str)> = vec![
        (
            "index",
            triangle_gltf(|g| {
                let idx = g.indices(&[0, 1, 17], U16);
                g.root["meshes"][0]["primitives"][0]["indices"] = json!(idx);
            }),
            "mesh 0 primitive 0: index 17 (at position 2 of its indices) is out of range of 4 positions",
        ),
        (
            "position",
            triangle_gltf(|g| {
                g.root["meshes"][0]["primitives"][0]["attributes"] = json!({"NORMAL": 0});
            }),
            "mesh 0 primitive 0: it has no POSITION attribute",
        ),
        (
            "accessor",
            triangle_gltf(|g| {
                g.root["meshes"][0]["primitives"][0]["attributes"]["POSITION"] = json!(9);
            }),
            "mesh 0 primitive 0: its POSITION accessor 9 does not exist: the file has 2 accessors",
        ),
        (
            "nan",
            triangle_gltf(|g| g.bin[12..16].copy_from_slice(&f32::NAN.to_le_bytes())),
            "mesh 0 primitive 0: POSITION 1 is not finite (NaN, 0, 0)",
        ),
        (
            "inf",
            triangle_gltf(|g| g.bin[28..32].copy_from_slice(&f32::NEG_INFINITY.to_le_bytes())),
            "mesh 0 primitive 0: POSITION 2 is not finite (0, -inf, 0)",
        ),
        (
            "count",
            triangle_gltf(|g| g.root["accessors"][0]["count"] = json!(5)),
            "POSITION accessor 0: 5 elements of 12 bytes, 12 bytes apart, from byte 0 do not fit in buffer view 0 (48 bytes)",
        ),
        (
            "view",
            triangle_gltf(|g| g.root["bufferViews"][1]["byteLength"] = json!(400)),
            "indices accessor 1: buffer view 1 (bytes 48 to 48 + 400) runs past the end of buffer 0 (54 bytes)",
        ),
        (
            "stride",
            triangle_gltf(|g| g.root["bufferViews"][0]["byteStride"] = json!(4)),
            "buffer view 0's byteStride of 4 is less than an element's 12 bytes",
        ),
        (
            "mode",
            triangle_gltf(|g| g.root["meshes"][0]["primitives"][0]["mode"] = json!(9)),
            "mesh 0 primitive 0: its mode is not one of glTF's (0 to 6)",
        ),
        (
            "multiple",
            triangle_gltf(|g| {
                let idx = g.indices(&[0, 1, 2, 3], U16);
                g.root["meshes"][0]["primitives"][0]["indices"] = json!(idx);
            }),
            "mesh 0 primitive 0: 4 indices for TRIANGLES, not a multiple of 3",
        ),
        (
            "cycle",
            triangle_gltf(|g| g.root["nodes"][0]["children"] = json!([0])),
            "node 0 is reached twice in scene 0",
        ),
        (
            "child",
            triangle_gltf(|g| g.root["nodes"][0]["children"] = json!([3])),
            "node 0 refers to child node 3, but the file has 1 nodes",
        ),
        (
            "far",
            triangle_gltf(|g| g.root["nodes"][0]["scale"] = json!([1e38, 1.0, 1.0])),
            "node 0 (mesh 0 primitive 0): POSITION 1 (1, 0, 0) transformed lies beyond the coordinate limit",
        ),
        (
            "affine",
            triangle_gltf(|g| {
                g.root["nodes"][0]["matrix"] =
                    json!([1, 0, 0, 1, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1]);
            }),
            "node 0: its matrix's last row is (1, 0, 0, 1), not (0, 0, 0, 1)",
        ),
        (
            "quaternion",
            triangle_gltf(|g| g.root["nodes"][0]["rotation"] = json!([0, 0, 0, 0])),
            "node 0: its rotation (0, 0, 0, 0) is not a unit quaternion",
        ),
        (
            "draco",
            triangle_gltf(|g| g.root["extensionsRequired"] = json!(["KHR_draco_mesh_compression"])),
            "the file requires the extension KHR_draco_mesh_compression, which raytree does not read",
        ),
        (
            "version",
            triangle_gltf(|g| g.root["asset"]["version"] = json!("1.0")),
            "glTF version 1.0: only glTF 2.0 is read",
        ),
        (
            "scenes",
            triangle_gltf(|g| g.root["scenes"] = json!([])),
            "the file has no scenes",
        ),
        (
            "lines",
            triangle_gltf(|g| g.root["meshes"][0]["primitives"][0]["mode"] = json!(1)),
            "the mesh has no triangles",
        ),
        (
            "json",
            triangle_gltf(|g| g.root["accessors"][0]["count"] = json!("three")),
            "not valid glTF JSON: invalid type: string \"three\"",
        ),
    ];
    for (name, g, want) in cases {
        for (file, bytes) in [
            (format!("{name}.glb"), g.glb()),
            (format!("{name}.gltf"), g.embedded()),
        ] {
            let msg = refusal(&file, &bytes);
            assert!(msg.contains(want), "{file}: {msg}\nwant: {want}");
        }
    }
}

#[test]
fn gltf_bad_containers_and_buffers_name_the_file_and_the_element() {
    let g = triangle_gltf(|_| {});
    let glb = g.glb();
    // The BIN chunk's length runs past the end of the file.
    let json_len = u32::from_le_bytes(glb[12..16].try_into().unwrap()) as usize;
    let bin_at = 20 + json_len;
    let mut bad = glb.clone();
    bad[bin_at..bin_at + 4].copy_from_slice(&1000u32.to_le_bytes());
    let msg = refusal("chunk.glb", &bad);
    assert!(
        msg.contains(&format!("GLB chunk 1 (BIN) at byte {bin_at}: its length of 1000 bytes runs past the end of the file")),
        "{msg}"
    );
    let msg = refusal("cut.glb", &glb[..glb.len() - 8]);
    assert!(msg.contains("it is truncated"), "{msg}");
    let msg = refusal("bad.gltf", b"{\"asset\": {\"version\": \"2.0\"}, ");
    assert!(
        msg.contains("bad.gltf: not valid glTF JSON: EOF while parsing"),
        "{msg}"
    );
    // External buffers: missing, short, not a relative file, not base64.
    let (json, bin) = g.external("missing.bin");
    let msg = refusal("ext.gltf", &json);
    assert!(
        msg.contains("ext.gltf: buffer 0: cannot read '") && msg.contains("missing.bin'"),
        "{msg}"
    );
    let dir = tempfile::tempdir().unwrap();
    write(dir.path(), "short.bin", &bin[..10]);
    let (json, _) = g.external("short.bin");
    let path = write(dir.path(), "short.gltf", &json);
    let msg = Scene::load(&path).unwrap_err().to_string();
    assert!(
        msg.contains("short.gltf: buffer 0: cannot read '")
            && msg
                .contains("short.bin': it has 10 bytes, fewer than the buffer's byteLength of 54"),
        "{msg}"
    );
    let (json, _) = g.external("https://example.com/a.bin");
    let msg = refusal("web.gltf", &json);
    assert!(
        msg.contains("is not a file name relative to the glTF file"),
        "{msg}"
    );
    let (json, _) = g.external("data:application/octet-stream,abc");
    assert!(refusal("data.gltf", &json).contains("is not base64"));
    let (json, _) = g.external("data:application/octet-stream;base64,AA!A");
    assert!(refusal("b64.gltf", &json).contains("'!' at position 2"));
    // A GLB whose buffer has no BIN chunk.
    let no_bin = files::glb(serde_json::to_vec(&g.root).unwrap(), None);
    let mut root = g.root.clone();
    root["buffers"] = json!([{"byteLength": 56}]);
    let no_bin_with_buffer = files::glb(serde_json::to_vec(&root).unwrap(), None);
    assert!(refusal("nobin.glb", &no_bin)
        .contains("buffer view 0 refers to buffer 0, but the file has 0 buffers"));
    assert!(refusal("nobin2.glb", &no_bin_with_buffer)
        .contains("buffer 0: it has no uri, and the file is not a GLB with a BIN chunk"));
}

#[test]
fn stl_bad_files_name_the_line_or_the_triangle() {
    let want = odd_cube();
    let binary = stl_binary(b"solid but binary", &want);
    let msg = refusal("cut.stl", &binary[..binary.len() - 7]);
    assert!(
        msg.contains("header counts 12 triangles, which take 684 bytes")
            && msg.contains("the file has 677 bytes: the file is truncated"),
        "{msg}"
    );
    let mut nan = binary.clone();
    let at = 84 + 50 * 5 + 12 + 12 + 4;
    nan[at..at + 4].copy_from_slice(&f32::NAN.to_le_bytes());
    let msg = refusal("nan.stl", &nan);
    assert!(
        msg.contains("binary STL: triangle 5 at byte 334: vertex 2 has a non-finite coordinate (")
            && msg.contains("NaN"),
        "{msg}"
    );
    let text = stl_ascii("cube", &want);
    let lines: Vec<&str> = text.lines().collect();
    let cut = lines[..20].join("\n");
    let msg = refusal("cut_ascii.stl", cut.as_bytes());
    assert!(
        msg.contains("cut_ascii.stl:20: the file ends inside solid 'cube' of line 1"),
        "{msg}"
    );
    let nan_text = text.replacen("vertex", "vertex nan 0 0 #", 1);
    let msg = refusal("nan_ascii.stl", nan_text.as_bytes());
    assert!(msg.contains("nan_ascii.stl:4: malformed vertex"), "{msg}");
    let inf_text = text.replacen(&lines[3].trim().to_string(), "vertex 0 inf 0", 1);
    let msg = refusal("inf_ascii.stl", inf_text.as_bytes());
    assert!(
        msg.contains("inf_ascii.stl:4: non-finite vertex coordinate"),
        "{msg}"
    );
    assert!(refusal("empty.stl", b"").contains("not an STL file"));
    assert!(refusal("none.stl", b"solid x\nendsolid x\n").contains("no triangles"));
}
