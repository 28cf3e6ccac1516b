//! The implicit layout of the stackless paper (its §2): the node at heap
//! position `i` has its children at `2i + 1` and `2i + 2`; positions of
//! missing nodes are gaps. The whole address space is reserved as one
//! anonymous mapping without swap reservation, and only the pages that hold
//! nodes are ever touched, so the gaps cost address space, not memory.
//!
//! Position `p` is stored in slot `p + 1`, so that every sibling pair
//! (`2i + 1`, `2i + 2`) starts on a 64-byte boundary: one cache line.
//! Nodes are [`OwnBoxNode`]s whose `extra` word holds the canonical id.

mod saved;
mod traverse;

use super::shared::own_box::{OwnBoxNode, LEAF};
use super::{Accel, TraversalKind};
use crate::bvh::{Bvh, NodeKind, ROOT};
use crate::error::{Error, Result};
use crate::geometry::{Aabb, Triangle};
use crate::geometry::{Hit, Ray};
use crate::stats::Stats;
use crate::structures::shared::tri_block::LeafBlocks;
use memmap2::{MmapMut, MmapOptions};
use std::marker::PhantomData;
use std::sync::Arc;

/// The deepest tree the traversals' 32-bit indices address: a node at depth
/// `d` has position below `2^(d+1) - 1`, and IMPLICIT-B's combined index
/// `2^d + levelIndex` must fit 32 bits.
pub const MAX_DEPTH: u32 = 30;
/// Default limit on the reserved address space: 64 GiB.
pub const DEFAULT_RESERVATION_LIMIT: u64 = 64 << 30;

const PAGE: usize = 4096;

/// The canonical BVH at heap positions, in [`OwnBoxNode`]s (32 bytes each) of
/// one reserved mapping of 32 × 2^(depth+1) bytes; see the module docs.
pub struct ImplicitBvh {
    map: MmapMut,
    pub(crate) index: Vec<u32>,
    /// The leaf list's triangles in blocks, as the traversals test them.
    pub(crate) blocks: LeafBlocks,
    pub(crate) triangles: Arc<[Triangle]>,
    reserved: usize,
    resident: usize,
    node_count: usize,
    inner_nodes: usize,
}

impl std::fmt::Debug for ImplicitBvh {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("ImplicitBvh")
            .field("reserved", &self.reserved)
            .field("resident", &self.resident)
            .field("nodes", &self.node_count)
            .finish()
    }
}

impl ImplicitBvh {
    /// Lays out `bvh` at its heap positions. [`Error::Limit`] for a tree
    /// deeper than [`MAX_DEPTH`], whose reservation (32 bytes × 2^(depth+1))
    /// passes `reservation_limit` bytes, or that the system cannot map.
    pub fn from_bvh(bvh: &Bvh, triangles: Arc<[Triangle]>, reservation_limit: u64) -> Result<Self> {
        let depth = bvh.stats.depth;
        let (mut map, reserved) = reserve(depth, reservation_limit)?;
        let nodes: &mut [OwnBoxNode] = bytemuck::cast_slice_mut(&mut map[..]);
        let mut index = Vec::with_capacity(bvh.prims.len());
        let mut pages = Vec::with_capacity(bvh.nodes.len());
        // (canonical id, heap position)
        let mut todo = vec![(ROOT, 0usize)];
        while let Some((id, pos)) = todo.pop() {
            let n = &bvh.nodes[id as usize];
            let link = match n.kind {
                NodeKind::Leaf { .. } => {
                    let first = index.len() as u32;
                    index.extend_from_slice(bvh.leaf_prims(n));
                    if let Some(last) = index.last_mut() {
                        *last |= LEAF;
                    }
                    LEAF | first
                }
                NodeKind::Inner { left, right, .. } => {
                    todo.push((right, 2 * pos + 2));
                    todo.push((left, 2 * pos + 1));
                    0
                }
            };
            nodes[pos + 1] = OwnBoxNode {
                bounds: n.bounds.to_array(),
                link,
                extra: id,
            };
            pages.push((pos + 1) * std::mem::size_of::<OwnBoxNode>() / PAGE);
        }
        pages.sort_unstable();
        pages.dedup();
        let blocks = LeafBlocks::new(&index, &triangles);
        Ok(ImplicitBvh {
            map,
            index,
            blocks,
            triangles,
            reserved,
            resident: pages.len() * PAGE,
            node_count: bvh.nodes.len(),
            inner_nodes: bvh.stats.inner_nodes,
        })
    }

    /// The nodes by slot (heap position + 1); gaps read as zeros.
    #[inline(always)]
    pub fn slots(&self) -> &[OwnBoxNode] {
        bytemuck::cast_slice(&self.map[..])
    }

    /// The root's box, in scene units ([`Aabb::EMPTY`] for a tree over no
    /// triangles).
    pub fn bounds(&self) -> Aabb {
        Aabb::from_array(&self.slots()[1].bounds)
    }

    /// Whether the tree holds no triangles.
    pub fn is_empty(&self) -> bool {
        self.index.is_empty()
    }

    /// The sign-terminated triangle index list.
    pub fn index(&self) -> &[u32] {
        &self.index
    }

    /// The mesh's triangles, in mesh order.
    pub fn triangles(&self) -> &[Triangle] {
        &self.triangles
    }

    /// Bytes of address space reserved for the nodes.
    pub fn reserved_bytes(&self) -> usize {
        self.reserved
    }

    /// Bytes of the pages that hold nodes (the memory actually used).
    pub fn resident_bytes(&self) -> usize {
        self.resident
    }

    /// Nodes of the tree (gaps not counted).
    pub fn node_count(&self) -> usize {
        self.node_count
    }

    /// Nodes with two children.
    pub fn inner_nodes(&self) -> usize {
        self.inner_nodes
    }

    /// Bytes of the sign-terminated triangle index list: 4 per triangle reference.
    pub fn index_bytes(&self) -> usize {
        self.index.len() * 4
    }
}

/// The anonymous no-swap-reserve mapping for a tree of `depth` levels
/// (32 bytes × 2^(depth+1)) and its size; errors as
/// [`ImplicitBvh::from_bvh`].
fn reserve(depth: u32, reservation_limit: u64) -> Result<(MmapMut, usize)> {
    let advice = "use the hybrid builder (--builder hybrid), whose median splits keep the tree balanced and shallow";
    if depth > MAX_DEPTH {
        return Err(Error::Limit(format!(
            "BVH depth {depth} exceeds the implicit layout's limit of {MAX_DEPTH} levels (32-bit heap indices); {advice}"
        )));
    }
    let slots = 1usize << (depth + 1);
    let reserved = slots * std::mem::size_of::<OwnBoxNode>();
    if reserved as u64 > reservation_limit {
        return Err(Error::Limit(format!(
            "BVH depth {depth} needs an implicit layout of 2^{} slots × 32 B = {:.1} GiB of address space, beyond the limit of {:.1} GiB; {advice}, or raise the limit",
            depth + 1,
            reserved as f64 / (1u64 << 30) as f64,
            reservation_limit as f64 / (1u64 << 30) as f64
        )));
    }
    let map = MmapOptions::new()
        .len(reserved)
        .no_reserve_swap()
        .map_anon()
        .map_err(|e| {
            Error::Limit(format!(
                "cannot reserve {reserved} bytes of address space for the implicit layout (depth {depth}): {e}; {advice}"
            ))
        })?;
    Ok((map, reserved))
}

/// An algorithm over the implicit layout.
pub trait ImplicitAlgorithm: Send + Sync + 'static {
    /// The traversal's registry entry.
    const KIND: TraversalKind;
    /// Traces `ray` over `layout`: the closest hit, or with `ANY` the first
    /// hit found.
    fn trace<S: Stats, const ANY: bool>(
        layout: &ImplicitBvh,
        ray: &Ray,
        stats: &mut S,
    ) -> Option<Hit>;
}

/// IMPLICIT-A (Algorithm 2).
pub struct ImplicitA;
/// IMPLICIT-B (Algorithm 3, combined index).
pub struct ImplicitB;

impl ImplicitAlgorithm for ImplicitA {
    const KIND: TraversalKind = TraversalKind::ImplicitA;
    #[inline(always)]
    fn trace<S: Stats, const ANY: bool>(l: &ImplicitBvh, r: &Ray, s: &mut S) -> Option<Hit> {
        traverse::implicit_a::<S, ANY>(l, r, s)
    }
}

impl ImplicitAlgorithm for ImplicitB {
    const KIND: TraversalKind = TraversalKind::ImplicitB;
    #[inline(always)]
    fn trace<S: Stats, const ANY: bool>(l: &ImplicitBvh, r: &Ray, s: &mut S) -> Option<Hit> {
        traverse::implicit_b::<S, ANY>(l, r, s)
    }
}

/// An implicit-layout algorithm with its layout.
pub struct OnImplicit<A: ImplicitAlgorithm> {
    /// The layout, shared with other algorithms over it.
    pub layout: Arc<ImplicitBvh>,
    _a: PhantomData<A>,
}

impl<A: ImplicitAlgorithm> OnImplicit<A> {
    /// `A` over `layout`. Infallible: [`ImplicitBvh::from_bvh`] already
    /// refused trees deeper than [`MAX_DEPTH`], which both algorithms address.
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bvh::BuildOptions;
    use crate::scene::Scene;

    #[test]
    fn nodes_sit_at_their_heap_positions() {
        let scene = Scene::builtin("chess:3000").unwrap();
        let bvh = Bvh::build(&scene.triangles, &BuildOptions::hybrid());
        let im = ImplicitBvh::from_bvh(&bvh, scene.triangles.clone(), DEFAULT_RESERVATION_LIMIT)
            .unwrap();
        assert_eq!(im.reserved_bytes(), 32 << (bvh.stats.depth + 1));
        assert!(im.resident_bytes() <= im.reserved_bytes());
        assert!(im.resident_bytes() >= 32 * bvh.nodes.len());
        // Walk the heap and compare with the canonical tree.
        let slots = im.slots();
        let mut todo = vec![(ROOT, 0usize)];
        let mut seen = 0;
        while let Some((id, pos)) = todo.pop() {
            seen += 1;
            let n = &slots[pos + 1];
            let c = &bvh.nodes[id as usize];
            assert_eq!(n.extra, id);
            assert_eq!(Aabb::from_array(&n.bounds), c.bounds);
            assert_eq!(n.is_leaf(), c.is_leaf());
            if let Some([l, r]) = c.children() {
                todo.push((l, 2 * pos + 1));
                todo.push((r, 2 * pos + 2));
            }
        }
        assert_eq!(seen, bvh.nodes.len());
    }

    #[test]
    fn reservation_limit_is_a_clear_error() {
        let scene = Scene::builtin("chess:3000").unwrap();
        let bvh = Bvh::build(&scene.triangles, &BuildOptions::sah());
        let e = ImplicitBvh::from_bvh(&bvh, scene.triangles.clone(), 1 << 16)
            .unwrap_err()
            .to_string();
        assert!(
            e.contains(&format!("depth {}", bvh.stats.depth)) && e.contains("hybrid"),
            "{e}"
        );
    }
}
