//! Faults found with inputs from the field (issue 20): a camera looking
//! along its up axis, the default render of a user's mesh, progress for
//! every long step.

use crate::support;
use std::path::Path;
use std::process::Command;
use support::*;

fn json(path: &Path) -> serde_json::Value {
    serde_json::from_slice(&std::fs::read(path).unwrap()).unwrap()
}

fn grey_pixels(path: &Path) -> Vec<u8> {
    image::open(path).unwrap().to_luma8().into_raw()
}

/// Item 7: `--eye 0,500,0 --look-at 0,0,0` looks along the default up
/// axis. The camera picks a valid basis: the board is seen from above, rays
/// do the ordinary amount of work, the image is not blank.
#[test]
fn a_camera_looking_along_up_sees_the_scene() {
    let dir = tempfile::tempdir().unwrap();
    let out = raytree(
        &[
            "render",
            "-s",
            "chess:5000",
            "--eye",
            "0,500,0",
            "--look-at",
            "0,0,0",
            "--width",
            "64",
            "--height",
            "64",
            "-o",
            "top.png",
            "--json",
            "top.json",
            "-q",
        ],
        dir.path(),
    );
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let report = json(&dir.path().join("top.json"));
    let nodes = report["per_ray"]["nodes"].as_f64().unwrap();
    let tris = report["per_ray"]["triangles"].as_f64().unwrap();
    // Before the fix every ray was NaN and visited every node and triangle
    // (about 1500 nodes and 5000 triangles per ray).
    assert!(
        nodes < 200.0 && tris < 100.0,
        "{nodes} nodes, {tris} triangles per ray"
    );
    let px = grey_pixels(&dir.path().join("top.png"));
    // The board seen from above is lit (white), the pieces and their
    // contact shadows are not: before the fix every pixel was white.
    let shaded = px.iter().filter(|&&p| p < 235).count();
    assert!(
        shaded * 50 > px.len(),
        "{shaded} of {} pixels below 235",
        px.len()
    );
    assert!(*px.iter().min().unwrap() < 215);
}

/// An OBJ of a closed, convex-ish shape: a 24-sided prism with caps.
fn write_prism(path: &Path) {
    let n = 24;
    let mut s = String::new();
    for ring in [0.0f32, 2.0] {
        for i in 0..n {
            let a = i as f32 / n as f32 * std::f32::consts::TAU;
            s += &format!("v {} {} {}\n", a.cos(), ring, a.sin());
        }
    }
    s += "v 0 0 0\nv 0 2 0\n";
    for i in 0..n {
        let j = (i + 1) % n;
        let (a, b, c, d) = (i + 1, j + 1, j + 1 + n, i + 1 + n);
        s += &format!("f {a} {b} {c}\nf {a} {c} {d}\n");
        s += &format!("f {} {b} {a}\nf {} {d} {c}\n", 2 * n + 1, 2 * n + 2);
    }
    std::fs::write(path, s).unwrap();
}

/// Item 8: the default render of a user's mesh shows its silhouette
/// against the background and its shape inside it.
#[test]
fn the_default_render_of_a_mesh_shows_its_shape() {
    let dir = tempfile::tempdir().unwrap();
    write_prism(&dir.path().join("prism.obj"));
    let out = raytree(
        &["render", "-s", "prism.obj", "-o", "prism.png", "-q"],
        dir.path(),
    );
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let px = grey_pixels(&dir.path().join("prism.png"));
    let n = px.len();
    let white = px.iter().filter(|&&p| p >= 240).count();
    assert!(white * 10 < n, "{white} of {n} pixels white");
    // Background and object are both there, far apart in tone.
    let background = px[0];
    let object: Vec<u8> = px
        .iter()
        .copied()
        .filter(|&p| p.abs_diff(background) > 40)
        .collect();
    assert!(
        object.len() * 10 > n,
        "the object covers {} of {n} pixels",
        object.len()
    );
    // Inside the object the tones vary (the facing ratio shades its sides).
    let (lo, hi) = (*object.iter().min().unwrap(), *object.iter().max().unwrap());
    assert!(hi - lo > 60, "object tones {lo}..{hi}");
    // Built-in scenes keep the paper's white sky.
    let out = raytree(
        &[
            "render",
            "-s",
            "chess:2000",
            "--width",
            "32",
            "--height",
            "16",
            "-o",
            "c.png",
            "-q",
        ],
        dir.path(),
    );
    assert!(out.status.success());
    assert_eq!(grey_pixels(&dir.path().join("c.png"))[0], 255);
}

/// Item 14: on a terminal, loading, building, converting and rendering each
/// show progress (run under `script`, which gives the command a terminal).
#[test]
fn every_long_step_shows_progress_on_a_terminal() {
    if Command::new("script").arg("--version").output().is_err() {
        eprintln!("skipped: no `script` command to give raytree a terminal");
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let cmd = format!(
        "{} render -s plant:300k -a dst --width 64 --height 64 -o p.png",
        env!("CARGO_BIN_EXE_raytree")
    );
    let out = Command::new("script")
        .args(["-qec", &cmd, "/dev/null"])
        .current_dir(dir.path())
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let text = String::from_utf8_lossy(&out.stdout);
    for step in [
        "loading plant:300k",
        "building the BVH over",
        "converting the BVH to dst",
        "render [",
    ] {
        assert!(text.contains(step), "no '{step}' in:\n{text}");
    }
}
