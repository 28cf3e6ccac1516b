//! Traversal algorithms over binary BVH layouts: STACK over the uncompressed
//! layout, and the stackless paper's algorithms with their baselines over
//! the sparse and implicit layouts. Each algorithm is a zero-sized type, and
//! [`OnSparse`] / [`OnImplicit`] pair it with a layout into an [`Accel`].

pub(crate) mod cbvh;
pub(crate) mod dst;
mod hapala;
pub(crate) mod htree;
mod implicit;
pub(crate) mod interval;
mod laine;
pub(crate) mod leaf;
mod sparse;
pub mod stack;

use crate::accel::{Accel, ImplicitBvh, SparseBvh, TraversalKind};
use crate::geometry::{Hit, Ray};
use crate::stats::Stats;
use std::marker::PhantomData;
use std::sync::Arc;

/// The deepest tree a fixed-size traversal stack holds: a stack traversal
/// holds at most one pending node per level.
pub const MAX_STACK_DEPTH: usize = 128;

/// The stack a tree of `depth` levels needs: 32, 64 or 128 entries. Stack
/// traversals are compiled for each size and pick theirs per tree, so that
/// a ray does not pay for clearing a stack deeper than its tree.
pub fn stack_capacity(depth: u32) -> usize {
    match depth {
        0..32 => 32,
        32..64 => 64,
        _ => MAX_STACK_DEPTH,
    }
}

/// Calls `$f::<.., N>($args)` with the stack capacity `N` for `$depth`.
macro_rules! with_stack {
    ($depth:expr, $f:ident::<$($g:ty),*; $any:ident>($($a:expr),*)) => {
        match $crate::traversal::stack_capacity($depth) {
            32 => $f::<$($g,)* $any, 32>($($a),*),
            64 => $f::<$($g,)* $any, 64>($($a),*),
            _ => $f::<$($g,)* $any, 128>($($a),*),
        }
    };
}
pub(crate) use with_stack;

/// An algorithm over the sparse layout.
pub trait SparseAlgorithm: Send + Sync + 'static {
    const KIND: TraversalKind;
    /// Deepest tree the algorithm's integers address.
    const MAX_DEPTH: u32;
    fn trace<S: Stats, const ANY: bool>(
        layout: &SparseBvh,
        ray: &Ray,
        stats: &mut S,
    ) -> Option<Hit>;
}

/// An algorithm over the implicit layout.
pub trait ImplicitAlgorithm: Send + Sync + 'static {
    const KIND: TraversalKind;
    fn trace<S: Stats, const ANY: bool>(
        layout: &ImplicitBvh,
        ray: &Ray,
        stats: &mut S,
    ) -> Option<Hit>;
}

/// STACK over the sparse layout (for ratios on the same nodes).
pub struct StackOnSparse;
/// SPARSE (Algorithm 4).
pub struct Sparse;
/// HAPALA.
pub struct Hapala;
/// LAINE-k with a short stack of `K` (0, 1, 2, 4 or 8) entries.
pub struct Laine<const K: usize>;
/// IMPLICIT-A (Algorithm 2).
pub struct ImplicitA;
/// IMPLICIT-B (Algorithm 3, combined index).
pub struct ImplicitB;

impl SparseAlgorithm for StackOnSparse {
    const KIND: TraversalKind = TraversalKind::Stack;
    const MAX_DEPTH: u32 = MAX_STACK_DEPTH as u32 - 1;
    #[inline(always)]
    fn trace<S: Stats, const ANY: bool>(l: &SparseBvh, r: &Ray, s: &mut S) -> Option<Hit> {
        stack::trace_sparse::<S, ANY>(l, r, s)
    }
}

impl SparseAlgorithm for Sparse {
    const KIND: TraversalKind = TraversalKind::Sparse;
    const MAX_DEPTH: u32 = 63;
    #[inline(always)]
    fn trace<S: Stats, const ANY: bool>(l: &SparseBvh, r: &Ray, s: &mut S) -> Option<Hit> {
        sparse::sparse::<S, ANY>(l, r, s)
    }
}

impl SparseAlgorithm for Hapala {
    const KIND: TraversalKind = TraversalKind::Hapala;
    const MAX_DEPTH: u32 = u32::MAX;
    #[inline(always)]
    fn trace<S: Stats, const ANY: bool>(l: &SparseBvh, r: &Ray, s: &mut S) -> Option<Hit> {
        hapala::hapala::<S, ANY>(l, r, s)
    }
}

impl<const K: usize> SparseAlgorithm for Laine<K> {
    const KIND: TraversalKind = match K {
        0 => TraversalKind::Laine0,
        1 => TraversalKind::Laine1,
        2 => TraversalKind::Laine2,
        4 => TraversalKind::Laine4,
        8 => TraversalKind::Laine8,
        _ => panic!("LAINE-k exists for k = 0, 1, 2, 4, 8"),
    };
    const MAX_DEPTH: u32 = 63;
    #[inline(always)]
    fn trace<S: Stats, const ANY: bool>(l: &SparseBvh, r: &Ray, s: &mut S) -> Option<Hit> {
        laine::laine::<S, ANY, K>(l, r, s)
    }
}

impl ImplicitAlgorithm for ImplicitA {
    const KIND: TraversalKind = TraversalKind::ImplicitA;
    #[inline(always)]
    fn trace<S: Stats, const ANY: bool>(l: &ImplicitBvh, r: &Ray, s: &mut S) -> Option<Hit> {
        implicit::implicit_a::<S, ANY>(l, r, s)
    }
}

impl ImplicitAlgorithm for ImplicitB {
    const KIND: TraversalKind = TraversalKind::ImplicitB;
    #[inline(always)]
    fn trace<S: Stats, const ANY: bool>(l: &ImplicitBvh, r: &Ray, s: &mut S) -> Option<Hit> {
        implicit::implicit_b::<S, ANY>(l, r, s)
    }
}

/// A sparse-layout algorithm with its layout (shared between algorithms).
pub struct OnSparse<A: SparseAlgorithm> {
    pub layout: Arc<SparseBvh>,
    _a: PhantomData<A>,
}

impl<A: SparseAlgorithm> OnSparse<A> {
    /// Refuses a tree deeper than the algorithm addresses.
    pub fn new(layout: Arc<SparseBvh>) -> crate::error::Result<Self> {
        if layout.depth > A::MAX_DEPTH {
            return Err(crate::error::Error::Limit(format!(
                "BVH depth {} exceeds {}'s limit of {} levels; use the hybrid builder (--builder hybrid)",
                layout.depth,
                A::KIND.name(),
                A::MAX_DEPTH
            )));
        }
        Ok(OnSparse {
            layout,
            _a: PhantomData,
        })
    }
}

impl<A: SparseAlgorithm> Accel for OnSparse<A> {
    fn name(&self) -> &'static str {
        "bvh"
    }
    fn bytes(&self) -> usize {
        self.layout.node_bytes() + self.layout.index_bytes()
    }
    fn closest_hit<S: Stats>(&self, ray: &Ray, stats: &mut S) -> Option<Hit> {
        A::trace::<S, false>(&self.layout, ray, stats)
    }
    fn any_hit<S: Stats>(&self, ray: &Ray, stats: &mut S) -> Option<Hit> {
        A::trace::<S, true>(&self.layout, ray, stats)
    }
}

/// An implicit-layout algorithm with its layout.
pub struct OnImplicit<A: ImplicitAlgorithm> {
    pub layout: Arc<ImplicitBvh>,
    _a: PhantomData<A>,
}

impl<A: ImplicitAlgorithm> OnImplicit<A> {
    pub fn new(layout: Arc<ImplicitBvh>) -> Self {
        OnImplicit {
            layout,
            _a: PhantomData,
        }
    }
}

impl<A: ImplicitAlgorithm> Accel for OnImplicit<A> {
    fn name(&self) -> &'static str {
        "bvh"
    }
    /// The resident bytes: the pages that hold nodes, and the index list.
    fn bytes(&self) -> usize {
        self.layout.resident_bytes() + self.layout.index_bytes()
    }
    fn closest_hit<S: Stats>(&self, ray: &Ray, stats: &mut S) -> Option<Hit> {
        A::trace::<S, false>(&self.layout, ray, stats)
    }
    fn any_hit<S: Stats>(&self, ray: &Ray, stats: &mut S) -> Option<Hit> {
        A::trace::<S, true>(&self.layout, ray, stats)
    }
}

/// Traversal state in bytes, counted as the stackless paper's Figure 5
/// counts it: 4 bytes per 32-bit state variable (8 for the 64-bit ones
/// here), and a stack adds its head and 4 bytes per entry (STACK's size
/// follows the tree's depth, see [`stack_capacity`]).
pub fn state_bytes(kind: TraversalKind, depth: u32) -> usize {
    use TraversalKind::*;
    let laine = |k: usize| 4 + 3 * 8 + if k > 0 { 4 + 4 * k } else { 0 };
    match kind {
        // node, stack head, entries
        Stack => 4 + 4 + 4 * stack_capacity(depth),
        // levelStart, levelIndex, swapMask
        ImplicitA => 3 * 4,
        // index, levelIndex
        ImplicitB => 2 * 4,
        // node, 64-bit levelIndex
        Sparse => 4 + 8,
        // cur, state
        Hapala => 2 * 4,
        // node, 64-bit trail, level and popLevel, short stack
        Laine0 => laine(0),
        Laine1 => laine(1),
        Laine2 => laine(2),
        Laine4 => laine(4),
        Laine8 => laine(8),
    }
}
