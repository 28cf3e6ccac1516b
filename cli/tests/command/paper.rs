//! The command line of issue 26: cameras that say what they mean, the
//! stackless paper's view and AO form under --paper, the form named in every
//! report, and clear errors for angles that are not angles.

use crate::support;
use std::path::Path;
use support::*;

fn fails(args: &[&str], code: i32, needle: &str) {
    let dir = tempfile::tempdir().unwrap();
    let out = raytree(args, dir.path());
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(code), "{args:?}: {err}");
    assert!(
        err.contains(needle),
        "{args:?}: stderr lacks '{needle}': {err}"
    );
    assert!(!err.contains("panicked"), "{args:?}: {err}");
    assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 0);
}

fn json(dir: &Path, name: &str) -> serde_json::Value {
    serde_json::from_slice(&std::fs::read(dir.join(name)).unwrap()).unwrap()
}

#[test]
fn bad_angles_are_refused_with_a_message() {
    for a in ["0", "180", "NaN", "inf", "-10", "x"] {
        fails(&["render", "--hfov", a], 2, "--hfov");
        fails(&["render", "--fov", a], 2, "--fov");
    }
    fails(
        &["render", "--fov", "40", "--hfov", "40"],
        2,
        "cannot be used with",
    );
    // The paper's angle scaled by a tall image's height/width passes 180°.
    fails(
        &[
            "render",
            "-s",
            "chess:2000",
            "--paper",
            "--width",
            "20",
            "--height",
            "160",
        ],
        1,
        "does not fit a 20×160 image",
    );
}

#[test]
fn paper_renders_use_the_papers_camera_and_ao_form_and_say_so() {
    let dir = tempfile::tempdir().unwrap();
    let base = [
        "render",
        "-s",
        "chess:2000",
        "--width",
        "16",
        "--height",
        "6",
        "-o",
        "a.png",
    ];
    let mut args = base.to_vec();
    args.extend(["--paper", "--json", "p.json"]);
    let out = ok(&raytree(&args, dir.path()));
    assert!(
        out.contains(
            "closest-hit AO rays, 4×4 stratified eye jitter, 4×4 stratified AO directions"
        ),
        "{out}"
    );
    assert!(
        out.contains("50° horizontal, the stackless paper's non-square pixels"),
        "{out}"
    );
    let p = json(dir.path(), "p.json");
    assert_eq!(p["ao"]["query"], "closest");
    assert_eq!(p["ao"]["sampling"], "stratified");
    assert_eq!(p["ao"]["radius"], 32.0);
    assert_eq!(p["camera"]["fov"]["kind"], "paper");
    assert_eq!(p["camera"]["fov"]["degrees"], 50.0);
    assert_eq!(p["camera"]["eye"], serde_json::json!([300.0, 100.0, 300.0]));

    // The any-hit form on request, named as such.
    let mut args = base.to_vec();
    args.extend(["--paper", "--ao-query", "any", "--json", "q.json"]);
    let out = ok(&raytree(&args, dir.path()));
    assert!(out.contains("any-hit AO rays"), "{out}");
    assert_eq!(json(dir.path(), "q.json")["ao"]["query"], "any");

    // The default render keeps its form and its vertical 50°.
    let mut args = base.to_vec();
    args.extend(["--json", "d.json"]);
    let out = ok(&raytree(&args, dir.path()));
    assert!(
        out.contains("any-hit AO rays, independent eye jitter, independent AO directions"),
        "{out}"
    );
    let d = json(dir.path(), "d.json");
    assert_eq!(d["ao"]["query"], "any");
    assert_eq!(d["ao"]["sampling"], "independent");
    assert_eq!(d["camera"]["fov"]["kind"], "vertical");

    // --hfov: a horizontal angle with square pixels.
    let mut args = base.to_vec();
    args.extend(["--hfov", "50", "--json", "h.json"]);
    ok(&raytree(&args, dir.path()));
    let h = json(dir.path(), "h.json");
    assert_eq!(h["camera"]["fov"]["kind"], "horizontal");
    assert_eq!(h["camera"]["fov"]["degrees"], 50.0);
}
