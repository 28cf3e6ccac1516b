//! The spatial split BVH builder (Stich, Friedrich and Dietrich 2009,
//! "Spatial Splits in Bounding Volume Hierarchies").
//!
//! The build works on *references*: a triangle index with a box that may be
//! smaller than the triangle's (the box of the part of the triangle a node
//! holds). Each node compares the best binned object split (§3, over the
//! references' box centres) with the best binned spatial split (§4.1):
//! bins of equal width over the node's box along each axis, each reference
//! clipped against the planes of the bins it spans (the triangle clipped,
//! its box intersected with the reference's box), entry and exit counts per
//! bin, and the SAH swept over the bin planes. Spatial splits are tried only
//! where the object split's children overlap by more than `α` times the
//! root's surface area (§4.3, [`super::BuildOptions::alpha`]). A reference a
//! spatial split cuts goes to both children with its two clipped boxes, so a
//! triangle may sit in several leaves. Reference unsplitting (§4.2) is not
//! done.
//!
//! The growth of the reference list is capped
//! ([`super::BuildOptions::max_reference_growth`]): the root may create
//! `(growth - 1) · N` extra references, and each node hands what its split
//! left of its allowance to its children in proportion to their references,
//! so the tree, like the other builders', does not depend on the number of
//! threads. Clipped boxes are computed in f64 and rounded outward to f32,
//! so that they always contain the part of the triangle they stand for.
//! After the build every inner box is set to the exact union of its
//! children's (a spatial split leaves the parent's box, the union of its
//! references' unclipped boxes, possibly larger).

use super::binning::{best_split, Blocks, PrimRef, Split, MAX_BINS};
use super::build::{BuildOptions, PARALLEL_SUBTREE, SAH_MAX_DEPTH};
use super::{Node, NodeKind, NO_PARENT};
use crate::geometry::{Aabb, Triangle};
use crate::structures::shared::simd::{self, SimdPath};
use arrayvec::ArrayVec;
use glam::{BVec3A, DVec3, Mat4, Vec3, Vec3A, Vec4};

/// A subtree while building.
enum Tmp {
    Leaf(Vec<u32>, Aabb),
    Inner { axis: u8, kids: Box<[Tmp; 2]> },
}

struct Ctx<'a> {
    triangles: &'a [Triangle],
    opts: &'a BuildOptions,
    /// `α · A(root)`: overlaps at least this large try spatial splits.
    min_overlap: f64,
}

/// Surface area in f64 (f32 areas overflow at the soups' 1e30 scales).
fn area(b: &Aabb) -> f64 {
    if b.is_empty() {
        return 0.0;
    }
    let e = (b.max - b.min).as_dvec3();
    2.0 * (e.x * e.y + e.y * e.z + e.z * e.x)
}

fn overlap(a: &Aabb, b: &Aabb) -> Aabb {
    Aabb {
        min: a.min.max(b.min),
        max: a.max.min(b.max),
    }
}

/// Rounds `x` to an f32 no greater than it.
fn down(x: f64) -> f32 {
    let v = x as f32;
    if v as f64 > x {
        v.next_down()
    } else {
        v
    }
}

/// Rounds `x` to an f32 no smaller than it.
fn up(x: f64) -> f32 {
    let v = x as f32;
    if (v as f64) < x {
        v.next_up()
    } else {
        v
    }
}

/// A box in f64: the parts of triangles as [`spatial_split`] bins them.
#[derive(Clone, Copy, Debug, PartialEq)]
struct DBox {
    min: DVec3,
    max: DVec3,
}

impl DBox {
    const EMPTY: DBox = DBox {
        min: DVec3::INFINITY,
        max: DVec3::NEG_INFINITY,
    };

    fn grow(&mut self, q: DVec3) {
        self.min = self.min.min(q);
        self.max = self.max.max(q);
    }

    fn union(self, o: DBox) -> DBox {
        DBox {
            min: self.min.min(o.min),
            max: self.max.max(o.max),
        }
    }
}

/// The points where the edges of triangle `v` cross the plane
/// `p[axis] = plane` (an edge that only touches it adds nothing), as a box.
fn crossings(v: &[DVec3; 3], axis: usize, plane: f64) -> DBox {
    let mut b = DBox::EMPTY;
    for i in 0..3 {
        let (a, c) = (v[i], v[(i + 1) % 3]);
        let (da, dc) = (a[axis] - plane, c[axis] - plane);
        if (da < 0.0 && dc > 0.0) || (da > 0.0 && dc < 0.0) {
            let mut q = a + (c - a) * (da / (da - dc));
            q[axis] = plane;
            b.grow(q);
        }
    }
    b
}

/// `b` grown by the vertices of `v` with `lo <= q[axis] <= hi`.
fn with_vertices(mut b: DBox, v: &[DVec3; 3], axis: usize, lo: f64, hi: f64) -> DBox {
    for q in v {
        if (lo..=hi).contains(&q[axis]) {
            b.grow(*q);
        }
    }
    b
}

/// The vertices of `tri` in f64.
fn vertices(tri: &Triangle) -> [DVec3; 3] {
    [tri.a.as_dvec3(), tri.b.as_dvec3(), tri.c.as_dvec3()]
}

/// The box of the part of `tri` with `lo <= p[axis] <= hi`, intersected
/// with `within`, or `None` when that part is empty. The part's corners are
/// the triangle's vertices inside the slab and the edges' crossings of its
/// two planes; they are computed in f64 and the box rounded outward.
fn clip(tri: &Triangle, within: &Aabb, axis: usize, lo: f32, hi: f32) -> Option<Aabb> {
    let v = vertices(tri);
    let (lo, hi) = (lo as f64, hi as f64);
    let part = crossings(&v, axis, lo).union(crossings(&v, axis, hi));
    let DBox { min, max } = with_vertices(part, &v, axis, lo, hi);
    if min.x > max.x {
        return None;
    }
    let clipped = Aabb {
        min: Vec3::new(down(min.x), down(min.y), down(min.z)),
        max: Vec3::new(up(max.x), up(max.y), up(max.z)),
    };
    let b = overlap(&clipped, within);
    (b.min.cmple(b.max).all()).then_some(b)
}

#[derive(Clone, Copy)]
struct ObjectSplit {
    split: Split,
    /// The area of the intersection of the two children's boxes.
    overlap: f64,
}

/// The box and the centroids' box of `refs`, corners in SSE registers.
fn bounds_of(refs: &[PrimRef]) -> (Aabb, Aabb) {
    let (mut lo, mut hi) = (Vec3A::INFINITY, Vec3A::NEG_INFINITY);
    let (mut clo, mut chi) = (Vec3A::INFINITY, Vec3A::NEG_INFINITY);
    for r in refs {
        lo = lo.min(r.min());
        hi = hi.max(r.max());
        let c = r.centroid();
        clo = clo.min(c);
        chi = chi.max(c);
    }
    (
        Aabb::new(lo.into(), hi.into()),
        Aabb::new(clo.into(), chi.into()),
    )
}

/// The cheapest binned object split of `refs` (§3): the SAH builder's
/// search ([`best_split`]), with the overlap of the two children's boxes.
fn object_split(
    refs: &[PrimRef],
    node: &Aabb,
    centroids: &Aabb,
    nbins: usize,
    blocks: Blocks,
) -> Option<ObjectSplit> {
    let split = best_split(refs, node.area(), centroids, nbins, blocks)?;
    let (mut l, mut r) = (FBox::EMPTY, FBox::EMPTY);
    for p in refs {
        let side = if split.goes_left(p.centroid()) {
            &mut l
        } else {
            &mut r
        };
        // `lower`: the overlap's area below subtracts these corners, and
        // `min`'s fourth lane (the index, a subnormal float) is slow there.
        side.min = side.min.min(p.lower());
        side.max = side.max.max(p.max());
    }
    let o = FBox {
        min: l.min.max(r.min),
        max: l.max.min(r.max),
    };
    Some(ObjectSplit {
        split,
        overlap: o.area(),
    })
}

/// A box in f32 SSE registers: the parts of triangles as [`spatial_split`]
/// bins them.
#[derive(Clone, Copy, Debug, PartialEq)]
struct FBox {
    min: Vec3A,
    max: Vec3A,
}

impl FBox {
    const EMPTY: FBox = FBox {
        min: Vec3A::INFINITY,
        max: Vec3A::NEG_INFINITY,
    };

    #[inline(always)]
    fn union(self, o: FBox) -> FBox {
        FBox {
            min: self.min.min(o.min),
            max: self.max.max(o.max),
        }
    }

    #[inline(always)]
    fn intersect(self, o: FBox) -> FBox {
        FBox {
            min: self.min.max(o.min),
            max: self.max.min(o.max),
        }
    }

    #[inline(always)]
    fn is_empty(&self) -> bool {
        self.min.cmpgt(self.max).any()
    }

    /// Surface area in f64 (f32 areas overflow at the soups' 1e30 scales);
    /// 0 for an empty box.
    fn area(&self) -> f64 {
        if self.is_empty() {
            return 0.0;
        }
        let e = (self.max - self.min).as_dvec3();
        2.0 * (e.x * e.y + e.y * e.z + e.z * e.x)
    }
}

/// The planes of `nbins` equal bins over `[lo, hi]`: `nbins + 1` values,
/// the first `lo` and the last `hi`, non-decreasing, with the arithmetic
/// that finds a coordinate's bin in a step or two.
struct Planes {
    p: ArrayVec<f32, { MAX_BINS + 1 }>,
    lo: f32,
    /// Bins per unit length.
    scale: f32,
}

impl Planes {
    fn new(lo: f32, hi: f32, nbins: usize) -> Self {
        let mut p: ArrayVec<f32, { MAX_BINS + 1 }> = (0..=nbins)
            .map(|k| {
                let t = k as f64 / nbins as f64;
                (lo as f64 + (hi as f64 - lo as f64) * t) as f32
            })
            .collect();
        p[0] = lo;
        p[nbins] = hi;
        for k in 1..=nbins {
            p[k] = p[k].max(p[k - 1]).min(hi);
        }
        let scale = (nbins as f64 / (hi as f64 - lo as f64)) as f32;
        Planes { p, lo, scale }
    }

    fn bins(&self) -> usize {
        self.p.len() - 1
    }

    /// A first guess at the bin of `x`, in `0..bins` (NaN gives 0).
    #[inline(always)]
    fn guess(&self, x: f32) -> usize {
        let g = (x - self.lo) * self.scale;
        if g >= 0.0 {
            (g as usize).min(self.bins() - 1)
        } else {
            0
        }
    }

    /// The bins `k0..=k1` whose slabs `[p[k], p[k + 1]]` cover `[a, b]`:
    /// `k0` the last bin whose lower plane is at or below `a` (0 if none),
    /// `k1` the first whose upper plane is at or above `b` (the last if
    /// none), and at least `k0`. The arithmetic guess is corrected against
    /// the planes themselves, so the span is exact whatever the rounding.
    #[inline(always)]
    fn span(&self, a: f32, b: f32) -> (usize, usize) {
        let (p, last) = (&self.p, self.bins() - 1);
        let mut k0 = self.guess(a);
        while k0 > 0 && p[k0] > a {
            k0 -= 1;
        }
        while k0 < last && p[k0 + 1] <= a {
            k0 += 1;
        }
        let mut k1 = self.guess(b);
        while k1 > 0 && p[k1] >= b {
            k1 -= 1;
        }
        while k1 < last && p[k1 + 1] < b {
            k1 += 1;
        }
        (k0, k1.max(k0))
    }
}

/// A triangle's three edges in structure-of-arrays form (one lane per edge,
/// the fourth lane repeating the first), for clipping against slabs without
/// a branch: each edge's start and vector per coordinate, and the
/// reciprocals of the vectors' coordinates.
struct Edges {
    start: [Vec4; 3],
    dir: [Vec4; 3],
    inv: [Vec4; 3],
}

impl Edges {
    #[inline(always)]
    fn new(v: &[Vec3A; 3]) -> Self {
        let start = [0, 1, 2].map(|c| Vec4::new(v[0][c], v[1][c], v[2][c], v[0][c]));
        let (e0, e1, e2) = (v[1] - v[0], v[2] - v[1], v[0] - v[2]);
        let dir = [0, 1, 2].map(|c| Vec4::new(e0[c], e1[c], e2[c], e0[c]));
        // An edge parallel to an axis's planes gets a large finite
        // reciprocal: its parameters are then ±large (all of it in the slab
        // or none), where `0 · inf` would give NaN for an edge on a plane.
        let inv = dir.map(|d| {
            let inv = Vec4::ONE / d;
            Vec4::select(inv.abs().cmplt(Vec4::splat(1e30)), inv, Vec4::splat(1e30))
        });
        Edges { start, dir, inv }
    }

    /// The box of the triangle's part in the slab `[lo, hi]` on the axis
    /// (empty if none), in f32: each edge clipped to the slab by its
    /// parameter interval, the ends of the pieces that remain being the
    /// corners of the part (the vertices inside the slab and the edges'
    /// crossings of its planes).
    #[inline(always)]
    fn part(&self, axis: usize, lo: f32, hi: f32) -> FBox {
        let (s, inv) = (self.start[axis], self.inv[axis]);
        let tl = (Vec4::splat(lo) - s) * inv;
        let th = (Vec4::splat(hi) - s) * inv;
        let t0 = tl.min(th).max(Vec4::ZERO);
        let t1 = tl.max(th).min(Vec4::ONE);
        let kept = t0.cmple(t1);
        let (mut lower, mut upper) = ([Vec4::ZERO; 4], [Vec4::ZERO; 4]);
        for c in 0..3 {
            let a = self.start[c] + self.dir[c] * t0;
            let b = self.start[c] + self.dir[c] * t1;
            lower[c] = Vec4::select(kept, a.min(b), Vec4::INFINITY);
            upper[c] = Vec4::select(kept, a.max(b), Vec4::NEG_INFINITY);
        }
        lower[3] = lower[2];
        upper[3] = upper[2];
        // Transposed, each column holds one edge's corner; the columns'
        // minimum (maximum) is the box's.
        let lo4 = Mat4::from_cols(lower[0], lower[1], lower[2], lower[3]).transpose();
        let hi4 = Mat4::from_cols(upper[0], upper[1], upper[2], upper[3]).transpose();
        let min = lo4.x_axis.min(lo4.y_axis).min(lo4.z_axis.min(lo4.w_axis));
        let max = hi4.x_axis.max(hi4.y_axis).max(hi4.z_axis.max(hi4.w_axis));
        FBox {
            min: Vec3A::from_vec4(min),
            max: Vec3A::from_vec4(max),
        }
    }
}

/// The part of triangle `v` in each slab `[p[k], p[k + 1]]`, `k` in
/// `k0..=k1`, intersected with `within`: `emit(k, box)` for each part that
/// is not empty, in increasing `k`. In f32 ([`Edges::part`]): the split
/// search's estimate of the boxes that [`clip`] computes exactly and rounds
/// outward for the split itself (compared in the tests).
fn clip_slabs(
    edges: &Edges,
    within: FBox,
    axis: usize,
    p: &[f32],
    (k0, k1): (usize, usize),
    mut emit: impl FnMut(usize, FBox),
) {
    let on_axis = BVec3A::from_array(std::array::from_fn(|a| a == axis));
    for k in k0..=k1 {
        let (lo, hi) = (p[k], p[k + 1]);
        // The slab's bounds on the axis, by a lane mask: a write to one
        // lane by index went through memory and stalled the box's reload.
        let slab = FBox {
            min: Vec3A::select(on_axis, Vec3A::splat(lo), Vec3A::NEG_INFINITY),
            max: Vec3A::select(on_axis, Vec3A::splat(hi), Vec3A::INFINITY),
        };
        let o = edges.part(axis, lo, hi).intersect(within).intersect(slab);
        if !o.is_empty() {
            emit(k, o);
        }
    }
}

#[derive(Clone, Copy)]
struct SpatialSplit {
    axis: usize,
    /// The split plane.
    pos: f32,
    cost: f64,
    /// References the split adds (at most; references whose part on one side
    /// turns out empty are not duplicated).
    added: usize,
}

/// A spatial bin: the box of the parts of triangles in it, and how many
/// references enter and leave the axis's bins there.
#[derive(Clone, Copy)]
struct SpatialBin {
    parts: FBox,
    entries: u32,
    exits: u32,
}

const EMPTY_SPATIAL_BIN: SpatialBin = SpatialBin {
    parts: FBox::EMPTY,
    entries: 0,
    exits: 0,
};

/// Spatial bins per axis: `bins[m]` for the axis `axes[m]`.
type AxisBins = [[SpatialBin; MAX_BINS]; 3];

/// Bins `refs` into `bins` along each of `axes`: a reference inside one bin
/// of an axis adds its box there, one spanning several is clipped against
/// their planes ([`clip_slabs`]); each counts as entering its first bin and
/// leaving its last.
#[inline(always)]
fn bin_refs(
    triangles: &[Triangle],
    refs: &[PrimRef],
    axes: &[(usize, Planes)],
    bins: &mut AxisBins,
) {
    for r in refs {
        let within = FBox {
            min: r.lower(),
            max: r.max(),
        };
        let mut edges: Option<Edges> = None;
        for (m, (axis, planes)) in axes.iter().enumerate() {
            let axis = *axis;
            let (k0, k1) = planes.span(within.min[axis], within.max[axis]);
            let bins = &mut bins[m];
            if k0 == k1 {
                bins[k0].parts = bins[k0].parts.union(within);
            } else {
                let edges = edges.get_or_insert_with(|| {
                    let t = &triangles[r.id() as usize];
                    Edges::new(&[t.a.into(), t.b.into(), t.c.into()])
                });
                clip_slabs(edges, within, axis, &planes.p, (k0, k1), |k, b| {
                    bins[k].parts = bins[k].parts.union(b);
                });
            }
            bins[k0].entries += 1;
            bins[k1].exits += 1;
        }
    }
}

/// [`bin_refs`] compiled for AVX2 and FMA (three-operand instructions and
/// blends; the same operations in the same order, so the same bins).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
fn bin_refs_avx2(
    triangles: &[Triangle],
    refs: &[PrimRef],
    axes: &[(usize, Planes)],
    bins: &mut AxisBins,
) {
    bin_refs(triangles, refs, axes, bins)
}

/// [`bin_refs`] on SIMD path `path` (the portable code where this build or
/// processor lacks it). Every path gives the same bins bit for bit.
fn bin_on(
    path: SimdPath,
    triangles: &[Triangle],
    refs: &[PrimRef],
    axes: &[(usize, Planes)],
    bins: &mut AxisBins,
) {
    #[cfg(target_arch = "x86_64")]
    if matches!(path, SimdPath::Avx2 | SimdPath::Avx512) && path.supported() {
        // SAFETY: the processor has AVX2 and FMA (`path.supported()`).
        return unsafe { bin_refs_avx2(triangles, refs, axes, bins) };
    }
    let _ = path;
    bin_refs(triangles, refs, axes, bins)
}

/// The cheapest binned spatial split of `refs` (§4.1) that adds at most
/// `budget` references and leaves each side fewer references than the node.
/// One pass over the references bins all three axes: a reference inside one
/// bin of an axis adds its box there, one spanning several is clipped
/// against their planes ([`clip_slabs`]).
fn spatial_split(
    ctx: &Ctx,
    refs: &[PrimRef],
    node: &Aabb,
    area_node: f64,
    budget: usize,
) -> Option<SpatialSplit> {
    let nbins = ctx.opts.spatial_bins;
    let blocks = ctx.opts.blocks();
    let n = refs.len();
    let axes: ArrayVec<(usize, Planes), 3> = (0..3)
        .filter_map(|axis| {
            let (lo, hi) = (node.min[axis], node.max[axis]);
            (hi > lo && (hi - lo).is_finite()).then(|| (axis, Planes::new(lo, hi, nbins)))
        })
        .collect();
    let mut bins = [[EMPTY_SPATIAL_BIN; MAX_BINS]; 3];
    bin_on(simd::active(), ctx.triangles, refs, &axes, &mut bins);
    let mut best: Option<SpatialSplit> = None;
    let mut right = [(0.0f64, 0u32); MAX_BINS];
    for (m, (axis, planes)) in axes.iter().enumerate() {
        let (axis, p, bins) = (*axis, &planes.p, &bins[m]);
        let (lo, hi) = (node.min[axis], node.max[axis]);
        let (mut acc, mut exits) = (FBox::EMPTY, 0u32);
        for k in (1..nbins).rev() {
            acc = acc.union(bins[k].parts);
            exits += bins[k].exits;
            right[k] = (acc.area(), exits);
        }
        let (mut acc, mut nl) = (FBox::EMPTY, 0u32);
        for k in 1..nbins {
            acc = acc.union(bins[k - 1].parts);
            nl += bins[k - 1].entries;
            let (ar, nr) = right[k];
            let (nl, nr) = (nl as usize, nr as usize);
            if nl == 0 || nr == 0 || nl >= n || nr >= n || nl + nr - n > budget {
                continue;
            }
            if p[k] <= lo || p[k] >= hi {
                continue;
            }
            // (nl and nr are below the node's reference count, a u32.)
            let cost = 1.0
                + (acc.area() * blocks.cost(nl as u32) as f64 + ar * blocks.cost(nr as u32) as f64)
                    / area_node;
            if best.is_none_or(|b| cost < b.cost) {
                best = Some(SpatialSplit {
                    axis,
                    pos: p[k],
                    cost,
                    added: nl + nr - n,
                });
            }
        }
    }
    best
}

/// Builds the nodes (preorder, parent links, depths) and the reference list
/// of the spatial split BVH over the non-degenerate triangles `live`.
pub(super) fn build(
    triangles: &[Triangle],
    live: &[u32],
    opts: &BuildOptions,
) -> (Vec<Node>, Vec<u32>) {
    if live.is_empty() {
        return (vec![Node::EMPTY_ROOT], Vec::new());
    }
    let refs: Vec<PrimRef> = live
        .iter()
        .map(|&prim| PrimRef::new(&triangles[prim as usize].bounds(), prim))
        .collect();
    let (root, _) = bounds_of(&refs);
    let ctx = Ctx {
        triangles,
        opts,
        min_overlap: opts.alpha as f64 * area(&root),
    };
    let growth = opts.max_reference_growth.max(1.0) as f64;
    let budget = ((growth - 1.0) * live.len() as f64).min(u32::MAX as f64 / 2.0) as usize;
    let tree = subtree(&ctx, refs, 0, budget);
    let mut nodes = Vec::new();
    let mut prims = Vec::with_capacity(live.len());
    flatten(tree, NO_PARENT, 0, &mut nodes, &mut prims);
    (nodes, prims)
}

fn subtree(ctx: &Ctx, mut refs: Vec<PrimRef>, depth: u32, budget: usize) -> Tmp {
    let n = refs.len();
    let (bounds, centroids) = bounds_of(&refs);
    let leaf = |refs: Vec<PrimRef>| Tmp::Leaf(refs.iter().map(PrimRef::id).collect(), bounds);
    let max_leaf = ctx.opts.max_leaf_size;
    let blocks = ctx.opts.blocks();
    // One block is a leaf without a search, as in the SAH builder: no split
    // costs less than 1.
    if n == 1 || (n <= max_leaf && n <= blocks.size()) {
        return leaf(refs);
    }
    let area_node = area(&bounds);
    let nbins = ctx.opts.bins;
    // The object split's search weighs areas in f32, as the SAH builder's.
    let use_sah = depth < SAH_MAX_DEPTH && area_node > 0.0 && bounds.area().is_finite();
    let object = if use_sah {
        object_split(&refs, &bounds, &centroids, nbins, blocks)
    } else {
        None
    };
    // Where no object split exists (the centroids coincide), a spatial split
    // is the alternative to the median split.
    let may_split = use_sah && budget > 0 && n > ctx.opts.spatial_min_refs;
    let worth_it = object.is_none_or(|o| {
        o.overlap > ctx.min_overlap
            && o.overlap > ctx.opts.spatial_min_node_overlap as f64 * area_node
    });
    let spatial = if may_split && worth_it {
        spatial_split(ctx, &refs, &bounds, area_node, budget)
    } else {
        None
    };
    let object_cost = |o: ObjectSplit| o.split.cost as f64;
    let best_cost = match (object, spatial) {
        (Some(o), Some(s)) => object_cost(o).min(s.cost),
        (Some(o), None) => object_cost(o),
        (None, Some(s)) => s.cost,
        (None, None) => f64::INFINITY,
    };
    if n <= max_leaf && best_cost >= blocks.cost(n as u32) as f64 {
        return leaf(refs);
    }
    let (left, right, axis, added) = match (object, spatial) {
        (_, Some(s)) if object.is_none_or(|o| s.cost < object_cost(o)) => {
            let (l, r) = split_spatial(ctx, &refs, s);
            let added = (l.len() + r.len()).saturating_sub(n);
            debug_assert!(added <= s.added);
            (l, r, s.axis, added)
        }
        (Some(o), _) => {
            let (l, r): (Vec<PrimRef>, Vec<PrimRef>) = refs
                .into_iter()
                .partition(|r| o.split.goes_left(r.centroid()));
            (l, r, o.split.map.axis, 0)
        }
        (None, _) => {
            // Median along the axis of largest centroid spread; ties by
            // triangle (a node never holds one triangle twice).
            let axis = centroids.largest_axis();
            let mid = n / 2;
            let key = |r: &PrimRef| (r.centroid()[axis], r.id());
            refs.select_nth_unstable_by(mid, |a, b| key(a).partial_cmp(&key(b)).unwrap());
            let r = refs.split_off(mid);
            (refs, r, axis, 0)
        }
    };
    // What is left of the allowance, shared in proportion to the children's
    // references.
    let rest = budget - added.min(budget);
    let (nl, nr) = (left.len(), right.len());
    let bl = (rest as u128 * nl as u128 / (nl + nr) as u128) as usize;
    let br = rest - bl;
    let kids = if nl + nr > PARALLEL_SUBTREE {
        rayon::join(
            || subtree(ctx, left, depth + 1, bl),
            || subtree(ctx, right, depth + 1, br),
        )
    } else {
        (
            subtree(ctx, left, depth + 1, bl),
            subtree(ctx, right, depth + 1, br),
        )
    };
    Tmp::Inner {
        axis: axis as u8,
        kids: Box::new([kids.0, kids.1]),
    }
}

/// Splits `refs` at the plane of `s`: references on one side go there, the
/// references the plane cuts go to both sides with their clipped boxes (to
/// one side when the triangle's part on the other is empty).
fn split_spatial(ctx: &Ctx, refs: &[PrimRef], s: SpatialSplit) -> (Vec<PrimRef>, Vec<PrimRef>) {
    let (mut l, mut r) = (Vec::new(), Vec::new());
    for x in refs {
        let (a, b) = (x.min()[s.axis], x.max()[s.axis]);
        if b <= s.pos {
            l.push(*x);
        } else if a >= s.pos {
            r.push(*x);
        } else {
            let tri = &ctx.triangles[x.id() as usize];
            let bounds = x.bounds();
            let lb = clip(tri, &bounds, s.axis, a, s.pos);
            let rb = clip(tri, &bounds, s.axis, s.pos, b);
            match (lb, rb) {
                (Some(lb), Some(rb)) => {
                    l.push(PrimRef::new(&lb, x.id()));
                    r.push(PrimRef::new(&rb, x.id()));
                }
                (Some(lb), None) => l.push(PrimRef::new(&lb, x.id())),
                (None, Some(rb)) => r.push(PrimRef::new(&rb, x.id())),
                // Unreachable for a triangle whose part the box holds; keep
                // the reference whole rather than lose it.
                (None, None) => l.push(*x),
            }
        }
    }
    (l, r)
}

/// Appends `t` to `nodes` in preorder and its leaves' triangles to `prims`;
/// returns its id. Inner boxes are the unions of their children's.
fn flatten(t: Tmp, parent: u32, depth: u32, nodes: &mut Vec<Node>, prims: &mut Vec<u32>) -> u32 {
    let id = nodes.len() as u32;
    match t {
        Tmp::Leaf(p, bounds) => {
            nodes.push(Node {
                bounds,
                parent,
                depth,
                kind: NodeKind::Leaf {
                    first: prims.len() as u32,
                    count: p.len() as u32,
                },
            });
            prims.extend_from_slice(&p);
        }
        Tmp::Inner { axis, kids } => {
            nodes.push(Node {
                bounds: Aabb::EMPTY,
                parent,
                depth,
                kind: NodeKind::Inner {
                    left: id + 1,
                    right: 0,
                    axis,
                },
            });
            let [l, r] = *kids;
            let left = flatten(l, id, depth + 1, nodes, prims);
            let right = flatten(r, id, depth + 1, nodes, prims);
            let bounds = nodes[left as usize]
                .bounds
                .union(nodes[right as usize].bounds);
            nodes[id as usize].bounds = bounds;
            nodes[id as usize].kind = NodeKind::Inner { left, right, axis };
        }
    }
    id
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn clipped_boxes_hold_the_part_and_round_outward() {
        let t = Triangle::new(
            Vec3::ZERO,
            Vec3::new(3.0, 0.0, 0.0),
            Vec3::new(0.0, 3.0, 0.0),
        );
        let b = clip(&t, &t.bounds(), 0, 1.0, 2.0).unwrap();
        assert_eq!(b.min.x, 1.0);
        assert_eq!(b.max.x, 2.0);
        assert_eq!(b.min.y, 0.0);
        assert!(b.max.y >= 2.0 && b.max.y <= 2.0f32.next_up());
        assert!(clip(&t, &t.bounds(), 0, 4.0, 5.0).is_none());
        // A vertex on the plane belongs to both sides.
        assert!(clip(&t, &t.bounds(), 0, 3.0, 3.0).is_some());
    }

    /// `clip_slabs`, the split search's f32 estimate, gives slab by slab
    /// the boxes `clip` computes exactly, to within f32 rounding of the
    /// triangle's extent: random triangles, references already clipped,
    /// planes through vertices and repeated planes. A slab only one of the
    /// two finds holds a part that merely touches it.
    #[test]
    fn slab_clipping_estimates_clipping_each_slab() {
        let mut rng = crate::rng::Pcg32::new(3, 9);
        let mut parts = 0;
        for case in 0..3000 {
            let mut q = || {
                Vec3::new(
                    rng.range(-4.0, 4.0),
                    rng.range(-4.0, 4.0),
                    rng.range(-4.0, 4.0),
                )
            };
            let axis = case % 3;
            let (a, mut b, c) = (q(), q(), q());
            if case % 7 == 0 {
                // An edge parallel to the planes (on one of them when a
                // plane is moved onto vertex `a` below).
                b[axis] = a[axis];
            }
            let t = Triangle::new(a, b, c);
            // A reference: the triangle's box, or a part of it.
            let mut within = t.bounds();
            if case % 2 == 0 {
                let cut = (within.min[axis] + within.max[axis]) * 0.5;
                within.min[axis] = cut;
            }
            let (lo, hi) = (within.min[axis], within.max[axis]);
            let mut planes = Planes::new(lo, hi, [2, 3, 8, 32][case % 4]);
            if case % 5 == 0 {
                // A plane through a vertex.
                let k = planes.p.len() / 2;
                planes.p[k] = t.a[axis].clamp(planes.p[k - 1], planes.p[k + 1]);
            }
            let p = &planes.p;
            let span = planes.span(lo, hi);
            let v = [t.a.into(), t.b.into(), t.c.into()];
            let fwithin = FBox {
                min: within.min.into(),
                max: within.max.into(),
            };
            let mut got = Vec::new();
            clip_slabs(&Edges::new(&v), fwithin, axis, p, span, |k, b| {
                got.push((k, b))
            });
            let want: Vec<(usize, Aabb)> = (span.0..=span.1)
                .filter_map(|k| clip(&t, &within, axis, p[k], p[k + 1]).map(|b| (k, b)))
                .collect();
            let tol = 1e-5 * t.bounds().extent().max_element();
            let thin = |b: &Aabb| (b.max - b.min).min_element() <= tol;
            let (mut g, mut w) = (got.iter().peekable(), want.iter().peekable());
            loop {
                match (g.peek(), w.peek()) {
                    (Some((kg, bg)), Some((kw, bw))) if kg == kw => {
                        let bg = Aabb::new(bg.min.into(), bg.max.into());
                        let near = (bg.min - bw.min).abs().max_element() <= tol
                            && (bg.max - bw.max).abs().max_element() <= tol;
                        assert!(near, "case {case}, slab {kg}: {bg:?} against {bw:?}");
                        g.next();
                        w.next();
                    }
                    (Some((kg, bg)), w_next) if w_next.is_none_or(|(kw, _)| kg < kw) => {
                        let bg = Aabb::new(bg.min.into(), bg.max.into());
                        assert!(thin(&bg), "case {case}: slab {kg} only estimated: {bg:?}");
                        g.next();
                    }
                    (_, Some((kw, bw))) => {
                        assert!(thin(bw), "case {case}: slab {kw} only from clip: {bw:?}");
                        w.next();
                    }
                    (None, None) => break,
                    (Some(_), None) => unreachable!(),
                }
            }
            parts += got.len();
        }
        assert!(parts > 10_000, "{parts}");
    }

    /// The bins a span covers, by binary search over the planes: the
    /// definition [`Planes::span`] computes from its arithmetic guess.
    fn span_by_search(p: &[f32], a: f32, b: f32) -> (usize, usize) {
        let nbins = p.len() - 1;
        // Last plane at or below a; first plane at or above b.
        let k0 = p[..nbins].partition_point(|&x| x <= a).saturating_sub(1);
        let k1 = p[1..].partition_point(|&x| x < b).min(nbins - 1);
        (k0, k1.max(k0))
    }

    #[test]
    fn bin_spans_cover_the_interval() {
        let planes = Planes::new(0.0, 1.0, 8);
        for &(a, b) in &[
            (0.0, 1.0),
            (0.1, 0.2),
            (0.125, 0.25),
            (0.3, 0.3),
            (1.0, 1.0),
        ] {
            let (k0, k1) = planes.span(a, b);
            let p = &planes.p;
            assert!(p[k0] <= a && p[k1 + 1] >= b, "{a} {b}: {k0} {k1}");
            assert_eq!((k0, k1), span_by_search(p, a, b));
        }
    }

    /// The arithmetic span equals the binary search's on random intervals
    /// of random, tiny, huge and offset ranges, inside, on and beyond the
    /// planes (and NaN).
    /// Every SIMD path bins the same references into the same bins, bit
    /// for bit (the tree must not depend on the processor).
    #[test]
    fn every_simd_path_bins_alike() {
        let mut rng = crate::rng::Pcg32::new(17, 4);
        let mut q = |s: f32| Vec3::new(rng.range(-s, s), rng.range(-s, s), rng.range(-s, s));
        let triangles: Vec<Triangle> = (0..2000)
            .map(|i| {
                let c = q(10.0);
                let s = if i % 7 == 0 { 6.0 } else { 0.8 };
                Triangle::new(c + q(s), c + q(s), c + q(s))
            })
            .collect();
        let refs: Vec<PrimRef> = triangles
            .iter()
            .enumerate()
            .map(|(i, t)| PrimRef::new(&t.bounds(), i as u32))
            .collect();
        let (node, _) = bounds_of(&refs);
        let axes: Vec<(usize, Planes)> = (0..3)
            .map(|a| (a, Planes::new(node.min[a], node.max[a], 16)))
            .collect();
        let bits = |bins: &AxisBins| -> Vec<u32> {
            bins.iter()
                .flatten()
                .flat_map(|b| {
                    let (lo, hi) = (b.parts.min.to_array(), b.parts.max.to_array());
                    lo.into_iter()
                        .chain(hi)
                        .map(f32::to_bits)
                        .chain([b.entries, b.exits])
                })
                .collect()
        };
        let mut want = [[EMPTY_SPATIAL_BIN; MAX_BINS]; 3];
        bin_on(SimdPath::Portable, &triangles, &refs, &axes, &mut want);
        let parts: u32 = want.iter().flatten().map(|b| b.entries).sum();
        assert_eq!(parts, 3 * 2000);
        for path in SimdPath::ALL.into_iter().filter(|p| p.supported()) {
            let mut got = [[EMPTY_SPATIAL_BIN; MAX_BINS]; 3];
            bin_on(path, &triangles, &refs, &axes, &mut got);
            assert!(bits(&got) == bits(&want), "{path}");
        }
    }

    #[test]
    fn arithmetic_spans_equal_the_search() {
        let mut rng = crate::rng::Pcg32::new(17, 2);
        for case in 0..20_000 {
            let lo = [0.0, -3.0, 1e6, 1e-30, -7e20][case % 5] * rng.range(0.5, 2.0);
            let width = [1.0, 1e-6, 1e4, 3e-38, 1e21][(case / 5) % 5] * rng.range(0.1, 3.0);
            let hi = lo + width;
            // (lo + width rounds to lo where the width is below its ulp.)
            if hi <= lo {
                continue;
            }
            let nbins = [2, 3, 16, 31, 64][(case / 25) % 5];
            let planes = Planes::new(lo, hi, nbins);
            let pick = |rng: &mut crate::rng::Pcg32| match rng.below(6) {
                0 => planes.p[rng.below(nbins as u32 + 1) as usize],
                1 => lo - width * rng.next_f32(),
                2 => hi + width * rng.next_f32(),
                3 => f32::NAN,
                _ => lo + width * rng.next_f32(),
            };
            let (x, y) = (pick(&mut rng), pick(&mut rng));
            let (a, b) = if x <= y { (x, y) } else { (y, x) };
            assert_eq!(
                planes.span(a, b),
                span_by_search(&planes.p, a, b),
                "case {case}: [{a}, {b}] over [{lo}, {hi}] in {nbins}"
            );
        }
    }
}
