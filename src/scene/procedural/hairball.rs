//! A hairball: many thin curved tubes tangled inside a sphere, like the
//! HAIRBALL scene: irregular, deep, full of overlapping boxes.

use super::shapes::{push_tube, random_in_ball};
use crate::rng::Pcg32;
use crate::scene::{Camera, Mesh, Scene};
use glam::Vec3;

const SIDES: usize = 6;
const POINTS: usize = 60;
const TRIANGLES_PER_TUBE: usize = (POINTS - 1) * SIDES * 2;
const SEED: u64 = 0x4841_4952;

pub fn scene(target_triangles: usize) -> Scene {
    let tubes = (target_triangles as f32 / TRIANGLES_PER_TUBE as f32)
        .round()
        .max(1.0) as usize;
    // Thinner tubes as there are more of them, so that the ball is about as
    // opaque at every size.
    let radius = 0.012 * (100_000.0 / target_triangles as f32).sqrt();
    let mut rng = Pcg32::new(SEED, 7);
    let mut mesh = Mesh::default();
    let mut path = Vec::with_capacity(POINTS);
    for _ in 0..tubes {
        path.clear();
        let mut p = random_in_ball(&mut rng) * 0.85;
        let mut dir = random_in_ball(&mut rng).normalize();
        let step = 0.035;
        for _ in 0..POINTS {
            path.push(p);
            // A wandering direction, steered back when it nears the shell.
            dir = (dir + random_in_ball(&mut rng) * 0.35).normalize();
            if p.length() > 0.9 {
                dir = (dir - p.normalize() * 0.6).normalize();
            }
            p += dir * step;
        }
        push_tube(&mut mesh, &path, radius, SIDES);
    }
    let camera = Camera::new(Vec3::new(0.4, 0.3, 3.1), Vec3::ZERO, Vec3::Y, 40.0);
    Scene::new("hairball", mesh, camera)
}
