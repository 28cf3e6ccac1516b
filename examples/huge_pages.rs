//! What 2 MiB pages under a structure's arrays pay ([`raytree::pages`]): builds
//! each structure twice over the same BVH, once on small pages and once
//! advised onto huge pages, times both conversions, then times closest hits
//! of eye rays, any hits of AO rays and closest hits of AO rays over both,
//! alternating, the least of `rounds` counting. One thread.
//!
//! `cargo run --release --example huge_pages -- [scene] [structures] [rounds]`
//! (defaults: `../shared/scenes/dragon.obj`, `bvh,bvh8,cwbvh,sparse`, 5).

use raytree::prelude::*;
use raytree::render::rayset;
use raytree::structures::{Built, StructureKind, TraversalKind, WithAccel};
use std::sync::Arc;
use std::time::Instant;

struct Time<'a>(&'a [Ray], bool);
impl WithAccel for Time<'_> {
    type Output = f64;
    fn run<A: Accel>(self, a: &A) -> f64 {
        let t = Instant::now();
        let mut n = 0usize;
        for r in self.0 {
            let h = if self.1 {
                a.any_hit(r, &mut NoStats)
            } else {
                a.closest_hit(r, &mut NoStats)
            };
            n += h.is_some() as usize;
        }
        std::hint::black_box(n);
        t.elapsed().as_secs_f64()
    }
}

fn main() {
    let mut args = std::env::args().skip(1);
    let spec = args.next().unwrap_or("../shared/scenes/dragon.obj".into());
    let names = args.next().unwrap_or("bvh,bvh8,cwbvh,sparse".into());
    let rounds: usize = args.next().map_or(5, |r| r.parse().expect("rounds"));
    raytree::pages::set_enabled(false);
    let scene = if std::path::Path::new(&spec).exists() {
        Scene::load(&spec)
    } else {
        Scene::builtin(&spec)
    }
    .expect("scene");
    let bvh = Bvh::build(&scene.triangles, &BuildOptions::sah());
    // Two copies of the triangles: one left on small pages, one advised.
    let small: Arc<[Triangle]> = scene.triangles.to_vec().into();
    let huge: Arc<[Triangle]> = scene.triangles.to_vec().into();
    raytree::pages::set_enabled(true);
    raytree::pages::advise(&huge);
    let probe = Built::new(
        StructureKind::Bvh,
        TraversalKind::Stack,
        &bvh,
        small.clone(),
    )
    .unwrap()
    .0;
    let eye = rayset::eye_rays(&scene, 512, 512, 1);
    let radius = 0.045 * scene.mesh.bounds().extent().length();
    let ao = probe.with(AoRays(&scene, &eye, radius));
    println!(
        "# {spec}: {} triangles, {} eye and {} AO rays, one thread, least of {rounds} rounds",
        scene.triangles.len(),
        eye.len(),
        ao.len()
    );
    println!("| structure | conversion small / huge ms | eye closest | AO any | AO closest |");
    println!("|---|---|---:|---:|---:|");
    for name in names.split(',') {
        let (s, t) = match name {
            "sparse" => (StructureKind::Bvh, TraversalKind::Sparse),
            other => (other.parse().expect("structure"), TraversalKind::Stack),
        };
        let build = |on: bool, tris: &Arc<[Triangle]>| {
            raytree::pages::set_enabled(on);
            let start = Instant::now();
            let b = Built::new(s, t, &bvh, tris.clone()).unwrap().0;
            (b, start.elapsed().as_secs_f64() * 1e3)
        };
        let (off, ms_off) = build(false, &small);
        let (on, ms_on) = build(true, &huge);
        let mut best = [[f64::INFINITY; 3]; 2];
        for _ in 0..rounds {
            for (k, b) in [&off, &on].into_iter().enumerate() {
                for (j, (rays, any)) in [(&eye, false), (&ao, true), (&ao, false)]
                    .into_iter()
                    .enumerate()
                {
                    best[k][j] = best[k][j].min(b.with(Time(rays, any)));
                }
            }
        }
        let cell = |j: usize| {
            format!(
                "{:.1} / {:.1} Mrays/s ({:.2}×)",
                eye_or_ao(j, &eye, &ao) / best[0][j] / 1e6,
                eye_or_ao(j, &eye, &ao) / best[1][j] / 1e6,
                best[0][j] / best[1][j]
            )
        };
        println!(
            "| {name} | {ms_off:.0} / {ms_on:.0} | {} | {} | {} |",
            cell(0),
            cell(1),
            cell(2)
        );
    }
}

fn eye_or_ao(j: usize, eye: &[Ray], ao: &[Ray]) -> f64 {
    if j == 0 {
        eye.len() as f64
    } else {
        ao.len() as f64
    }
}

/// Four AO rays from each eye ray's closest hit.
struct AoRays<'a>(&'a Scene, &'a [Ray], f32);
impl WithAccel for AoRays<'_> {
    type Output = Vec<Ray>;
    fn run<A: Accel>(self, a: &A) -> Vec<Ray> {
        rayset::ao_rays(self.0, a, self.1, 4, self.2)
    }
}
