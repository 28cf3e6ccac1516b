//! Tree optimization by reinsertion (Bittner, Hapala and Havran 2013,
//! "Fast Insertion-Based Optimization of Bounding Volume Hierarchies").
//!
//! A round takes the inner nodes that fit their children worst (§4.1: the
//! product of `A(N) / A(children)`'s mean, `A(N) / min A(child)` and
//! `A(N)`), and for each in turn removes it and its parent from the tree
//! (the sibling takes the parent's place) and reinserts its two children,
//! larger box first, each where it adds the least SAH cost: a branch and
//! bound search from the root (§4.2) keeping, per candidate, the cost its
//! ancestors' boxes would grow by (the *induced* cost) in a priority queue,
//! and stopping when the smallest possible cost of what remains in the
//! queue is no better than the best place found. The two freed nodes become
//! the new parents. Leaves are moved whole, so the optimized tree holds the
//! same leaves, each with the same triangle references, as the input.
//!
//! The search is sequential (Meister and Bittner 2022's parallel form,
//! which removes and reinserts many nodes at once, is not implemented).
//! After each round the tree's SAH cost is measured; the cheapest tree seen
//! is kept, so the result never costs more than the input, and the pass
//! ends after [`OptimizeOptions::max_rounds`] rounds or when a round does
//! not improve the cost by at least 0.1%. A tree deeper than
//! [`MAX_DEPTH`] (or the input's depth, if deeper) is not kept.

use super::{Bvh, Node, NodeKind, NO_PARENT};
use crate::geometry::Aabb;
use serde::Serialize;
use std::cmp::Ordering;
use std::collections::BinaryHeap;
use std::time::Instant;

/// The deepest optimized tree kept (the traversals' stacks hold 128 levels).
pub const MAX_DEPTH: u32 = 96;

const NONE: u32 = u32::MAX;

/// How an optimization pass runs; [`OptimizeOptions::default`] gives the
/// defaults.
#[derive(Clone, Debug)]
pub struct OptimizeOptions {
    /// Rounds at most (default 32).
    pub max_rounds: usize,
    /// Share of the inner nodes removed and reinserted per round (default
    /// 0.02).
    pub batch: f64,
}

impl Default for OptimizeOptions {
    fn default() -> Self {
        OptimizeOptions {
            max_rounds: 32,
            batch: 0.02,
        }
    }
}

/// What an optimization pass reports.
#[derive(Clone, Debug, Default, Serialize)]
pub struct OptimizeStats {
    /// SAH cost of the tree before the pass.
    pub sah_cost_before: f64,
    /// SAH cost after it (never more than before).
    pub sah_cost_after: f64,
    /// Rounds run.
    pub rounds: usize,
    /// Nodes removed and their children reinserted.
    pub reinsertions: usize,
    /// Wall-clock time of the pass, in seconds.
    pub seconds: f64,
}

fn area(b: &Aabb) -> f64 {
    if b.is_empty() {
        return 0.0;
    }
    let e = (b.max - b.min).as_dvec3();
    2.0 * (e.x * e.y + e.y * e.z + e.z * e.x)
}

/// The tree as links, leaves pointing at their node in the input.
#[derive(Clone)]
struct Tree {
    root: u32,
    parent: Vec<u32>,
    kids: Vec<[u32; 2]>,
    bounds: Vec<Aabb>,
    /// Triangles of a leaf (`kids[i] == [NONE, NONE]`), 0 for inner nodes.
    count: Vec<u32>,
}

impl Tree {
    fn of(bvh: &Bvh) -> Tree {
        let n = bvh.nodes.len();
        let mut t = Tree {
            root: 0,
            parent: bvh.nodes.iter().map(|n| n.parent).collect(),
            kids: vec![[NONE; 2]; n],
            bounds: bvh.nodes.iter().map(|n| n.bounds).collect(),
            count: vec![0; n],
        };
        for (i, node) in bvh.nodes.iter().enumerate() {
            match node.kind {
                NodeKind::Inner { left, right, .. } => t.kids[i] = [left, right],
                NodeKind::Leaf { count, .. } => t.count[i] = count,
            }
        }
        t
    }

    fn is_leaf(&self, i: u32) -> bool {
        self.kids[i as usize][0] == NONE
    }

    /// Unnormalized SAH cost: inner areas plus leaf areas times triangles.
    fn cost(&self) -> f64 {
        (0..self.kids.len())
            .map(|i| {
                let a = area(&self.bounds[i]);
                if self.kids[i][0] == NONE {
                    a * self.count[i] as f64
                } else {
                    a
                }
            })
            .sum()
    }

    fn depth(&self) -> u32 {
        let mut deepest = 0;
        let mut todo = vec![(self.root, 0u32)];
        while let Some((i, d)) = todo.pop() {
            deepest = deepest.max(d);
            if !self.is_leaf(i) {
                for k in self.kids[i as usize] {
                    todo.push((k, d + 1));
                }
            }
        }
        deepest
    }

    fn replace_child(&mut self, p: u32, old: u32, new: u32) {
        let k = &mut self.kids[p as usize];
        if k[0] == old {
            k[0] = new;
        } else {
            debug_assert_eq!(k[1], old);
            k[1] = new;
        }
    }

    /// Recomputes boxes from `i` up while they change.
    fn refit(&mut self, mut i: u32) {
        while i != NONE {
            let [l, r] = self.kids[i as usize];
            let b = self.bounds[l as usize].union(self.bounds[r as usize]);
            if b == self.bounds[i as usize] {
                break;
            }
            self.bounds[i as usize] = b;
            i = self.parent[i as usize];
        }
    }

    /// Bittner et al.'s inefficiency measure of inner node `i`.
    fn inefficiency(&self, i: usize) -> f64 {
        let a = area(&self.bounds[i]);
        let [l, r] = self.kids[i];
        let (al, ar) = (
            area(&self.bounds[l as usize]),
            area(&self.bounds[r as usize]),
        );
        let m_sum = a / (0.5 * (al + ar)).max(f64::MIN_POSITIVE);
        let m_min = a / al.min(ar).max(f64::MIN_POSITIVE);
        m_sum * m_min * a
    }

    /// The node whose sibling a subtree with box `b` is best inserted as
    /// (§4.2: least direct plus induced cost, branch and bound).
    fn best_position(&self, b: &Aabb) -> u32 {
        #[derive(PartialEq)]
        struct Item(f64, u32);
        impl Eq for Item {}
        impl PartialOrd for Item {
            fn partial_cmp(&self, o: &Self) -> Option<Ordering> {
                Some(self.cmp(o))
            }
        }
        impl Ord for Item {
            // Smallest induced cost first; ties by node id.
            fn cmp(&self, o: &Self) -> Ordering {
                o.0.total_cmp(&self.0).then(o.1.cmp(&self.1))
            }
        }
        let ab = area(b);
        let mut heap = BinaryHeap::new();
        heap.push(Item(0.0, self.root));
        let (mut best, mut best_cost) = (self.root, f64::INFINITY);
        while let Some(Item(induced, x)) = heap.pop() {
            if induced + ab >= best_cost {
                break;
            }
            let ax = &self.bounds[x as usize];
            let direct = area(&ax.union(*b));
            let cost = direct + induced;
            if cost < best_cost {
                best_cost = cost;
                best = x;
            }
            let child_induced = cost - area(ax);
            if !self.is_leaf(x) && child_induced + ab < best_cost {
                for k in self.kids[x as usize] {
                    heap.push(Item(child_induced, k));
                }
            }
        }
        best
    }

    /// Makes free node `p` the parent of `x` and `s` at `x`'s place.
    fn insert(&mut self, p: u32, s: u32) {
        let x = self.best_position(&self.bounds[s as usize]);
        let g = self.parent[x as usize];
        self.parent[p as usize] = g;
        self.kids[p as usize] = [x, s];
        self.parent[x as usize] = p;
        self.parent[s as usize] = p;
        self.bounds[p as usize] = self.bounds[x as usize].union(self.bounds[s as usize]);
        if g == NONE {
            self.root = p;
        } else {
            self.replace_child(g, x, p);
            self.refit(g);
        }
    }

    /// Removes inner node `n` and its parent and reinserts `n`'s children;
    /// false when `n` is too near the root to be removed.
    fn reinsert(&mut self, n: u32) -> bool {
        let p = self.parent[n as usize];
        if self.is_leaf(n) || p == NONE || self.parent[p as usize] == NONE {
            return false;
        }
        let g = self.parent[p as usize];
        let [a, b] = self.kids[p as usize];
        let s = if a == n { b } else { a };
        self.replace_child(g, p, s);
        self.parent[s as usize] = g;
        self.refit(g);
        let [l, r] = self.kids[n as usize];
        let (first, second) = if area(&self.bounds[l as usize]) >= area(&self.bounds[r as usize]) {
            (l, r)
        } else {
            (r, l)
        };
        self.insert(p, first);
        self.insert(n, second);
        true
    }
}

/// Runs the pass over `bvh` (see the module's notes); returns the optimized
/// tree, with the input's leaves, and what the pass did.
pub(super) fn optimize(bvh: &Bvh, opts: &OptimizeOptions) -> (Bvh, OptimizeStats) {
    let start = Instant::now();
    let before = bvh.sah_cost();
    let mut stats = OptimizeStats {
        sah_cost_before: before,
        sah_cost_after: before,
        ..Default::default()
    };
    let inner = bvh.stats.inner_nodes;
    if inner < 3 {
        stats.seconds = start.elapsed().as_secs_f64();
        return (bvh.clone(), stats);
    }
    let depth_limit = MAX_DEPTH.max(bvh.stats.depth);
    let mut tree = Tree::of(bvh);
    let mut best_cost = tree.cost();
    let mut best: Option<Tree> = None;
    let batch = ((inner as f64 * opts.batch) as usize).max(1);
    for _ in 0..opts.max_rounds {
        stats.rounds += 1;
        let mut order: Vec<(f64, u32)> = (0..tree.kids.len())
            .filter(|&i| !tree.is_leaf(i as u32))
            .map(|i| (tree.inefficiency(i), i as u32))
            .collect();
        let k = batch.min(order.len());
        order.select_nth_unstable_by(k - 1, |a, b| b.0.total_cmp(&a.0).then(a.1.cmp(&b.1)));
        order.truncate(k);
        order.sort_unstable_by(|a, b| b.0.total_cmp(&a.0).then(a.1.cmp(&b.1)));
        for &(_, n) in &order {
            if tree.reinsert(n) {
                stats.reinsertions += 1;
            }
        }
        let cost = tree.cost();
        let improved = cost < best_cost * (1.0 - 1e-3);
        if cost < best_cost && tree.depth() <= depth_limit {
            best_cost = cost;
            best = Some(tree.clone());
        }
        if !improved {
            break;
        }
    }
    let out = match best {
        None => bvh.clone(),
        Some(t) => flatten(&t, bvh),
    };
    stats.sah_cost_after = out.sah_cost();
    // Rounding in the normalized sums: never report more than before.
    if stats.sah_cost_after > before {
        stats.sah_cost_after = before;
    }
    stats.seconds = start.elapsed().as_secs_f64();
    (out, stats)
}

/// The tree in preorder, leaves listing their input leaves' triangles.
fn flatten(t: &Tree, bvh: &Bvh) -> Bvh {
    let mut nodes: Vec<Node> = Vec::with_capacity(t.kids.len());
    let mut prims = Vec::with_capacity(bvh.prims.len());
    // (tree node, parent id in `nodes`, depth, slot to patch as right child)
    let mut todo = vec![(t.root, NO_PARENT, 0u32)];
    while let Some((i, parent, depth)) = todo.pop() {
        let id = nodes.len() as u32;
        if parent != NO_PARENT {
            // The left child directly follows its parent; patch the right.
            if let NodeKind::Inner {
                left,
                ref mut right,
                ..
            } = nodes[parent as usize].kind
            {
                if id != left {
                    *right = id;
                }
            }
        }
        let bounds = t.bounds[i as usize];
        if t.is_leaf(i) {
            let old = &bvh.nodes[i as usize];
            let p = bvh.leaf_prims(old);
            nodes.push(Node {
                bounds,
                parent,
                depth,
                kind: NodeKind::Leaf {
                    first: prims.len() as u32,
                    count: p.len() as u32,
                },
            });
            prims.extend_from_slice(p);
        } else {
            let [l, r] = t.kids[i as usize];
            let (cl, cr) = (t.bounds[l as usize].center(), t.bounds[r as usize].center());
            let axis = (cr - cl).abs().max_position() as u8;
            nodes.push(Node {
                bounds,
                parent,
                depth,
                kind: NodeKind::Inner {
                    left: id + 1,
                    right: 0,
                    axis,
                },
            });
            todo.push((r, id, depth + 1));
            todo.push((l, id, depth + 1));
        }
    }
    let leaves = nodes.iter().filter(|n| n.is_leaf()).count();
    let mut stats = bvh.stats.clone();
    stats.nodes = nodes.len();
    stats.inner_nodes = nodes.len() - leaves;
    stats.leaves = leaves;
    stats.references = prims.len();
    stats.depth = nodes.iter().map(|n| n.depth).max().unwrap_or(0);
    let mut out = Bvh {
        nodes,
        prims,
        stats,
    };
    out.stats.sah_cost = out.sah_cost();
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bvh::BuildOptions;
    use crate::scene::Scene;

    fn leaves(b: &Bvh) -> Vec<Vec<u32>> {
        let mut l: Vec<Vec<u32>> = b
            .nodes
            .iter()
            .filter(|n| n.is_leaf())
            .map(|n| b.leaf_prims(n).to_vec())
            .collect();
        l.sort();
        l
    }

    #[test]
    fn optimizing_keeps_the_leaves_and_never_costs_more() {
        for spec in ["chess:3000", "hairball:3000", "atrium:3000"] {
            let scene = Scene::builtin(spec).unwrap();
            for opts in [
                BuildOptions::sah(),
                BuildOptions::hybrid(),
                BuildOptions::sbvh(),
            ] {
                let bvh = Bvh::build(&scene.triangles, &opts);
                let (o, s) = optimize(&bvh, &OptimizeOptions::default());
                o.validate(&scene.triangles).unwrap();
                assert_eq!(leaves(&o), leaves(&bvh));
                assert!(s.sah_cost_after <= s.sah_cost_before);
                assert!(o.sah_cost() <= bvh.sah_cost() * (1.0 + 1e-9), "{spec}");
                assert_eq!(o.stats.nodes, bvh.stats.nodes);
            }
        }
    }

    #[test]
    fn the_median_tree_improves() {
        let scene = Scene::builtin("chess:3000").unwrap();
        let mut opts = BuildOptions::hybrid();
        opts.sah_levels = 0;
        let bvh = Bvh::build(&scene.triangles, &opts);
        let (_, s) = optimize(&bvh, &OptimizeOptions::default());
        assert!(s.sah_cost_after < 0.95 * s.sah_cost_before, "{s:?}");
    }
}
