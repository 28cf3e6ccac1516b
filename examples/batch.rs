//! Loads a mesh, builds the structure named on the command line (`bvh`,
//! `bvh/laine-4`, `dst`, ...) and traces a batch of rays in parallel:
//! `cargo run --release --example batch -- ../shared/scenes/bunny.obj dst`.
use raytree::prelude::*;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let scene = Scene::from_spec(args.first().map_or("chess", |s| s))?;
    let bvh = Bvh::build(&scene.triangles, &BuildOptions::sah());
    let structure = args.get(1).map_or("bvh", |s| s);
    let tracer = raytree::structures::tracer(structure, &bvh, scene.triangles.clone())?;
    let pixel = |i: usize| {
        scene
            .camera
            .ray((i % 100) as f32 / 100.0, (i / 100) as f32 / 100.0, 1.0)
    };
    let rays: Vec<Ray> = (0..10_000).map(pixel).collect();
    let mut hits = vec![None; rays.len()];
    tracer.intersect(&rays, &mut hits, None)?;
    println!(
        "{structure}: {} of {} rays hit",
        hits.iter().flatten().count(),
        rays.len()
    );
    Ok(())
}
