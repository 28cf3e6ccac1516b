//! LAINE-k (Laine 2010, "Restart trail for stackless BVH traversal"): a
//! trail of one bit per level says which subtrees are finished; when the
//! short stack of `K` entries is empty, traversal restarts at the root and
//! descends along the trail. Children are ordered by distance as in STACK,
//! and distances do not depend on the current closest hit, so a restart
//! takes the same turns.
//!
//! The trail, level and pop level are 64 bits (root at bit 63): trees up to
//! depth 63. Two more words of one bit per level (`path`, `one`; see
//! [`trace`]) let a restart's descent load each next node before its box
//! test has decided it: LAINE-0's kernel time 0.57x on the paired nodes and
//! 0.63x on the own-box nodes, on the paper's CHESS rays (ARCHITECTURE.md,
//! issue 26). A restart then passes through the path's nodes above the pop
//! target's parent without testing their boxes (each holds the boxes below
//! it, so a test there culls nothing that the pop target's own test would
//! not): the same hits, fewer plane tests, and where the closest hit has
//! since culled an ancestor on the path, a restart per pending level below
//! it instead of one (checked against a reference walk in the tests
//! below). Hairball, one thread, kernel time over STACK's: LAINE-1
//! 1.22-1.26 to 1.17-1.20, LAINE-0 1.54-1.57 to 1.37-1.42. Short stacks of
//! 4 or more entries rarely restart and keep Laine's plain restart.

use super::SparseLayout;
use crate::geometry::{Hit, Ray};
use crate::stats::Stats;
use crate::structures::shared::own_box::{branch_pick, BinaryNode, Children, Step};

const ROOT_LEVEL: u64 = 1 << 63;

/// Short stacks this size and larger restart rarely: their walks keep no
/// `path` and restart as Laine's does.
const RUN_AHEAD_BELOW: usize = 4;

/// Closest hit (`ANY = false`) or any hit, with a short stack of `K`.
///
/// Beside Laine's trail, level and pop level the walk keeps two more words
/// of one bit per level: `path` (set where the current path takes the
/// right child) and `one` (set where only one child was entered). A
/// restart's descent to its pop level reads the child it will take from
/// `path`: above the pop target's parent it tests no box (a node's box
/// holds its descendants', so the pop target's test culls whatever an
/// ancestor's would), and at that parent the test only confirms that its
/// hit mask is the one the level had (both children, or the one in
/// `path`); where it is not, the plain step takes that test's result. Where the mask is the expected one
/// the plain step would take the same child and change nothing: entry
/// distances do not depend on the closest hit, so a level entered with
/// both children orders them as before; `path` at the pop level is turned
/// to its far child when the pop finds it.
#[inline]
pub fn trace<L: SparseLayout, S: Stats, const ANY: bool, const K: usize>(
    sp: &L,
    ray: &Ray,
    stats: &mut S,
) -> Option<Hit> {
    if sp.is_empty() {
        return None;
    }
    let mut w = sp.walk::<ANY, S>(ray, stats)?;
    let mut t = Trail::<K> {
        level: ROOT_LEVEL,
        ..Default::default()
    };
    let mut node = 0u32;
    'visit: loop {
        match w.step(node as usize, BinaryNode::target, || sp.id(node), stats) {
            Step::Inner { left, children } => {
                if let Some(next) = t.descend(left, children) {
                    node = next;
                    continue;
                }
            }
            Step::Leaf => {}
            Step::Done => break,
        }
        loop {
            // Pop: to the short stack's top, or restart.
            if t.pop() {
                break 'visit;
            }
            if let Some(far) = t.short.pop() {
                node = far;
                continue 'visit;
            }
            // Restart: descend from the root along `path` to the pop level.
            node = 0;
            t.level = ROOT_LEVEL;
            if !Trail::<K>::RUN_AHEAD {
                continue 'visit;
            }
            // Through the path's nodes above the pop target's parent,
            // untested.
            while t.level >> 1 != t.pop_level {
                let below = t.level >> 1;
                let right = t.path & below != 0;
                let left = w.pass_inner(node as usize, BinaryNode::target, || sp.id(node), stats);
                t.level = below;
                node = left + right as u32;
                if K > 0 && t.trail & below == 0 {
                    t.short.push(left + !right as u32);
                }
            }
            // The pop target's parent: its test confirms the level's mask,
            // and the walk goes on at the pop target (the pop set its trail
            // bit: nothing to push); otherwise the plain step decides on
            // this test, a pop again when it enters no child.
            let below = t.level >> 1;
            let right = t.path & below != 0;
            let (left, hit, tl, tr) =
                w.step_inner(node as usize, BinaryNode::target, || sp.id(node), stats);
            let expected = if t.one & below != 0 {
                1 + right as u32
            } else {
                3
            };
            if hit == expected {
                t.level = below;
                node = left + right as u32;
                continue 'visit;
            }
            if let Some(next) = t.descend(left, Children::of_mask(hit, tl, tr)) {
                node = next;
                continue 'visit;
            }
        }
    }
    w.finish(stats)
}

/// The walk's state besides its node: Laine's trail, level and pop level,
/// the `path` and `one` words (see [`trace`]) and the short stack.
#[derive(Default)]
struct Trail<const K: usize> {
    trail: u64,
    level: u64,
    pop_level: u64,
    path: u64,
    one: u64,
    short: ShortStack<K>,
}

impl<const K: usize> Trail<K> {
    /// Whether restarts run ahead along `path` (the words kept up to date).
    const RUN_AHEAD: bool = K < RUN_AHEAD_BELOW;

    /// An inner node's step, `children` entered from the pair at `left`:
    /// the child to visit next, or `None` for a pop.
    #[inline(always)]
    fn descend(&mut self, left: u32, children: Children) -> Option<u32> {
        match children {
            Children::Both { right_first } => {
                self.level >>= 1;
                let far_taken = self.trail & self.level != 0;
                let right = right_first != far_taken;
                if Self::RUN_AHEAD {
                    self.path =
                        (self.path & !self.level) | (self.level & (right as u64).wrapping_neg());
                    self.one &= !self.level;
                }
                if K > 0 && !far_taken {
                    self.short.push(left + !right as u32);
                }
                Some(branch_pick(right, left + 1, left))
            }
            Children::One { right } => {
                self.level >>= 1;
                if self.level == self.pop_level {
                    // At the pop level with one child hit: the far child
                    // (the pop target) is culled now; the near one is done.
                    return None;
                }
                self.trail |= self.level;
                if Self::RUN_AHEAD {
                    self.path =
                        (self.path & !self.level) | (self.level & (right as u64).wrapping_neg());
                    self.one |= self.level;
                }
                Some(branch_pick(right, left + 1, left))
            }
            Children::None => None,
        }
    }

    /// Marks the current level finished; the carry runs through the
    /// finished levels to the deepest pending one, which becomes the pop
    /// level (its path turned to the far child). True when none is left.
    #[inline(always)]
    fn pop(&mut self) -> bool {
        self.trail &= self.level.wrapping_neg();
        self.trail = self.trail.wrapping_add(self.level);
        if self.trail & ROOT_LEVEL != 0 {
            return true;
        }
        self.level = self.trail & self.trail.wrapping_neg();
        self.pop_level = self.level;
        if Self::RUN_AHEAD {
            self.path ^= self.level;
        }
        false
    }
}

/// The short stack of `K` entries (0, 1, 2, 4 or 8). A push onto a full
/// stack drops the oldest entry, as Laine's short stack does. Below
/// [`RUN_AHEAD_BELOW`] it is a ring (the push overwrites the oldest entry in
/// place); at 4 and 8 it is a plain stack whose rare full push moves the
/// others down, because there the stack is seldom full and the ring's index
/// arithmetic on every push and pop was the cost: on battlefield's matched
/// paper workload (one thread, 4 alternated rounds) LAINE-8-paired cost 4.7%
/// more than STACK-paired with the ring and 0.4% more with the plain stack,
/// visiting the same nodes.
#[derive(Default)]
struct ShortStack<const K: usize> {
    entries: [u32; 8],
    /// Where the next push goes, modulo `K`.
    head: usize,
    /// Entries held, at most `K`.
    len: usize,
}

impl<const K: usize> ShortStack<K> {
    const MASK: usize = {
        assert!(K <= 8 && (K == 0 || K.is_power_of_two()));
        K.saturating_sub(1)
    };

    #[inline(always)]
    fn push(&mut self, far: u32) {
        if K == 0 {
            return;
        }
        if K >= RUN_AHEAD_BELOW {
            // A plain stack: the entries in order, `len` the top; a push
            // onto a full one (rare at these sizes) drops the oldest by
            // moving the others down.
            if self.len == K {
                std::hint::cold_path();
                self.entries.copy_within(1..K, 0);
                self.len = K - 1;
            }
            self.entries[self.len] = far;
            self.len += 1;
            return;
        }
        self.entries[self.head & Self::MASK] = far;
        self.head = (self.head + 1) & Self::MASK;
        self.len = (self.len + 1).min(K);
    }

    #[inline(always)]
    fn pop(&mut self) -> Option<u32> {
        if K == 0 || self.len == 0 {
            return None;
        }
        self.len -= 1;
        if K >= RUN_AHEAD_BELOW {
            return Some(self.entries[self.len]);
        }
        self.head = self.head.wrapping_sub(1) & Self::MASK;
        Some(self.entries[self.head])
    }
}

#[cfg(test)]
mod tests {
    use super::{ShortStack, SparseLayout, ROOT_LEVEL};
    use crate::bvh::{BuildOptions, Bvh};
    use crate::geometry::{Hit, Ray};
    use crate::render::rayset;
    use crate::scene::Scene;
    use crate::stats::{Stats, VisitLog};
    use crate::structures::shared::own_box::{BinaryNode, Children, Step};
    use crate::structures::sparse::{PairedBvh, SparseBvh};
    use crate::structures::BinaryBvh;
    use std::sync::Arc;

    /// The trail walk as Laine gives it, the reference the kernel's visits
    /// are checked against. Short stacks of 4 and 8: each restart descends
    /// from the root by box tests, the trail choosing the turns. Smaller
    /// ones (the kernel's pass-through restarts): a restart passes through
    /// the current path's nodes from the root, untested, read from a list
    /// of the path's node at each depth rather than from the kernel's
    /// `path` bits, and tests only at the pop target's parent.
    fn plain<L: SparseLayout, S: Stats, const ANY: bool, const K: usize>(
        sp: &L,
        ray: &Ray,
        stats: &mut S,
    ) -> Option<Hit> {
        if sp.is_empty() {
            return None;
        }
        let mut w = sp.walk::<ANY, S>(ray, stats)?;
        let mut node = 0u32;
        let (mut trail, mut level, mut pop_level) = (0u64, ROOT_LEVEL, 0u64);
        // Short stack; when full, the oldest entry is dropped.
        let mut short = [0u32; 8];
        let mut head = 0usize;
        let push = |short: &mut [u32; 8], head: &mut usize, far: u32| {
            if K == 0 {
                return;
            }
            if *head < K {
                short[*head] = far;
                *head += 1;
            } else {
                short.copy_within(1..K, 0);
                short[K - 1] = far;
            }
        };
        // The node at each depth of the current path.
        let mut at = [0u32; 64];
        let depth = |level: u64| level.leading_zeros() as usize;
        loop {
            at[depth(level)] = node;
            match w.step(node as usize, BinaryNode::target, || sp.id(node), stats) {
                Step::Inner { left, children } => match children {
                    Children::Both { right_first } => {
                        let (near, far) = if right_first {
                            (left + 1, left)
                        } else {
                            (left, left + 1)
                        };
                        level >>= 1;
                        if trail & level != 0 {
                            node = far;
                        } else {
                            node = near;
                            push(&mut short, &mut head, far);
                        }
                        continue;
                    }
                    Children::One { right } => {
                        level >>= 1;
                        if level != pop_level {
                            trail |= level;
                            node = left + right as u32;
                            continue;
                        }
                        // At the pop level with one child hit: the far child
                        // (the pop target) is culled now; the near one is done.
                    }
                    Children::None => {}
                },
                Step::Leaf => {}
                Step::Done => break,
            }
            // Pop: mark this level finished; the carry runs through the
            // finished levels to the deepest pending one.
            trail &= level.wrapping_neg();
            trail = trail.wrapping_add(level);
            if trail & ROOT_LEVEL != 0 {
                break;
            }
            level = trail & trail.wrapping_neg();
            pop_level = level;
            if K > 0 && head > 0 {
                head -= 1;
                node = short[head];
            } else if K >= 4 {
                node = 0;
                level = ROOT_LEVEL;
            } else {
                // Through the path's nodes above the pop target's parent,
                // pushing the far child where the trail has it pending.
                let parent = depth(pop_level) - 1;
                for d in 0..parent {
                    let left =
                        w.pass_inner(at[d] as usize, BinaryNode::target, || sp.id(at[d]), stats);
                    let next = at[d + 1];
                    if trail & (ROOT_LEVEL >> (d + 1)) == 0 {
                        push(&mut short, &mut head, 2 * left + 1 - next);
                    }
                }
                node = at[parent];
                level = pop_level << 1;
            }
        }
        w.finish(stats)
    }

    /// Whether the kernel and the plain walk agree on `r` (visits, work,
    /// hit); true when the walk visited some node twice (it restarted).
    fn agree<L: SparseLayout, const ANY: bool, const K: usize>(l: &L, r: &Ray) -> bool {
        let (mut la, mut lb) = (VisitLog::default(), VisitLog::default());
        let ha = super::trace::<L, VisitLog, ANY, K>(l, r, &mut la);
        let hb = plain::<L, VisitLog, ANY, K>(l, r, &mut lb);
        assert_eq!(ha, hb, "K = {K}, any {ANY}, ray {r:?}");
        assert_eq!(la.visits, lb.visits, "K = {K}, any {ANY}, ray {r:?}");
        assert_eq!(la.counters, lb.counters, "K = {K}, any {ANY}, ray {r:?}");
        let mut seen = la.visits.clone();
        seen.sort_unstable();
        seen.dedup();
        seen.len() < la.visits.len()
    }

    fn compare<L: SparseLayout, const K: usize>(l: &L, rays: &[Ray]) -> usize {
        rays.iter()
            .map(|r| agree::<L, false, K>(l, r) as usize + agree::<L, true, K>(l, r) as usize)
            .sum()
    }

    /// The kernel's restarts (through the path's nodes untested, along
    /// `path`, then the pop target's parent tested) visit exactly the nodes
    /// the reference trail walk visits,
    /// count the same work and return the same hits, on both node records,
    /// every short stack size, closest and any hit.
    #[test]
    fn restarts_visit_what_the_plain_trail_walk_visits() {
        for spec in ["chess:4000", "hairball:3000"] {
            let scene = Scene::builtin(spec).unwrap();
            let bvh = Bvh::build(&scene.triangles, &BuildOptions::hybrid());
            let sp = Arc::new(SparseBvh::from_bvh(&bvh, scene.triangles.clone()).unwrap());
            let pa = PairedBvh::from_sparse(sp.clone());
            let bin = BinaryBvh::from_bvh(&bvh, scene.triangles.clone()).unwrap();
            let eye = rayset::eye_rays(&scene, 40, 30, 1);
            let radius = 0.2 * scene.mesh.bounds().extent().length();
            let ao = rayset::ao_rays(&scene, &bin, &eye, 4, radius);
            let rays: Vec<Ray> = eye.iter().chain(&ao).copied().collect();
            let restarted = compare::<SparseBvh, 0>(&sp, &rays)
                + compare::<PairedBvh, 0>(&pa, &rays)
                + compare::<SparseBvh, 1>(&sp, &rays)
                + compare::<PairedBvh, 2>(&pa, &rays)
                + compare::<SparseBvh, 4>(&sp, &rays)
                + compare::<PairedBvh, 8>(&pa, &rays);
            // Most rays restart at least once (a node visited twice).
            assert!(
                restarted > rays.len(),
                "{spec}: {restarted} walks restarted"
            );
        }
    }

    /// Pushes `n` entries onto a `K`-entry short stack and pops it empty.
    fn drain<const K: usize>(n: u32) -> Vec<u32> {
        let mut st = ShortStack::<K>::default();
        (0..n).for_each(|i| st.push(i));
        std::iter::from_fn(|| st.pop()).collect()
    }

    #[test]
    fn short_stack_keeps_the_newest_k_entries() {
        // Both forms (ring below 4, plain stack at 4 and 8) pop the newest
        // entries first and drop the oldest once full.
        assert_eq!(drain::<0>(5), Vec::<u32>::new());
        assert_eq!(drain::<1>(5), vec![4]);
        assert_eq!(drain::<2>(5), vec![4, 3]);
        assert_eq!(drain::<4>(3), vec![2, 1, 0]);
        assert_eq!(drain::<4>(7), vec![6, 5, 4, 3]);
        assert_eq!(drain::<8>(8), (0..8).rev().collect::<Vec<_>>());
        assert_eq!(drain::<8>(20), (12..20).rev().collect::<Vec<_>>());
        // Interleaved: a pop after an overflowing push returns the newest.
        let mut st = ShortStack::<8>::default();
        (0..10).for_each(|i| st.push(i));
        assert_eq!(st.pop(), Some(9));
        st.push(42);
        assert_eq!(st.pop(), Some(42));
        assert_eq!(st.pop(), Some(8));
    }
}
