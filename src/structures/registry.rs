//! Structures and traversals by name, as the command line, the JSON reports
//! and the benchmarks spell them, and the dispatch from a name to a
//! monomorphized trace.

use super::dst::plan::Rules;
use super::dst::DstStats;
use super::htree::HtreeStats;
use super::implicit::{ImplicitA, ImplicitB, OnImplicit, DEFAULT_RESERVATION_LIMIT};
use super::shared::stack_capacity;
use super::sparse::{Hapala, Laine, OnSparse, PairedBvh, Sparse, SparseLayout, StackOnSparse};
use super::{
    Accel, Bih, BinaryBvh, BruteForce, Bvh4, Bvh8, CompactBvh, CwBvh, DualSplitTree, HTree,
    ImplicitBvh, SparseBvh,
};
use crate::bvh::Bvh;
use crate::error::{Error, Result};
use crate::geometry::Triangle;
use crate::names::Named;
use crate::saved::{Sections, Source};
use serde::Serialize;
use std::sync::Arc;
use std::time::Instant;

/// Every structure raytree names. The registry is [`Named::TABLE`]: one
/// line per structure; [`Built::with_options`] derives each from the BVH.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum StructureKind {
    /// Uncompressed binary BVH: 52-byte inner nodes, 4-byte leaves.
    Bvh,
    /// Dual-split tree with the BVH's partitioning (identical conversion).
    Dst,
    /// Dual-split tree, similar conversion (carving may be deferred).
    DstSimilar,
    /// Bounding interval hierarchy with clip nodes.
    Bih,
    /// H-tree (kd-splits and bounding nodes).
    Htree,
    /// Compact BVH (shared planes, 32-byte nodes).
    Cbvh,
    /// 4-wide BVH collapsed from the binary one by SAH.
    Bvh4,
    /// 8-wide BVH collapsed from the binary one by SAH.
    Bvh8,
    /// Compressed 8-wide BVH (Ylitie et al. 2017): 80-byte nodes.
    Cwbvh,
    /// Brute force: every triangle (the oracle).
    Brute,
}

impl Named for StructureKind {
    const WHAT: &'static str = "structure";
    const TABLE: &'static [(Self, &'static str, &'static str)] = &[
        (
            StructureKind::Bvh,
            "bvh",
            "uncompressed binary BVH: 52-byte inner nodes, 4-byte leaves",
        ),
        (
            StructureKind::Dst,
            "dst",
            "dual-split tree, identical conversion (Lin et al. 2019)",
        ),
        (
            StructureKind::DstSimilar,
            "dst-similar",
            "dual-split tree, similar conversion (carving may be deferred)",
        ),
        (
            StructureKind::Bih,
            "bih",
            "bounding interval hierarchy with clip nodes",
        ),
        (
            StructureKind::Htree,
            "htree",
            "H-tree: kd-splits and bounding nodes",
        ),
        (
            StructureKind::Cbvh,
            "cbvh",
            "Compact BVH: shared planes, 32-byte nodes",
        ),
        (
            StructureKind::Bvh4,
            "bvh4",
            "4-wide BVH: SAH-optimal collapse, child boxes side by side, 128-byte nodes",
        ),
        (
            StructureKind::Bvh8,
            "bvh8",
            "8-wide BVH: SAH-optimal collapse, child boxes side by side, 256-byte nodes",
        ),
        (
            StructureKind::Cwbvh,
            "cwbvh",
            "compressed 8-wide BVH (Ylitie et al. 2017): child boxes in 8-bit planes, 80-byte nodes, leaves of at most 12 triangles",
        ),
        (
            StructureKind::Brute,
            "brute",
            "brute force: every triangle (the oracle)",
        ),
    ];
}

crate::named_from_str!(StructureKind);

/// Every traversal raytree names (for `bvh`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum TraversalKind {
    /// Stack of node references, nearest child first.
    Stack,
    /// Stackless, implicit heap layout (Barringer and Akenine-Möller, Alg. 2).
    ImplicitA,
    /// Stackless, implicit layout, one combined index (Alg. 3).
    ImplicitB,
    /// Stackless over parent links (Alg. 4).
    Sparse,
    /// Parent links, child order by ray direction (Hapala et al. 2011).
    Hapala,
    /// Restart trail, no short stack (Laine 2010).
    #[serde(rename = "laine-0")]
    Laine0,
    /// Restart trail, short stack of 1.
    #[serde(rename = "laine-1")]
    Laine1,
    /// Restart trail, short stack of 2.
    #[serde(rename = "laine-2")]
    Laine2,
    /// Restart trail, short stack of 4.
    #[serde(rename = "laine-4")]
    Laine4,
    /// Restart trail, short stack of 8.
    #[serde(rename = "laine-8")]
    Laine8,
}

impl Named for TraversalKind {
    const WHAT: &'static str = "traversal";
    const TABLE: &'static [(Self, &'static str, &'static str)] = &[
        (
            TraversalKind::Stack,
            "stack",
            "stack of node references, nearest child first",
        ),
        (
            TraversalKind::ImplicitA,
            "implicit-a",
            "stackless, implicit heap layout (Barringer and Akenine-Möller 2013, Alg. 2)",
        ),
        (
            TraversalKind::ImplicitB,
            "implicit-b",
            "stackless, implicit layout, one combined index (Alg. 3)",
        ),
        (
            TraversalKind::Sparse,
            "sparse",
            "stackless over parent links (Alg. 4)",
        ),
        (
            TraversalKind::Hapala,
            "hapala",
            "parent links, child order by ray direction (Hapala et al. 2011)",
        ),
        (
            TraversalKind::Laine0,
            "laine-0",
            "restart trail, no short stack (Laine 2010)",
        ),
        (
            TraversalKind::Laine1,
            "laine-1",
            "restart trail, short stack of 1",
        ),
        (
            TraversalKind::Laine2,
            "laine-2",
            "restart trail, short stack of 2",
        ),
        (
            TraversalKind::Laine4,
            "laine-4",
            "restart trail, short stack of 4",
        ),
        (
            TraversalKind::Laine8,
            "laine-8",
            "restart trail, short stack of 8",
        ),
    ];
}

crate::named_from_str!(TraversalKind);

impl StructureKind {
    /// The structure's name (`bvh`, `dst-similar`).
    pub fn name(self) -> &'static str {
        Named::name(self)
    }

    /// Every structure, in the registry's order.
    pub fn all() -> &'static [StructureKind] {
        const ALL: [StructureKind; 10] = {
            let t = <StructureKind as Named>::TABLE;
            [
                t[0].0, t[1].0, t[2].0, t[3].0, t[4].0, t[5].0, t[6].0, t[7].0, t[8].0, t[9].0,
            ]
        };
        &ALL
    }
}

impl TraversalKind {
    /// The traversal's name (`stack`, `laine-4`).
    pub fn name(self) -> &'static str {
        Named::name(self)
    }

    /// Every traversal, in the registry's order.
    pub fn all() -> &'static [TraversalKind] {
        const ALL: [TraversalKind; 10] = {
            let t = <TraversalKind as Named>::TABLE;
            [
                t[0].0, t[1].0, t[2].0, t[3].0, t[4].0, t[5].0, t[6].0, t[7].0, t[8].0, t[9].0,
            ]
        };
        &ALL
    }
}

/// Whether `structure` with `traversal` can be built: [`Error::Invalid`]
/// for a traversal other than STACK on a structure that has its own.
pub fn check(structure: StructureKind, traversal: TraversalKind) -> Result<()> {
    if structure != StructureKind::Bvh && traversal != TraversalKind::Stack {
        return Err(Error::Invalid(format!(
            "traversal '{}' applies to the 'bvh' structure only; '{}' has its own",
            traversal.name(),
            structure.name()
        )));
    }
    Ok(())
}

/// Limits of the layouts that have them.
#[derive(Clone, Copy, Debug)]
pub struct LayoutOptions {
    /// Most address space the implicit layout may reserve, in bytes.
    pub implicit_reservation_limit: u64,
}

impl Default for LayoutOptions {
    fn default() -> Self {
        LayoutOptions {
            implicit_reservation_limit: DEFAULT_RESERVATION_LIMIT,
        }
    }
}

/// A structure, built and ready to trace.
/// One variant per structure × traversal pair, each holding its concrete
/// type so that [`Built::with`] can monomorphize.
pub enum Built {
    /// `bvh` with STACK over the binary layout.
    Bvh(BinaryBvh),
    /// STACK over the sparse layout (for ratios on the same nodes).
    StackOnSparse(OnSparse<StackOnSparse>),
    /// SPARSE: the stackless paper's Algorithm 4.
    Sparse(OnSparse<Sparse>),
    /// HAPALA over the sparse layout.
    Hapala(OnSparse<Hapala>),
    /// LAINE-0 over the sparse layout.
    Laine0(OnSparse<Laine<0>>),
    /// LAINE-1 over the sparse layout.
    Laine1(OnSparse<Laine<1>>),
    /// LAINE-2 over the sparse layout.
    Laine2(OnSparse<Laine<2>>),
    /// LAINE-4 over the sparse layout.
    Laine4(OnSparse<Laine<4>>),
    /// LAINE-8 over the sparse layout.
    Laine8(OnSparse<Laine<8>>),
    /// STACK, SPARSE or LAINE-k over the stackless paper tracer's 64-byte
    /// nodes ([`PairedBvh`]).
    Paired(OnPaired),
    /// IMPLICIT-A: the stackless paper's Algorithm 2.
    ImplicitA(OnImplicit<ImplicitA>),
    /// IMPLICIT-B: the stackless paper's Algorithm 3.
    ImplicitB(OnImplicit<ImplicitB>),
    /// `dst` or `dst-similar`.
    Dst(DualSplitTree),
    /// `bih`.
    Bih(Bih),
    /// `htree`.
    Htree(HTree),
    /// `cbvh`.
    Cbvh(CompactBvh),
    /// `bvh4`.
    Bvh4(Bvh4),
    /// `bvh8`.
    Bvh8(Bvh8),
    /// `cwbvh`.
    Cwbvh(CwBvh),
    /// `brute`, the oracle.
    Brute(BruteForce),
}

/// What a structure reports about itself.
#[derive(Clone, Debug, Serialize)]
pub struct StructureInfo {
    /// The structure built.
    pub structure: StructureKind,
    /// Its traversal, for `bvh` only (the others have their own).
    pub traversal: Option<TraversalKind>,
    /// The layout the traversal runs over: `binary` (52-byte inner nodes),
    /// `sparse` or `implicit` (32-byte own-box nodes), or the structure's own.
    pub layout: &'static str,
    /// Node and index bytes in memory (for the implicit layout, the pages
    /// that hold nodes).
    pub bytes: usize,
    /// Bytes of the nodes (for the implicit layout, its resident pages).
    pub node_bytes: usize,
    /// Bytes of the triangle index lists the leaves refer to.
    pub index_bytes: usize,
    /// Address space reserved (implicit layout only).
    pub reserved_bytes: Option<usize>,
    /// Nodes that are not leaves (for a dual-split tree or a BIH, splitting
    /// and carving nodes; for an H-tree, split and bounding nodes).
    pub inner_nodes: usize,
    /// Nodes that hold triangles (carving leaves included).
    pub leaves: usize,
    /// Per-ray traversal state in bytes, counted as the stackless paper's
    /// Figure 5 ([`state_bytes`]); `bvh` only.
    pub state_bytes: Option<usize>,
    /// Time to derive it from the canonical BVH, in seconds.
    pub conversion_seconds: f64,
    /// Node kinds and carving levels of a dual-split tree (or a BIH: its
    /// split nodes and single-axis carving, i.e. clip, nodes).
    pub dst: Option<DstStats>,
    /// Node kinds of an H-tree.
    pub htree: Option<HtreeStats>,
}

/// A computation over any structure: [`Built::with`] calls `run` with the
/// concrete type, so that the trace loop inside is monomorphized.
pub trait WithAccel {
    /// What the computation returns.
    type Output;
    /// The computation, on the structure as its concrete type.
    fn run<A: Accel>(self, accel: &A) -> Self::Output;
}

impl Built {
    /// Derives `structure` (traversed by `traversal`) from `bvh` over
    /// `triangles` (the mesh's, in mesh order). [`Error::Invalid`] for a pair
    /// [`check`] refuses, or a `cbvh` over a BVH whose boxes are not the
    /// exact unions of their children's; [`Error::Limit`] for a tree the
    /// layout cannot hold (too deep, too many nodes, an offset or a
    /// reservation too large).
    pub fn new(
        structure: StructureKind,
        traversal: TraversalKind,
        bvh: &Bvh,
        triangles: Arc<[Triangle]>,
    ) -> Result<(Built, StructureInfo)> {
        Self::with_options(
            structure,
            traversal,
            bvh,
            triangles,
            &LayoutOptions::default(),
        )
    }

    /// [`Built::new`] with explicit layout limits.
    pub fn with_options(
        structure: StructureKind,
        traversal: TraversalKind,
        bvh: &Bvh,
        triangles: Arc<[Triangle]>,
        opts: &LayoutOptions,
    ) -> Result<(Built, StructureInfo)> {
        check(structure, traversal)?;
        let start = Instant::now();
        let built = match (structure, traversal) {
            (StructureKind::Bvh, TraversalKind::Stack) => {
                Built::Bvh(BinaryBvh::from_bvh(bvh, triangles)?)
            }
            (StructureKind::Bvh, TraversalKind::ImplicitA | TraversalKind::ImplicitB) => {
                let im = Arc::new(ImplicitBvh::from_bvh(
                    bvh,
                    triangles,
                    opts.implicit_reservation_limit,
                )?);
                if traversal == TraversalKind::ImplicitA {
                    Built::ImplicitA(OnImplicit::new(im))
                } else {
                    Built::ImplicitB(OnImplicit::new(im))
                }
            }
            (StructureKind::Bvh, t) => {
                Built::sparse(t, Arc::new(SparseBvh::from_bvh(bvh, triangles)?))?
            }
            (StructureKind::Dst | StructureKind::DstSimilar, _) => {
                let similar = structure == StructureKind::DstSimilar;
                Built::Dst(DualSplitTree::from_bvh(bvh, triangles, similar)?)
            }
            (StructureKind::Bih, _) => Built::Bih(Bih::from_bvh(bvh, triangles)?),
            (StructureKind::Htree, _) => Built::Htree(HTree::from_bvh(bvh, triangles)?),
            (StructureKind::Cbvh, _) => Built::Cbvh(CompactBvh::from_bvh(bvh, triangles)?),
            (StructureKind::Bvh4, _) => Built::Bvh4(Bvh4::from_bvh(bvh, triangles)?),
            (StructureKind::Bvh8, _) => Built::Bvh8(Bvh8::from_bvh(bvh, triangles)?),
            (StructureKind::Cwbvh, _) => Built::Cwbvh(CwBvh::from_bvh(bvh, triangles)?),
            (StructureKind::Brute, _) => Built::Brute(BruteForce::new(triangles)),
        };
        let mut info = built.info(bvh);
        info.conversion_seconds = start.elapsed().as_secs_f64();
        Ok((built, info))
    }

    /// The structure, its traversal (STACK for the structures that have
    /// their own) and the layout it runs over ([`StructureInfo::layout`]).
    pub fn kind(&self) -> (StructureKind, TraversalKind, &'static str) {
        use StructureKind as S;
        use TraversalKind as T;
        match self {
            Built::Bvh(_) => (S::Bvh, T::Stack, "binary"),
            Built::StackOnSparse(_) => (S::Bvh, T::Stack, "sparse"),
            Built::Sparse(_) => (S::Bvh, T::Sparse, "sparse"),
            Built::Hapala(_) => (S::Bvh, T::Hapala, "sparse"),
            Built::Laine0(_) => (S::Bvh, T::Laine0, "sparse"),
            Built::Laine1(_) => (S::Bvh, T::Laine1, "sparse"),
            Built::Laine2(_) => (S::Bvh, T::Laine2, "sparse"),
            Built::Laine4(_) => (S::Bvh, T::Laine4, "sparse"),
            Built::Laine8(_) => (S::Bvh, T::Laine8, "sparse"),
            Built::Paired(p) => (S::Bvh, p.traversal(), "paired"),
            Built::ImplicitA(_) => (S::Bvh, T::ImplicitA, "implicit"),
            Built::ImplicitB(_) => (S::Bvh, T::ImplicitB, "implicit"),
            Built::Dst(t) if t.rules().complete => (S::Dst, T::Stack, "dual-split"),
            Built::Dst(_) => (S::DstSimilar, T::Stack, "dual-split"),
            Built::Bih(_) => (S::Bih, T::Stack, "bih"),
            Built::Htree(_) => (S::Htree, T::Stack, "htree"),
            Built::Cbvh(_) => (S::Cbvh, T::Stack, "compact"),
            Built::Bvh4(_) => (S::Bvh4, T::Stack, "wide-4"),
            Built::Bvh8(_) => (S::Bvh8, T::Stack, "wide-8"),
            Built::Cwbvh(_) => (S::Cwbvh, T::Stack, "compressed-8"),
            Built::Brute(_) => (S::Brute, T::Stack, "triangles"),
        }
    }

    /// The sparse layout of a sparse-layout variant.
    fn sparse_layout(&self) -> Option<&Arc<SparseBvh>> {
        Some(match self {
            Built::StackOnSparse(a) => &a.layout,
            Built::Sparse(a) => &a.layout,
            Built::Hapala(a) => &a.layout,
            Built::Laine0(a) => &a.layout,
            Built::Laine1(a) => &a.layout,
            Built::Laine2(a) => &a.layout,
            Built::Laine4(a) => &a.layout,
            Built::Laine8(a) => &a.layout,
            Built::Paired(p) => p.layout().sparse_arc(),
            _ => return None,
        })
    }

    /// What the structure reports about itself, derived from `bvh` (its
    /// conversion time zero).
    pub fn info(&self, bvh: &Bvh) -> StructureInfo {
        let (structure, traversal, layout) = self.kind();
        let info = |node_bytes: usize, index_bytes: usize| StructureInfo {
            structure,
            traversal: (structure == StructureKind::Bvh).then_some(traversal),
            layout,
            bytes: node_bytes + index_bytes,
            node_bytes,
            index_bytes,
            reserved_bytes: None,
            inner_nodes: bvh.stats.inner_nodes,
            leaves: bvh.stats.leaves,
            state_bytes: (structure == StructureKind::Bvh)
                .then(|| state_bytes(traversal, bvh.stats.depth)),
            conversion_seconds: 0.0,
            dst: None,
            htree: None,
        };
        let dst = |s: &DstStats, dual: bool| {
            let mut i = info(s.node_bytes, s.index_bytes);
            i.inner_nodes = s.split_nodes + s.carve_single + if dual { s.carve_dual } else { 0 }
                - s.carving_leaves;
            i.leaves = s.leaves();
            i.dst = Some(s.clone());
            i
        };
        if let Built::Paired(p) = self {
            return info(p.layout().node_bytes(), p.layout().sparse().index_bytes());
        }
        if let Some(sp) = self.sparse_layout() {
            return info(sp.node_bytes(), sp.index_bytes());
        }
        match self {
            Built::Bvh(b) => info(b.node_bytes(), b.index_bytes()),
            Built::ImplicitA(OnImplicit { layout: im, .. })
            | Built::ImplicitB(OnImplicit { layout: im, .. }) => {
                let mut i = info(im.resident_bytes(), im.index_bytes());
                i.reserved_bytes = Some(im.reserved_bytes());
                i
            }
            Built::Dst(t) => dst(&t.stats, true),
            Built::Bih(b) => dst(b.stats(), false),
            Built::Htree(h) => {
                let s = &h.stats;
                let mut i = info(s.node_bytes, s.index_bytes);
                i.inner_nodes = s.split_nodes + s.bound_nodes;
                i.leaves = s.leaves;
                i.htree = Some(s.clone());
                i
            }
            Built::Cbvh(c) => {
                let mut i = info(c.node_bytes(), c.index_bytes());
                i.inner_nodes = c.nodes().len();
                i.leaves = c.leaves();
                i
            }
            Built::Bvh4(w) => {
                let mut i = info(w.node_bytes(), w.index_bytes());
                i.inner_nodes = w.inner_nodes();
                i.leaves = w.leaves();
                i
            }
            Built::Bvh8(w) => {
                let mut i = info(w.node_bytes(), w.index_bytes());
                i.inner_nodes = w.inner_nodes();
                i.leaves = w.leaves();
                i
            }
            Built::Cwbvh(w) => {
                let mut i = info(w.node_bytes(), w.index_bytes());
                i.inner_nodes = w.inner_nodes();
                i.leaves = w.leaves();
                i
            }
            Built::Brute(b) => {
                let mut i = info(0, b.bytes());
                i.inner_nodes = 0;
                i.leaves = 1;
                i
            }
            _ => unreachable!("sparse layouts answered above"),
        }
    }

    /// Writes the structure's own arrays as sections of a saved file.
    pub(crate) fn save<'a>(&'a self, s: &mut Sections<'a>) {
        if let Some(sp) = self.sparse_layout() {
            return sp.save(s);
        }
        match self {
            Built::Bvh(b) => b.save(s),
            Built::ImplicitA(a) => a.layout.save(s),
            Built::ImplicitB(a) => a.layout.save(s),
            Built::Dst(t) => t.save(s),
            Built::Bih(b) => b.save(s),
            Built::Htree(h) => h.save(s),
            Built::Cbvh(c) => c.save(s),
            Built::Bvh4(w) => w.save(s),
            Built::Bvh8(w) => w.save(s),
            Built::Cwbvh(w) => w.save(s),
            Built::Brute(_) => {}
            _ => unreachable!("sparse layouts saved above"),
        }
    }

    /// Reads a saved structure (`structure` with `traversal` over `layout`,
    /// as the file's header names them) over `triangles` back from a
    /// file's sections, checking every invariant its traversal relies on.
    /// The error says what is wrong.
    pub(crate) fn load(
        structure: StructureKind,
        traversal: TraversalKind,
        layout: &str,
        s: &Source<'_>,
        triangles: Arc<[Triangle]>,
        opts: &LayoutOptions,
    ) -> std::result::Result<Built, String> {
        use StructureKind as S;
        use TraversalKind as T;
        check(structure, traversal).map_err(|e| e.to_string())?;
        let built = match (structure, traversal, layout) {
            (S::Bvh, T::Stack, "binary") => Built::Bvh(BinaryBvh::load(s, triangles)?),
            (S::Bvh, T::ImplicitA | T::ImplicitB, "implicit") => {
                let im = Arc::new(ImplicitBvh::load(
                    s,
                    triangles,
                    opts.implicit_reservation_limit,
                )?);
                if traversal == T::ImplicitA {
                    Built::ImplicitA(OnImplicit::new(im))
                } else {
                    Built::ImplicitB(OnImplicit::new(im))
                }
            }
            (S::Bvh, t, "sparse") if !matches!(t, T::ImplicitA | T::ImplicitB) => {
                Built::sparse(t, Arc::new(SparseBvh::load(s, triangles)?))
                    .map_err(|e| e.to_string())?
            }
            (S::Bvh, t, "paired") => Built::paired(t, Arc::new(SparseBvh::load(s, triangles)?))
                .map_err(|e| e.to_string())?,
            (S::Dst, _, "dual-split") => {
                Built::Dst(DualSplitTree::load(s, triangles, Rules::IDENTICAL)?)
            }
            (S::DstSimilar, _, "dual-split") => {
                Built::Dst(DualSplitTree::load(s, triangles, Rules::SIMILAR)?)
            }
            (S::Bih, _, "bih") => Built::Bih(Bih::load(s, triangles)?),
            (S::Htree, _, "htree") => Built::Htree(HTree::load(s, triangles)?),
            (S::Cbvh, _, "compact") => Built::Cbvh(CompactBvh::load(s, triangles)?),
            (S::Bvh4, _, "wide-4") => Built::Bvh4(Bvh4::load(s, triangles)?),
            (S::Bvh8, _, "wide-8") => Built::Bvh8(Bvh8::load(s, triangles)?),
            (S::Cwbvh, _, "compressed-8") => Built::Cwbvh(CwBvh::load(s, triangles)?),
            (S::Brute, _, "triangles") => Built::Brute(BruteForce::new(triangles)),
            _ => {
                return Err(format!(
                    "the header names structure '{}' with traversal '{}' over layout '{layout}', which this raytree does not save",
                    structure.name(),
                    traversal.name()
                ))
            }
        };
        Ok(built)
    }

    /// Traversal `t` (STACK, SPARSE or LAINE-k) over the stackless paper
    /// tracer's 64-byte nodes, derived from the sparse layout `sp`.
    /// [`Error::Invalid`] for another traversal; [`Error::Limit`] for a
    /// tree deeper than the traversal can follow.
    pub fn paired(t: TraversalKind, sp: Arc<SparseBvh>) -> Result<Built> {
        let l = Arc::new(PairedBvh::from_sparse(sp));
        use TraversalKind::*;
        Ok(Built::Paired(match t {
            Stack => OnPaired::Stack(OnSparse::new(l)?),
            Sparse => OnPaired::Sparse(OnSparse::new(l)?),
            Laine0 => OnPaired::Laine0(OnSparse::new(l)?),
            Laine1 => OnPaired::Laine1(OnSparse::new(l)?),
            Laine2 => OnPaired::Laine2(OnSparse::new(l)?),
            Laine4 => OnPaired::Laine4(OnSparse::new(l)?),
            Laine8 => OnPaired::Laine8(OnSparse::new(l)?),
            Hapala | ImplicitA | ImplicitB => {
                return Err(Error::Invalid(format!(
                    "{} does not run over the paired layout (STACK, SPARSE and LAINE-k do)",
                    t.name()
                )))
            }
        }))
    }

    /// Traversal `t` over an existing sparse layout; STACK means STACK over
    /// the sparse layout here. [`Error::Invalid`] for IMPLICIT-A/B;
    /// [`Error::Limit`] for a tree deeper than the traversal can follow.
    pub fn sparse(t: TraversalKind, sp: Arc<SparseBvh>) -> Result<Built> {
        use TraversalKind::*;
        Ok(match t {
            Stack => Built::StackOnSparse(OnSparse::new(sp)?),
            Sparse => Built::Sparse(OnSparse::new(sp)?),
            Hapala => Built::Hapala(OnSparse::new(sp)?),
            Laine0 => Built::Laine0(OnSparse::new(sp)?),
            Laine1 => Built::Laine1(OnSparse::new(sp)?),
            Laine2 => Built::Laine2(OnSparse::new(sp)?),
            Laine4 => Built::Laine4(OnSparse::new(sp)?),
            Laine8 => Built::Laine8(OnSparse::new(sp)?),
            ImplicitA | ImplicitB => {
                return Err(Error::Invalid(format!(
                    "{} runs over the implicit layout",
                    t.name()
                )))
            }
        })
    }

    /// Runs `w` on the structure held, as its concrete type.
    pub fn with<W: WithAccel>(&self, w: W) -> W::Output {
        match self {
            Built::Bvh(a) => w.run(a),
            Built::StackOnSparse(a) => w.run(a),
            Built::Sparse(a) => w.run(a),
            Built::Hapala(a) => w.run(a),
            Built::Laine0(a) => w.run(a),
            Built::Laine1(a) => w.run(a),
            Built::Laine2(a) => w.run(a),
            Built::Laine4(a) => w.run(a),
            Built::Laine8(a) => w.run(a),
            Built::Paired(p) => p.with(w),
            Built::ImplicitA(a) => w.run(a),
            Built::ImplicitB(a) => w.run(a),
            Built::Dst(a) => w.run(a),
            Built::Bih(a) => w.run(a),
            Built::Htree(a) => w.run(a),
            Built::Cbvh(a) => w.run(a),
            Built::Bvh4(a) => w.run(a),
            Built::Bvh8(a) => w.run(a),
            Built::Cwbvh(a) => w.run(a),
            Built::Brute(a) => w.run(a),
        }
    }
}

/// Traversal state in bytes, counted as the stackless paper's Figure 5
/// counts it: 4 bytes per 32-bit state variable (8 for the 64-bit ones
/// here), and a stack adds its head and 4 bytes per entry (STACK's size
/// follows the tree's depth, see [`stack_capacity`]).
pub fn state_bytes(kind: TraversalKind, depth: u32) -> usize {
    use TraversalKind::*;
    // The paper's LAINE-k holds node, trail, level and popLevel (28 bytes
    // with 64-bit words); for short stacks of fewer than 4 entries this
    // kernel adds its `path` and `one` words (structures/sparse/laine.rs),
    // which let a restart run ahead of its box tests.
    let laine =
        |k: usize| 4 + 3 * 8 + if k < 4 { 2 * 8 } else { 0 } + if k > 0 { 4 + 4 * k } else { 0 };
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
        // node, 64-bit trail, level, popLevel (path and one below k = 4),
        // short stack
        Laine0 => laine(0),
        Laine1 => laine(1),
        Laine2 => laine(2),
        Laine4 => laine(4),
        Laine8 => laine(8),
    }
}

/// A traversal over the stackless paper tracer's 64-byte nodes
/// ([`Built::paired`]): one variant per algorithm, each monomorphized.
pub enum OnPaired {
    /// STACK.
    Stack(OnSparse<StackOnSparse, PairedBvh>),
    /// SPARSE.
    Sparse(OnSparse<Sparse, PairedBvh>),
    /// LAINE-0.
    Laine0(OnSparse<Laine<0>, PairedBvh>),
    /// LAINE-1.
    Laine1(OnSparse<Laine<1>, PairedBvh>),
    /// LAINE-2.
    Laine2(OnSparse<Laine<2>, PairedBvh>),
    /// LAINE-4.
    Laine4(OnSparse<Laine<4>, PairedBvh>),
    /// LAINE-8.
    Laine8(OnSparse<Laine<8>, PairedBvh>),
}

impl OnPaired {
    /// The traversal.
    pub fn traversal(&self) -> TraversalKind {
        use TraversalKind as T;
        match self {
            OnPaired::Stack(_) => T::Stack,
            OnPaired::Sparse(_) => T::Sparse,
            OnPaired::Laine0(_) => T::Laine0,
            OnPaired::Laine1(_) => T::Laine1,
            OnPaired::Laine2(_) => T::Laine2,
            OnPaired::Laine4(_) => T::Laine4,
            OnPaired::Laine8(_) => T::Laine8,
        }
    }

    /// The layout.
    pub fn layout(&self) -> &Arc<PairedBvh> {
        match self {
            OnPaired::Stack(a) => &a.layout,
            OnPaired::Sparse(a) => &a.layout,
            OnPaired::Laine0(a) => &a.layout,
            OnPaired::Laine1(a) => &a.layout,
            OnPaired::Laine2(a) => &a.layout,
            OnPaired::Laine4(a) => &a.layout,
            OnPaired::Laine8(a) => &a.layout,
        }
    }

    /// Runs `w` on the traversal held, as its concrete type.
    pub fn with<W: WithAccel>(&self, w: W) -> W::Output {
        match self {
            OnPaired::Stack(a) => w.run(a),
            OnPaired::Sparse(a) => w.run(a),
            OnPaired::Laine0(a) => w.run(a),
            OnPaired::Laine1(a) => w.run(a),
            OnPaired::Laine2(a) => w.run(a),
            OnPaired::Laine4(a) => w.run(a),
            OnPaired::Laine8(a) => w.run(a),
        }
    }

    /// As a trait object for batches.
    pub fn tracer(self) -> Box<dyn super::batch::Tracer> {
        match self {
            OnPaired::Stack(a) => Box::new(a),
            OnPaired::Sparse(a) => Box::new(a),
            OnPaired::Laine0(a) => Box::new(a),
            OnPaired::Laine1(a) => Box::new(a),
            OnPaired::Laine2(a) => Box::new(a),
            OnPaired::Laine4(a) => Box::new(a),
            OnPaired::Laine8(a) => Box::new(a),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_are_the_documented_ones() {
        let s: Vec<_> = StructureKind::all().iter().map(|s| s.name()).collect();
        assert_eq!(
            s,
            [
                "bvh",
                "dst",
                "dst-similar",
                "bih",
                "htree",
                "cbvh",
                "bvh4",
                "bvh8",
                "cwbvh",
                "brute"
            ]
        );
        let t: Vec<_> = TraversalKind::all().iter().map(|t| t.name()).collect();
        assert_eq!(
            t,
            [
                "stack",
                "implicit-a",
                "implicit-b",
                "sparse",
                "hapala",
                "laine-0",
                "laine-1",
                "laine-2",
                "laine-4",
                "laine-8"
            ]
        );
        assert_eq!(
            serde_json::to_string(&TraversalKind::Laine4).unwrap(),
            "\"laine-4\""
        );
        assert_eq!(
            serde_json::to_string(&StructureKind::DstSimilar).unwrap(),
            "\"dst-similar\""
        );
        // Names parse back, and the JSON names are the same.
        for &s in StructureKind::all() {
            assert_eq!(s.name().parse::<StructureKind>(), Ok(s));
            assert_eq!(
                serde_json::to_string(&s).unwrap(),
                format!("\"{}\"", s.name())
            );
        }
        for &t in TraversalKind::all() {
            assert_eq!(t.name().parse::<TraversalKind>(), Ok(t));
            assert_eq!(
                serde_json::to_string(&t).unwrap(),
                format!("\"{}\"", t.name())
            );
        }
        let e = "bvh16".parse::<StructureKind>().unwrap_err().to_string();
        assert_eq!(
            e,
            "unknown structure 'bvh16' (known: bvh, dst, dst-similar, bih, htree, cbvh, bvh4, bvh8, cwbvh, brute)"
        );
    }
}
