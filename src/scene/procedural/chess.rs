//! A chess set in its starting position, like the stackless paper's CHESS
//! scene: a board of 64 square tiles and 32 lathe-turned pieces.

use super::shapes::{push_box, push_lathe, resample};
use crate::scene::{Camera, Mesh, Scene};
use glam::Vec3;

/// One tile's width in scene units: the board is 500 units wide, as in the
/// paper's CHESS scene, so that its camera and AO radius (32) carry over.
const SQUARE: f32 = 62.5;
/// Piece profiles are in units of this (the king is about 68 units tall).
const PIECE: f32 = 37.5;

const PAWN: &[(f32, f32)] = &[
    (0.0, 0.0),
    (0.36, 0.0),
    (0.36, 0.08),
    (0.29, 0.12),
    (0.26, 0.18),
    (0.15, 0.26),
    (0.11, 0.5),
    (0.19, 0.55),
    (0.11, 0.6),
    (0.19, 0.68),
    (0.21, 0.78),
    (0.16, 0.88),
    (0.07, 0.93),
    (0.0, 0.94),
];
const ROOK: &[(f32, f32)] = &[
    (0.0, 0.0),
    (0.4, 0.0),
    (0.4, 0.1),
    (0.32, 0.15),
    (0.25, 0.25),
    (0.22, 0.8),
    (0.3, 0.85),
    (0.3, 1.05),
    (0.22, 1.05),
    (0.22, 0.98),
    (0.0, 0.98),
];
const KNIGHT: &[(f32, f32)] = &[
    (0.0, 0.0),
    (0.4, 0.0),
    (0.4, 0.1),
    (0.3, 0.15),
    (0.22, 0.3),
    (0.25, 0.6),
    (0.3, 0.9),
    (0.18, 1.1),
    (0.08, 1.15),
    (0.0, 1.16),
];
const BISHOP: &[(f32, f32)] = &[
    (0.0, 0.0),
    (0.4, 0.0),
    (0.4, 0.1),
    (0.3, 0.15),
    (0.16, 0.3),
    (0.12, 0.85),
    (0.24, 0.9),
    (0.12, 0.95),
    (0.2, 1.1),
    (0.22, 1.2),
    (0.14, 1.35),
    (0.05, 1.42),
    (0.08, 1.46),
    (0.0, 1.5),
];
const QUEEN: &[(f32, f32)] = &[
    (0.0, 0.0),
    (0.42, 0.0),
    (0.42, 0.1),
    (0.32, 0.16),
    (0.18, 0.35),
    (0.13, 1.0),
    (0.27, 1.08),
    (0.16, 1.14),
    (0.22, 1.3),
    (0.3, 1.5),
    (0.2, 1.55),
    (0.1, 1.6),
    (0.12, 1.65),
    (0.0, 1.7),
];
const KING: &[(f32, f32)] = &[
    (0.0, 0.0),
    (0.42, 0.0),
    (0.42, 0.1),
    (0.32, 0.16),
    (0.18, 0.35),
    (0.14, 1.05),
    (0.28, 1.12),
    (0.16, 1.18),
    (0.22, 1.35),
    (0.26, 1.5),
    (0.12, 1.55),
    (0.06, 1.6),
    (0.06, 1.8),
    (0.0, 1.82),
];
const BACK_ROW: [&[(f32, f32)]; 8] = [ROOK, KNIGHT, BISHOP, QUEEN, KING, BISHOP, KNIGHT, ROOK];

/// Board tiles and frame: 65 boxes.
const BOARD_TRIANGLES: usize = 65 * 12;

pub fn scene(target_triangles: usize) -> Scene {
    // Each piece is a lathe of S `segments` around and P `rings` profile
    // points: 2·S·(P-2) triangles (the two pole caps are fans). With
    // P = S/2 + 1 that is S² - 2S.
    let per_piece = target_triangles.saturating_sub(BOARD_TRIANGLES) as f32 / 32.0;
    let segments = ((1.0 + (1.0 + per_piece).sqrt()).round() as usize).max(6);
    let rings = (segments / 2 + 1).max(4);

    let mut mesh = Mesh::default();
    let half = 4.0 * SQUARE;
    push_box(
        &mut mesh,
        Vec3::new(-half - 20.0, -12.0, -half - 20.0),
        Vec3::new(half + 20.0, -4.0, half + 20.0),
    );
    for row in 0..8 {
        for col in 0..8 {
            let lo = Vec3::new(
                -half + col as f32 * SQUARE,
                -4.0,
                -half + row as f32 * SQUARE,
            );
            // Light tiles stand a little higher, so that the board has relief.
            let top = if (row + col) % 2 == 0 { 0.0 } else { -1.5 };
            push_box(&mut mesh, lo, lo + Vec3::new(SQUARE, 4.0 + top, SQUARE));
        }
    }
    let profiles: Vec<_> = [PAWN, ROOK, KNIGHT, BISHOP, QUEEN, KING]
        .iter()
        .map(|p| resample(p, rings))
        .collect();
    let profile_of = |p: &[(f32, f32)]| {
        let i = [PAWN, ROOK, KNIGHT, BISHOP, QUEEN, KING]
            .iter()
            .position(|q| *q == p)
            .unwrap();
        &profiles[i]
    };
    let center = |row: usize, col: usize| {
        Vec3::new(
            -half + (col as f32 + 0.5) * SQUARE,
            0.0,
            -half + (row as f32 + 0.5) * SQUARE,
        )
    };
    for (col, back) in BACK_ROW.into_iter().enumerate() {
        for (row, piece) in [(0, back), (1, PAWN), (6, PAWN), (7, back)] {
            push_lathe(
                &mut mesh,
                profile_of(piece),
                segments,
                center(row, col),
                PIECE,
            );
        }
    }
    // The default view: the paper's eye (300, 100, 300) and target
    // (0, 10, 0), but 50 degrees VERTICAL with square pixels, which at
    // 800×300 is about 102° wide; `render --paper` and `bench stackless
    // --preset paper` use the paper's own camera instead
    // (`Camera::stackless_chess`: 50° horizontal, non-square pixels).
    let camera = Camera::new(
        Vec3::new(300.0, 100.0, 300.0),
        Vec3::new(0.0, 10.0, 0.0),
        Vec3::Y,
        50.0,
    );
    Scene::new("chess", mesh, camera)
}
