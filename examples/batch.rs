//! Loads a mesh, builds the structure named on the command line (`bvh`,
//! `bvh/laine-4`, `dst`, ...) and traces a batch of rays in parallel:
//! `cargo run --release --example batch -- ../shared/scenes/bunny.obj dst`.
use raytree::prelude::*;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().collect();
    let scene = Scene::from_spec(args.get(1).map_or("chess", |s| s))?;
    let name = args.get(2).map_or("bvh", |s| s);
    let bvh = Bvh::build(&scene.triangles, &BuildOptions::sah());
    let tracer = tracer(name, &bvh, scene.triangles.clone())?;
    let cam = &scene.camera;
    let ray = |i: usize| cam.ray((i % 100) as f32 / 99.0, (i / 100) as f32 / 99.0, 1.0);
    let rays: Vec<Ray> = (0..10_000).map(ray).collect();
    let mut hits = vec![None; rays.len()];
    tracer.intersect(&rays, &mut hits, None)?; // closest hits; `occluded` for any hit
    let n = hits.iter().flatten().count();
    println!("{name}: {n} of {} rays hit", rays.len());
    Ok(())
}
