//! The SAH-optimal collapse of a binary BVH into a `W`-wide one (Ylitie,
//! Karras and Laine 2017, "Efficient Incoherent Ray Traversal on GPUs Through
//! Compressed Wide BVHs", §3.1), whose leaves are the binary tree's leaves or
//! small binary subtrees merged into one leaf.
//!
//! `slots(n, k)` is the least SAH cost of covering binary subtree `n` with at
//! most `k` children of a wide node, each a leaf or a wide node:
//! - a leaf: its triangle blocks' cost, whatever `k`;
//! - an inner node: `slots(n, 1)` is the better of the node itself made a
//!   wide node (its node cost plus the best split of `W` slots between its
//!   two children) and, when its subtree holds at most [`MERGED_LEAF`]
//!   triangle references, the subtree made one leaf; for `k ≥ 2` the better
//!   of `slots(n, k − 1)` and the best split of `k` slots between its
//!   children (`n` dissolved into its parent).
//!
//! Costs are areas relative to the root's times [`NODE_COST`] per node and
//! [`BLOCK_COST`] per block of four triangles: a leaf is tested a block at a
//! time (`shared/tri_block`), so a leaf of one triangle costs what one of
//! four does, and merging small sibling leaves into one block saves both a
//! block test and a child slot.

use crate::bvh::{Bvh, NodeKind, ROOT};
use crate::structures::shared::tri_block::LANES;

/// SAH cost of visiting a node.
pub const NODE_COST: f32 = 1.0;
/// SAH cost of testing one block of [`LANES`] triangles: four times the
/// paper's 0.3 per triangle.
pub const BLOCK_COST: f32 = 1.2;
/// The most triangle references a subtree may hold to be merged into one
/// leaf (two blocks).
pub const MERGED_LEAF: u32 = 8;

/// The SAH cost of a leaf of `count` triangle references and relative area
/// `area`.
fn leaf_cost(area: f32, count: u32) -> f32 {
    BLOCK_COST * area * count.div_ceil(LANES as u32) as f32
}

/// The collapse's choices for every binary node.
pub struct Plan {
    /// `slots[n][k - 1]`: see the module docs (k = 1..=8).
    slots: Vec<[f32; 8]>,
    /// `choice[n][k - 1]` for k ≥ 2: 0 if `k − 1` slots do as well, else the
    /// slots given to the left child.
    choice: Vec<[u8; 8]>,
    /// The left child's share of the `W` slots when `n` is a wide node.
    wide_split: Vec<u8>,
    /// Inner binary nodes whose subtree becomes one leaf.
    merged: Vec<bool>,
    /// The wide tree's SAH cost.
    pub cost: f64,
    /// The width the plan was made for.
    width: usize,
}

/// Plans the collapse of `bvh` into `W`-wide nodes (`W` ≤ 8).
pub fn plan<const W: usize>(bvh: &Bvh) -> Plan {
    let n = bvh.nodes.len();
    let root_area = bvh.bounds().area().max(f32::MIN_POSITIVE);
    let mut p = Plan {
        slots: vec![[0.0; 8]; n],
        choice: vec![[0; 8]; n],
        wide_split: vec![0; n],
        merged: vec![false; n],
        cost: 0.0,
        width: W,
    };
    // Triangle references below each node.
    let mut refs = vec![0u32; n];
    // Children follow their parents (preorder): go backwards.
    for id in (0..n).rev() {
        let node = &bvh.nodes[id];
        let area = node.bounds.area() / root_area;
        match node.kind {
            NodeKind::Leaf { count, .. } => {
                refs[id] = count;
                p.slots[id] = [leaf_cost(area, count); 8];
            }
            NodeKind::Inner { left, right, .. } => {
                let (l, r) = (&p.slots[left as usize], &p.slots[right as usize]);
                // The best split of k slots between the children.
                let split = |k: usize| {
                    (1..k)
                        .map(|i| (l[i - 1] + r[k - i - 1], i as u8))
                        .fold((f32::INFINITY, 0), |a, b| if b.0 < a.0 { b } else { a })
                };
                let (w_cost, w_i) = split(W);
                let mut slots = [0.0; 8];
                let mut choice = [0; 8];
                slots[0] = NODE_COST * area + w_cost;
                refs[id] = refs[left as usize].saturating_add(refs[right as usize]);
                if refs[id] <= MERGED_LEAF {
                    let merged = leaf_cost(area, refs[id]);
                    if merged < slots[0] {
                        slots[0] = merged;
                        p.merged[id] = true;
                    }
                }
                for k in 2..=W {
                    let (c, i) = split(k);
                    if c < slots[k - 2] {
                        slots[k - 1] = c;
                        choice[k - 1] = i;
                    } else {
                        slots[k - 1] = slots[k - 2];
                    }
                }
                p.slots[id] = slots;
                p.choice[id] = choice;
                p.wide_split[id] = w_i;
            }
        }
    }
    p.cost = p.slots[ROOT as usize][0] as f64;
    p
}

impl Plan {
    /// The triangles of binary node `id` if it becomes a leaf of the wide
    /// tree: a binary leaf's own, or a merged subtree's in the order of its
    /// leaves, each triangle once (a spatial-split build may list one in
    /// several leaves). `None` if it becomes a wide node.
    pub fn leaf(&self, bvh: &Bvh, id: u32) -> Option<Vec<u32>> {
        let node = &bvh.nodes[id as usize];
        if node.is_leaf() {
            return Some(bvh.leaf_prims(node).to_vec());
        }
        if !self.merged[id as usize] {
            return None;
        }
        let mut prims = Vec::new();
        let mut todo = vec![id];
        while let Some(x) = todo.pop() {
            let n = &bvh.nodes[x as usize];
            match n.children() {
                Some([l, r]) => todo.extend([r, l]),
                None => {
                    for &p in bvh.leaf_prims(n) {
                        if !prims.contains(&p) {
                            prims.push(p);
                        }
                    }
                }
            }
        }
        Some(prims)
    }

    /// The children (binary node ids) of the wide node made from inner
    /// binary node `id`: at most `W`, each a leaf or a future wide node.
    pub fn children(&self, bvh: &Bvh, id: u32) -> Vec<u32> {
        let mut out = Vec::with_capacity(8);
        let [l, r] = bvh.nodes[id as usize].children().expect("an inner node");
        let i = self.wide_split[id as usize] as usize;
        let w = self.width;
        self.take(bvh, l, i, &mut out);
        self.take(bvh, r, w - i, &mut out);
        out
    }

    /// Appends the subtrees covering `x` with at most `k` slots.
    fn take(&self, bvh: &Bvh, x: u32, k: usize, out: &mut Vec<u32>) {
        let node = &bvh.nodes[x as usize];
        if k <= 1 || node.is_leaf() || self.merged[x as usize] {
            out.push(x);
            return;
        }
        let i = self.choice[x as usize][k - 1] as usize;
        if i == 0 {
            return self.take(bvh, x, k - 1, out);
        }
        let [l, r] = node.children().expect("an inner node");
        self.take(bvh, l, i, out);
        self.take(bvh, r, k - i, out);
    }
}

/// The SAH cost of `bvh` itself under the same constants: an upper bound of
/// any collapse's.
#[cfg(test)]
pub fn binary_cost(bvh: &Bvh) -> f64 {
    let root_area = bvh.bounds().area().max(f32::MIN_POSITIVE) as f64;
    bvh.nodes
        .iter()
        .map(|n| {
            let a = n.bounds.area() as f64 / root_area;
            match n.kind {
                NodeKind::Leaf { count, .. } => leaf_cost(1.0, count) as f64 * a,
                NodeKind::Inner { .. } => NODE_COST as f64 * a,
            }
        })
        .sum()
}
