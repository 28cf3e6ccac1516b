//! An arcaded courtyard like Crytek Sponza: two storeys of columns and round
//! arches around an open court, tiled floors, a balustraded gallery, hanging
//! drapes and vases. Regular and architectural, with large flat walls beside
//! finely curved detail; the camera stands inside, as in Sponza's usual view.
//!
//! The layout is fixed; the size sets the tessellation (segments around each
//! column, points along each arch, the drapes' grid), chosen as the smallest
//! that reaches the requested triangle count.

use super::shapes::tube_triangles;
use super::shapes::{lathe_triangles, push_box, push_grid, push_lathe, push_tube, resample};
use crate::scene::{Camera, Mesh, Scene};
use glam::Vec3;

/// Half the court's length (x) and the colonnades' distance from its axis (z),
/// in metres.
const HALF_LENGTH: f32 = 16.0;
const COLONNADE_Z: f32 = 4.5;
const WALL_Z: f32 = 7.5;
/// Columns per colonnade (per side and storey), 3.5 m apart.
const COLUMNS: usize = 9;
const BAY: f32 = 3.5;
/// (bottom, column height) of the two storeys; the arches spring from the
/// columns' tops with radius BAY / 2.
const STOREYS: [(f32, f32); 2] = [(0.0, 3.2), (5.4, 2.6)];
const BALUSTERS_PER_BAY: usize = 8;
const VASES: usize = 6;

/// Column and baluster profiles, (radius, height) for a height of 1.
const COLUMN: &[(f32, f32)] = &[
    (0.0, 0.0),
    (0.1, 0.0),
    (0.1, 0.05),
    (0.08, 0.08),
    (0.065, 0.1),
    (0.055, 0.85),
    (0.07, 0.9),
    (0.1, 0.95),
    (0.1, 1.0),
    (0.0, 1.0),
];
const BALUSTER: &[(f32, f32)] = &[
    (0.0, 0.0),
    (0.06, 0.0),
    (0.06, 0.1),
    (0.04, 0.2),
    (0.08, 0.45),
    (0.03, 0.75),
    (0.05, 0.9),
    (0.05, 1.0),
    (0.0, 1.0),
];
const VASE: &[(f32, f32)] = &[
    (0.0, 0.0),
    (0.25, 0.0),
    (0.3, 0.1),
    (0.45, 0.45),
    (0.4, 0.75),
    (0.25, 0.9),
    (0.3, 1.0),
    (0.27, 1.0),
    (0.2, 0.9),
    (0.0, 0.85),
];

/// The tessellation at detail `s`: profile rings and segments of columns,
/// balusters and vases, points along an arch, quads across a drape.
struct Detail {
    column: Vec<(f32, f32)>,
    baluster: Vec<(f32, f32)>,
    vase: Vec<(f32, f32)>,
    segments: usize,
    small_segments: usize,
    arch_points: usize,
    drape_quads: usize,
}

impl Detail {
    fn new(s: usize) -> Self {
        Detail {
            column: resample(COLUMN, s / 2 + 2),
            baluster: resample(BALUSTER, s / 3 + 3),
            vase: resample(VASE, s / 2 + 2),
            segments: s,
            small_segments: (s / 2).max(4),
            arch_points: s / 2 + 2,
            drape_quads: s / 2 + 1,
        }
    }

    /// Triangles of the whole scene at this detail: must match [`scene`].
    fn triangles(&self) -> usize {
        let sides = 2 * STOREYS.len();
        let columns = sides * COLUMNS * lathe_triangles(&self.column, self.segments);
        let arches = sides * (COLUMNS - 1) * tube_triangles(self.arch_points, 4);
        let balusters = 2
            * (COLUMNS - 1)
            * BALUSTERS_PER_BAY
            * lathe_triangles(&self.baluster, self.small_segments);
        let drapes = 2 * (COLUMNS - 1) * 2 * self.drape_quads * self.drape_quads;
        let vases = VASES * lathe_triangles(&self.vase, self.segments);
        columns + arches + balusters + drapes + vases + 12 * BOXES
    }
}

/// Boxes of floors, walls, slabs, beams, rails and pilasters.
const FLOOR_TILES: (usize, usize) = (16, 6);
const BOXES: usize = FLOOR_TILES.0 * FLOOR_TILES.1 // court tiles
    + 2 * 2 // gallery floors, ground and upper
    + 2 + 2 // long and end walls
    + 2 * 2 // beams over both storeys' arches
    + 2 // roofs over the galleries
    + 2 // balustrade rails
    + 2 * COLUMNS; // pilasters on the long walls

pub fn scene(target_triangles: usize) -> Scene {
    let s = (4..4096)
        .find(|&s| Detail::new(s).triangles() >= target_triangles)
        .unwrap_or(4096);
    // The nearer of s and s - 1 to the target.
    let s = if s > 4
        && target_triangles.abs_diff(Detail::new(s - 1).triangles())
            < target_triangles.abs_diff(Detail::new(s).triangles())
    {
        s - 1
    } else {
        s
    };
    let d = Detail::new(s);
    let mut mesh = Mesh::default();
    build(&mut mesh, &d);
    debug_assert_eq!(mesh.indices.len(), d.triangles());
    // Sponza's usual view: from one end of the court along its length.
    let camera = Camera::new(
        Vec3::new(13.5, 1.8, 0.8),
        Vec3::new(-10.0, 3.6, -0.4),
        Vec3::Y,
        62.0,
    );
    Scene::new("atrium", mesh, camera)
}

fn build(mesh: &mut Mesh, d: &Detail) {
    let (tx, tz) = FLOOR_TILES;
    let tile = Vec3::new(
        2.0 * HALF_LENGTH / tx as f32,
        0.0,
        2.0 * COLONNADE_Z / tz as f32,
    );
    for i in 0..tx {
        for j in 0..tz {
            let lo = Vec3::new(
                -HALF_LENGTH + i as f32 * tile.x,
                -0.1,
                -COLONNADE_Z + j as f32 * tile.z,
            );
            // Alternate tiles sit 1 cm lower: a chequered relief.
            let top = if (i + j) % 2 == 0 { 0.0 } else { -0.01 };
            push_box(mesh, lo, Vec3::new(lo.x + tile.x, top, lo.z + tile.z));
        }
    }
    let upper_floor = STOREYS[1].0;
    for side in [-1.0f32, 1.0] {
        let (z0, z1) = order(side * COLONNADE_Z, side * WALL_Z);
        let (l, h) = (-HALF_LENGTH, HALF_LENGTH);
        // Gallery floors, ground and upper.
        push_box(mesh, Vec3::new(l, -0.1, z0), Vec3::new(h, 0.0, z1));
        push_box(
            mesh,
            Vec3::new(l, upper_floor - 0.3, z0),
            Vec3::new(h, upper_floor, z1),
        );
        // Long wall.
        let (w0, w1) = order(side * WALL_Z, side * (WALL_Z + 0.4));
        push_box(
            mesh,
            Vec3::new(l - 0.4, -0.1, w0),
            Vec3::new(h + 0.4, 11.0, w1),
        );
        // End wall.
        let (e0, e1) = order(side * HALF_LENGTH, side * (HALF_LENGTH + 0.4));
        push_box(
            mesh,
            Vec3::new(e0, -0.1, -WALL_Z),
            Vec3::new(e1, 11.0, WALL_Z),
        );
        // Beams over the arches of both storeys, and the gallery roof.
        let (b0, b1) = order(side * (COLONNADE_Z - 0.25), side * (COLONNADE_Z + 0.25));
        for (bottom, height) in STOREYS {
            let top = bottom + height + BAY / 2.0;
            push_box(
                mesh,
                Vec3::new(l, top - 0.05, b0),
                Vec3::new(h, top + 0.35, b1),
            );
        }
        let roof = STOREYS[1].0 + STOREYS[1].1 + BAY / 2.0 + 0.3;
        push_box(mesh, Vec3::new(l, roof, z0), Vec3::new(h, roof + 0.3, z1));
        // Balustrade rail on the upper gallery's edge.
        let (r0, r1) = order(side * (COLONNADE_Z - 0.08), side * (COLONNADE_Z + 0.08));
        push_box(
            mesh,
            Vec3::new(l, upper_floor + 0.9, r0),
            Vec3::new(h, upper_floor + 1.0, r1),
        );
        for c in 0..COLUMNS {
            let x = column_x(c);
            let (p0, p1) = order(side * (WALL_Z - 0.2), side * WALL_Z);
            push_box(
                mesh,
                Vec3::new(x - 0.3, 0.0, p0),
                Vec3::new(x + 0.3, 10.0, p1),
            );
        }
        for (bottom, height) in STOREYS {
            for c in 0..COLUMNS {
                let at = Vec3::new(column_x(c), bottom, side * COLONNADE_Z);
                push_lathe(mesh, &d.column, d.segments, at, height);
            }
            for c in 0..COLUMNS - 1 {
                // A semicircular arch from one column top to the next,
                // a square section 0.3 m wide (a 4-sided tube).
                let center =
                    Vec3::new(column_x(c) + BAY / 2.0, bottom + height, side * COLONNADE_Z);
                let n = d.arch_points;
                let path: Vec<Vec3> = (0..n)
                    .map(|k| {
                        let a = std::f32::consts::PI * k as f32 / (n - 1) as f32;
                        center + Vec3::new(-a.cos(), a.sin(), 0.0) * (BAY / 2.0 - 0.15)
                    })
                    .collect();
                push_tube(mesh, &path, 0.2, 4);
            }
        }
        for c in 0..COLUMNS - 1 {
            for b in 0..BALUSTERS_PER_BAY {
                let x = column_x(c) + BAY * (b as f32 + 0.5) / BALUSTERS_PER_BAY as f32;
                let at = Vec3::new(x, upper_floor, side * COLONNADE_Z);
                push_lathe(mesh, &d.baluster, d.small_segments, at, 0.9);
            }
            // A drape hung inside the upper gallery behind each bay, in
            // folds that deepen towards its hem.
            let q = d.drape_quads;
            let x0 = column_x(c) + 0.35;
            let width = BAY - 0.7;
            let top = STOREYS[1].0 + STOREYS[1].1 + 0.8;
            let z = side * (COLONNADE_Z + 1.2);
            push_grid(mesh, q, q, |i, j| {
                let v = i as f32 / q as f32;
                let u = j as f32 / q as f32;
                let fold = (u * std::f32::consts::TAU * 4.0).sin() * (0.05 + 0.12 * v);
                Vec3::new(x0 + u * width, top - v * 3.6, z + fold)
            });
        }
    }
    for v in 0..VASES {
        let x = -HALF_LENGTH + 4.0 + v as f32 * (2.0 * HALF_LENGTH - 8.0) / (VASES - 1) as f32;
        let z = if v % 2 == 0 { -2.8 } else { 2.8 };
        push_lathe(mesh, &d.vase, d.segments, Vec3::new(x, 0.0, z), 1.1);
    }
}

fn column_x(c: usize) -> f32 {
    -BAY * (COLUMNS - 1) as f32 / 2.0 + c as f32 * BAY
}

fn order(a: f32, b: f32) -> (f32, f32) {
    (a.min(b), a.max(b))
}
