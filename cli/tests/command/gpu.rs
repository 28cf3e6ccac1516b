//! `--device gpu` (feature `gpu`): `trace` on the GPU gives the CPU's hits
//! and counters; without an adapter the command says so in one line and
//! exits 1. Without an adapter on this machine the agreement test prints
//! why and passes, unless `RAYTREE_REQUIRE_GPU` is set (CI).
#![cfg(feature = "gpu")]

use crate::common;
use crate::support::{ok, raytree};
use raytree::prelude::*;
use raytree::rayfile;
use std::process::Command;

/// The hits and JSON report of `raytree trace` with `extra` options.
fn trace(dir: &std::path::Path, extra: &[&str]) -> (Vec<Option<Hit>>, serde_json::Value) {
    let mut args = vec![
        "trace",
        "-s",
        "chess:2000",
        "--rays",
        "r.rays",
        "-o",
        "h.bin",
        "--json",
        "t.json",
    ];
    args.extend_from_slice(extra);
    let out = ok(&raytree(&args, dir));
    assert!(out.contains("traced"), "{out}");
    let hits = rayfile::decode_hits(&std::fs::read(dir.join("h.bin")).unwrap()).unwrap();
    let json = serde_json::from_str(&std::fs::read_to_string(dir.join("t.json")).unwrap()).unwrap();
    (hits, json)
}

#[test]
fn trace_on_the_gpu_gives_the_cpus_hits_and_counters() {
    let dir = tempfile::tempdir().unwrap();
    let probe = raytree(&["bench", "gpu", "--help"], dir.path());
    assert!(probe.status.success());
    let scene = Scene::builtin("chess:2000").unwrap();
    let rays = common::mixed_rays(&scene, 2000, 5);
    std::fs::write(dir.path().join("r.rays"), rayfile::encode_rays(&rays)).unwrap();
    for structure in [
        &["-a", "bvh"][..],
        &["-a", "bvh", "-t", "sparse"],
        &["-a", "bvh", "-t", "laine-2", "--builder", "hybrid"],
        &["-a", "dst"],
        &["-a", "bvh8"],
    ] {
        for any in [false, true] {
            let mut cpu_args = structure.to_vec();
            if any {
                cpu_args.push("--any-hit");
            }
            let (want, want_json) = trace(dir.path(), &cpu_args);
            let mut gpu_args = cpu_args.clone();
            gpu_args.extend(["--device", "gpu"]);
            let out = raytree(
                &[
                    &[
                        "trace",
                        "-s",
                        "chess:2000",
                        "--rays",
                        "r.rays",
                        "-o",
                        "g.bin",
                        "--json",
                        "g.json",
                    ][..],
                    &gpu_args,
                ]
                .concat(),
                dir.path(),
            );
            if !out.status.success() {
                let err = String::from_utf8_lossy(&out.stderr);
                if err.contains("no GPU adapter")
                    && std::env::var_os("RAYTREE_REQUIRE_GPU").is_none()
                {
                    eprintln!("skipping the GPU trace test: {err}");
                    return;
                }
                panic!("{structure:?}: {err}");
            }
            let got =
                rayfile::decode_hits(&std::fs::read(dir.path().join("g.bin")).unwrap()).unwrap();
            let json: serde_json::Value =
                serde_json::from_str(&std::fs::read_to_string(dir.path().join("g.json")).unwrap())
                    .unwrap();
            assert_eq!(json["device"], "gpu");
            assert!(json["gpu"]["adapter"].is_string());
            assert_eq!(got.len(), want.len());
            for (i, (g, w)) in got.iter().zip(&want).enumerate() {
                let same = match (g, w) {
                    (None, None) => true,
                    (Some(g), Some(w)) => g.prim == w.prim && (g.t - w.t).abs() <= 1e-6 * w.t.abs(),
                    _ => false,
                };
                assert!(
                    same,
                    "{structure:?} any={any} ray {i}: GPU {g:?}, CPU {w:?}"
                );
            }
            // The same work, counted on the GPU.
            assert_eq!(
                json["counters"], want_json["counters"],
                "{structure:?} any={any}"
            );
        }
    }
}

#[test]
fn bench_gpu_paper_preset_runs_both_papers_workloads() {
    let dir = tempfile::tempdir().unwrap();
    let out = raytree(
        &[
            "bench",
            "gpu",
            "--preset",
            "paper",
            "-s",
            "chess:2000",
            "--width",
            "24",
            "--height",
            "9",
            "--repeats",
            "1",
            "--json",
            "g.json",
        ],
        dir.path(),
    );
    if !out.status.success() {
        let err = String::from_utf8_lossy(&out.stderr);
        if err.contains("no GPU adapter") && std::env::var_os("RAYTREE_REQUIRE_GPU").is_none() {
            eprintln!("skipping the GPU bench test: {err}");
            return;
        }
        panic!("{err}");
    }
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.path().join("g.json")).unwrap()).unwrap();
    assert_eq!(json["preset"], "paper");
    let scene = &json["scenes"][0];
    // The stackless paper's form and camera, its eye and AO rays together:
    // 24×9 pixels of 16 eye rays, and 16 AO rays for each eye ray that hits.
    let words = scene["ao_workload"].as_str().unwrap();
    for part in [
        "24×9",
        "50° horizontal",
        "16 eye rays",
        "closest-hit AO",
        "stratified",
    ] {
        assert!(words.contains(part), "{words}");
    }
    let rays = scene["ao_rays"].as_u64().unwrap();
    assert!(rays > 24 * 9 * 16 && rays <= 24 * 9 * 16 * 17, "{rays}");
    let names = |t: &str| -> Vec<String> {
        scene[t]
            .as_array()
            .unwrap()
            .iter()
            .map(|r| r["name"].as_str().unwrap().to_string())
            .collect()
    };
    assert_eq!(names("stackless").len(), 10);
    assert_eq!(names("dst"), ["bvh", "dst", "dst-similar", "bvh4", "bvh8"]);
    for t in ["stackless", "dst"] {
        for row in scene[t].as_array().unwrap() {
            assert_eq!(row["disagree"], 0, "{row}");
            assert!(row["gpu_mrays"].as_f64().unwrap() > 0.0, "{row}");
        }
    }
}

#[test]
fn no_adapter_is_one_line_and_exit_1() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(
        dir.path().join("r.rays"),
        rayfile::encode_rays(&[Ray::infinite(Vec3::ZERO, Vec3::X)]),
    )
    .unwrap();
    // No Vulkan driver to be found: the loader's list of drivers is empty.
    for args in [
        &[
            "trace",
            "-s",
            "chess:2000",
            "--rays",
            "r.rays",
            "-o",
            "h.bin",
            "--device",
            "gpu",
        ][..],
        &["bench", "gpu", "-s", "chess:2000"],
    ] {
        let out = Command::new(env!("CARGO_BIN_EXE_raytree"))
            .args(args)
            .current_dir(dir.path())
            .env("VK_ICD_FILENAMES", "/nonexistent/icd.json")
            .env("VK_DRIVER_FILES", "/nonexistent/icd.json")
            .output()
            .unwrap();
        assert_eq!(out.status.code(), Some(1), "{args:?}");
        let err = String::from_utf8_lossy(&out.stderr);
        let lines: Vec<&str> = err
            .lines()
            .filter(|l| !l.contains("XDG_RUNTIME_DIR"))
            .collect();
        assert_eq!(lines.len(), 1, "{args:?}: {err}");
        assert!(lines[0].contains("no GPU adapter"), "{err}");
        assert!(!dir.path().join("h.bin").exists());
    }
}
