//! The 32-byte node of the stackless paper's layouts: a node holds its own
//! box, so that an inner node's children are tested by reading the two
//! adjacent sibling nodes.

use super::leaf::enter;
use super::tri_block::LeafBlocks;
use crate::geometry::{BoxRay, Hit, Ray, Triangle};
use crate::stats::{Stats, Tally};
use bytemuck::{Pod, Zeroable};

/// `bounds` is `[min xyz, max xyz]`. `link`: bit 31 set for a leaf; bits
/// 0–30 the left child's index (the right child follows it) or the leaf's
/// first position in the triangle index list (sign-bit terminated). `extra`
/// belongs to the layout: parent link and split axis in the sparse layout,
/// the canonical node id in the implicit one.
#[repr(C, align(32))]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct OwnBoxNode {
    /// The node's own box, `[min xyz, max xyz]`, in scene units.
    pub bounds: [f32; 6],
    /// Bit 31: leaf; bits 0–30: left child's slot or first index-list position.
    pub link: u32,
    /// The layout's word: parent and axis (sparse) or canonical id (implicit).
    pub extra: u32,
}

/// `link` bit of a leaf.
pub(crate) const LEAF: u32 = 1 << 31;

impl OwnBoxNode {
    /// Ray-plane tests of one box test: an own-box node holds 6 planes.
    pub const PLANES: u32 = 6;

    /// Whether `link`'s bit 31 marks a leaf.
    #[inline(always)]
    pub fn is_leaf(&self) -> bool {
        self.link & LEAF != 0
    }

    /// Left child (inner) or first index-list position (leaf).
    #[inline(always)]
    pub fn target(&self) -> u32 {
        self.link & !LEAF
    }
}

/// A binary node record the walks step through ([`Walk`]): whether it is a
/// leaf, its target (left child's slot or first leaf-list position), and
/// where its two children's boxes are read from: their own records
/// ([`OwnBoxNode`]) or the node's ([`ChildBoxNode`]).
pub trait BinaryNode: Copy + Send + Sync + 'static {
    /// Whether the record is a leaf.
    fn is_leaf(&self) -> bool;
    /// Left child's slot (inner) or first index-list position (leaf).
    fn target(&self) -> u32;
    /// Which children of inner node `nodes[node]`, whose left child is at
    /// slot `left`, the ray enters within `[tmin, tmax]`.
    fn enter_children(
        br: &BoxRay,
        nodes: &[Self],
        node: usize,
        left: usize,
        tmin: f32,
        tmax: f32,
    ) -> Children;
    /// [`Self::enter_children`] as a hit mask (bit 0 the left child, bit 1
    /// the right) and the entry distances `(tl, tr)`, meaningful where
    /// the mask is set: the same decision, for walks that compare it with
    /// an expected one rather than branch on it.
    fn enter_mask(
        br: &BoxRay,
        nodes: &[Self],
        node: usize,
        left: usize,
        tmin: f32,
        tmax: f32,
    ) -> (u32, f32, f32);
}

impl BinaryNode for OwnBoxNode {
    #[inline(always)]
    fn is_leaf(&self) -> bool {
        OwnBoxNode::is_leaf(self)
    }
    #[inline(always)]
    fn target(&self) -> u32 {
        OwnBoxNode::target(self)
    }
    /// [`Children::of`] the two children's own box tests.
    #[inline(always)]
    fn enter_children(
        br: &BoxRay,
        nodes: &[Self],
        _node: usize,
        left: usize,
        tmin: f32,
        tmax: f32,
    ) -> Children {
        let [tl, tr] = test_children(br, nodes, left, tmin, tmax);
        Children::of(tl, tr)
    }
    #[inline(always)]
    fn enter_mask(
        br: &BoxRay,
        nodes: &[Self],
        _node: usize,
        left: usize,
        tmin: f32,
        tmax: f32,
    ) -> (u32, f32, f32) {
        let [tl, tr] = test_children(br, nodes, left, tmin, tmax);
        let hit = (tl != f32::INFINITY) as u32 | ((tr != f32::INFINITY) as u32) << 1;
        (hit, tl, tr)
    }
}

/// The 64-byte node of the stackless paper's own tracer (its supplemental
/// `Bvh::Node`: kind, parent, first, last and both children's boxes, 64
/// bytes, cache-line aligned): a node holds its two children's boxes, so a
/// step reads one record, and a parent link. `planes` are the children's
/// boxes per axis, `[lo_left, lo_right, hi_left, hi_right]` for x, y, z
/// (as [`BoxRay::test_pair`] reads them; zeros in a leaf); `link` and
/// `extra` as in [`OwnBoxNode`].
#[repr(C, align(64))]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct ChildBoxNode {
    /// Both children's boxes per axis, in scene units (zeros in a leaf).
    pub planes: [f32; 12],
    /// Bit 31: leaf; bits 0–30: left child's slot or first index-list position.
    pub link: u32,
    /// The layout's word: parent and axis (sparse layout).
    pub extra: u32,
    /// Skip links in what would be the cache line's padding: the slots of
    /// the ancestors 2 and 4 levels up (0 where there is none), so that
    /// SPARSE's ascent of `k` levels takes `k/4 + (k%4)/2 + k%2` dependent
    /// loads instead of `k` ([`crate::structures::sparse::PairedBvh`]).
    pub skip: [u32; 2],
}

impl BinaryNode for ChildBoxNode {
    #[inline(always)]
    fn is_leaf(&self) -> bool {
        self.link & LEAF != 0
    }
    #[inline(always)]
    fn target(&self) -> u32 {
        self.link & !LEAF
    }
    /// From the pair test's hit mask ([`BoxRay::test_pair_mask`]): the same
    /// decision as [`Children::of`] on its distances, with one comparison
    /// less on the path to the branch.
    #[inline(always)]
    fn enter_children(
        br: &BoxRay,
        nodes: &[Self],
        node: usize,
        _left: usize,
        tmin: f32,
        tmax: f32,
    ) -> Children {
        let (hit, t) = br.test_pair_mask(&nodes[node].planes, tmin, tmax);
        Children::of_mask(hit, t.x, t.y)
    }
    #[inline(always)]
    fn enter_mask(
        br: &BoxRay,
        nodes: &[Self],
        node: usize,
        _left: usize,
        tmin: f32,
        tmax: f32,
    ) -> (u32, f32, f32) {
        let (hit, t) = br.test_pair_mask(&nodes[node].planes, tmin, tmax);
        (hit, t.x, t.y)
    }
}

/// Entry distances (`+inf` on a miss) of the sibling pair whose left node is
/// `nodes[left]`.
#[inline(always)]
pub fn test_children(
    br: &BoxRay,
    nodes: &[OwnBoxNode],
    left: usize,
    tmin: f32,
    tmax: f32,
) -> [f32; 2] {
    let pair: &[OwnBoxNode; 2] = nodes[left..left + 2].try_into().unwrap();
    [
        br.test(&pair[0].bounds, tmin, tmax),
        br.test(&pair[1].bounds, tmin, tmax),
    ]
}

/// `if_true` or `if_false` as `b` says, chosen by a branch. Written as a
/// plain `if` or `b as u32`, LLVM computes
/// the child a walk goes to next (`left + right as u32`) by arithmetic on
/// the box test's comparison, so the next node's load waits for the whole
/// test; a branch, predicted right most of the time, lets the load start
/// at once. The cold-path hint on one arm is what keeps the branch (LLVM
/// would fold two plain arms back into the arithmetic); it does not say the
/// arm is rare. STACK on the paired nodes took 0.61x, on the own-box nodes
/// 0.57x its time with it (issue 26, `examples/paper_speed`).
#[inline(always)]
pub fn branch_pick(b: bool, if_true: u32, if_false: u32) -> u32 {
    if b {
        std::hint::cold_path();
        if_true
    } else {
        if_false
    }
}

/// Which of an inner node's two children a ray enters, from their entry
/// distances (`+inf` for a miss). Ties go to the left child.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Children {
    /// Both: the right one is nearer when `right_first`.
    Both {
        /// The right child's entry distance is the smaller (ties go left).
        right_first: bool,
    },
    /// Only the right one (`right`) or only the left one.
    One {
        /// The one entered is the right child.
        right: bool,
    },
    /// Neither.
    None,
}

impl Children {
    /// Classifies the entry distances `tl`, `tr` of the left and right child.
    #[inline(always)]
    pub fn of(tl: f32, tr: f32) -> Children {
        let (hit_l, hit_r) = (tl != f32::INFINITY, tr != f32::INFINITY);
        // Both hit, one hit, none: three plain branches. Choosing the near
        // child by distance only when both are hit measured 1.5× faster than
        // one select covering both cases.
        if hit_l && hit_r {
            Children::Both {
                right_first: tr < tl,
            }
        } else if hit_l || hit_r {
            Children::One { right: hit_r }
        } else {
            Children::None
        }
    }

    /// [`Self::of`] from a hit mask (bit 0 the left child, bit 1 the right)
    /// and the entry distances `tl`, `tr`, read only where hit
    /// ([`BoxRay::test_pair_mask`]).
    #[inline(always)]
    pub fn of_mask(hit: u32, tl: f32, tr: f32) -> Children {
        match hit {
            3 => Children::Both {
                right_first: tr < tl,
            },
            0 => Children::None,
            _ => Children::One { right: hit == 2 },
        }
    }
}

/// What the node step found, and so where a traversal goes next.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Step {
    /// An inner node whose children (the pair starting at slot `left`) were
    /// tested.
    Inner {
        /// Slot of the left child; the right one is at `left + 1`.
        left: u32,
        /// Which children the ray enters, and in which order.
        children: Children,
    },
    /// A leaf whose triangles were tested: the traversal goes on elsewhere.
    Leaf,
    /// Any hit (`ANY = true`) found: the traversal ends.
    Done,
}

/// One ray's walk over own-box nodes: the state that STACK, SPARSE,
/// LAINE-k and IMPLICIT-A/B share (the ray's box constants, its interval,
/// the closest hit so far, its tally) and the node step they all take. Each
/// traversal keeps only its own state (a stack, a level index, a trail)
/// beside it.
pub struct Walk<'a, const ANY: bool, N: BinaryNode = OwnBoxNode> {
    br: BoxRay,
    ray: &'a Ray,
    tmin: f32,
    tmax: f32,
    best: Option<Hit>,
    tally: Tally,
    nodes: &'a [N],
    leaves: &'a LeafBlocks,
    triangles: &'a [Triangle],
}

impl<'a, const ANY: bool, N: BinaryNode> Walk<'a, ANY, N> {
    /// Tests the root's box `root` (`[min xyz, max xyz]`, 6 plane tests);
    /// `None` when the ray misses it (its tally then handed to `stats`).
    /// `leaves` holds the leaf list's triangle blocks and `triangles` the
    /// mesh's.
    #[inline(always)]
    pub fn enter<S: Stats>(
        ray: &'a Ray,
        nodes: &'a [N],
        root: &[f32; 6],
        leaves: &'a LeafBlocks,
        triangles: &'a [Triangle],
        stats: &mut S,
    ) -> Option<Self> {
        let (br, tally) = enter(ray, root, stats)?;
        Some(Walk {
            br,
            ray,
            tmin: ray.tmin,
            tmax: ray.tmax,
            best: None,
            tally,
            nodes,
            leaves,
            triangles,
        })
    }

    /// Visits `nodes[node]`: a leaf's triangles are tested, an inner node's
    /// two children (the pair at slot `children(node)`) are tested against
    /// the ray shortened to the closest hit so far. `id` gives the node's
    /// canonical id, asked only when `stats` logs visits.
    #[inline(always)]
    pub fn step<S: Stats>(
        &mut self,
        node: usize,
        children: impl FnOnce(&N) -> u32,
        id: impl FnOnce() -> u32,
        stats: &mut S,
    ) -> Step {
        let n = &self.nodes[node];
        self.tally.nodes += 1;
        if S::LOGS {
            stats.visit(id());
        }
        if n.is_leaf() {
            if self.leaves.intersect::<ANY, S>(
                n.target(),
                self.triangles,
                self.ray,
                &mut self.tmax,
                &mut self.best,
                &mut self.tally,
                stats,
            ) {
                return Step::Done;
            }
            return Step::Leaf;
        }
        self.tally.planes += 2 * OwnBoxNode::PLANES;
        let left = children(n);
        let children = N::enter_children(
            &self.br,
            self.nodes,
            node,
            left as usize,
            self.tmin,
            self.tmax,
        );
        Step::Inner { left, children }
    }

    /// [`Self::step`] at a node known to be inner (a restart's descent
    /// above its pop level): the same visit, counts and test, returned as
    /// the left child's slot and [`BinaryNode::enter_mask`]'s mask and
    /// distances. [`Children::of_mask`] of them is what `step` returns.
    /// Written out beside `step` rather than shared with it: `step` built
    /// on this (and `enter_children` on `enter_mask`) took 1.1x the time of
    /// every walk over these nodes, STACK included.
    #[inline(always)]
    pub fn step_inner<S: Stats>(
        &mut self,
        node: usize,
        children: impl FnOnce(&N) -> u32,
        id: impl FnOnce() -> u32,
        stats: &mut S,
    ) -> (u32, u32, f32, f32) {
        let n = &self.nodes[node];
        debug_assert!(!n.is_leaf());
        self.tally.nodes += 1;
        if S::LOGS {
            stats.visit(id());
        }
        self.tally.planes += 2 * OwnBoxNode::PLANES;
        let left = children(n);
        let (hit, tl, tr) = N::enter_mask(
            &self.br,
            self.nodes,
            node,
            left as usize,
            self.tmin,
            self.tmax,
        );
        (left, hit, tl, tr)
    }

    /// Passes through inner node `node` without testing its children's
    /// boxes (a visit, no plane tests): its left child's slot. For a
    /// descent whose turns are already known (LAINE's restarts, whose
    /// ancestors' boxes hold the boxes tested further down).
    #[inline(always)]
    pub fn pass_inner<S: Stats>(
        &mut self,
        node: usize,
        children: impl FnOnce(&N) -> u32,
        id: impl FnOnce() -> u32,
        stats: &mut S,
    ) -> u32 {
        let n = &self.nodes[node];
        debug_assert!(!n.is_leaf());
        self.tally.nodes += 1;
        if S::LOGS {
            stats.visit(id());
        }
        children(n)
    }

    /// Ends the walk: hands the tally to `stats` and returns the hit.
    #[inline(always)]
    pub fn finish<S: Stats>(self, stats: &mut S) -> Option<Hit> {
        stats.add(self.tally);
        self.best
    }
}

#[cfg(test)]
mod tests {
    #[test]
    fn is_32_bytes() {
        assert_eq!(std::mem::size_of::<super::OwnBoxNode>(), 32);
        assert_eq!(std::mem::align_of::<super::OwnBoxNode>(), 32);
    }

    #[test]
    fn child_box_node_is_one_cache_line() {
        assert_eq!(std::mem::size_of::<super::ChildBoxNode>(), 64);
        assert_eq!(std::mem::align_of::<super::ChildBoxNode>(), 64);
    }
}
