//! Brute force: every triangle tested for every ray, the oracle every
//! structure is checked against.

use super::Accel;
use crate::geometry::{Hit, Ray, Triangle};
use crate::stats::{Stats, Tally};
use std::sync::Arc;

/// The oracle: tests every triangle. Degenerate triangles are skipped, as
/// every structure skips them.
#[derive(Clone, Debug)]
pub struct BruteForce {
    triangles: Arc<[Triangle]>,
    live: Vec<u32>,
}

impl BruteForce {
    /// The oracle over `triangles` (mesh order); 4 bytes per non-degenerate
    /// triangle.
    pub fn new(triangles: Arc<[Triangle]>) -> Self {
        let live = (0..triangles.len() as u32)
            .filter(|&i| !triangles[i as usize].is_degenerate())
            .collect();
        BruteForce { triangles, live }
    }
}

impl Accel for BruteForce {
    fn name(&self) -> &'static str {
        "brute"
    }

    fn bytes(&self) -> usize {
        self.live.len() * 4
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
        for &p in &self.live {
            if let Some(h) = self.triangles[p as usize].hit(ray, ray.tmin, tmax, p) {
                if S::HITS {
                    stats.hit(h);
                } else if h.beats(&best) {
                    tmax = h.t;
                    best = Some(h);
                }
            }
        }
        best
    }

    fn any_hit<S: Stats>(&self, ray: &Ray, stats: &mut S) -> Option<Hit> {
        if !ray.is_valid() {
            return None;
        }
        for (k, &p) in self.live.iter().enumerate() {
            if let Some(h) = self.triangles[p as usize].hit(ray, ray.tmin, ray.tmax, p) {
                stats.add(Tally {
                    triangles: k as u32 + 1,
                    ..Tally::default()
                });
                return Some(h);
            }
        }
        stats.add(Tally {
            triangles: self.live.len() as u32,
            ..Tally::default()
        });
        None
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
