//! Every structure and every traversal renders bit-identical images across
//! runs and thread counts, and equal to the BVH with STACK's: per-pixel
//! random streams, and closest hits that do not depend on visiting order.

use raytree::accel::{Built, StructureKind, TraversalKind, WithAccel};
use raytree::prelude::*;
use raytree::render::{render, AoSettings, Image, Integrator, PathSettings};

struct Render<'a> {
    scene: &'a Scene,
    integrator: &'a Integrator,
}

impl WithAccel for Render<'_> {
    type Output = Image;
    fn run<A: Accel>(self, a: &A) -> Image {
        render(a, self.scene, self.integrator, 40, 32, &|_| {}).image
    }
}

fn pool(threads: usize) -> rayon::ThreadPool {
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .unwrap()
}

#[test]
fn images_are_identical_for_every_structure_traversal_and_thread_count() {
    let scene = Scene::builtin("chess:3000").unwrap();
    let integrators = [
        Integrator::Ao(AoSettings {
            eye_rays: 2,
            ao_rays: 4,
            radius: 32.0,
            background: 1.0,
        }),
        Integrator::Path(PathSettings::default()),
    ];
    let mut configs: Vec<_> = TraversalKind::all()
        .iter()
        .map(|&t| (StructureKind::Bvh, t))
        .collect();
    configs.extend(
        StructureKind::all()
            .iter()
            .filter(|&&s| s != StructureKind::Bvh)
            .map(|&s| (s, TraversalKind::Stack)),
    );
    for builder in Builder::ALL {
        let bvh = Bvh::build(&scene.triangles, &BuildOptions::new(builder));
        for integrator in &integrators {
            let mut reference: Option<Image> = None;
            for &(s, t) in &configs {
                let (built, _) = Built::new(s, t, &bvh, scene.triangles.clone()).unwrap();
                let job = || {
                    built.with(Render {
                        scene: &scene,
                        integrator,
                    })
                };
                let images = [
                    pool(1).install(job),
                    pool(2).install(job),
                    pool(3).install(job),
                ];
                let what = format!("{} / {} / {}", s.name(), t.name(), builder.name());
                assert!(images[0] == images[1], "{what}: 1 and 2 threads differ");
                assert!(images[0] == images[2], "{what}: 1 and 3 threads differ");
                assert!(images[0] == job(), "{what}: two runs differ");
                match &reference {
                    None => reference = Some(images[0].clone()),
                    Some(r) => assert!(*r == images[0], "{what}: differs from bvh/stack"),
                }
            }
        }
    }
}
