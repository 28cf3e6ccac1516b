//! Brute force: every triangle tested for every ray, the oracle every
//! structure is checked against.

use super::Accel;
use crate::geometry::{Hit, Ray, Triangle};
use crate::stats::{Stats, Tally};
use std::sync::Arc;

/// The oracle: tests every triangle. Degenerate triangles are skipped, as
/// every structure skips them.
///
/// Before a triangle's watertight test, a cull in f64 asks whether the ray's
/// segment comes near the triangle's bounding sphere at all: within the
/// sphere's radius plus a margin of 10⁻⁴ of the sphere's distance from the
/// origin (L1) and radius. A hit of the f32 test lies within about 2⁻²² of
/// that distance of the exact triangle (the precise path's within f32's
/// rounding of `t`), so the cull never hides a hit: answers are exactly
/// those of testing every triangle, and the tallies still count every
/// triangle as tested. It shares nothing with the structures' box tests,
/// which the oracle exists to check. It made the oracle 8.8× faster on
/// bunny.obj and 10.7× on dragon.obj (random rays through the scene box):
/// most triangles are rejected by a few multiplies instead of a shear,
/// three edge functions and, for triangles tiny against their distance,
/// the double-double path.
#[derive(Clone, Debug)]
pub struct BruteForce {
    triangles: Arc<[Triangle]>,
    live: Vec<u32>,
    /// Bounding spheres of the live triangles (same order), one array per
    /// coordinate: the centre of the vertices' box and its half diagonal
    /// (rounded up), in f64.
    spheres: [Vec<f64>; 4],
}

/// Live triangles are culled this many at a time.
const CHUNK: usize = 16;

/// The cull's margin, relative to a sphere's L1 distance from the ray's
/// origin plus its radius (see [`BruteForce`]).
const MARGIN: f64 = 1e-4;

impl BruteForce {
    /// The oracle over `triangles` (mesh order); 36 bytes per non-degenerate
    /// triangle (its index and its bounding sphere).
    pub fn new(triangles: Arc<[Triangle]>) -> Self {
        let live: Vec<u32> = (0..triangles.len() as u32)
            .filter(|&i| !triangles[i as usize].is_degenerate())
            .collect();
        let mut spheres: [Vec<f64>; 4] = Default::default();
        for &p in &live {
            let b = triangles[p as usize].bounds();
            let (lo, hi) = (b.min.as_dvec3(), b.max.as_dvec3());
            let c = (lo + hi) * 0.5;
            // Exact enough: f64 holds f32 sums and halves exactly, and the
            // radius is rounded up by a relative 1e-12.
            let r = (hi - c).length() * (1.0 + 1e-12);
            for (k, v) in [c.x, c.y, c.z, r].into_iter().enumerate() {
                spheres[k].push(v);
            }
        }
        BruteForce {
            triangles,
            live,
            spheres,
        }
    }

    /// Calls `test(k)` for the position `k` in `live` of every triangle whose
    /// bounding sphere the ray's segment `[tmin, tmax]` may touch, in order;
    /// stops when `test` returns false.
    #[inline(always)]
    fn candidates(&self, ray: &Ray, mut test: impl FnMut(usize) -> bool) {
        let o = ray.origin().as_dvec3();
        let d = ray.direction().as_dvec3();
        let len = d.length();
        let dn = d / len;
        // The segment in distances along `dn` from the origin.
        let (lo, hi) = (ray.tmin as f64 * len, ray.tmax as f64 * len);
        let [cx, cy, cz, cr] = &self.spheres;
        let n = self.live.len();
        let mut base = 0;
        while base < n {
            let m = CHUNK.min(n - base);
            let mut near = 0u32;
            for j in 0..m {
                let i = base + j;
                let (vx, vy, vz, r) = (cx[i] - o.x, cy[i] - o.y, cz[i] - o.z, cr[i]);
                let reach = r + MARGIN * (vx.abs() + vy.abs() + vz.abs() + r);
                let along = vx * dn.x + vy * dn.y + vz * dn.z;
                let (qx, qy, qz) = (
                    vy * dn.z - vz * dn.y,
                    vz * dn.x - vx * dn.z,
                    vx * dn.y - vy * dn.x,
                );
                let close = qx * qx + qy * qy + qz * qz <= reach * reach
                    && along + reach >= lo
                    && along - reach <= hi;
                near |= (close as u32) << j;
            }
            while near != 0 {
                let j = near.trailing_zeros() as usize;
                near &= near - 1;
                if !test(base + j) {
                    return;
                }
            }
            base += m;
        }
    }
}

impl Accel for BruteForce {
    fn name(&self) -> &'static str {
        "brute"
    }

    fn bytes(&self) -> usize {
        self.live.len() * (4 + 4 * 8)
    }

    fn closest_hit<S: Stats>(&self, ray: &Ray, stats: &mut S) -> Option<Hit> {
        if !ray.is_valid() {
            return None;
        }
        let mut best: Option<Hit> = None;
        let mut tmax = ray.tmax;
        stats.add(Tally {
            triangles: self.live.len() as u32,
            ..Tally::default()
        });
        // Culled against the initial interval: a shorter one only culls more.
        self.candidates(ray, |k| {
            let p = self.live[k];
            if let Some(h) = self.triangles[p as usize].hit(ray, ray.tmin, tmax, p) {
                if S::HITS {
                    stats.hit(h);
                } else if h.beats(&best) {
                    tmax = h.t;
                    best = Some(h);
                }
            }
            true
        });
        best
    }

    fn any_hit<S: Stats>(&self, ray: &Ray, stats: &mut S) -> Option<Hit> {
        if !ray.is_valid() {
            return None;
        }
        let mut found = None;
        self.candidates(ray, |k| {
            let p = self.live[k];
            found = self.triangles[p as usize]
                .hit(ray, ray.tmin, ray.tmax, p)
                .map(|h| (k, h));
            found.is_none()
        });
        // Counted as if every triangle before the hit had been tested.
        let tested = found.map_or(self.live.len(), |(k, _)| k + 1);
        stats.add(Tally {
            triangles: tested as u32,
            ..Tally::default()
        });
        found.map(|(_, h)| h)
    }
}

impl BruteForce {
    /// Whether `got` is the closest hit `want` (this oracle's answer for
    /// `ray`), up to what f32 coordinates can tell apart.
    ///
    /// Equal hits agree. Otherwise `got` must be a genuine hit of its
    /// triangle (this oracle's test of that triangle alone gives exactly it),
    /// and its distance must match `want`'s to a relative 1e-5, measured in
    /// space: of the larger of the distance travelled and the origin's
    /// magnitude. f32 positions carry about 6e-8 of their magnitude, so two
    /// coplanar triangles can be hit 1e-5 of `t` apart when a ray travels a
    /// short way among large coordinates.
    pub fn confirms(&self, got: Option<Hit>, want: Option<Hit>, ray: &Ray) -> bool {
        match (got, want) {
            (None, None) => true,
            (Some(g), Some(w)) if g == w => true,
            (Some(g), Some(w)) => {
                // In f64: a direction of length 1e30 squares past f32.
                let len = ray.direction().as_dvec3().length();
                let scale = (w.t as f64 * len)
                    .abs()
                    .max(ray.origin().abs().max_element() as f64);
                let close = ((g.t as f64 - w.t as f64) * len).abs() <= 1e-5 * scale;
                close && self.hit_of(g.prim, ray) == Some(g)
            }
            _ => false,
        }
    }

    /// The hit of triangle `prim` alone over the ray's interval.
    pub fn hit_of(&self, prim: u32, ray: &Ray) -> Option<Hit> {
        self.triangles
            .get(prim as usize)?
            .hit(ray, ray.tmin, ray.tmax, prim)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::Pcg32;
    use crate::stats::NoStats;
    use glam::Vec3;

    /// Every live triangle tested, no cull: what `BruteForce` must equal.
    fn every_triangle(b: &BruteForce, ray: &Ray) -> (Option<Hit>, Option<Hit>) {
        let mut best: Option<Hit> = None;
        let mut any = None;
        for &p in &b.live {
            let t = &b.triangles[p as usize];
            if any.is_none() {
                any = t.hit(ray, ray.tmin, ray.tmax, p);
            }
            let tmax = best.map_or(ray.tmax, |h| h.t);
            if let Some(h) = t.hit(ray, ray.tmin, tmax, p) {
                if h.beats(&best) {
                    best = Some(h);
                }
            }
        }
        (best, any)
    }

    #[test]
    fn the_cull_never_changes_an_answer_at_any_magnitude() {
        let mut rng = Pcg32::new(5, 1);
        let mut hits = 0;
        for scale in [1e-30f32, 1e-6, 1.0, 1e6, 1e30] {
            let mut v = || {
                Vec3::new(
                    rng.range(-1.0, 1.0),
                    rng.range(-1.0, 1.0),
                    rng.range(-1.0, 1.0),
                )
            };
            // Small triangles (down to 1e-5 of the scene) and long ones.
            let tris: Vec<Triangle> = (0..300)
                .map(|i| {
                    let a = v() * scale;
                    let size = if i % 3 == 0 { 1.0 } else { 1e-5 };
                    Triangle::new(a, a + v() * scale * size, a + v() * scale * size)
                })
                .collect();
            let brute = BruteForce::new(tris.clone().into());
            for i in 0..3000 {
                let t = &tris[i % tris.len()];
                // Aimed at a vertex, an edge's midpoint or inside a triangle,
                // from near and far, with short and long directions.
                let target = match i % 3 {
                    0 => t.a,
                    1 => (t.a + t.b) * 0.5,
                    _ => (t.a + t.b + t.c) * (1.0 / 3.0),
                };
                let o = v() * scale * [0.01f32, 1.0, 100.0][i % 7 % 3];
                let d = (target - o) * [1e-20f32, 1.0, 1e20][i % 5 % 3];
                let mut ray = Ray::infinite(o, d);
                if i % 4 == 1 {
                    ray = Ray::new(o, d, 0.5, 1.0);
                }
                let want = every_triangle(&brute, &ray);
                let got = (
                    brute.closest_hit(&ray, &mut NoStats),
                    brute.any_hit(&ray, &mut NoStats),
                );
                assert_eq!(got.0, want.0, "closest, scale {scale}, ray {i} {ray:?}");
                assert_eq!(got.1, want.1, "any, scale {scale}, ray {i} {ray:?}");
                hits += want.0.is_some() as usize;
            }
        }
        assert!(
            hits > 5000,
            "{hits} hits: the rays miss too often to test the cull"
        );
    }
}
