//! Images and per-pixel work of every structure and traversal, pinned by
//! hashes recorded before the structure-per-folder move (issue 19): any
//! change to what a kernel returns or counts changes a hash. Record anew
//! only for an intended change: `RAYTREE_RECORD_HASHES=1 cargo test --test
//! image_hashes` rewrites `tests/data/image_hashes.txt`.

use crate::common;

use common::configurations;
use raytree::prelude::*;
use raytree::render::{AoSettings, Integrator, PathSettings, Rendered};
use raytree::structures::Built;
use std::fmt::Write;

/// FNV-1a, 64 bits.
fn fnv(bytes: impl IntoIterator<Item = u8>) -> u64 {
    bytes.into_iter().fold(0xcbf2_9ce4_8422_2325, |h, b| {
        (h ^ b as u64).wrapping_mul(0x0100_0000_01b3)
    })
}

/// FNV-1a of a render's sRGB image and of its per-pixel work.
fn hashes(r: &Rendered) -> (u64, u64) {
    let image = fnv(r.image.to_srgb8());
    let work = fnv(r
        .work
        .pixels
        .iter()
        .flat_map(|t| [t.nodes, t.planes, t.triangles])
        .flat_map(u32::to_le_bytes));
    (image, work)
}

fn table() -> String {
    let mut out = String::new();
    for spec in ["chess:3000", "hairball:2000", "atrium:2000"] {
        let scene = Scene::builtin(spec).unwrap();
        let radius = 0.1 * scene.mesh.bounds().extent().length();
        let integrators = [
            (
                "ao-paper",
                Integrator::Ao(AoSettings {
                    eye_rays: 4,
                    ao_rays: 4,
                    ..AoSettings::paper(radius)
                }),
            ),
            ("ao-plain", Integrator::Ao(AoSettings::plain(2, 4, radius))),
            ("path", Integrator::Path(PathSettings::default())),
        ];
        for builder in Builder::ALL {
            let bvh = Bvh::build(&scene.triangles, &BuildOptions::new(builder));
            for (s, t) in configurations() {
                let (built, _) = Built::new(s, t, &bvh, scene.triangles.clone()).unwrap();
                for (name, integrator) in &integrators {
                    let (image, work) = hashes(&built.render(&scene, integrator, 40, 24, &|_| {}));
                    writeln!(
                        out,
                        "{spec} {builder:?} {}/{} {name} {image:016x} {work:016x}",
                        s.name(),
                        t.name()
                    )
                    .unwrap();
                }
            }
        }
    }
    out
}

#[test]
fn images_and_work_equal_the_recorded_ones() {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/data/image_hashes.txt");
    let got = table();
    if std::env::var_os("RAYTREE_RECORD_HASHES").is_some() {
        std::fs::write(path, &got).unwrap();
        return;
    }
    let want = std::fs::read_to_string(path).unwrap();
    let differ: Vec<_> = got
        .lines()
        .zip(want.lines())
        .filter(|(g, w)| g != w)
        .map(|(g, w)| format!("  got  {g}\n  want {w}"))
        .collect();
    assert!(
        differ.is_empty() && got.lines().count() == want.lines().count(),
        "{} of {} renders differ from the recorded ones:\n{}",
        differ.len(),
        want.lines().count(),
        differ.join("\n")
    );
}
