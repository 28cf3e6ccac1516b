//! Vegetation: a meadow of grass blades on rolling ground with branching
//! trees in leaf, like the dual-split paper's vegetation scenes. Irregular:
//! millions of small, thin, randomly oriented triangles, overlapping boxes
//! everywhere, and deep foliage that rays cross many times.
//!
//! The size sets the number of trees (one per 50k triangles), the leaves on
//! them (45% of the triangles with the branches) and the grass blades (the
//! rest after 2% of ground).

use super::shapes::{push_grid, push_tube, random_in_ball, tube_triangles};
use crate::rng::Pcg32;
use crate::scene::{Camera, Mesh, Scene};
use glam::Vec3;

const SEED: u64 = 0x464f_5245;
/// The meadow spans [-HALF, HALF]² metres.
const HALF: f32 = 30.0;
const TRIANGLES_PER_TREE: usize = 50_000;
/// Branching: each branch carries this many children, to this depth below
/// the trunk.
const CHILDREN: usize = 3;
const DEPTH: u32 = 3;
const BRANCH_POINTS: usize = 6;
const BRANCH_SIDES: usize = 6;
/// A blade is 3 segments: two quads and a tip triangle.
const BLADE_TRIANGLES: usize = 5;

fn branches_per_tree() -> usize {
    (0..=DEPTH).map(|d| CHILDREN.pow(d)).sum()
}

/// Ground height at (x, z): gentle swells.
fn ground(x: f32, z: f32) -> f32 {
    0.6 * (0.13 * x).sin() * (0.11 * z).cos() + 0.25 * (0.31 * x + 0.2 * z).sin()
}

pub fn scene(target_triangles: usize) -> Scene {
    let target = target_triangles;
    let cells = (((0.02 * target as f64) / 2.0).sqrt().round() as usize).max(2);
    let trees = (target as f64 / TRIANGLES_PER_TREE as f64).round().max(1.0) as usize;
    let branch_triangles = branches_per_tree() * tube_triangles(BRANCH_POINTS, BRANCH_SIDES);
    let tree_share = (0.45 * target as f64) as usize;
    let leaves = tree_share.saturating_sub(trees * branch_triangles) / 2;
    let fixed = 2 * cells * cells + trees * branch_triangles + 2 * leaves;
    let blades = target.saturating_sub(fixed) / BLADE_TRIANGLES;

    let mut rng = Pcg32::new(SEED, 11);
    let mut mesh = Mesh::default();
    push_grid(&mut mesh, cells, cells, |i, j| {
        let x = -HALF + 2.0 * HALF * j as f32 / cells as f32;
        let z = -HALF + 2.0 * HALF * i as f32 / cells as f32;
        Vec3::new(x, ground(x, z), z)
    });
    // Trees stand away from the camera's foreground (z > 15).
    let mut tips = Vec::new();
    for t in 0..trees {
        let x = rng.range(-HALF + 2.0, HALF - 2.0);
        let z = rng.range(-HALF + 2.0, 12.0);
        let base = Vec3::new(x, ground(x, z) - 0.2, z);
        let height = rng.range(6.0, 10.0);
        tips.clear();
        grow(
            &mut mesh,
            &mut rng,
            base,
            Vec3::Y,
            height,
            0.25 + 0.02 * height,
            0,
            &mut tips,
        );
        // Leaves: quads around the outermost branches' tips.
        let share = leaves / trees + usize::from(t < leaves % trees);
        for _ in 0..share {
            let tip = tips[rng.below(tips.len() as u32) as usize];
            let at = tip + random_unit(&mut rng) * rng.range(0.1, 1.4);
            push_leaf(&mut mesh, &mut rng, at);
        }
    }
    for _ in 0..blades {
        let x = rng.range(-HALF, HALF);
        let z = rng.range(-HALF, HALF);
        push_blade(&mut mesh, &mut rng, Vec3::new(x, ground(x, z) - 0.02, z));
    }
    // Eye height over the meadow's edge, looking into the trees.
    let eye = Vec3::new(2.0, ground(2.0, 27.0) + 1.6, 27.0);
    let camera = Camera::new(eye, Vec3::new(0.0, 3.0, 0.0), Vec3::Y, 55.0);
    Scene::new("forest", mesh, camera)
}

/// A branch from `from` along `dir`, bending a little, with its children
/// (recursively); outermost tips are collected for leaves.
#[allow(clippy::too_many_arguments)]
fn grow(
    mesh: &mut Mesh,
    rng: &mut Pcg32,
    from: Vec3,
    dir: Vec3,
    length: f32,
    radius: f32,
    depth: u32,
    tips: &mut Vec<Vec3>,
) {
    let bend = random_unit(rng) * 0.15;
    let mut path = Vec::with_capacity(BRANCH_POINTS);
    let mut p = from;
    let mut d = dir;
    for _ in 0..BRANCH_POINTS {
        path.push(p);
        d = (d + bend).normalize();
        p += d * (length / (BRANCH_POINTS - 1) as f32);
    }
    push_tube(mesh, &path, radius, BRANCH_SIDES);
    if depth == DEPTH {
        tips.push(path[BRANCH_POINTS - 1]);
        return;
    }
    for c in 0..CHILDREN {
        // Children leave from the upper part of the branch, spread around it
        // and tilted up.
        let along = path[2 + c % (BRANCH_POINTS - 2)];
        let around = std::f32::consts::TAU * (c as f32 + rng.range(0.0, 0.6)) / CHILDREN as f32;
        let side = d.any_orthonormal_pair();
        let out = side.0 * around.cos() + side.1 * around.sin();
        let child = (d * 0.7 + out + Vec3::Y * 0.3).normalize();
        grow(
            mesh,
            rng,
            along,
            child,
            length * 0.55,
            radius * 0.55,
            depth + 1,
            tips,
        );
    }
}

fn push_leaf(mesh: &mut Mesh, rng: &mut Pcg32, at: Vec3) {
    let u = random_unit(rng) * 0.12;
    let v = random_unit(rng).cross(u).normalize_or(Vec3::X) * 0.07;
    let base = mesh.positions.len() as u32;
    mesh.positions
        .extend([at - u - v, at + u - v, at + u + v, at - u + v]);
    mesh.indices.push([base, base + 1, base + 2]);
    mesh.indices.push([base, base + 2, base + 3]);
}

/// A curved, tapering blade: 7 vertices, 5 triangles.
fn push_blade(mesh: &mut Mesh, rng: &mut Pcg32, root: Vec3) {
    let height = rng.range(0.25, 0.7);
    let a = rng.range(0.0, std::f32::consts::TAU);
    let facing = Vec3::new(a.cos(), 0.0, a.sin());
    let across = Vec3::new(-facing.z, 0.0, facing.x) * 0.02;
    let lean = rng.range(0.05, 0.35);
    let base = mesh.positions.len() as u32;
    for k in 0..3 {
        let f = k as f32 / 3.0;
        let p = root + Vec3::Y * (height * f) + facing * (lean * height * f * f);
        let w = 1.0 - 0.8 * f;
        mesh.positions.extend([p - across * w, p + across * w]);
    }
    mesh.positions
        .push(root + Vec3::Y * height + facing * (lean * height));
    for k in 0..2 {
        let (a, b) = (base + 2 * k, base + 2 * k + 1);
        mesh.indices.push([a, b, b + 2]);
        mesh.indices.push([a, b + 2, a + 2]);
    }
    mesh.indices.push([base + 4, base + 5, base + 6]);
}

/// A uniformly random unit vector.
fn random_unit(rng: &mut Pcg32) -> Vec3 {
    let v = random_in_ball(rng);
    v / v.length_squared().sqrt()
}
