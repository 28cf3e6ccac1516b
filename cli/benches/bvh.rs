//! BVH build time on a 1M-triangle scene, and single-thread STACK throughput
//! on eye (coherent) and AO (incoherent) rays, beside the `obvhs` crate's
//! binary BVH traversal on the same rays: once over raytree's own tree
//! (the same nodes: a traversal-against-traversal comparison) and once over
//! obvhs's own PLOC build. Every contender uses raytree's watertight
//! triangle test, so only the trees and traversals differ.
//!
//! Run: `cargo bench --bench bvh` (add `RUSTFLAGS="-C target-cpu=native"`
//! to let both use the host's vector units).

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};
use raytree::prelude::*;
use raytree::render::rayset;
use raytree_cli::bench::peers;
use std::hint::black_box;
use std::time::Duration;

fn bench_build(c: &mut Criterion) {
    let scene = Scene::builtin("hairball:1M").unwrap();
    let mut g = c.benchmark_group("build hairball:1M");
    g.sample_size(10).measurement_time(Duration::from_secs(20));
    g.throughput(Throughput::Elements(scene.triangles.len() as u64));
    for builder in Builder::ALL {
        g.bench_function(builder.name(), |b| {
            b.iter(|| Bvh::build(black_box(&scene.triangles), &BuildOptions::new(builder)))
        });
    }
    g.bench_function("obvhs ploc medium", |b| {
        let tris = peers::obvhs::triangles(&scene);
        b.iter(|| {
            obvhs::bvh2::builder::build_bvh2_from_tris(
                black_box(&tris),
                obvhs::BvhBuildParams::medium_build(),
                &mut Duration::default(),
            )
        })
    });
    g.finish();
}

fn bench_trace(c: &mut Criterion) {
    for spec in ["chess", "hairball:1M"] {
        let scene = Scene::builtin(spec).unwrap();
        let bvh = Bvh::build(&scene.triangles, &BuildOptions::sah());
        let layout = BinaryBvh::from_bvh(&bvh, scene.triangles.clone()).unwrap();
        let eye = rayset::eye_rays(&scene, 256, 256, 1);
        let radius = 0.045 * scene.mesh.bounds().extent().length();
        let ao = rayset::ao_rays(&scene, &layout, &eye, 4, radius);
        let same_tree = peers::obvhs::bvh2_from(&bvh);
        let own_tree = obvhs::bvh2::builder::build_bvh2_from_tris(
            &peers::obvhs::triangles(&scene),
            obvhs::BvhBuildParams::medium_build(),
            &mut Duration::default(),
        );
        let tris = scene.triangles.clone();

        let mut g = c.benchmark_group(format!("trace {spec} 1 thread"));
        g.sample_size(10).measurement_time(Duration::from_secs(6));
        g.throughput(Throughput::Elements(eye.len() as u64));
        g.bench_with_input(
            BenchmarkId::new("eye closest", "raytree stack"),
            &eye,
            |b, rays| {
                b.iter(|| {
                    rays.iter()
                        .filter(|r| layout.closest_hit(r, &mut NoStats).is_some())
                        .count()
                })
            },
        );
        for (name, t) in [
            ("obvhs same tree", &same_tree),
            ("obvhs own tree", &own_tree),
        ] {
            g.bench_with_input(BenchmarkId::new("eye closest", name), &eye, |b, rays| {
                b.iter(|| {
                    rays.iter()
                        .filter(|r| {
                            let mut hit = obvhs::ray::RayHit::none();
                            t.ray_traverse(peers::obvhs::to_obvhs(r), &mut hit, |ray, i| {
                                let p = t.primitive_indices[i];
                                tris[p as usize]
                                    .intersect(r, r.tmin, ray.tmax)
                                    .map_or(f32::INFINITY, |h| h.0)
                            })
                        })
                        .count()
                })
            });
        }
        g.throughput(Throughput::Elements(ao.len() as u64));
        g.bench_with_input(
            BenchmarkId::new("ao any", "raytree stack"),
            &ao,
            |b, rays| {
                b.iter(|| {
                    rays.iter()
                        .filter(|r| layout.any_hit(r, &mut NoStats).is_some())
                        .count()
                })
            },
        );
        for (name, t) in [
            ("obvhs same tree", &same_tree),
            ("obvhs own tree", &own_tree),
        ] {
            g.bench_with_input(BenchmarkId::new("ao any", name), &ao, |b, rays| {
                b.iter(|| {
                    rays.iter()
                        .filter(|r| {
                            !t.ray_traverse_miss(peers::obvhs::to_obvhs(r), |ray, i| {
                                let p = t.primitive_indices[i];
                                tris[p as usize]
                                    .intersect(r, r.tmin, ray.tmax)
                                    .map_or(f32::INFINITY, |h| h.0)
                            })
                        })
                        .count()
                })
            });
        }
        g.finish();
    }
}

criterion_group!(benches, bench_build, bench_trace);
criterion_main!(benches);
