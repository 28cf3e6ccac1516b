//! Work counters, passed to every traversal as a generic sink so that the
//! [`NoStats`] sink compiles to nothing.

use crate::geometry::Hit;
use serde::Serialize;
use std::ops::AddAssign;

/// Receives the work a traversal does.
///
/// A traversal counts into a local [`Tally`] (registers, not memory) and
/// hands it over once per ray with [`Stats::add`]; only visit logs see each
/// node as it is visited. With [`NoStats`] both vanish.
pub trait Stats {
    /// Whether [`Stats::visit`] wants every visited node.
    const LOGS: bool = false;
    /// Node `id` of the canonical [`crate::bvh::Bvh`] was visited. Called
    /// only when [`Stats::LOGS`] is set; layouts may look the id up in a
    /// side table.
    fn visit(&mut self, _id: u32) {}
    /// The work of one ray.
    fn add(&mut self, tally: Tally);
    /// Whether the sink wants every hit: the traversal then reports each hit
    /// within the ray's interval to [`Stats::hit`], never shortens the ray
    /// and never stops early, and its own answer is `None`. This is the
    /// all-hits query ([`crate::structures::Accel::all_hits`]).
    const HITS: bool = false;
    /// A hit, when [`Stats::HITS`] is set.
    fn hit(&mut self, _hit: Hit) {}
}

/// One ray's work, kept in locals by a traversal.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Tally {
    /// Nodes visited: their children tested, or their triangles processed.
    pub nodes: u32,
    /// Ray-plane tests (a box test counts 6).
    pub planes: u32,
    /// Ray-triangle tests.
    pub triangles: u32,
}

/// Counts nothing, costs nothing.
#[derive(Clone, Copy, Debug, Default)]
pub struct NoStats;

impl Stats for NoStats {
    #[inline(always)]
    fn add(&mut self, _: Tally) {}
}

/// Totals of nodes visited, plane tests and triangle tests (and rays, kept
/// by the caller) so that per-ray averages can be reported.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize)]
pub struct Counters {
    /// Rays traced; not counted by [`Stats::add`], the caller sets it.
    pub rays: u64,
    /// Sum of [`Tally::nodes`].
    pub nodes: u64,
    /// Sum of [`Tally::planes`].
    pub planes: u64,
    /// Sum of [`Tally::triangles`].
    pub triangles: u64,
}

impl Stats for Counters {
    #[inline(always)]
    fn add(&mut self, t: Tally) {
        self.nodes += t.nodes as u64;
        self.planes += t.planes as u64;
        self.triangles += t.triangles as u64;
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

/// Bytes in a MiB, the unit of storage figures (the dual-split paper's
/// Table 1 gives its storage in MiB).
pub const MIB: f64 = (1u64 << 20) as f64;

/// Per-ray averages.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct PerRay {
    /// Nodes visited per ray.
    pub nodes: f64,
    /// Ray-plane tests per ray (a box test counts 6).
    pub planes: f64,
    /// Ray-triangle tests per ray.
    pub triangles: f64,
}

impl Counters {
    /// Each total divided by [`Self::rays`] (by 1 when no rays were counted).
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
    /// The work, as [`Counters`] would count it.
    pub counters: Counters,
    /// Canonical [`crate::bvh::Bvh`] node ids in visiting order, over every
    /// ray traced into this log.
    pub visits: Vec<u32>,
}

impl Stats for VisitLog {
    const LOGS: bool = true;
    fn visit(&mut self, id: u32) {
        self.visits.push(id);
    }
    fn add(&mut self, t: Tally) {
        self.counters.add(t);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn counters_add_and_average() {
        let mut c = Counters::default();
        c.add(Tally {
            nodes: 1,
            planes: 12,
            triangles: 3,
        });
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
        l.visit(7);
        l.visit(3);
        l.add(Tally {
            nodes: 2,
            ..Default::default()
        });
        assert_eq!(l.visits, vec![7, 3]);
        assert_eq!(l.counters.nodes, 2);
    }
}

/// Collects every hit along a ray (the all-hits query), passing the work on
/// to `inner`. A triangle that several leaves list (spatial splits,
/// [`crate::bvh::Builder::Sbvh`]) is found once per leaf the ray enters; it
/// is kept once.
#[derive(Clone, Debug, Default)]
pub struct HitList<S: Stats = NoStats> {
    /// The hits, in the order the traversal found them.
    pub hits: Vec<Hit>,
    /// The sink that receives the work.
    pub inner: S,
}

impl<S: Stats> Stats for HitList<S> {
    const LOGS: bool = S::LOGS;
    const HITS: bool = true;
    #[inline(always)]
    fn visit(&mut self, id: u32) {
        self.inner.visit(id)
    }
    #[inline(always)]
    fn add(&mut self, tally: Tally) {
        self.inner.add(tally)
    }
    #[inline(always)]
    fn hit(&mut self, hit: Hit) {
        if !self.hits.iter().any(|h| h.prim == hit.prim) {
            self.hits.push(hit)
        }
    }
}

/// Counts the hits along a ray (the all-hits query without the hits),
/// passing the work on to `inner`. Each triangle counts once, however many
/// leaves list it (spatial splits, [`crate::bvh::Builder::Sbvh`]).
#[derive(Clone, Debug, Default)]
pub struct HitCount<S: Stats = NoStats> {
    /// Hits found: distinct triangles.
    pub count: u32,
    /// The sink that receives the work.
    pub inner: S,
    /// The triangles counted so far.
    seen: Vec<u32>,
}

impl<S: Stats> HitCount<S> {
    /// No hits yet, the work going to `inner`.
    pub fn new(inner: S) -> Self {
        HitCount {
            count: 0,
            inner,
            seen: Vec::new(),
        }
    }
}

impl<S: Stats> Stats for HitCount<S> {
    const LOGS: bool = S::LOGS;
    const HITS: bool = true;
    #[inline(always)]
    fn visit(&mut self, id: u32) {
        self.inner.visit(id)
    }
    #[inline(always)]
    fn add(&mut self, tally: Tally) {
        self.inner.add(tally)
    }
    #[inline(always)]
    fn hit(&mut self, hit: Hit) {
        if !self.seen.contains(&hit.prim) {
            self.seen.push(hit.prim);
            self.count += 1
        }
    }
}

/// A borrowed sink counts into what it borrows.
impl<S: Stats> Stats for &mut S {
    const LOGS: bool = S::LOGS;
    const HITS: bool = S::HITS;
    #[inline(always)]
    fn visit(&mut self, id: u32) {
        (**self).visit(id)
    }
    #[inline(always)]
    fn add(&mut self, tally: Tally) {
        (**self).add(tally)
    }
    #[inline(always)]
    fn hit(&mut self, hit: Hit) {
        (**self).hit(hit)
    }
}
