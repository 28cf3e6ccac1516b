//! `raytree build` and saved structures in place of scenes: `trace`,
//! `render` and `info` on a saved file give what they give on its scene;
//! options that ask for something else are refused unless --rebuild; bad
//! files fail with one line naming them.

use crate::common;

use crate::support::*;
use raytree::prelude::*;
use raytree::rayfile;
use serde_json::Value;
use std::path::Path;

fn run(args: &[&str], dir: &Path) -> String {
    ok(&raytree(args, dir))
}

/// One line on stderr containing `needle`, exit 1.
fn fails(args: &[&str], dir: &Path, needle: &str) {
    let out = raytree(args, dir);
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{args:?}: {err}");
    assert!(
        err.contains(needle),
        "{args:?}: stderr lacks '{needle}': {err}"
    );
    assert_eq!(err.trim_end().lines().count(), 1, "{args:?}: {err}");
}

/// A JSON report without its timings.
fn untimed(mut v: Value) -> Value {
    fn strip(v: &mut Value) {
        match v {
            Value::Object(m) => {
                // Measurements of this run (times, a build's peak heap,
                // which a loaded tree does not have) and where it ran.
                m.retain(|k, _| {
                    !k.ends_with("_seconds")
                        && !["saved", "machine", "peak_heap_bytes"].contains(&k.as_str())
                });
                m.values_mut().for_each(strip);
            }
            Value::Array(a) => a.iter_mut().for_each(strip),
            _ => {}
        }
    }
    strip(&mut v);
    v
}

fn json(dir: &Path, name: &str) -> Value {
    serde_json::from_slice(&std::fs::read(dir.join(name)).unwrap()).unwrap()
}

#[test]
fn trace_render_and_info_on_a_saved_file_match_the_scene() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let scene = Scene::builtin("chess:3000").unwrap();
    let rays = common::mixed_rays(&scene, 2000, 5);
    std::fs::write(d.join("r.rays"), rayfile::encode_rays(&rays)).unwrap();
    let configs: [&[&str]; 6] = [
        &["-a", "bvh"],
        &["-a", "bvh", "-t", "laine-4"],
        &["-a", "bvh", "-t", "implicit-b", "--builder", "hybrid"],
        &["-a", "dst"],
        &["--structure", "htree", "--max-leaf", "4"],
        &["-a", "bvh8"],
    ];
    for opts in configs {
        let with = |args: &[&str]| -> Vec<String> {
            args.iter().chain(opts).map(|s| s.to_string()).collect()
        };
        let strs = |v: &[String]| v.iter().map(String::as_str).collect::<Vec<_>>().join(" ");
        let build = with(&[
            "build",
            "-s",
            "chess:3000",
            "-o",
            "s.rtree",
            "--json",
            "b.json",
        ]);
        let out = run(&build.iter().map(String::as_str).collect::<Vec<_>>(), d);
        assert!(out.contains("wrote      s.rtree"), "{out}");
        let b = json(d, "b.json");
        assert_eq!(b["header"]["version"], 1);
        assert_eq!(
            b["header"]["file_bytes"].as_u64().unwrap(),
            std::fs::metadata(d.join("s.rtree")).unwrap().len()
        );
        for any in [&[][..], &["--any-hit"][..]] {
            let mut saved = vec!["trace", "-s", "s.rtree", "--rays", "r.rays", "-o", "a.bin"];
            saved.extend(any);
            saved.extend(["--format", "bin-geometry", "--json", "t.json"]);
            let out = run(&saved, d);
            assert!(out.contains("saved      s.rtree"), "{out}");
            let mut fresh = with(&[
                "trace",
                "-s",
                "chess:3000",
                "--rays",
                "r.rays",
                "-o",
                "b.bin",
            ]);
            fresh.extend(any.iter().map(|s| s.to_string()));
            fresh.extend(["--format", "bin-geometry"].map(String::from));
            run(&fresh.iter().map(String::as_str).collect::<Vec<_>>(), d);
            let (a, b) = (
                std::fs::read(d.join("a.bin")).unwrap(),
                std::fs::read(d.join("b.bin")).unwrap(),
            );
            assert!(a == b, "{}: other hits from the saved file", strs(&fresh));
            let t = json(d, "t.json");
            assert_eq!(t["saved"]["file"], "s.rtree");
            assert_eq!(
                t["structure"],
                b_structure(&json(d, "b.json")),
                "{}",
                strs(&fresh)
            );
        }
        let img = ["--width", "40", "--height", "30", "-q"];
        let mut saved = vec!["render", "-s", "s.rtree", "-o", "a.png"];
        saved.extend(img);
        let out = run(&saved, d);
        assert!(out.contains("saved      s.rtree"), "{out}");
        let mut fresh = with(&["render", "-s", "chess:3000", "-o", "b.png"]);
        fresh.extend(img.map(String::from));
        run(&fresh.iter().map(String::as_str).collect::<Vec<_>>(), d);
        let a = image::open(d.join("a.png")).unwrap().to_luma8();
        let b = image::open(d.join("b.png")).unwrap().to_luma8();
        assert_eq!(a, b, "{}: another image from the saved file", strs(&fresh));
    }
    // info: every structure derived from the saved BVH, as from the scene.
    run(&["info", "-s", "s.rtree", "--json", "a.json"], d);
    run(&["info", "-s", "chess:3000", "--json", "b.json"], d);
    let (a, b) = (json(d, "a.json"), json(d, "b.json"));
    assert_eq!(a["saved"]["header"]["structure"], "bvh8");
    assert_eq!(untimed(a), untimed(b));
}

/// A build report's structure, as a trace report gives it.
fn b_structure(b: &Value) -> Value {
    b["structure"].clone()
}

#[test]
fn other_options_are_refused_unless_rebuilt() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let scene = Scene::builtin("chess:2000").unwrap();
    let rays = common::mixed_rays(&scene, 500, 8);
    std::fs::write(d.join("r.rays"), rayfile::encode_rays(&rays)).unwrap();
    run(&["build", "-s", "chess:2000", "-o", "s.rtree"], d);
    fn trace<'a>(extra: &[&'a str]) -> Vec<&'a str> {
        let mut a = vec!["trace", "-s", "s.rtree", "--rays", "r.rays", "-o", "h.bin"];
        a.extend(extra);
        a
    }
    fails(
        &trace(&["-a", "dst"]),
        d,
        "s.rtree holds a saved bvh/stack, but the options ask for dst",
    );
    fails(&trace(&["-t", "sparse"]), d, "ask for bvh/sparse");
    fails(
        &trace(&["--builder", "hybrid"]),
        d,
        "--builder hybrid (the file's BVH: sah)",
    );
    fails(
        &["info", "-s", "s.rtree", "--max-leaf", "2"],
        d,
        "--max-leaf 2",
    );
    fails(
        &["info", "-s", "s.rtree", "--sah-block", "4"],
        d,
        "--sah-block 4 (the file's BVH: 1)",
    );
    // A BVH built with SAH blocks keeps its block size in the file and
    // answers as the same build from the scene.
    let out = run(
        &[
            "build",
            "-s",
            "chess:2000",
            "--sah-block",
            "4",
            "-o",
            "b.rtree",
        ],
        d,
    );
    assert!(out.contains("SAH leaf cost per block of 4"), "{out}");
    let out = run(&["info", "-s", "b.rtree"], d);
    assert!(out.contains("SAH leaf cost per block of 4"), "{out}");
    let traced = |scene: &'static str, out: &'static str, block: &'static str| {
        [
            "trace",
            "-s",
            scene,
            "--rays",
            "r.rays",
            "-o",
            out,
            "--sah-block",
            block,
        ]
    };
    run(&traced("b.rtree", "hb.bin", "4"), d);
    run(&traced("chess:2000", "wb.bin", "4"), d);
    let hits = |f: &str| rayfile::decode_hits(&std::fs::read(d.join(f)).unwrap()).unwrap();
    assert_eq!(hits("hb.bin"), hits("wb.bin"));
    fails(
        &traced("b.rtree", "x.bin", "1"),
        d,
        "--sah-block 1 (the file's BVH: 4)",
    );
    // Asking for what the file holds is no conflict.
    run(
        &trace(&[
            "-a",
            "bvh",
            "-t",
            "stack",
            "--builder",
            "sah",
            "--max-leaf",
            "8",
        ]),
        d,
    );
    // --rebuild derives the structure from the file's BVH (or builds one).
    let out = run(&trace(&["-a", "dst", "--rebuild", "--json", "t.json"]), d);
    assert!(out.contains("rebuilt: structure"), "{out}");
    let got = rayfile::decode_hits(&std::fs::read(d.join("h.bin")).unwrap()).unwrap();
    run(
        &[
            "trace",
            "-s",
            "chess:2000",
            "-a",
            "dst",
            "--rays",
            "r.rays",
            "-o",
            "w.bin",
        ],
        d,
    );
    let want = rayfile::decode_hits(&std::fs::read(d.join("w.bin")).unwrap()).unwrap();
    assert_eq!(got, want);
    let out = run(&trace(&["--builder", "hybrid", "--rebuild"]), d);
    assert!(out.contains("rebuilt: bvh, structure"), "{out}");
    // build from a saved file: the structure derived from its BVH.
    let out = run(
        &["build", "-s", "s.rtree", "-a", "cbvh", "-o", "c.rtree"],
        d,
    );
    assert!(out.contains("rebuilt: structure"), "{out}");
    let out = run(&["info", "-s", "c.rtree"], d);
    assert!(
        out.contains("saved       c.rtree: cbvh over the compact layout"),
        "{out}"
    );
}

#[test]
fn bad_saved_files_fail_with_one_line_naming_them() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let ray = Ray::infinite(Vec3::new(0.0, 50.0, 300.0), Vec3::new(0.0, -0.2, -1.0));
    std::fs::write(d.join("r.rays"), rayfile::encode_rays(&[ray])).unwrap();
    run(
        &["build", "-s", "chess:1000", "-a", "dst", "-o", "s.rtree"],
        d,
    );
    let bytes = std::fs::read(d.join("s.rtree")).unwrap();
    std::fs::write(d.join("cut.rtree"), &bytes[..bytes.len() - 100]).unwrap();
    let mut flipped = bytes.clone();
    let at = flipped.len() - 500;
    flipped[at] ^= 4;
    std::fs::write(d.join("flip.rtree"), &flipped).unwrap();
    let mut other = bytes.clone();
    other[8] = 9;
    std::fs::write(d.join("v9.rtree"), &other).unwrap();
    std::fs::write(d.join("mesh.rtree"), "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n").unwrap();
    for cmd in [
        &["trace", "--rays", "r.rays", "-o", "h.bin"][..],
        &["render", "-o", "x.png", "--width", "8", "--height", "8"][..],
        &["info"][..],
    ] {
        let with = |file: &'static str| {
            let mut a = cmd.to_vec();
            a.extend(["-s", file]);
            a
        };
        fails(&with("cut.rtree"), d, "cut.rtree: truncated");
        fails(&with("flip.rtree"), d, "flip.rtree: section");
        fails(&with("flip.rtree"), d, "checksum");
        fails(
            &with("v9.rtree"),
            d,
            "v9.rtree: format version 9, but this raytree reads version 1",
        );
        fails(
            &with("mesh.rtree"),
            d,
            "mesh.rtree: not a saved raytree structure",
        );
        fails(&with("missing.rtree"), d, "missing.rtree");
    }
    assert!(!d.join("h.bin").exists() && !d.join("x.png").exists());
    // Commands that need the scene itself say so rather than "unknown format".
    fails(
        &["bench", "dst", "-s", "s.rtree"],
        d,
        "s.rtree: a saved structure (raytree build), not a mesh",
    );
    fails(
        &["build", "-s", "chess:1000", "-o", "-"],
        d,
        "writes a file",
    );
}
