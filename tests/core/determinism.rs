//! Every structure and every traversal renders bit-identical images across
//! runs and thread counts, and equal to the BVH with STACK's: per-pixel
//! random streams, and closest hits that do not depend on visiting order.

use raytree::prelude::*;
use raytree::render::{AoQuery, AoSettings, Image, Integrator, PathSettings, Sampling};
use raytree::stats::Tally;
use raytree::structures::{Built, StructureKind, TraversalKind};

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
            facing: false,
            query: AoQuery::Any,
            sampling: Sampling::Independent,
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
    for (builder, opts) in crate::common::build_variants() {
        let bvh = Bvh::build(&scene.triangles, &opts);
        for integrator in &integrators {
            let mut reference: Option<Image> = None;
            for &(s, t) in &configs {
                let (built, _) = Built::new(s, t, &bvh, scene.triangles.clone()).unwrap();
                let job = || built.render(&scene, integrator, 40, 32, &|_| {}).image;
                let images = [
                    pool(1).install(job),
                    pool(2).install(job),
                    pool(3).install(job),
                ];
                let what = format!("{} / {} / {builder}", s.name(), t.name());
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

/// Every builder's tree is the same on 1, 2 and 3 threads, on a scene large
/// enough for subtrees to be built on other threads (more than 4096
/// triangles below the top levels).
#[test]
fn trees_do_not_depend_on_the_thread_count() {
    let scene = Scene::builtin("hairball:30000").unwrap();
    for (builder, opts) in crate::common::build_variants() {
        let build = || Bvh::build(&scene.triangles, &opts);
        let one = pool(1).install(build);
        one.validate(&scene.triangles)
            .unwrap_or_else(|e| panic!("{builder}: {e}"));
        for threads in [2, 3] {
            let other = pool(threads).install(build);
            assert!(
                one.nodes == other.nodes,
                "{builder}: nodes differ on {threads} threads"
            );
            assert_eq!(
                one.prims, other.prims,
                "{builder}: order differs on {threads} threads"
            );
        }
    }
}

/// Both renders of one structure: counted, then uncounted.
#[test]
fn an_uncounted_render_traces_the_same_rays_and_counts_only_them() {
    let scene = Scene::builtin("chess:3000").unwrap();
    let bvh = Bvh::build(&scene.triangles, &BuildOptions::sah());
    let integrators = [
        Integrator::Ao(AoSettings {
            eye_rays: 1,
            ao_rays: 4,
            radius: 32.0,
            background: 1.0,
            facing: false,
            query: AoQuery::Any,
            sampling: Sampling::Independent,
        }),
        Integrator::Path(PathSettings::default()),
    ];
    for &s in StructureKind::all() {
        let (built, _) =
            Built::new(s, TraversalKind::Stack, &bvh, scene.triangles.clone()).unwrap();
        for integrator in &integrators {
            let counted = built.render(&scene, integrator, 40, 32, &|_| {});
            let uncounted = built.render_uncounted(&scene, integrator, 40, 32, &|_| {});
            let what = format!("{} / {integrator:?}", s.name());
            assert!(counted.image == uncounted.image, "{what}: images differ");
            assert!(counted.counters.rays > 0, "{what}: no rays");
            assert_eq!(counted.counters.rays, uncounted.counters.rays, "{what}");
            // Brute force visits no nodes; every structure tests triangles.
            assert!(counted.counters.triangles > 0, "{what}: nothing counted");
            assert_eq!(
                (
                    uncounted.counters.nodes,
                    uncounted.counters.planes,
                    uncounted.counters.triangles
                ),
                (0, 0, 0),
                "{what}"
            );
            assert!(
                uncounted.work.pixels.iter().all(|t| *t == Tally::default()),
                "{what}"
            );
        }
    }
}
