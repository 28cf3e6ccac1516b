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

use super::binning::MAX_BINS;
use super::build::{BuildOptions, PARALLEL_SUBTREE, SAH_MAX_DEPTH};
use super::{Node, NodeKind, NO_PARENT};
use crate::geometry::{Aabb, Triangle};
use arrayvec::ArrayVec;
use glam::{DVec3, Vec3};

/// A triangle reference: the triangle's index and the box of its part.
#[derive(Clone, Copy, Debug)]
struct Ref {
    bounds: Aabb,
    prim: u32,
}

impl Ref {
    fn centroid(&self) -> Vec3 {
        self.bounds.center()
    }
}

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

    fn of(b: &Aabb) -> DBox {
        DBox {
            min: b.min.as_dvec3(),
            max: b.max.as_dvec3(),
        }
    }

    /// Surface area; 0 for the empty box.
    fn area(&self) -> f64 {
        if self.min.cmpgt(self.max).any() {
            return 0.0;
        }
        let e = self.max - self.min;
        2.0 * (e.x * e.y + e.y * e.z + e.z * e.x)
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

/// The part of `tri` in each slab `[p[k], p[k + 1]]`, `k` in `k0..=k1`,
/// as [`clip`] finds it but without rounding to f32: `emit(k, box)` for
/// each part that meets `within`, in increasing `k`, with the box of the
/// part intersected with `within`. Rounded outward, each box is `clip`'s
/// (tested below). Each plane's edge crossings are computed once, not once
/// for each slab beside it. For the spatial split search, which only
/// weighs the parts' areas; the split itself clips with [`clip`].
fn clip_slabs(
    tri: &Triangle,
    within: &Aabb,
    axis: usize,
    p: &[f32],
    (k0, k1): (usize, usize),
    mut emit: impl FnMut(usize, DBox),
) {
    let v = vertices(tri);
    let within = DBox::of(within);
    let mut below = crossings(&v, axis, p[k0] as f64);
    for k in k0..=k1 {
        let (lo, hi) = (p[k] as f64, p[k + 1] as f64);
        let above = crossings(&v, axis, hi);
        let b = with_vertices(below.union(above), &v, axis, lo, hi);
        below = above;
        if b.min.x > b.max.x {
            continue;
        }
        let o = DBox {
            min: b.min.max(within.min),
            max: b.max.min(within.max),
        };
        if o.min.cmple(o.max).all() {
            emit(k, o);
        }
    }
}

#[derive(Clone, Copy)]
struct ObjectSplit {
    axis: usize,
    /// References whose centroid bin is below `bin` go left.
    bin: usize,
    min: f32,
    scale: f32,
    cost: f64,
    overlap: f64,
}

impl ObjectSplit {
    fn goes_left(&self, r: &Ref, nbins: usize) -> bool {
        let k = ((r.centroid()[self.axis] - self.min) * self.scale) as isize;
        (k.clamp(0, nbins as isize - 1) as usize) < self.bin
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

/// The cheapest binned object split of `refs` (§3).
fn object_split(refs: &[Ref], area_node: f64, nbins: usize) -> Option<ObjectSplit> {
    let cb = refs.iter().fold(Aabb::EMPTY, |b, r| b.grow(r.centroid()));
    let extent = cb.extent();
    let mut best: Option<ObjectSplit> = None;
    // Fixed arrays: no allocation per node.
    let mut bins = [(Aabb::EMPTY, 0u32); MAX_BINS];
    let mut right = [(0.0f64, Aabb::EMPTY); MAX_BINS];
    let (bins, right) = (&mut bins[..nbins], &mut right[..nbins]);
    for axis in 0..3 {
        if extent[axis] <= 0.0 || !extent[axis].is_finite() {
            continue;
        }
        let (min, scale) = (cb.min[axis], nbins as f32 * (1.0 - 1e-6) / extent[axis]);
        bins.fill((Aabb::EMPTY, 0));
        for r in refs {
            let k = ((r.centroid()[axis] - min) * scale) as isize;
            let bin = &mut bins[k.clamp(0, nbins as isize - 1) as usize];
            bin.0 = bin.0.union(r.bounds);
            bin.1 += 1;
        }
        let (mut acc, mut n) = (Aabb::EMPTY, 0u32);
        for k in (1..nbins).rev() {
            acc = acc.union(bins[k].0);
            n += bins[k].1;
            right[k] = (area(&acc) * n as f64, acc);
        }
        let (mut acc, mut n) = (Aabb::EMPTY, 0u32);
        for k in 1..nbins {
            acc = acc.union(bins[k - 1].0);
            n += bins[k - 1].1;
            if n == 0 || n as usize == refs.len() {
                continue;
            }
            let cost = 1.0 + (area(&acc) * n as f64 + right[k].0) / area_node;
            if best.is_none_or(|b| cost < b.cost) {
                best = Some(ObjectSplit {
                    axis,
                    bin: k,
                    min,
                    scale,
                    cost,
                    overlap: area(&overlap(&acc, &right[k].1)),
                });
            }
        }
    }
    best
}

/// The planes of `nbins` equal bins over `[lo, hi]`: `nbins + 1` values,
/// the first `lo` and the last `hi`, non-decreasing.
fn planes(lo: f32, hi: f32, nbins: usize) -> ArrayVec<f32, { MAX_BINS + 1 }> {
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
    p
}

/// The bins `k0..=k1` whose slabs `[p[k], p[k + 1]]` cover `[a, b]`.
fn bin_span(p: &[f32], a: f32, b: f32) -> (usize, usize) {
    let nbins = p.len() - 1;
    // Last plane at or below a; first plane at or above b.
    let k0 = p[..nbins].partition_point(|&x| x <= a).saturating_sub(1);
    let k1 = p[1..].partition_point(|&x| x < b).min(nbins - 1);
    (k0, k1.max(k0))
}

/// The cheapest binned spatial split of `refs` (§4.1) that adds at most
/// `budget` references and leaves each side fewer references than the node.
fn spatial_split(
    ctx: &Ctx,
    refs: &[Ref],
    node: &Aabb,
    area_node: f64,
    budget: usize,
) -> Option<SpatialSplit> {
    let nbins = ctx.opts.spatial_bins;
    let n = refs.len();
    let mut best: Option<SpatialSplit> = None;
    // Per bin: box of the parts, entries, exits.
    let mut bins = [(DBox::EMPTY, 0u32, 0u32); MAX_BINS];
    let mut right = [(0.0f64, 0u32); MAX_BINS];
    let (bins, right) = (&mut bins[..nbins], &mut right[..nbins]);
    for axis in 0..3 {
        let (lo, hi) = (node.min[axis], node.max[axis]);
        if hi <= lo || !(hi - lo).is_finite() {
            continue;
        }
        let p = planes(lo, hi, nbins);
        bins.fill((DBox::EMPTY, 0, 0));
        for r in refs {
            let (k0, k1) = bin_span(&p, r.bounds.min[axis], r.bounds.max[axis]);
            if k0 == k1 {
                bins[k0].0 = bins[k0].0.union(DBox::of(&r.bounds));
            } else {
                let tri = &ctx.triangles[r.prim as usize];
                clip_slabs(tri, &r.bounds, axis, &p, (k0, k1), |k, b| {
                    bins[k].0 = bins[k].0.union(b);
                });
            }
            bins[k0].1 += 1;
            bins[k1].2 += 1;
        }
        let (mut acc, mut m) = (DBox::EMPTY, 0u32);
        for k in (1..nbins).rev() {
            acc = acc.union(bins[k].0);
            m += bins[k].2;
            right[k] = (acc.area(), m);
        }
        let (mut acc, mut nl) = (DBox::EMPTY, 0u32);
        for k in 1..nbins {
            acc = acc.union(bins[k - 1].0);
            nl += bins[k - 1].1;
            let (ar, nr) = right[k];
            let (nl, nr) = (nl as usize, nr as usize);
            if nl == 0 || nr == 0 || nl >= n || nr >= n || nl + nr - n > budget {
                continue;
            }
            if p[k] <= lo || p[k] >= hi {
                continue;
            }
            let cost = 1.0 + (acc.area() * nl as f64 + ar * nr as f64) / area_node;
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
        let leaf = Node {
            bounds: Aabb::EMPTY,
            parent: NO_PARENT,
            depth: 0,
            kind: NodeKind::Leaf { first: 0, count: 0 },
        };
        return (vec![leaf], Vec::new());
    }
    let refs: Vec<Ref> = live
        .iter()
        .map(|&prim| Ref {
            bounds: triangles[prim as usize].bounds(),
            prim,
        })
        .collect();
    let root = refs.iter().fold(Aabb::EMPTY, |b, r| b.union(r.bounds));
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

fn subtree(ctx: &Ctx, mut refs: Vec<Ref>, depth: u32, budget: usize) -> Tmp {
    let n = refs.len();
    let bounds = refs.iter().fold(Aabb::EMPTY, |b, r| b.union(r.bounds));
    let leaf = |refs: Vec<Ref>| Tmp::Leaf(refs.iter().map(|r| r.prim).collect(), bounds);
    let max_leaf = ctx.opts.max_leaf_size;
    if n == 1 {
        return leaf(refs);
    }
    let area_node = area(&bounds);
    let nbins = ctx.opts.bins;
    let use_sah = depth < SAH_MAX_DEPTH && area_node > 0.0 && area_node.is_finite();
    let object = if use_sah {
        object_split(&refs, area_node, nbins)
    } else {
        None
    };
    let spatial = match object {
        Some(o) if o.overlap > ctx.min_overlap && budget > 0 => {
            spatial_split(ctx, &refs, &bounds, area_node, budget)
        }
        None if use_sah && budget > 0 => spatial_split(ctx, &refs, &bounds, area_node, budget),
        _ => None,
    };
    let best_cost = match (object, spatial) {
        (Some(o), Some(s)) => o.cost.min(s.cost),
        (Some(o), None) => o.cost,
        (None, Some(s)) => s.cost,
        (None, None) => f64::INFINITY,
    };
    if n <= max_leaf && best_cost >= n as f64 {
        return leaf(refs);
    }
    let (left, right, axis, added) = match (object, spatial) {
        (_, Some(s)) if object.is_none_or(|o| s.cost < o.cost) => {
            let (l, r) = split_spatial(ctx, &refs, s);
            let added = (l.len() + r.len()).saturating_sub(n);
            debug_assert!(added <= s.added);
            (l, r, s.axis, added)
        }
        (Some(o), _) => {
            let (l, r): (Vec<Ref>, Vec<Ref>) =
                refs.into_iter().partition(|r| o.goes_left(r, nbins));
            (l, r, o.axis, 0)
        }
        (None, _) => {
            // Median along the axis of largest centroid spread; ties by
            // triangle (a node never holds one triangle twice).
            let cb = refs.iter().fold(Aabb::EMPTY, |b, r| b.grow(r.centroid()));
            let axis = cb.largest_axis();
            let mid = n / 2;
            let key = |r: &Ref| (r.centroid()[axis], r.prim);
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
fn split_spatial(ctx: &Ctx, refs: &[Ref], s: SpatialSplit) -> (Vec<Ref>, Vec<Ref>) {
    let (mut l, mut r) = (Vec::new(), Vec::new());
    for x in refs {
        let (a, b) = (x.bounds.min[s.axis], x.bounds.max[s.axis]);
        if b <= s.pos {
            l.push(*x);
        } else if a >= s.pos {
            r.push(*x);
        } else {
            let tri = &ctx.triangles[x.prim as usize];
            let lb = clip(tri, &x.bounds, s.axis, a, s.pos);
            let rb = clip(tri, &x.bounds, s.axis, s.pos, b);
            match (lb, rb) {
                (Some(lb), Some(rb)) => {
                    l.push(Ref { bounds: lb, ..*x });
                    r.push(Ref { bounds: rb, ..*x });
                }
                (Some(lb), None) => l.push(Ref { bounds: lb, ..*x }),
                (None, Some(rb)) => r.push(Ref { bounds: rb, ..*x }),
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

    /// `clip_slabs` gives, slab by slab, the boxes `clip` gives: random
    /// triangles, references already clipped, planes through vertices and
    /// repeated planes.
    #[test]
    fn slab_clipping_equals_clipping_each_slab() {
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
            let t = Triangle::new(q(), q(), q());
            let axis = case % 3;
            // A reference: the triangle's box, or a part of it.
            let mut within = t.bounds();
            if case % 2 == 0 {
                let cut = (within.min[axis] + within.max[axis]) * 0.5;
                within.min[axis] = cut;
            }
            let (lo, hi) = (within.min[axis], within.max[axis]);
            let mut p = planes(lo, hi, [2, 3, 8, 32][case % 4]);
            if case % 5 == 0 {
                // A plane through a vertex.
                let k = p.len() / 2;
                p[k] = t.a[axis].clamp(p[k - 1], p[k + 1]);
            }
            let (k0, k1) = bin_span(&p, lo, hi);
            let mut got = Vec::new();
            clip_slabs(&t, &within, axis, &p, (k0, k1), |k, b| got.push((k, b)));
            let want: Vec<(usize, Aabb)> = (k0..=k1)
                .filter_map(|k| clip(&t, &within, axis, p[k], p[k + 1]).map(|b| (k, b)))
                .collect();
            // Rounded outward, each f64 part is `clip`'s box. `clip` may
            // keep a part that touches `within` only after rounding.
            let rounded = |b: &DBox| Aabb {
                min: Vec3::new(down(b.min.x), down(b.min.y), down(b.min.z)),
                max: Vec3::new(up(b.max.x), up(b.max.y), up(b.max.z)),
            };
            let mut w = want.iter().peekable();
            for (k, b) in &got {
                while w.peek().is_some_and(|(kw, _)| kw < k) {
                    let (kw, bw) = w.next().unwrap();
                    let touching = bw.min.cmpeq(bw.max).any();
                    assert!(touching, "case {case}: slab {kw} only from clip: {bw:?}");
                }
                let (kw, bw) = w.next().expect("a part clip has too");
                assert_eq!((kw, bw), (k, &rounded(b)), "case {case}");
            }
            for (kw, bw) in w {
                let touching = bw.min.cmpeq(bw.max).any();
                assert!(touching, "case {case}: slab {kw} only from clip: {bw:?}");
            }
            parts += got.len();
        }
        assert!(parts > 10_000, "{parts}");
    }

    #[test]
    fn bin_spans_cover_the_interval() {
        let p = planes(0.0, 1.0, 8);
        for &(a, b) in &[
            (0.0, 1.0),
            (0.1, 0.2),
            (0.125, 0.25),
            (0.3, 0.3),
            (1.0, 1.0),
        ] {
            let (k0, k1) = bin_span(&p, a, b);
            assert!(p[k0] <= a && p[k1 + 1] >= b, "{a} {b}: {k0} {k1}");
        }
    }
}
