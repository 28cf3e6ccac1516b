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
        let mut best: Option<Hit> = None;
        let mut tmax = ray.tmax;
        stats.add(Tally {
            triangles: self.live.len() as u32,
            ..Tally::default()
        });
        for &p in &self.live {
            if let Some(h) = self.triangles[p as usize].hit(ray, ray.tmin, tmax, p) {
                if h.beats(&best) {
                    tmax = h.t;
                    best = Some(h);
                }
            }
        }
        best
    }

    fn any_hit<S: Stats>(&self, ray: &Ray, stats: &mut S) -> Option<Hit> {
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
    /// The hit of triangle `prim` alone over the ray's interval.
    pub fn hit_of(&self, prim: u32, ray: &Ray) -> Option<Hit> {
        self.triangles
            .get(prim as usize)?
            .hit(ray, ray.tmin, ray.tmax, prim)
    }
}
