//! Work counters, passed to every traversal as a generic sink so that the
//! [`NoStats`] sink compiles to nothing.

use serde::Serialize;
use std::ops::AddAssign;

/// Receives the work a traversal does.
pub trait Stats {
    /// A node was visited: its children tested, or its triangles processed.
    /// `id` gives the node's id in the canonical [`crate::bvh::Bvh`]; it is only
    /// called by sinks that log, so layouts may look it up in a side table.
    fn node(&mut self, id: impl FnOnce() -> u32);
    /// `n` ray-plane tests (a box test counts 6).
    fn planes(&mut self, n: u32);
    /// `n` ray-triangle tests.
    fn triangles(&mut self, n: u32);
}

/// Counts nothing, costs nothing.
#[derive(Clone, Copy, Debug, Default)]
pub struct NoStats;

impl Stats for NoStats {
    #[inline(always)]
    fn node(&mut self, _: impl FnOnce() -> u32) {}
    #[inline(always)]
    fn planes(&mut self, _: u32) {}
    #[inline(always)]
    fn triangles(&mut self, _: u32) {}
}

/// Totals of nodes visited, plane tests and triangle tests (and rays, kept
/// by the caller) so that per-ray averages can be reported.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize)]
pub struct Counters {
    pub rays: u64,
    pub nodes: u64,
    pub planes: u64,
    pub triangles: u64,
}

impl Stats for Counters {
    #[inline(always)]
    fn node(&mut self, _: impl FnOnce() -> u32) {
        self.nodes += 1;
    }
    #[inline(always)]
    fn planes(&mut self, n: u32) {
        self.planes += n as u64;
    }
    #[inline(always)]
    fn triangles(&mut self, n: u32) {
        self.triangles += n as u64;
    }
}

impl AddAssign for Counters {
    fn add_assign(&mut self, o: Self) {
        self.rays += o.rays;
        self.nodes += o.nodes;
        self.planes += o.planes;
        self.triangles += o.triangles;
    }
}

/// Per-ray averages.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct PerRay {
    pub nodes: f64,
    pub planes: f64,
    pub triangles: f64,
}

impl Counters {
    pub fn per_ray(&self) -> PerRay {
        let r = self.rays.max(1) as f64;
        PerRay {
            nodes: self.nodes as f64 / r,
            planes: self.planes as f64 / r,
            triangles: self.triangles as f64 / r,
        }
    }
}

/// Counters plus the sequence of visited canonical node ids, for the tests
/// that compare traversal orders.
#[derive(Clone, Debug, Default)]
pub struct VisitLog {
    pub counters: Counters,
    pub visits: Vec<u32>,
}

impl Stats for VisitLog {
    fn node(&mut self, id: impl FnOnce() -> u32) {
        self.counters.nodes += 1;
        self.visits.push(id());
    }
    fn planes(&mut self, n: u32) {
        self.counters.planes(n);
    }
    fn triangles(&mut self, n: u32) {
        self.counters.triangles(n);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn counters_add_and_average() {
        let mut c = Counters::default();
        c.node(|| unreachable!("counters do not ask for ids"));
        c.planes(12);
        c.triangles(3);
        c.rays = 2;
        let mut total = Counters::default();
        total += c;
        total += c;
        assert_eq!(total.nodes, 2);
        assert_eq!(total.per_ray().planes, 6.0);
        assert_eq!(total.per_ray().triangles, 1.5);
    }

    #[test]
    fn log_records_ids_in_order() {
        let mut l = VisitLog::default();
        l.node(|| 7);
        l.node(|| 3);
        assert_eq!(l.visits, vec![7, 3]);
        assert_eq!(l.counters.nodes, 2);
    }
}
