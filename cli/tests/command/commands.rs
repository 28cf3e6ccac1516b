//! Tests that run the `raytree` binary.

use crate::common;

use crate::support;

#[path = "../../../tests/core/scenes/files.rs"]
mod files;

use raytree::prelude::*;
use raytree::rayfile;
use std::path::Path;
use std::process::{Command, Output};
use support::*;

/// Fails with `code`, one line on stderr that contains `needle`, and leaves
/// the directory as it was (no partial output).
fn fails(args: &[&str], code: i32, needle: &str) {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("short.rays"), [0u8; 40]).unwrap();
    let before: Vec<_> = std::fs::read_dir(dir.path())
        .unwrap()
        .map(|e| e.unwrap().file_name())
        .collect();
    let out = raytree(args, dir.path());
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(code), "{args:?}: {err}");
    assert!(
        err.contains(needle),
        "{args:?}: stderr lacks '{needle}': {err}"
    );
    if code == 1 {
        assert_eq!(
            err.trim_end().lines().count(),
            1,
            "{args:?}: not one line: {err}"
        );
    }
    let after: Vec<_> = std::fs::read_dir(dir.path())
        .unwrap()
        .map(|e| e.unwrap().file_name())
        .collect();
    assert_eq!(before, after, "{args:?} left files behind");
}

#[test]
fn ao_and_path_renders_have_the_asked_size() {
    let dir = tempfile::tempdir().unwrap();
    for integrator in ["ao", "path"] {
        let out = ok(&raytree(
            &[
                "render",
                "-s",
                "chess:3000",
                "-i",
                integrator,
                "--width",
                "40",
                "--height",
                "24",
                "-q",
                "-o",
                "x.png",
                "--json",
                "x.json",
            ],
            dir.path(),
        ));
        assert!(out.contains("Mrays/s"), "{out}");
        let img = image::open(dir.path().join("x.png")).unwrap().to_luma8();
        assert_eq!(img.dimensions(), (40, 24));
        // Sky is white (AO background, path sky radiance 1), and the scene
        // is shaded: values span a range.
        let (lo, hi) = img
            .pixels()
            .fold((255u8, 0u8), |(lo, hi), p| (lo.min(p.0[0]), hi.max(p.0[0])));
        assert_eq!(hi, 255, "{integrator}: no sky");
        assert!(lo < 200, "{integrator}: nothing shaded ({lo})");
        let json: serde_json::Value =
            serde_json::from_slice(&std::fs::read(dir.path().join("x.json")).unwrap()).unwrap();
        assert!(json["rays"].as_u64().unwrap() >= 40 * 24);
        assert!(json["per_ray"]["nodes"].as_f64().unwrap() > 0.0);
        assert_eq!(json["structure"]["structure"], "bvh");
        assert_eq!(json["machine"]["threads"][0], json["threads"]);
    }
}

#[test]
fn images_are_bit_identical_for_any_thread_count() {
    let dir = tempfile::tempdir().unwrap();
    for integrator in ["ao", "path"] {
        for threads in ["1", "2", "3"] {
            let name = format!("{integrator}{threads}.ppm");
            ok(&raytree(
                &[
                    "render",
                    "-s",
                    "hairball:2000",
                    "-i",
                    integrator,
                    "--width",
                    "37",
                    "--height",
                    "29",
                    "--threads",
                    threads,
                    "-q",
                    "-o",
                    &name,
                ],
                dir.path(),
            ));
        }
        let one = std::fs::read(dir.path().join(format!("{integrator}1.ppm"))).unwrap();
        assert!(one.starts_with(b"P6\n37 29\n255\n"));
        for t in ["2", "3"] {
            assert_eq!(
                one,
                std::fs::read(dir.path().join(format!("{integrator}{t}.ppm"))).unwrap(),
                "{integrator}"
            );
        }
    }
}

#[test]
fn trace_gives_the_librarys_answers() {
    let dir = tempfile::tempdir().unwrap();
    let scene = Scene::builtin("chess:2000").unwrap();
    let rays = common::mixed_rays(&scene, 3000, 11);
    std::fs::write(dir.path().join("r.rays"), rayfile::encode_rays(&rays)).unwrap();
    let bvh = Bvh::build(&scene.triangles, &BuildOptions::sah());
    let layout = BinaryBvh::from_bvh(&bvh, scene.triangles.clone()).unwrap();
    let brute = BruteForce::new(scene.triangles.clone());
    for any in [false, true] {
        for accel in ["bvh", "brute"] {
            let mut args = vec![
                "trace",
                "-s",
                "chess:2000",
                "-a",
                accel,
                "--rays",
                "r.rays",
                "-o",
                "h.bin",
                "--stats",
                "--json",
                "t.json",
            ];
            if any {
                args.push("--any-hit");
            }
            let out = ok(&raytree(&args, dir.path()));
            assert!(out.contains("per ray"), "{out}");
            let hits =
                rayfile::decode_hits(&std::fs::read(dir.path().join("h.bin")).unwrap()).unwrap();
            assert_eq!(hits.len(), rays.len());
            for (r, h) in rays.iter().zip(&hits) {
                if any {
                    assert_eq!(h.is_some(), layout.closest_hit(r, &mut NoStats).is_some());
                } else if accel == "bvh" {
                    assert_eq!(*h, layout.closest_hit(r, &mut NoStats));
                } else {
                    assert_eq!(*h, brute.closest_hit(r, &mut NoStats));
                }
            }
            let json: serde_json::Value =
                serde_json::from_slice(&std::fs::read(dir.path().join("t.json")).unwrap()).unwrap();
            assert_eq!(json["rays"], rays.len());
            assert!(json["mrays_per_second"].as_f64().unwrap() > 0.0);
            assert_eq!(json["machine"]["threads"][0], json["threads"]);
        }
        // CSV: the same values as text.
        let mut args = vec![
            "trace",
            "-s",
            "chess:2000",
            "--rays",
            "r.rays",
            "-o",
            "h.csv",
            "--format",
            "csv",
        ];
        if any {
            args.push("--any-hit");
        }
        ok(&raytree(&args, dir.path()));
        let csv = std::fs::read_to_string(dir.path().join("h.csv")).unwrap();
        let lines: Vec<&str> = csv.lines().collect();
        assert_eq!(lines[0], "ray,t,triangle,u,v,geometry,primitive");
        assert_eq!(lines.len(), rays.len() + 1);
        for (i, (line, r)) in lines[1..].iter().zip(&rays).enumerate() {
            let f: Vec<&str> = line.split(',').collect();
            assert_eq!(f[0], i.to_string());
            let want = if any {
                layout.any_hit(r, &mut NoStats)
            } else {
                layout.closest_hit(r, &mut NoStats)
            };
            match want {
                Some(h) => {
                    assert_eq!(f[1].parse::<f32>().unwrap(), h.t);
                    assert_eq!(f[2].parse::<u32>().unwrap(), h.prim);
                    // A built-in scene is one geometry.
                    assert_eq!(f[5..], ["0".to_string(), h.prim.to_string()]);
                }
                None => assert_eq!(
                    (f[1], f[2], f[5], f[6]),
                    ("inf", "4294967295", "4294967295", "4294967295")
                ),
            }
        }
    }
}

#[test]
fn failures_are_one_clear_line_and_leave_no_output() {
    fails(
        &["render", "-s", "missing.obj", "-o", "a.png"],
        1,
        "missing.obj",
    );
    fails(
        &["render", "-s", "nosuchscene", "-o", "a.png"],
        1,
        "unknown scene",
    );
    fails(&["render", "-s", "chess:1", "-o", "a.png"], 1, "size");
    fails(
        &["render", "-a", "bih", "-t", "sparse", "-o", "a.png"],
        1,
        "applies to the 'bvh' structure only",
    );
    // A tree too deep for the implicit layout (the SAH build of a 1M-triangle
    // hairball is not; this exercises the limit option instead).
    fails(
        &[
            "render",
            "-s",
            "chess:3000",
            "-t",
            "implicit-a",
            "--implicit-limit",
            "0.000001",
            "-o",
            "a.png",
        ],
        1,
        "hybrid",
    );
    fails(
        &["render", "-a", "brute", "-t", "laine-2", "-o", "a.png"],
        1,
        "bvh",
    );
    fails(
        &[
            "render",
            "-s",
            "chess:2000",
            "-o",
            "/nonexistent/dir/a.png",
            "-q",
        ],
        1,
        "/nonexistent/dir/a.png",
    );
    fails(&["render", "--ao-radius=-1", "-o", "a.png"], 1, "ao-radius");
    fails(
        &[
            "trace",
            "-s",
            "chess:2000",
            "--rays",
            "short.rays",
            "-o",
            "h.bin",
        ],
        1,
        "multiple of 32",
    );
    fails(
        &[
            "trace",
            "-s",
            "chess:2000",
            "--rays",
            "none.rays",
            "-o",
            "h.bin",
        ],
        1,
        "none.rays",
    );
    // Usage errors: exit 2.
    fails(&["render", "-a", "octree"], 2, "octree");
    fails(&["render", "--width", "0"], 2, "width");
    fails(&["render", "--eye", "1,2"], 2, "eye");
    fails(&["render", "--fov", "200"], 2, "fov");
    fails(&["trace", "-s", "chess"], 2, "--rays");
    fails(&["frobnicate"], 2, "frobnicate");
}

#[test]
fn info_lists_the_structures() {
    let dir = tempfile::tempdir().unwrap();
    let out = ok(&raytree(
        &["info", "-s", "chess:3000", "--json", "i.json"],
        dir.path(),
    ));
    assert!(
        out.contains("| bvh |") && out.contains("| brute |"),
        "{out}"
    );
    let json: serde_json::Value =
        serde_json::from_slice(&std::fs::read(dir.path().join("i.json")).unwrap()).unwrap();
    let bvh = &json["structures"][0];
    let inner = bvh["inner_nodes"].as_u64().unwrap();
    let leaves = bvh["leaves"].as_u64().unwrap();
    assert_eq!(bvh["node_bytes"].as_u64().unwrap(), 52 * inner + 4 * leaves);
    assert_eq!(json["bvh"]["nodes"].as_u64().unwrap(), inner + leaves);
    // Node storage alone against the BVH's: the Compact BVH's 32 bytes per
    // inner node against 52 + 4.
    let cbvh = out.lines().find(|l| l.starts_with("| cbvh |")).unwrap();
    let cells: Vec<&str> = cbvh.split('|').map(str::trim).collect();
    let want = 32.0 * inner as f64 / (52 * inner + 4 * leaves) as f64;
    assert_eq!(cells[6], format!("{:.1}%", 100.0 * want), "{cbvh}");
    // The build's peak heap holds at least the tree it returns (its nodes
    // and its references), and not absurdly more.
    let peak = json["bvh"]["peak_heap_bytes"].as_u64().unwrap();
    let refs = json["bvh"]["references"].as_u64().unwrap();
    let tree = (inner + leaves) * std::mem::size_of::<raytree::bvh::Node>() as u64 + 4 * refs;
    assert!(
        peak >= tree && peak < 64 * tree,
        "peak heap {peak} bytes for a tree of {tree}"
    );
    assert!(out.contains("peak heap during the build"), "{out}");
}

#[test]
fn bench_stackless_reports_every_algorithm() {
    let dir = tempfile::tempdir().unwrap();
    let out = ok(&raytree(
        &[
            "bench",
            "stackless",
            "-s",
            "chess:3000",
            "-s",
            "hairball:2000",
            "--threads",
            "1,2",
            "-q",
            "--json",
            "b.json",
            "--charts",
            "charts",
        ],
        dir.path(),
    ));
    let json: serde_json::Value =
        serde_json::from_slice(&std::fs::read(dir.path().join("b.json")).unwrap()).unwrap();
    // The machine beside the figures: the thread counts asked for.
    assert_eq!(json["machine"]["threads"], serde_json::json!([1, 2]));
    let scenes = json["scenes"].as_array().unwrap();
    assert_eq!(scenes.len(), 2);
    for scene in scenes {
        let rows = scene["rows"].as_array().unwrap();
        assert_eq!(rows.len(), 2 * raytree_cli::bench::stackless::ROWS.len());
        // On the paper tracer's 64-byte nodes each traversal visits the
        // nodes it visits on the own-box ones: the same work per ray.
        let row = |name: &str| {
            rows.iter()
                .find(|r| r["algorithm"] == name)
                .unwrap_or_else(|| panic!("row {name}"))
        };
        for (paired, own) in [
            ("stack-paired", "stack-sparse"),
            ("sparse-paired", "sparse"),
            ("laine-0-paired", "laine-0"),
            ("laine-8-paired", "laine-8"),
        ] {
            for phase in ["eye", "ao"] {
                assert_eq!(
                    row(paired)[phase]["counters"],
                    row(own)[phase]["counters"],
                    "{paired} against {own}"
                );
            }
        }
        for row in rows {
            let name = row["algorithm"].as_str().unwrap();
            assert!(
                out.contains(&format!("| {name} |")),
                "{name} missing from the table"
            );
            assert!(row["seconds"].as_f64().unwrap() > 0.0);
            assert!(row["ratio"].as_f64().unwrap().is_finite());
            assert_eq!(row["same_image"], true, "{name} renders another image");
            assert!(row["state_bytes"].as_u64().unwrap() > 0);
            // The work comes from the counted render, not the timed ones.
            for phase in ["eye", "ao"] {
                assert!(row[phase]["counters"]["nodes"].as_u64().unwrap() > 0);
                assert!(
                    row[format!("{phase}_per_ray")]["triangles"]
                        .as_f64()
                        .unwrap()
                        > 0.0
                );
            }
        }
    }
    for t in [1, 2] {
        let svg = std::fs::read_to_string(
            dir.path()
                .join(format!("charts/stackless-chess-3000-{t}t.svg")),
        )
        .unwrap();
        assert!(svg.contains("implicit-b") && svg.contains("laine-8"));
    }
}

#[test]
fn bench_dst_reports_every_structure() {
    let dir = tempfile::tempdir().unwrap();
    let out = ok(&raytree(
        &[
            "bench",
            "dst",
            "-s",
            "chess:3000",
            "-s",
            "hairball:2000",
            "--width",
            "48",
            "--height",
            "40",
            "--frames",
            "2",
            "-q",
            "--json",
            "d.json",
            "--report",
            "rep",
        ],
        dir.path(),
    ));
    let json: serde_json::Value =
        serde_json::from_slice(&std::fs::read(dir.path().join("d.json")).unwrap()).unwrap();
    // The report: the same JSON, a CSV row per scene and structure with
    // finite numbers, and an HTML page holding both scenes' charts, frames
    // and heat maps.
    let rep = dir.path().join("rep");
    let same: serde_json::Value =
        serde_json::from_slice(&std::fs::read(rep.join("dst.json")).unwrap()).unwrap();
    assert_eq!(same, json);
    let csv = std::fs::read_to_string(rep.join("dst.csv")).unwrap();
    let lines: Vec<&str> = csv.lines().collect();
    assert_eq!(lines[0], raytree_cli::bench::report::CSV_HEADER);
    assert_eq!(lines.len(), 1 + 2 * 9);
    for l in &lines[1..] {
        let f: Vec<&str> = l.split(',').collect();
        assert_eq!(f.len(), 20, "{l}");
        for v in &f[3..19] {
            assert!(v.parse::<f64>().unwrap().is_finite(), "{l}");
        }
    }
    let html = std::fs::read_to_string(rep.join("report.html")).unwrap();
    assert_eq!(html.matches("<section class=\"scene\">").count(), 2);
    assert!(html.contains("<h2>All scenes</h2>"));
    // Two scenes: the means over them, one line per structure.
    assert!(out.contains("### Over 2 scenes"), "{out}");
    assert!(out.contains("| dst-similar | "));
    assert_eq!(
        html.matches("<svg").count(),
        4,
        "storage and frame time per scene"
    );
    // A frame and 4 heat maps (planes and triangles, bvh and dst) per scene.
    assert_eq!(html.matches("src=\"data:image/png;base64,").count(), 2 * 5);
    const STRUCTURES: [&str; 9] = [
        "bvh",
        "dst",
        "dst-similar",
        "bih",
        "htree",
        "cbvh",
        "bvh4",
        "bvh8",
        "cwbvh",
    ];
    for s in STRUCTURES {
        assert!(html.contains(&format!("<td>{s}</td>")), "{s} missing");
    }
    assert!(json["machine"]["logical_cores"].as_u64().unwrap() >= 1);
    let scenes = json["scenes"].as_array().unwrap();
    assert_eq!(scenes.len(), 2);
    for scene in scenes {
        assert_eq!(scene["frames"], 2);
        let rows = scene["rows"].as_array().unwrap();
        let names: Vec<&str> = rows
            .iter()
            .map(|r| r["structure"].as_str().unwrap())
            .collect();
        assert_eq!(names, STRUCTURES);
        for row in rows {
            let name = row["structure"].as_str().unwrap();
            assert!(
                out.contains(&format!("| {name} |")),
                "{name} not in the table"
            );
            for key in [
                "frame_seconds",
                "frame_ratio",
                "storage_ratio",
                "mrays_per_second",
            ] {
                let v = row[key].as_f64().unwrap();
                assert!(v.is_finite() && v > 0.0, "{name} {key} = {v}");
            }
            for key in ["nodes", "planes", "triangles"] {
                assert!(row["per_ray"][key].as_f64().unwrap() > 0.0, "{name} {key}");
            }
            // Every structure finds the BVH's closest hits: same image.
            assert_eq!(row["same_image"], true, "{name} renders another image");
            assert_eq!(
                row["bytes"].as_u64().unwrap(),
                row["node_bytes"].as_u64().unwrap() + row["index_bytes"].as_u64().unwrap()
            );
        }
        // Storage below the BVH's for every compressed structure of the
        // dual-split paper, and the Compact BVH at exactly the BVH's
        // per-ray nodes; the wide BVHs (their triangles copied into
        // blocks) are not compressed, but cwbvh's nodes are bvh8's at 80
        // bytes instead of 256.
        let bvh = &rows[0];
        let by_name = |n: &str| rows.iter().find(|r| r["structure"] == n).unwrap();
        let (b8, cw) = (by_name("bvh8"), by_name("cwbvh"));
        assert_eq!(
            cw["node_bytes"].as_u64().unwrap() * 256,
            b8["node_bytes"].as_u64().unwrap() * 80
        );
        assert_eq!(cw["index_bytes"], b8["index_bytes"]);
        for row in &rows[1..6] {
            assert!(row["storage_ratio"].as_f64().unwrap() < 1.0);
            assert!(
                row["node_storage_ratio"].as_f64().unwrap()
                    < row["storage_ratio"].as_f64().unwrap()
            );
        }
        // The Compact BVH's nodes: 32 bytes per BVH inner node against 52 + 4.
        let inner = scene["bvh"]["inner_nodes"].as_f64().unwrap();
        assert_eq!(
            rows[5]["node_storage_ratio"].as_f64().unwrap(),
            32.0 * inner / (52.0 * inner + 4.0 * (inner + 1.0))
        );
        assert_eq!(rows[5]["per_ray"]["nodes"], bvh["per_ray"]["nodes"]);
        assert!(rows[1]["dst"]["split_nodes"].as_u64().unwrap() > 0);
        assert_eq!(rows[3]["dst"]["carve_dual"], 0);
        assert!(rows[4]["htree"]["bound_nodes"].as_u64().unwrap() > 0);
    }
}

#[test]
fn bench_dst_without_the_bvh_shows_no_ratios() {
    let dir = tempfile::tempdir().unwrap();
    let out = ok(&raytree(
        &[
            "bench",
            "dst",
            "-s",
            "chess:2000",
            "-a",
            "dst,cbvh",
            "--width",
            "24",
            "--height",
            "16",
            "--frames",
            "1",
            "-q",
            "--json",
            "d.json",
        ],
        dir.path(),
    ));
    let json: serde_json::Value =
        serde_json::from_slice(&std::fs::read(dir.path().join("d.json")).unwrap()).unwrap();
    for row in json["scenes"][0]["rows"].as_array().unwrap() {
        for key in ["storage_ratio", "frame_ratio", "same_image"] {
            assert!(row.get(key).is_none(), "{key} without a BVH to compare");
        }
        assert!(row["frame_seconds"].as_f64().unwrap() > 0.0);
    }
    let dst_line = out.lines().find(|l| l.starts_with("| dst |")).unwrap();
    assert_eq!(dst_line.matches("| – ").count(), 7, "{dst_line}");
    assert!(!out.contains("-100.0%") && !out.contains("### Over"));
}

#[test]
#[cfg(unix)]
fn an_interrupt_exits_130_and_leaves_no_file() {
    let dir = tempfile::tempdir().unwrap();
    let child = Command::new(env!("CARGO_BIN_EXE_raytree"))
        .args([
            "render",
            "-s",
            "hairball:200k",
            "--paper",
            "-q",
            "-o",
            "out.png",
            "--json",
            "r.json",
        ])
        .current_dir(dir.path())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    // Long enough to be rendering, far from done (the render takes seconds).
    std::thread::sleep(std::time::Duration::from_millis(700));
    let status = Command::new("kill")
        .args(["-INT", &child.id().to_string()])
        .status()
        .unwrap();
    assert!(status.success());
    let out = child.wait_with_output().unwrap();
    assert_eq!(out.status.code(), Some(130));
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(err.trim().lines().count(), 1, "{err}");
    assert!(err.contains("interrupted"), "{err}");
    let left: Vec<_> = std::fs::read_dir(dir.path()).unwrap().collect();
    assert!(left.is_empty(), "{left:?}");
}

#[test]
fn heatmaps_are_written_for_each_measure() {
    let dir = tempfile::tempdir().unwrap();
    let out = ok(&raytree(
        &[
            "render",
            "-s",
            "chess:3000",
            "-a",
            "dst",
            "--width",
            "64",
            "--height",
            "48",
            "--heatmap",
            "nodes,planes,triangles",
            "-o",
            "img.png",
            "--json",
            "r.json",
            "-q",
        ],
        dir.path(),
    ));
    let json: serde_json::Value =
        serde_json::from_slice(&std::fs::read(dir.path().join("r.json")).unwrap()).unwrap();
    let maps = json["heatmaps"].as_array().unwrap();
    assert_eq!(maps.len(), 3);
    for (m, name) in maps.iter().zip(["nodes", "planes", "triangles"]) {
        assert_eq!(m["measure"], name);
        assert!(m["scale_top"].as_u64().unwrap() > 0);
        assert!(m["max"].as_u64().unwrap() >= m["scale_top"].as_u64().unwrap());
        let file = dir.path().join(format!("img-{name}.png"));
        assert!(out.contains(&format!("img-{name}.png")));
        // The image, a one-pixel gap and an 8-pixel colour bar.
        let png = image::open(&file).unwrap().to_rgb8();
        assert_eq!(png.dimensions(), (64, 48 + 1 + 8));
        // The bar runs from dark to white.
        let (l, r) = (png.get_pixel(0, 56).0, png.get_pixel(63, 56).0);
        assert!(
            l.iter().all(|&c| c < 40) && r == [255, 255, 255],
            "{l:?} {r:?}"
        );
    }
}

#[test]
fn a_scene_too_big_for_memory_is_refused_before_it_is_built() {
    let dir = tempfile::tempdir().unwrap();
    let out = Command::new(env!("CARGO_BIN_EXE_raytree"))
        .args(["render", "-s", "chess:64000", "-o", "a.png"])
        .env(raytree::scene::memory::LIMIT_VARIABLE, "1000000")
        .current_dir(dir.path())
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(1));
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(err.trim().lines().count(), 1, "{err}");
    assert!(
        err.contains("chess:64000")
            && err.contains("need about 11.0 MiB")
            && err.contains("only 976.6 KiB")
            && err.contains("smaller scene"),
        "{err}"
    );
    assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 0);
}

/// A reader that goes away (`raytree bench dst | head -1`) ends the printing,
/// not the command: no panic, a normal exit, and the JSON still written.
#[test]
fn a_closed_pipe_stops_the_printing_but_not_the_command() {
    use std::process::Stdio;
    let dir = tempfile::tempdir().unwrap();
    let mut child = Command::new(env!("CARGO_BIN_EXE_raytree"))
        .args([
            "bench",
            "dst",
            "-q",
            "-s",
            "chess:2000",
            "-s",
            "hairball:2000",
            "--width",
            "16",
            "--height",
            "16",
            "--frames",
            "1",
            "--json",
            "b.json",
        ])
        .current_dir(dir.path())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    // Close the reading end before the first line is printed: scenes are
    // built and structures converted first.
    drop(child.stdout.take());
    let out = child.wait_with_output().unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "exit {:?}: {err}", out.status.code());
    assert!(!err.contains("panicked"), "{err}");
    let json: serde_json::Value =
        serde_json::from_slice(&std::fs::read(dir.path().join("b.json")).unwrap()).unwrap();
    assert_eq!(json["scenes"].as_array().unwrap().len(), 2);
}

/// Standard output that cannot be written for another reason (a full
/// disk) fails the command with one line on stderr.
#[cfg(target_os = "linux")]
#[test]
fn an_unwritable_stdout_fails_the_command() {
    let full = std::fs::OpenOptions::new()
        .write(true)
        .open("/dev/full")
        .unwrap();
    let out = Command::new(env!("CARGO_BIN_EXE_raytree"))
        .args(["info", "-s", "chess:2000"])
        .stdout(full)
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{err}");
    assert_eq!(err.trim_end().lines().count(), 1, "{err}");
    assert!(err.contains("cannot write to standard output"), "{err}");
}

#[test]
fn a_bad_memory_limit_is_an_error_naming_it() {
    for bad in ["abc", "-1", "0", "12 apples"] {
        let dir = tempfile::tempdir().unwrap();
        let out = Command::new(env!("CARGO_BIN_EXE_raytree"))
            .args(["info", "-s", "chess:2000"])
            .env(raytree::scene::memory::LIMIT_VARIABLE, bad)
            .current_dir(dir.path())
            .output()
            .unwrap();
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(1), "{bad}: {err}");
        assert_eq!(err.trim().lines().count(), 1, "{err}");
        assert!(
            err.contains(&format!(
                "RAYTREE_MEMORY_LIMIT='{bad}' is not a memory size"
            )),
            "{err}"
        );
        // Refused before any work: nothing on stdout.
        assert!(out.stdout.is_empty());
    }
    // A unit is understood.
    let dir = tempfile::tempdir().unwrap();
    let out = Command::new(env!("CARGO_BIN_EXE_raytree"))
        .args(["info", "-s", "chess:2000"])
        .env(raytree::scene::memory::LIMIT_VARIABLE, "4G")
        .current_dir(dir.path())
        .output()
        .unwrap();
    ok(&out);
}

#[test]
fn a_bad_simd_path_is_refused_before_any_work() {
    for bad in ["avx1024", "AVX2", "portable,avx2"] {
        let dir = tempfile::tempdir().unwrap();
        let out = Command::new(env!("CARGO_BIN_EXE_raytree"))
            .args(["render", "-s", "chess:2000", "-a", "cwbvh", "--width", "16"])
            .args(["--height", "8", "-o", "x.png"])
            .env("RAYTREE_SIMD", bad)
            .current_dir(dir.path())
            .output()
            .unwrap();
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(1), "{bad}: {err}");
        assert_eq!(err.trim().lines().count(), 1, "{err}");
        assert!(
            err.contains("RAYTREE_SIMD") && err.contains("known: portable"),
            "{err}"
        );
        assert!(!dir.path().join("x.png").exists());
    }
    // The portable path runs everywhere, and info says it was forced.
    let dir = tempfile::tempdir().unwrap();
    let out = Command::new(env!("CARGO_BIN_EXE_raytree"))
        .args(["info", "-s", "chess:2000"])
        .env("RAYTREE_SIMD", "portable")
        .current_dir(dir.path())
        .output()
        .unwrap();
    ok(&out);
    let text = String::from_utf8_lossy(&out.stdout);
    let line = text.lines().find(|l| l.starts_with("simd ")).unwrap();
    assert!(
        line.contains("portable") && line.contains("forced"),
        "{line}"
    );
    assert!(text.contains("| cwbvh |"), "{text}");
}

fn render_to(name: &str, dir: &Path) -> Output {
    raytree(
        &[
            "render",
            "-s",
            "chess:2000",
            "--width",
            "24",
            "--height",
            "16",
            "-q",
            "-o",
            name,
        ],
        dir,
    )
}

#[test]
fn the_output_extension_chooses_the_image_format() {
    let dir = tempfile::tempdir().unwrap();
    for (name, magic) in [
        ("a.png", &b"\x89PNG\r\n"[..]),
        ("a.jpg", &b"\xff\xd8\xff"[..]),
        ("a.JPEG", &b"\xff\xd8\xff"[..]),
        ("a.ppm", &b"P6\n24 16\n255\n"[..]),
        ("a.exr", &b"\x76\x2f\x31\x01"[..]),
    ] {
        ok(&render_to(name, dir.path()));
        let bytes = std::fs::read(dir.path().join(name)).unwrap();
        assert!(bytes.starts_with(magic), "{name}: {:x?}", &bytes[..8]);
    }
    let png = image::open(dir.path().join("a.png")).unwrap().to_luma8();
    let jpg = image::open(dir.path().join("a.jpg")).unwrap().to_luma8();
    assert_eq!(jpg.dimensions(), (24, 16));
    // The JPEG is the same picture, up to its compression.
    let diff: f64 = png
        .pixels()
        .zip(jpg.pixels())
        .map(|(a, b)| (a.0[0] as f64 - b.0[0] as f64).abs())
        .sum::<f64>()
        / (24.0 * 16.0);
    assert!(diff < 8.0, "mean difference {diff}");
    // Unknown or missing extensions are refused before any work, leaving
    // nothing behind.
    fails(
        &["render", "-o", "x.gif"],
        1,
        "x.gif: unknown image format '.gif'",
    );
    fails(&["render", "-o", "x"], 1, "x: no extension");
    fails(
        &[
            "render",
            "-s",
            "chess:2000",
            "--heatmap",
            "nodes",
            "-o",
            "x.tiff",
        ],
        1,
        ".png, .jpg (or .jpeg), .ppm or .exr",
    );
}

#[test]
fn output_dash_is_png_on_standard_output() {
    let dir = tempfile::tempdir().unwrap();
    let out = render_to("-", dir.path());
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(out.stdout.starts_with(b"\x89PNG\r\n"));
    let png = image::load_from_memory(&out.stdout).unwrap();
    assert_eq!((png.width(), png.height()), (24, 16));
    // The report went to stderr; no file named "-".
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("wrote      standard output (PNG)"), "{err}");
    assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 0);
    // The same picture as a file.
    ok(&render_to("b.png", dir.path()));
    assert_eq!(
        image::open(dir.path().join("b.png")).unwrap().to_luma8(),
        png.to_luma8()
    );
}

#[test]
fn each_command_takes_only_the_options_it_uses() {
    for cmd in ["info", "trace"] {
        for opt in ["--eye", "--look-at", "--up"] {
            fails(
                &[cmd, opt, "1,2,3"],
                2,
                &format!("unexpected argument '{opt}'"),
            );
        }
        fails(&[cmd, "--fov", "40"], 2, "unexpected argument '--fov'");
    }
    fails(
        &["render", "--up", "0,0,0"],
        2,
        "the up direction must not be zero",
    );
    fails(&["render", "--up", "0,1"], 2, "--up");
    fails(&["bench", "dst", "--up", "0,-0,0"], 2, "must not be zero");
    // --up turns the picture: with up = -y, it is the default upside down.
    let dir = tempfile::tempdir().unwrap();
    let args = |up: &str, name: &str| {
        let mut a = vec![
            "render",
            "-s",
            "chess:2000",
            "--width",
            "24",
            "--height",
            "16",
            "-q",
            "-i",
            "path",
            "--eye",
            "300,100,300",
            "--look-at",
            "0,10,0",
            "-o",
        ];
        a.push(name);
        if !up.is_empty() {
            a.extend(["--up", up]);
        }
        a.iter().map(|s| s.to_string()).collect::<Vec<_>>()
    };
    for (up, name) in [("", "a.png"), ("0,-1,0", "b.png"), ("0,2,0", "c.png")] {
        let a = args(up, name);
        ok(&raytree(
            &a.iter().map(|s| s.as_str()).collect::<Vec<_>>(),
            dir.path(),
        ));
    }
    let a = image::open(dir.path().join("a.png")).unwrap().to_luma8();
    let b = image::open(dir.path().join("b.png")).unwrap().to_luma8();
    let c = image::open(dir.path().join("c.png")).unwrap().to_luma8();
    assert_eq!(a, c, "a longer up vector is the same camera");
    assert_ne!(a, b, "--up was not applied");
}

#[test]
fn negative_numbers_get_a_message_about_the_value() {
    fails(
        &["render", "--width", "-5"],
        2,
        "invalid value '-5' for '--width <WIDTH>': -5 is not in 1..=16384",
    );
    fails(&["render", "--height", "-1"], 2, "-1 is not in 1..=16384");
    fails(&["render", "--threads", "-2"], 2, "-2 is not in 1..=1024");
    fails(
        &["render", "--fov", "-30"],
        2,
        "-30 is not an angle in (0, 180) degrees",
    );
    fails(&["render", "--max-leaf", "-8"], 2, "-8 is not in 1..=255");
    fails(
        &["render", "--sah-block", "3"],
        2,
        "invalid value '3' for '--sah-block <SAH_BLOCK>'",
    );
    fails(
        &["bench", "peers", "--sah-block", "32"],
        2,
        "invalid value '32' for '--sah-block <SAH_BLOCK>'",
    );
    fails(
        &["render", "--implicit-limit", "-1"],
        2,
        "'-1' is not a positive number of GiB",
    );
    fails(
        &["render", "--samples", "-1.5"],
        2,
        "invalid value '-1.5' for '--samples",
    );
    fails(
        &["trace", "--threads", "-3", "--rays", "r", "-o", "h"],
        2,
        "-3 is not in 1..=1024",
    );
    fails(
        &["bench", "dst", "--frames", "-1"],
        2,
        "-1 is not in 1..=10000",
    );
    fails(
        &["bench", "peers", "--width", "-7"],
        2,
        "-7 is not in 1..=16384",
    );
    // Checked after parsing: still about the value.
    fails(
        &["render", "--ao-radius", "-1", "-s", "chess:2000"],
        1,
        "--ao-radius -1: must be a positive number",
    );
    // Negative coordinates are values, not flags.
    let dir = tempfile::tempdir().unwrap();
    ok(&raytree(
        &[
            "render",
            "-s",
            "chess:2000",
            "--width",
            "8",
            "--height",
            "8",
            "-q",
            "--eye",
            "-300,100,-300",
            "--look-at",
            "-1,-2,-3",
            "-o",
            "n.png",
        ],
        dir.path(),
    ));
}

/// Writes the files of a three-file scene into `dir`: `a.obj` (a quad at x
/// in [0, 1], z = 0), `b.stl` (binary, a quad at x in [2, 3]) and `c.glb`
/// (the unit cube at x = 4 and x = 6, and a LINES primitive per instance).
fn three_files(dir: &Path) {
    use files::{cube, stl_binary, Gltf, U16};
    use serde_json::json;
    std::fs::write(
        dir.join("a.obj"),
        "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3 4\n",
    )
    .unwrap();
    std::fs::write(
        dir.join("b.stl"),
        stl_binary(
            b"solid quad",
            &[
                [[2.0, 0.0, 0.0], [3.0, 0.0, 0.0], [3.0, 1.0, 0.0]],
                [[2.0, 0.0, 0.0], [3.0, 1.0, 0.0], [2.0, 1.0, 0.0]],
            ],
        ),
    )
    .unwrap();
    let mut g = Gltf::new();
    let (points, indices) = cube();
    let pos = g.positions(&points);
    let idx = g.indices(&indices, U16);
    let line = g.indices(&[0, 7], U16);
    g.mesh(
        Some("Cube"),
        vec![
            json!({"attributes": {"POSITION": pos}, "indices": idx}),
            json!({"attributes": {"POSITION": pos}, "indices": line, "mode": 1}),
        ],
    );
    g.node(json!({"mesh": 0, "translation": [4.0, 0.0, 0.0]}));
    g.node(json!({"mesh": 0, "translation": [6.0, 0.0, 0.0]}));
    g.scene(&[0, 1]);
    std::fs::write(dir.join("c.glb"), g.glb()).unwrap();
}

#[test]
fn trace_reports_geometry_ids_of_several_files() {
    let dir = tempfile::tempdir().unwrap();
    three_files(dir.path());
    // Straight down at points inside known triangles -> (geometry, its
    // triangle); the cube's top is its triangles 2 (x + y < 1) and 3.
    // (geometry, triangle within it, triangle in the scene).
    type Want = Option<(u32, u32, u32)>;
    let cases: [((f32, f32), Want); 9] = [
        ((0.75, 0.25), Some((0, 0, 0))),
        ((0.25, 0.75), Some((0, 1, 1))),
        ((2.75, 0.25), Some((1, 0, 2))),
        ((2.25, 0.75), Some((1, 1, 3))),
        ((4.25, 0.25), Some((2, 2, 6))),
        ((4.75, 0.75), Some((2, 3, 7))),
        ((6.25, 0.25), Some((3, 2, 18))),
        ((6.75, 0.75), Some((3, 3, 19))),
        ((5.5, 0.5), None),
    ];
    let rays: Vec<Ray> = cases
        .iter()
        .map(|&((x, y), _)| Ray::infinite(Vec3::new(x, y, 10.0), Vec3::NEG_Z))
        .collect();
    std::fs::write(dir.path().join("r.rays"), rayfile::encode_rays(&rays)).unwrap();
    let scene = "a.obj,b.stl,c.glb";
    for format in ["bin", "bin-geometry", "csv"] {
        let out = raytree(
            &[
                "trace", "-s", scene, "--rays", "r.rays", "-o", "h.out", "--format", format,
                "--json", "t.json",
            ],
            dir.path(),
        );
        ok(&out);
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(
            err.contains("raytree: warning: c.glb: skipped 2 primitives of mode LINES"),
            "{err}"
        );
        let bytes = std::fs::read(dir.path().join("h.out")).unwrap();
        let got: Vec<Want> = match format {
            "bin" => {
                assert_eq!(bytes.len(), 16 * rays.len());
                rayfile::decode_hits(&bytes)
                    .unwrap()
                    .iter()
                    .map(|h| h.map(|h| (0, 0, h.prim)))
                    .collect()
            }
            "bin-geometry" => {
                assert_eq!(bytes.len(), 24 * rays.len());
                rayfile::decode_geometry_hits(&bytes)
                    .unwrap()
                    .iter()
                    .map(|h| h.map(|h| (h.geometry, h.primitive, h.hit.prim)))
                    .collect()
            }
            _ => {
                let text = String::from_utf8(bytes).unwrap();
                let mut lines = text.lines();
                assert_eq!(lines.next(), Some("ray,t,triangle,u,v,geometry,primitive"));
                lines
                    .map(|l| {
                        let f: Vec<&str> = l.split(',').collect();
                        let n = |k: usize| f[k].parse::<u32>().unwrap();
                        (n(2) != rayfile::MISS).then(|| (n(5), n(6), n(2)))
                    })
                    .collect()
            }
        };
        let want: Vec<_> = cases
            .iter()
            .map(|&(_, w)| {
                w.map(|(g, l, t)| {
                    if format == "bin" {
                        (0, 0, t)
                    } else {
                        (g, l, t)
                    }
                })
            })
            .collect();
        assert_eq!(got, want, "{format}");
        if format == "csv" {
            // The misses' geometry columns.
            let text = std::fs::read_to_string(dir.path().join("h.out")).unwrap();
            assert!(text.ends_with("8,inf,4294967295,0,0,4294967295,4294967295\n"));
        }
        let json: serde_json::Value =
            serde_json::from_slice(&std::fs::read(dir.path().join("t.json")).unwrap()).unwrap();
        assert_eq!(json["geometries"].as_array().unwrap().len(), 4);
        assert_eq!(json["geometries"][3]["first_triangle"], 16);
        assert_eq!(
            json["warnings"][0],
            "c.glb: skipped 2 primitives of mode LINES"
        );
    }
}

#[test]
fn info_and_render_accept_gltf_stl_and_several_files() {
    let dir = tempfile::tempdir().unwrap();
    three_files(dir.path());
    let out = ok(&raytree(
        &["info", "-s", "a.obj,b.stl,c.glb", "--json", "i.json"],
        dir.path(),
    ));
    assert!(out.contains("triangles   28 (24 vertices)"), "{out}");
    assert!(
        out.contains(
            "geometries  4\n     0  a.obj: 2 triangles (0..2)\n     1  b.stl: 2 triangles (2..4)\n     2  c.glb: node 0, mesh 0 \"Cube\", primitive 0: 12 triangles (4..16)\n"
        ),
        "{out}"
    );
    let json: serde_json::Value =
        serde_json::from_slice(&std::fs::read(dir.path().join("i.json")).unwrap()).unwrap();
    let g = &json["geometries"];
    assert_eq!(g[0]["name"], "a.obj");
    assert_eq!(g[1]["name"], "b.stl");
    assert_eq!(g[1]["id"], 1);
    assert_eq!(g[1]["triangles"], 2);
    assert_eq!(g[2]["name"], "c.glb: node 0, mesh 0 \"Cube\", primitive 0");
    assert_eq!(json["scene"], "a.obj,b.stl,c.glb");
    for scene in ["c.glb", "b.stl", "a.obj,c.glb"] {
        let out = ok(&raytree(&["info", "-s", scene], dir.path()));
        assert!(out.contains("geometries"), "{out}");
        ok(&raytree(
            &[
                "render", "-s", scene, "--width", "24", "--height", "16", "-q", "-o", "r.png",
            ],
            dir.path(),
        ));
        assert!(dir.path().join("r.png").exists());
    }
    // A built-in scene is one geometry.
    let out = ok(&raytree(&["info", "-s", "chess:2000"], dir.path()));
    assert!(out.contains("geometries  1\n"), "{out}");
}

#[test]
fn bad_scene_files_fail_with_the_file_and_element() {
    let dir = tempfile::tempdir().unwrap();
    three_files(dir.path());
    let mut glb = std::fs::read(dir.path().join("c.glb")).unwrap();
    glb.truncate(glb.len() - 4);
    std::fs::write(dir.path().join("cut.glb"), glb).unwrap();
    let stl = std::fs::read(dir.path().join("b.stl")).unwrap();
    std::fs::write(dir.path().join("cut.stl"), &stl[..stl.len() - 1]).unwrap();
    for (scene, needle) in [
        ("cut.glb", "cut.glb: GLB: its header gives a length of"),
        (
            "cut.stl",
            "cut.stl: binary STL: its header counts 2 triangles",
        ),
        ("a.obj,cut.stl", "cut.stl: binary STL"),
        ("a.obj,,b.stl", "has an empty entry"),
        ("chess,a.obj", "'chess' is a built-in scene"),
        ("a.obj,none.glb", "none.glb"),
    ] {
        for command in ["info", "render", "trace"] {
            let mut args = vec![command, "-s", scene];
            if command == "trace" {
                std::fs::write(dir.path().join("r.rays"), [0u8; 0]).unwrap();
                args.extend(["--rays", "r.rays", "-o", "h.bin"]);
            } else if command == "render" {
                args.extend(["-o", "x.png", "-q"]);
            }
            let out = raytree(&args, dir.path());
            let err = String::from_utf8_lossy(&out.stderr);
            assert_eq!(out.status.code(), Some(1), "{args:?}: {err}");
            assert!(err.contains(needle), "{args:?}: {err}");
            assert_eq!(err.lines().count(), 1, "{err}");
        }
    }
    assert!(!dir.path().join("x.png").exists() && !dir.path().join("h.bin").exists());
}
