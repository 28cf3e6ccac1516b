//! Mesh-building pieces shared by the procedural scenes.

use crate::rng::Pcg32;
use crate::scene::Mesh;
use glam::Vec3;

/// A uniformly random point of the unit ball, away from its centre (so it
/// can be normalized).
pub fn random_in_ball(rng: &mut Pcg32) -> Vec3 {
    loop {
        let v = Vec3::new(
            rng.range(-1.0, 1.0),
            rng.range(-1.0, 1.0),
            rng.range(-1.0, 1.0),
        );
        let l = v.length_squared();
        if l > 1e-4 && l <= 1.0 {
            return v;
        }
    }
}

/// Appends an axis-aligned box (12 triangles, outward winding).
pub fn push_box(mesh: &mut Mesh, lo: Vec3, hi: Vec3) {
    let base = mesh.positions.len() as u32;
    for i in 0..8 {
        mesh.positions.push(Vec3::new(
            if i & 1 == 0 { lo.x } else { hi.x },
            if i & 2 == 0 { lo.y } else { hi.y },
            if i & 4 == 0 { lo.z } else { hi.z },
        ));
    }
    const QUADS: [[u32; 4]; 6] = [
        [0, 2, 3, 1],
        [4, 5, 7, 6],
        [0, 1, 5, 4],
        [2, 6, 7, 3],
        [0, 4, 6, 2],
        [1, 3, 7, 5],
    ];
    for q in QUADS {
        mesh.indices.push([base + q[0], base + q[1], base + q[2]]);
        mesh.indices.push([base + q[0], base + q[2], base + q[3]]);
    }
}

/// Resamples a polyline profile of `(radius, height)` points to `n` points
/// evenly spaced along its length.
pub fn resample(profile: &[(f32, f32)], n: usize) -> Vec<(f32, f32)> {
    let seg_len: Vec<f32> = profile
        .windows(2)
        .map(|w| ((w[1].0 - w[0].0).powi(2) + (w[1].1 - w[0].1).powi(2)).sqrt())
        .collect();
    let total: f32 = seg_len.iter().sum();
    let mut out = Vec::with_capacity(n);
    let (mut seg, mut start) = (0, 0.0);
    for i in 0..n {
        let d = total * i as f32 / (n - 1) as f32;
        while seg + 1 < seg_len.len() && start + seg_len[seg] < d {
            start += seg_len[seg];
            seg += 1;
        }
        let f = ((d - start) / seg_len[seg].max(1e-12)).clamp(0.0, 1.0);
        let (a, b) = (profile[seg], profile[seg + 1]);
        out.push((a.0 + (b.0 - a.0) * f, a.1 + (b.1 - a.1) * f));
    }
    // Exact poles, so the caps close.
    out[0] = profile[0];
    out[n - 1] = profile[profile.len() - 1];
    out
}

/// Appends the surface of revolution of `profile` (radius, height) about the
/// vertical axis through `at`, scaled by `scale`, with `segments` around.
/// Points of radius 0 become single pole vertices.
pub fn push_lathe(mesh: &mut Mesh, profile: &[(f32, f32)], segments: usize, at: Vec3, scale: f32) {
    let mut rings: Vec<Vec<u32>> = Vec::with_capacity(profile.len());
    for &(r, y) in profile {
        let first = mesh.positions.len() as u32;
        if r == 0.0 {
            mesh.positions.push(at + Vec3::new(0.0, y * scale, 0.0));
            rings.push(vec![first]);
            continue;
        }
        for j in 0..segments {
            let a = std::f32::consts::TAU * j as f32 / segments as f32;
            mesh.positions
                .push(at + Vec3::new(r * a.cos(), y, r * a.sin()) * scale);
        }
        rings.push((first..first + segments as u32).collect());
    }
    for w in rings.windows(2) {
        let (lo, hi) = (&w[0], &w[1]);
        for j in 0..segments {
            let k = (j + 1) % segments;
            match (lo.len(), hi.len()) {
                (1, 1) => {}
                (1, _) => mesh.indices.push([lo[0], hi[k], hi[j]]),
                (_, 1) => mesh.indices.push([lo[j], lo[k], hi[0]]),
                _ => {
                    mesh.indices.push([lo[j], lo[k], hi[k]]);
                    mesh.indices.push([lo[j], hi[k], hi[j]]);
                }
            }
        }
    }
}

/// The number of triangles [`push_lathe`] makes of `profile` with
/// `segments` around: a fan where one ring is a pole, a band of two per
/// segment between full rings, nothing between two poles.
pub fn lathe_triangles(profile: &[(f32, f32)], segments: usize) -> usize {
    profile
        .windows(2)
        .map(|w| match (w[0].0 == 0.0, w[1].0 == 0.0) {
            (true, true) => 0,
            (true, false) | (false, true) => segments,
            (false, false) => 2 * segments,
        })
        .sum()
}

/// The number of triangles [`push_tube`] makes of a path of `points` points
/// with `sides` sides.
pub fn tube_triangles(points: usize, sides: usize) -> usize {
    2 * sides * points.saturating_sub(1)
}

/// Appends a grid surface of `rows` × `cols` quads (two triangles each),
/// whose vertex `(i, j)` for `i` in `0..=rows`, `j` in `0..=cols` is
/// `at(i, j)`.
pub fn push_grid(mesh: &mut Mesh, rows: usize, cols: usize, at: impl Fn(usize, usize) -> Vec3) {
    let base = mesh.positions.len() as u32;
    for i in 0..=rows {
        for j in 0..=cols {
            mesh.positions.push(at(i, j));
        }
    }
    let stride = cols as u32 + 1;
    for i in 0..rows as u32 {
        for j in 0..cols as u32 {
            let a = base + i * stride + j;
            let (b, c, d) = (a + 1, a + stride, a + stride + 1);
            mesh.indices.push([a, b, d]);
            mesh.indices.push([a, d, c]);
        }
    }
}

/// Appends an open tube of radius `radius` with `sides` sides along the
/// polyline `path`, its rings oriented by parallel transport (no twist).
pub fn push_tube(mesh: &mut Mesh, path: &[Vec3], radius: f32, sides: usize) {
    let base = mesh.positions.len() as u32;
    let tangent = |i: usize| {
        let a = path[i.saturating_sub(1)];
        let b = path[(i + 1).min(path.len() - 1)];
        (b - a).normalize_or(Vec3::X)
    };
    let mut normal = tangent(0).any_orthonormal_vector();
    for (i, &p) in path.iter().enumerate() {
        let t = tangent(i);
        normal = (normal - t * normal.dot(t)).normalize_or(t.any_orthonormal_vector());
        let binormal = t.cross(normal);
        for j in 0..sides {
            let a = std::f32::consts::TAU * j as f32 / sides as f32;
            mesh.positions
                .push(p + (normal * a.cos() + binormal * a.sin()) * radius);
        }
    }
    let s = sides as u32;
    for i in 0..path.len() as u32 - 1 {
        for j in 0..s {
            let k = (j + 1) % s;
            let (a, b) = (base + i * s + j, base + i * s + k);
            let (c, d) = (a + s, b + s);
            mesh.indices.push([a, b, d]);
            mesh.indices.push([a, d, c]);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn box_is_closed() {
        let mut m = Mesh::default();
        push_box(&mut m, Vec3::ZERO, Vec3::ONE);
        assert_eq!(m.indices.len(), 12);
        // Every edge of a closed mesh is used by exactly two triangles.
        let mut edges = std::collections::HashMap::new();
        for t in &m.indices {
            for e in 0..3 {
                let (a, b) = (t[e], t[(e + 1) % 3]);
                *edges.entry((a.min(b), a.max(b))).or_insert(0) += 1;
            }
        }
        assert!(edges.values().all(|&c| c == 2));
    }

    #[test]
    fn triangle_counts_match_what_is_built() {
        let profile = resample(&[(0.0, 0.0), (1.0, 0.0), (0.5, 2.0), (0.0, 2.0)], 9);
        for segments in [3, 8, 17] {
            let mut m = Mesh::default();
            push_lathe(&mut m, &profile, segments, Vec3::ZERO, 2.0);
            assert_eq!(m.indices.len(), lathe_triangles(&profile, segments));
            let open = [(0.5, 0.0), (0.5, 1.0), (0.3, 1.5)];
            let mut m = Mesh::default();
            push_lathe(&mut m, &open, segments, Vec3::ZERO, 1.0);
            assert_eq!(m.indices.len(), lathe_triangles(&open, segments));
        }
        let path: Vec<Vec3> = (0..7)
            .map(|i| Vec3::new(i as f32, (i * i) as f32, 0.0))
            .collect();
        let mut m = Mesh::default();
        push_tube(&mut m, &path, 0.1, 5);
        assert_eq!(m.indices.len(), tube_triangles(7, 5));
        let mut m = Mesh::default();
        push_grid(&mut m, 3, 4, |i, j| Vec3::new(j as f32, 0.0, i as f32));
        assert_eq!(m.indices.len(), 24);
        m.validate().unwrap();
    }

    #[test]
    fn lathe_counts() {
        let mut m = Mesh::default();
        let p = resample(&[(0.0, 0.0), (1.0, 0.0), (1.0, 1.0), (0.0, 1.0)], 6);
        push_lathe(&mut m, &p, 8, Vec3::ZERO, 1.0);
        // Two caps of 8 and three bands of 16.
        assert_eq!(m.indices.len(), 8 + 8 + 3 * 16);
        m.validate().unwrap();
    }
}
