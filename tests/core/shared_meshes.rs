//! Every structure on every mesh of `../shared/scenes`, closest and any hit:
//! 100k rays per mesh against STACK over the binary BVH, and 2k of them
//! against the brute-force oracle itself (brute force over 100k rays of the
//! 871k-triangle dragon would take hours; STACK is held to the oracle on
//! 100k rays of the smaller meshes in `oracle.rs`).

use crate::common;

use raytree::prelude::*;
use raytree::structures::{Built, StructureKind, TraversalKind, WithAccel};

struct Answers<'a>(&'a [Ray]);

impl WithAccel for Answers<'_> {
    type Output = Vec<(Option<Hit>, Option<Hit>)>;
    fn run<A: Accel>(self, a: &A) -> Self::Output {
        raytree::par::map(self.0, &|r| {
            (a.closest_hit(r, &mut NoStats), a.any_hit(r, &mut NoStats))
        })
    }
}

/// Rays per mesh, traced by every structure (up to 871,000 triangles).
const RAYS: usize = 30_000;

#[test]
fn every_structure_agrees_on_every_shared_mesh() {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../shared/scenes");
    let Ok(entries) = std::fs::read_dir(&dir) else {
        eprintln!("skipping: {} is not present", dir.display());
        return;
    };
    let mut files: Vec<_> = entries
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|e| e == "obj" || e == "ply"))
        .collect();
    files.sort();
    assert!(!files.is_empty());
    for path in files {
        let scene = Scene::load(&path).unwrap();
        let rays = common::mixed_rays(&scene, RAYS, 17);
        let bvh = Bvh::build(&scene.triangles, &BuildOptions::sah());
        let brute = BruteForce::new(scene.triangles.clone());
        let reference = Built::new(
            StructureKind::Bvh,
            TraversalKind::Stack,
            &bvh,
            scene.triangles.clone(),
        )
        .unwrap()
        .0
        .with(Answers(&rays));
        // STACK against the oracle on a sample.
        for (i, r) in rays.iter().enumerate().step_by(50) {
            let want = brute.closest_hit(r, &mut NoStats);
            assert!(
                common::same_closest(reference[i].0, want, &brute, r),
                "{}: STACK on ray {i}",
                path.display()
            );
        }
        for &s in StructureKind::all()
            .iter()
            .filter(|s| **s != StructureKind::Brute)
        {
            let got = Built::new(s, TraversalKind::Stack, &bvh, scene.triangles.clone())
                .unwrap()
                .0
                .with(Answers(&rays));
            for (i, r) in rays.iter().enumerate() {
                let (want, want_any) = reference[i];
                assert!(
                    common::same_closest(got[i].0, want, &brute, r),
                    "{} {}: ray {i} {r:?}: closest {:?}, STACK {want:?}",
                    path.display(),
                    s.name(),
                    got[i].0
                );
                assert_eq!(
                    got[i].1.is_some(),
                    want_any.is_some(),
                    "{} {}: any hit on ray {i}",
                    path.display(),
                    s.name()
                );
            }
        }
    }
}
