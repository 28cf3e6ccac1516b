//! Rays that cross a closed surface through a shared edge or vertex never
//! slip through.

use crate::common;

use raytree::prelude::*;
use raytree::rng::Pcg32;
use raytree::scene::procedural::shapes::{push_lathe, resample};

/// A closed sphere-like lathe of radius 1 about the origin.
fn sphere(segments: usize, rings: usize) -> Mesh {
    let profile: Vec<(f32, f32)> = (0..=16)
        .map(|i| {
            let a = std::f32::consts::PI * i as f32 / 16.0;
            if i == 0 || i == 16 {
                (0.0, -a.cos())
            } else {
                (a.sin(), -a.cos())
            }
        })
        .collect();
    let mut m = Mesh::default();
    push_lathe(
        &mut m,
        &resample(&profile, rings),
        segments,
        Vec3::ZERO,
        1.0,
    );
    m
}

#[test]
fn rays_through_shared_edges_and_vertices_never_miss() {
    let mesh = sphere(37, 23);
    let tris: std::sync::Arc<[Triangle]> = mesh.triangles().into();
    let oracle = BruteForce::new(tris.clone());
    let bvh = BinaryBvh::from_bvh(
        &Bvh::build(&tris, &BuildOptions::sah().with_max_leaf_size(2)),
        tris.clone(),
    )
    .unwrap();
    let mut rng = Pcg32::new(5, 5);
    let mut tested = 0;
    while tested < 100_000 {
        let t = &tris[rng.below(tris.len() as u32) as usize];
        // Exactly a vertex, or a point on an edge (as close as f32 allows).
        let target = match rng.below(3) {
            0 => t.a,
            1 => t.b,
            _ => t.a + (t.c - t.a) * rng.next_f32(),
        };
        let origin = common::unit(&mut rng) * rng.range(1.5, 30.0);
        let d = target - origin;
        // Only rays that cross the surface there, not graze it.
        if target.normalize().dot(d.normalize()) > -0.2 {
            continue;
        }
        let scale = 10f32.powf(rng.range(-2.0, 2.0));
        let ray = Ray::infinite(origin, d * scale);
        for (name, hit) in [
            ("oracle", oracle.closest_hit(&ray, &mut NoStats)),
            ("bvh", bvh.closest_hit(&ray, &mut NoStats)),
            ("bvh any", bvh.any_hit(&ray, &mut NoStats)),
        ] {
            assert!(
                hit.is_some(),
                "{name}: {ray:?} slipped through at {target:?}"
            );
        }
        tested += 1;
    }
}

#[test]
fn closed_box_edges_never_slip() {
    // Axis-aligned rays exactly along the planes of shared edges of a cube.
    let mut m = Mesh::default();
    raytree::scene::procedural::shapes::push_box(&mut m, Vec3::splat(-1.0), Vec3::splat(1.0));
    let tris: std::sync::Arc<[Triangle]> = m.triangles().into();
    let oracle = BruteForce::new(tris);
    let mut rng = Pcg32::new(9, 1);
    for _ in 0..20_000 {
        // Through the diagonal edge of the z = +1 face (x = y), from above.
        let s = rng.range(-1.0, 1.0);
        let d = Vec3::new(rng.range(-0.5, 0.5), rng.range(-0.5, 0.5), -1.0);
        let target = Vec3::new(s, s, 1.0);
        let ray = Ray::infinite(target - d * 3.0, d);
        assert!(oracle.closest_hit(&ray, &mut NoStats).is_some(), "{ray:?}");
    }
}
