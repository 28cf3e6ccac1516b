//! Every traversal kernel on fixed ray sets, one thread: STACK and the
//! stackless algorithms over one hybrid BVH (the stackless paper's build),
//! and every structure converted from one SAH BVH (the dual-split paper's),
//! each on the same eye rays (coherent) and AO rays (incoherent), closest
//! hit and any hit. Throughput is in rays.
//!
//! Run: `cargo bench --bench traversals` (one group per ray set; criterion
//! prints each kernel's time and rays/s, so ratios are taken in one run).

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};
use raytree::prelude::*;
use raytree::render::rayset;
use raytree::structures::{Built, StructureKind, TraversalKind, WithAccel};
use std::hint::black_box;
use std::time::Duration;

/// Traces every ray of a set, closest or any hit; returns the hits found.
struct Trace<'a> {
    rays: &'a [Ray],
    any: bool,
}

impl WithAccel for Trace<'_> {
    type Output = usize;
    fn run<A: Accel>(self, a: &A) -> usize {
        self.rays
            .iter()
            .filter(|r| {
                if self.any {
                    a.any_hit(black_box(r), &mut NoStats).is_some()
                } else {
                    a.closest_hit(black_box(r), &mut NoStats).is_some()
                }
            })
            .count()
    }
}

/// The fixed ray sets of a scene: eye rays, and AO rays from their hits.
fn ray_sets(scene: &Scene) -> [(&'static str, Vec<Ray>); 2] {
    let bvh = Bvh::build(&scene.triangles, &BuildOptions::sah());
    let layout = BinaryBvh::from_bvh(&bvh, scene.triangles.clone()).unwrap();
    let eye = rayset::eye_rays(scene, 200, 150, 1);
    let radius = 0.045 * scene.mesh.bounds().extent().length();
    let ao = rayset::ao_rays(scene, &layout, &eye, 4, radius);
    [("eye", eye), ("ao", ao)]
}

fn bench_kernels(c: &mut Criterion) {
    let scene = Scene::builtin("chess").unwrap();
    let hybrid = Bvh::build(&scene.triangles, &BuildOptions::hybrid());
    let sah = Bvh::build(&scene.triangles, &BuildOptions::sah());
    let mut kernels: Vec<(String, Built)> = Vec::new();
    for &t in TraversalKind::all() {
        let (b, _) = Built::new(StructureKind::Bvh, t, &hybrid, scene.triangles.clone()).unwrap();
        kernels.push((format!("hybrid bvh/{}", t.name()), b));
    }
    for &s in StructureKind::all() {
        if s == StructureKind::Brute {
            continue;
        }
        let (b, _) = Built::new(s, TraversalKind::Stack, &sah, scene.triangles.clone()).unwrap();
        kernels.push((format!("sah {}", s.name()), b));
    }
    for (set, rays) in ray_sets(&scene) {
        for any in [false, true] {
            let query = if any { "any" } else { "closest" };
            let mut g = c.benchmark_group(format!("chess {set} rays, {query} hit"));
            g.sample_size(10).measurement_time(Duration::from_secs(2));
            g.throughput(Throughput::Elements(rays.len() as u64));
            for (name, built) in &kernels {
                g.bench_with_input(BenchmarkId::from_parameter(name), &rays, |b, rays| {
                    b.iter(|| built.with(Trace { rays, any }))
                });
            }
            g.finish();
        }
    }
}

criterion_group!(benches, bench_kernels);
criterion_main!(benches);
