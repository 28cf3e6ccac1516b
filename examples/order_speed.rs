//! What tracing a large incoherent batch in the coherent order of
//! `structures::order` costs and saves, in one run: the batch traced whole
//! (reordered) against the same rays in batches too small to be reordered
//! (the given order), and the ordering's own steps alone; one and two
//! threads, the fastest of several rounds taken in turn.
//! `cargo run --release --example order_speed -- ../shared/scenes/dragon.obj bvh8`.
//! Rays as `python/bench/bench_raycast.py` makes them: from random points of
//! a sphere of twice the mesh's bounding radius towards random points of
//! its box.
use raytree::prelude::*;
use raytree::rng::Pcg32;
use raytree::structures::order::{coherent_order, places, MIN_RAYS};
use std::time::Instant;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().collect();
    let scene = Scene::from_spec(args.get(1).map_or("chess", |s| s))?;
    let name = args.get(2).map_or("bvh8", |s| s);
    let n: usize = args.get(3).map_or(Ok(1_000_000), |s| s.parse())?;
    let bvh = Bvh::build(&scene.triangles, &BuildOptions::sah());
    let tracer = tracer(name, &bvh, scene.triangles.clone())?;
    let b = scene.mesh.bounds();
    let (c, radius) = (b.center(), b.extent().length() / 2.0);
    let mut rng = Pcg32::new(1, 1);
    let rays: Vec<Ray> = (0..n)
        .map(|_| {
            let mut u = || rng.next_f32();
            let d = loop {
                let v = Vec3::new(u() * 2.0 - 1.0, u() * 2.0 - 1.0, u() * 2.0 - 1.0);
                if v.length_squared() > 1e-4 && v.length_squared() <= 1.0 {
                    break v.normalize();
                }
            };
            let o = c + d * 2.0 * radius;
            let target = b.min + (b.max - b.min) * Vec3::new(u(), u(), u());
            Ray::infinite(o, target - o)
        })
        .collect();
    let mut hits = vec![None; n];
    for threads in [1, 2] {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()?;
        let mut best = [f64::INFINITY; 4];
        for _ in 0..5 {
            let mut time = |k: usize, f: &mut (dyn FnMut() + Send)| {
                let t = Instant::now();
                pool.install(&mut *f);
                best[k] = best[k].min(t.elapsed().as_secs_f64());
            };
            time(0, &mut || tracer.intersect(&rays, &mut hits, None).unwrap());
            time(1, &mut || {
                for (r, h) in rays.chunks(MIN_RAYS - 1).zip(hits.chunks_mut(MIN_RAYS - 1)) {
                    tracer.intersect(r, h, None).unwrap();
                }
            });
            let mut order = None;
            time(2, &mut || {
                order = coherent_order(n, |i| (rays[i].origin(), rays[i].direction()))
            });
            let order = order.expect("an incoherent batch");
            time(3, &mut || {
                std::hint::black_box(places(&order));
            });
        }
        println!(
            "{name}, {n} rays, {threads} thread(s): reordered {:.3} s, given order {:.3} s ({:.2}x); \
             coherent_order {:.3} s, places {:.3} s",
            best[0],
            best[1],
            best[0] / best[1],
            best[2],
            best[3]
        );
    }
    Ok(())
}
