//! Top-down builders: binned SAH, and the stackless paper's hybrid (SAH for
//! the top levels, median splits below). Subtrees are built in parallel.

use super::binning::{best_split, Blocks, PrimRef, Split, MAX_BINS};
use super::{BuildStats, Bvh, Node, NodeKind, NO_PARENT};
use crate::geometry::{Aabb, Triangle};
use glam::Vec3A;
use rayon::prelude::*;
use std::time::Instant;

/// Which split rule a build uses.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Builder {
    /// Binned SAH at every level.
    Sah,
    /// Binned SAH for the top `sah_levels` levels, then median splits along
    /// the axis of largest centroid spread (Barringer and Akenine-Möller 2013).
    Hybrid,
    /// Binned SAH with spatial splits (Stich, Friedrich and Dietrich 2009):
    /// a triangle may be referenced by several leaves, each with the box of
    /// its part (`bvh::sbvh`).
    Sbvh,
    /// A linear BVH (Lauterbach et al. 2009, Karras 2012): triangles sorted
    /// along a Morton curve of their centroids, each range split where its
    /// codes first differ, subtrees of at most `max_leaf_size` triangles
    /// made leaves where the SAH prefers them (`bvh::lbvh`). The fast build
    /// for scenes that change every frame; trees of higher SAH cost.
    Lbvh,
}

impl Builder {
    /// Every builder.
    pub const ALL: [Builder; 4] = [Builder::Sah, Builder::Hybrid, Builder::Sbvh, Builder::Lbvh];

    /// `"sah"`, `"hybrid"`, `"sbvh"` or `"lbvh"`, as serialized and reported in
    /// [`super::BuildStats`].
    pub fn name(self) -> &'static str {
        match self {
            Builder::Sah => "sah",
            Builder::Hybrid => "hybrid",
            Builder::Sbvh => "sbvh",
            Builder::Lbvh => "lbvh",
        }
    }
}

/// How to build a [`super::Bvh`]; [`BuildOptions::new`] gives the defaults.
#[derive(Clone, Debug)]
pub struct BuildOptions {
    /// The split rule.
    pub builder: Builder,
    /// Leaves hold at most this many triangles (1..=255).
    pub max_leaf_size: usize,
    /// Levels split by SAH in the hybrid builder (the stackless paper's 8).
    pub sah_levels: u32,
    /// SAH bins per axis for object splits (2..=64).
    pub bins: usize,
    /// The SAH's intersection cost counted per block of this many
    /// triangles (1, 2, 4, 8 or 16; default 1, the textbook cost per
    /// triangle): a leaf of `n` triangles costs `⌈n / sah_block⌉`, as its
    /// triangles are tested `sah_block` at a time, and a node of at most
    /// `sah_block` triangles is a leaf (its one block is never dearer than
    /// a split). Embree's `sahBlockSize` (4 for its four-triangle leaf
    /// blocks). With 4, the binned SAH build made 2.5× fewer nodes and
    /// took 0.7–0.8 of the time on chess, hairball, bunny.obj and
    /// dragon.obj (`ARCHITECTURE.md`, "Builders"); the tree's per-triangle
    /// SAH cost ([`super::BuildStats::sah_cost`]) is 10–20% higher. Every
    /// builder takes it: SAH and SBVH at every SAH split, the hybrid at its
    /// SAH levels.
    pub sah_block: usize,
    /// [`Builder::Sbvh`]: bins per axis for spatial splits (2..=64; default
    /// 16, Embree's count). Each reference is clipped against every bin
    /// it spans, so this sets most of the build's time: against 32 bins,
    /// 16 took 0.55-0.65 of the time for the same or a lower SAH cost on
    /// chess, atrium and samurai_monastery.obj.
    pub spatial_bins: usize,
    /// [`Builder::Sbvh`]: spatial splits are tried at a node whose best
    /// object split's children overlap by more than `alpha` times the root's
    /// surface area (Stich et al. 2009, §4.3; their `α`, default `1e-5`).
    pub alpha: f32,
    /// [`Builder::Sbvh`]: and only where that overlap is also more than
    /// this fraction of the node's own surface area (default 0: every node
    /// past `alpha`, as Stich et al. do). Embree uses 0.1, which made the
    /// build 1.1–1.7× faster but raised the SAH cost by 4.3% on
    /// fg_hawaii_big_island.obj and 1% on chess.
    pub spatial_min_node_overlap: f32,
    /// [`Builder::Sbvh`]: spatial splits are tried only at nodes of more
    /// than this many references (default 16). The smallest nodes cost the
    /// search the most per reference (each triangle spans most of the 16
    /// bins of every axis) and gain the least: against 0, 16 made the build
    /// 1.5× faster on chess and 1.9× on hairball, the SAH cost within 0.25%
    /// (lower on chess).
    pub spatial_min_refs: usize,
    /// [`Builder::Sbvh`]: the reference list grows to at most this many
    /// times the number of (non-degenerate) triangles (at least 1; default
    /// 1.5).
    pub max_reference_growth: f32,
}

/// Below this depth even the SAH builder switches to median splits, which
/// halve the triangle count at each level: adversarial inputs (exponentially
/// spaced triangles) cannot make the tree arbitrarily deep.
pub(super) const SAH_MAX_DEPTH: u32 = 64;
/// Subtrees with more triangles than this are built on another thread.
pub(super) const PARALLEL_SUBTREE: usize = 4096;

impl BuildOptions {
    /// The block sizes [`Self::sah_block`] may take.
    pub const SAH_BLOCKS: [usize; 5] = [1, 2, 4, 8, 16];

    /// `builder` with leaves of at most 8 triangles, 8 SAH levels (hybrid),
    /// 32 bins per axis (16 for spatial splits), SAH costs per triangle
    /// (blocks of one), `α = 1e-5`, spatial splits
    /// at nodes of more than 16 references, and references growing to at
    /// most 1.5 times the triangles (sbvh).
    pub fn new(builder: Builder) -> Self {
        BuildOptions {
            builder,
            max_leaf_size: 8,
            sah_levels: 8,
            bins: 32,
            sah_block: 1,
            spatial_bins: 16,
            alpha: 1e-5,
            spatial_min_node_overlap: 0.0,
            spatial_min_refs: 16,
            max_reference_growth: 1.5,
        }
    }

    /// [`Self::new`] with [`Builder::Sbvh`].
    pub fn sbvh() -> Self {
        Self::new(Builder::Sbvh)
    }

    /// [`Self::new`] with [`Builder::Sah`].
    pub fn sah() -> Self {
        Self::new(Builder::Sah)
    }

    /// [`Self::new`] with [`Builder::Hybrid`]: the stackless paper's tree (§4).
    pub fn hybrid() -> Self {
        Self::new(Builder::Hybrid)
    }

    /// The same options with leaves of at most `n` triangles;
    /// [`super::Bvh::build`] panics unless `n` is in `1..=255` (and unless
    /// [`Self::bins`] is in `2..=64` and [`Self::sah_block`] is 1, 2, 4, 8
    /// or 16).
    pub fn with_max_leaf_size(mut self, n: usize) -> Self {
        self.max_leaf_size = n;
        self
    }

    /// The same options with SAH costs counted in blocks of `n` triangles
    /// ([`Self::sah_block`]).
    pub fn with_sah_block(mut self, n: usize) -> Self {
        self.sah_block = n;
        self
    }

    /// [`Self::sah_block`] as the split search takes it.
    pub(super) fn blocks(&self) -> Blocks {
        Blocks::of(self.sah_block)
    }
}

struct Ctx<'a> {
    opts: &'a BuildOptions,
    /// Subtrees are handed to other threads only above this depth (and
    /// above [`PARALLEL_SUBTREE`] references): a right subtree built
    /// apart is copied into its parent's node list, once per level of
    /// such nesting, so the nesting is kept to a few levels more than the
    /// threads need (none on one thread).
    spawn_depth: u32,
}

impl Ctx<'_> {
    fn node_capacity(&self, n: usize) -> usize {
        node_capacity(self.opts, n)
    }
}

/// Room for the nodes of a subtree of `n` references: at most `2n − 1`
/// whatever the tree, reserved at about what the builder's leaves hold
/// (SAH leaves of up to 8 triangles held 1.6 to 2.1 on average on chess,
/// hairball and dragon, LBVH leaves 1.6 to 2.1 on chess, hairball, atrium,
/// bunny, samurai and hawaii; one exactly at a leaf size of 1) so that the list rarely grows and the heap meter reports what is
/// used.
pub(super) fn node_capacity(opts: &BuildOptions, n: usize) -> usize {
    let max_leaf = opts.max_leaf_size as f64;
    let per_leaf = match opts.builder {
        Builder::Hybrid => (max_leaf / 2.0).floor().max(1.0),
        Builder::Sah | Builder::Sbvh | Builder::Lbvh => max_leaf.min(1.6),
    };
    ((2.0 * n as f64 / per_leaf) as usize + 1).min(2 * n.max(1) - 1)
}

pub(super) fn build(triangles: &[Triangle], opts: &BuildOptions) -> Bvh {
    assert!(
        (1..=255).contains(&opts.max_leaf_size),
        "max_leaf_size must be in 1..=255"
    );
    assert!(
        (2..=MAX_BINS).contains(&opts.bins) && (2..=MAX_BINS).contains(&opts.spatial_bins),
        "bins and spatial_bins must be in 2..={MAX_BINS}"
    );
    let _ = opts.blocks(); // panics unless sah_block is 1, 2, 4, 8 or 16
    let start = Instant::now();
    let prims: Vec<u32> = (0..triangles.len() as u32)
        .into_par_iter()
        .filter(|&i| !triangles[i as usize].is_degenerate())
        .collect();
    let degenerate = triangles.len() - prims.len();
    let (nodes, prims) = if opts.builder == Builder::Sbvh {
        super::sbvh::build(triangles, &prims, opts)
    } else {
        let refs: Vec<PrimRef> = prims
            .par_iter()
            .map(|&i| PrimRef::new(&triangles[i as usize].bounds(), i))
            .collect();
        drop(prims);
        let threads = rayon::current_num_threads();
        let spawn_depth = if threads > 1 {
            threads.next_power_of_two().trailing_zeros() + 8
        } else {
            0
        };
        if opts.builder == Builder::Lbvh {
            super::lbvh::build(refs, opts, spawn_depth)
        } else {
            binned(&Ctx { opts, spawn_depth }, refs)
        }
    };
    finish(nodes, prims, opts, degenerate, start)
}

/// The binned SAH and hybrid builds: nodes and triangle order.
fn binned(ctx: &Ctx, mut refs: Vec<PrimRef>) -> (Vec<Node>, Vec<u32>) {
    let mut nodes = Vec::with_capacity(ctx.node_capacity(refs.len()));
    if refs.is_empty() {
        nodes.push(Node::EMPTY_ROOT);
    } else {
        let b = bounds_of(&refs);
        // The stable partition of large nodes writes here; small nodes are
        // partitioned in place. Kept for the whole build (32 bytes per
        // reference on the peak heap, which one allocation per large node
        // also reached at the root) rather than made and freed per node.
        let mut scratch = if refs.len() >= PARALLEL_PARTITION {
            refs.clone()
        } else {
            Vec::new()
        };
        subtree(ctx, &mut refs, &mut scratch, 0, 0, b, NO_PARENT, &mut nodes);
    }
    nodes.shrink_to_fit();
    let prims = refs.par_iter().map(PrimRef::id).collect();
    (nodes, prims)
}

fn finish(
    nodes: Vec<Node>,
    prims: Vec<u32>,
    opts: &BuildOptions,
    degenerate: usize,
    start: Instant,
) -> Bvh {
    let mut bvh = Bvh {
        nodes,
        prims,
        stats: BuildStats::default(),
    };
    let leaves = bvh.nodes.iter().filter(|n| n.is_leaf()).count();
    bvh.stats = BuildStats {
        builder: opts.builder.name().into(),
        max_leaf_size: opts.max_leaf_size,
        sah_block: opts.sah_block,
        build_seconds: start.elapsed().as_secs_f64(),
        nodes: bvh.nodes.len(),
        inner_nodes: bvh.nodes.len() - leaves,
        leaves,
        references: bvh.prims.len(),
        depth: bvh.nodes.iter().map(|n| n.depth).max().unwrap_or(0),
        sah_cost: bvh.sah_cost(),
        degenerate_triangles: degenerate,
        optimized: None,
        peak_heap_bytes: None,
    };
    bvh
}

/// The box and the centroids' box of `refs`.
pub(super) fn bounds_of(refs: &[PrimRef]) -> (Aabb, Aabb) {
    let one = |mut s: Sides, r: &PrimRef| {
        s.add(r, true);
        s
    };
    let sides = if refs.len() >= 1 << 15 {
        refs.par_chunks(PARTITION_CHUNK)
            .map(|c| c.iter().fold(Sides::new(), one))
            .reduce(Sides::new, Sides::join)
    } else {
        refs.iter().fold(Sides::new(), one)
    };
    sides.boxes().0
}

/// Builds the subtree over `refs` (whose box and centroids' box are
/// `bounds`, from the parent's partition), appending its nodes to `nodes`
/// in preorder, its root's parent being `parent` (an index in `nodes`).
/// Serial subtrees append to the caller's vector; a parallel split builds
/// its right subtree into a vector of its own, appended afterwards with its
/// links moved: one allocation per parallel split, none per node.
#[allow(clippy::too_many_arguments)]
fn subtree(
    ctx: &Ctx,
    refs: &mut [PrimRef],
    scratch: &mut [PrimRef],
    first: usize,
    depth: u32,
    (bounds, cbounds): (Aabb, Aabb),
    parent: u32,
    nodes: &mut Vec<Node>,
) {
    let n = refs.len();
    let id = nodes.len() as u32;
    let leaf = |nodes: &mut Vec<Node>| {
        nodes.push(Node {
            bounds,
            parent,
            depth,
            kind: NodeKind::Leaf {
                first: first as u32,
                count: n as u32,
            },
        })
    };
    let max_leaf = ctx.opts.max_leaf_size;
    let use_sah = match ctx.opts.builder {
        Builder::Sah | Builder::Sbvh | Builder::Lbvh => depth < SAH_MAX_DEPTH,
        Builder::Hybrid => depth < ctx.opts.sah_levels.min(SAH_MAX_DEPTH),
    };
    let blocks = ctx.opts.blocks();
    // A node of one block is a leaf without a search: every split costs
    // `1 + (A_L·C_L + A_R·C_R) / A ≥ 1`, one block's cost, and a tie goes
    // to the leaf below.
    if n == 1 || (n <= max_leaf && (!use_sah || n <= blocks.size())) {
        return leaf(nodes);
    }
    let split: Option<Split> = if use_sah {
        best_split(refs, bounds.area(), &cbounds, ctx.opts.bins, blocks)
    } else {
        None
    };
    let (mid, axis, lb, rb) = match split {
        // SAH: a leaf when it is no dearer than the best split.
        Some(s) if n <= max_leaf && s.cost >= blocks.cost(n as u32) => return leaf(nodes),
        Some(s) => {
            let (mid, lb, rb) = partition(refs, scratch, |c| s.goes_left(c));
            (mid, s.map.axis, lb, rb)
        }
        None if n <= max_leaf => return leaf(nodes),
        None => {
            // Median along the axis of largest centroid spread; ties by id, so
            // that the result does not depend on the input order.
            let axis = cbounds.largest_axis();
            let mid = n / 2;
            let key = |r: &PrimRef| (r.centroid()[axis], r.id());
            refs.select_nth_unstable_by(mid, |a, b| key(a).partial_cmp(&key(b)).unwrap());
            let (lb, rb) = (bounds_of(&refs[..mid]), bounds_of(&refs[mid..]));
            (mid, axis, lb, rb)
        }
    };
    nodes.push(Node {
        bounds,
        parent,
        depth,
        kind: NodeKind::Inner {
            left: id + 1,
            right: 0,
            axis: axis as u8,
        },
    });
    let (l, r) = refs.split_at_mut(mid);
    // The scratch list goes with the references that still need it.
    let (sl, sr): (&mut [PrimRef], &mut [PrimRef]) = if scratch.len() == n {
        scratch.split_at_mut(mid)
    } else {
        (&mut [], &mut [])
    };
    let right = if n > PARALLEL_SUBTREE && depth < ctx.spawn_depth {
        let mut theirs = Vec::with_capacity(ctx.node_capacity(r.len()));
        rayon::join(
            || subtree(ctx, l, sl, first, depth + 1, lb, id, nodes),
            || {
                subtree(
                    ctx,
                    r,
                    sr,
                    first + mid,
                    depth + 1,
                    rb,
                    NO_PARENT,
                    &mut theirs,
                )
            },
        );
        append_subtree(nodes, theirs, id)
    } else {
        subtree(ctx, l, sl, first, depth + 1, lb, id, nodes);
        let right = nodes.len() as u32;
        subtree(ctx, r, sr, first + mid, depth + 1, rb, id, nodes);
        right
    };
    if let NodeKind::Inner {
        right: ref mut r, ..
    } = nodes[id as usize].kind
    {
        *r = right;
    }
}

/// Appends `theirs`, a subtree built into a list of its own (its root's
/// parent [`NO_PARENT`], its links indices into that list), to `nodes` as
/// the child of node `parent`; returns the index its root gets.
pub(super) fn append_subtree(nodes: &mut Vec<Node>, theirs: Vec<Node>, parent: u32) -> u32 {
    let offset = nodes.len() as u32;
    nodes.extend(theirs.into_iter().map(|mut node| {
        node.parent = if node.parent == NO_PARENT {
            parent
        } else {
            node.parent + offset
        };
        if let NodeKind::Inner { left, right, axis } = node.kind {
            node.kind = NodeKind::Inner {
                left: left + offset,
                right: right + offset,
                axis,
            };
        }
        node
    }));
    offset
}

/// Nodes of at least this many triangles are partitioned in parallel.
const PARALLEL_PARTITION: usize = 1 << 16;
/// The chunks of a parallel partition. Fixed, so that the order of the
/// partitioned refs, and so the tree, does not depend on the thread count.
const PARTITION_CHUNK: usize = 1 << 14;

/// The two sides' boxes and centroid boxes while partitioning, corners in
/// SSE registers: a box grows by two instructions.
#[derive(Clone, Copy)]
struct Sides {
    lb: (Vec3A, Vec3A),
    lc: (Vec3A, Vec3A),
    rb: (Vec3A, Vec3A),
    rc: (Vec3A, Vec3A),
}

impl Sides {
    const EMPTY: (Vec3A, Vec3A) = (Vec3A::INFINITY, Vec3A::NEG_INFINITY);

    fn new() -> Self {
        Sides {
            lb: Self::EMPTY,
            lc: Self::EMPTY,
            rb: Self::EMPTY,
            rc: Self::EMPTY,
        }
    }

    #[inline(always)]
    fn add(&mut self, r: &PrimRef, left: bool) {
        let (c, min, max) = (r.centroid(), r.min(), r.max());
        let (bb, cb) = if left {
            (&mut self.lb, &mut self.lc)
        } else {
            (&mut self.rb, &mut self.rc)
        };
        bb.0 = bb.0.min(min);
        bb.1 = bb.1.max(max);
        cb.0 = cb.0.min(c);
        cb.1 = cb.1.max(c);
    }

    fn join(self, o: Sides) -> Sides {
        let u = |a: (Vec3A, Vec3A), b: (Vec3A, Vec3A)| (a.0.min(b.0), a.1.max(b.1));
        Sides {
            lb: u(self.lb, o.lb),
            lc: u(self.lc, o.lc),
            rb: u(self.rb, o.rb),
            rc: u(self.rc, o.rc),
        }
    }

    fn boxes(self) -> ((Aabb, Aabb), (Aabb, Aabb)) {
        let aabb = |b: (Vec3A, Vec3A)| Aabb::new(b.0.into(), b.1.into());
        (
            (aabb(self.lb), aabb(self.lc)),
            (aabb(self.rb), aabb(self.rc)),
        )
    }
}

/// Moves the refs whose centroid `left` accepts to the front; returns how
/// many, and the boxes and centroid boxes of the two sides. Large nodes
/// are partitioned in parallel and stably ([`partition_parallel`]), small
/// ones in place.
fn partition(
    refs: &mut [PrimRef],
    scratch: &mut [PrimRef],
    left: impl Fn(Vec3A) -> bool + Sync,
) -> (usize, (Aabb, Aabb), (Aabb, Aabb)) {
    if refs.len() >= PARALLEL_PARTITION {
        return partition_parallel(refs, scratch, left);
    }
    partition_serial(refs, left)
}

/// [`partition`] on this thread, in place (not stable).
fn partition_serial(
    refs: &mut [PrimRef],
    left: impl Fn(Vec3A) -> bool,
) -> (usize, (Aabb, Aabb), (Aabb, Aabb)) {
    let mut sides = Sides::new();
    let mut mid = 0;
    for k in 0..refs.len() {
        let r = refs[k];
        let goes_left = left(r.centroid());
        sides.add(&r, goes_left);
        if goes_left {
            refs.swap(mid, k);
            mid += 1;
        }
    }
    let (l, r) = sides.boxes();
    (mid, l, r)
}

/// [`partition`] over chunks of [`PARTITION_CHUNK`] refs on rayon's
/// threads: each chunk's left count, then each chunk writes its refs to its
/// own places on both sides of `scratch` (as long as `refs`: lefts, then
/// rights, in their order), which is copied back.
fn partition_parallel(
    refs: &mut [PrimRef],
    scratch: &mut [PrimRef],
    left: impl Fn(Vec3A) -> bool + Sync,
) -> (usize, (Aabb, Aabb), (Aabb, Aabb)) {
    assert_eq!(
        scratch.len(),
        refs.len(),
        "a scratch list as long as the references"
    );
    let counts: Vec<usize> = refs
        .par_chunks(PARTITION_CHUNK)
        .map(|c| c.iter().filter(|r| left(r.centroid())).count())
        .collect();
    let mid: usize = counts.iter().sum();
    let (mut lefts, mut rights) = scratch.split_at_mut(mid);
    let mut places = Vec::with_capacity(counts.len());
    for (chunk, &nl) in refs.chunks(PARTITION_CHUNK).zip(&counts) {
        let (l, rest) = std::mem::take(&mut lefts).split_at_mut(nl);
        lefts = rest;
        let (r, rest) = std::mem::take(&mut rights).split_at_mut(chunk.len() - nl);
        rights = rest;
        places.push((l, r));
    }
    let sides = refs
        .par_chunks(PARTITION_CHUNK)
        .zip(places)
        .map(|(chunk, (l, r))| {
            let mut sides = Sides::new();
            let (mut nl, mut nr) = (0, 0);
            for p in chunk {
                let goes_left = left(p.centroid());
                sides.add(p, goes_left);
                if goes_left {
                    l[nl] = *p;
                    nl += 1;
                } else {
                    r[nr] = *p;
                    nr += 1;
                }
            }
            sides
        })
        .reduce(Sides::new, Sides::join);
    refs.copy_from_slice(scratch);
    let (l, r) = sides.boxes();
    (mid, l, r)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::Scene;
    use glam::Vec3;

    #[test]
    fn both_builders_make_valid_trees_for_every_leaf_size() {
        let scene = Scene::builtin("chess:3000").unwrap();
        for builder in Builder::ALL {
            for leaf in [1, 2, 4, 8] {
                let opts = BuildOptions::new(builder).with_max_leaf_size(leaf);
                let bvh = Bvh::build(&scene.triangles, &opts);
                bvh.validate(&scene.triangles).unwrap();
                assert_eq!(bvh.stats.nodes, 2 * bvh.stats.leaves - 1);
                assert!(bvh.stats.sah_cost > 0.0);
            }
        }
    }

    #[test]
    fn build_is_deterministic_across_thread_counts() {
        let scene = Scene::builtin("hairball:20000").unwrap();
        let one = rayon::ThreadPoolBuilder::new()
            .num_threads(1)
            .build()
            .unwrap();
        let a = one.install(|| Bvh::build(&scene.triangles, &BuildOptions::sah()));
        let b = Bvh::build(&scene.triangles, &BuildOptions::sah());
        assert_eq!(a.nodes, b.nodes);
        assert_eq!(a.prims, b.prims);
    }

    /// The parallel partition is a stable partition of the ids, with each
    /// side's box and centroid box, and gives the same order on one thread
    /// as on several.
    #[test]
    fn parallel_partition_is_a_stable_partition() {
        let scene = Scene::builtin("hairball:3000").unwrap();
        let bounds: Vec<Aabb> = scene.triangles.iter().map(Triangle::bounds).collect();
        let centroids: Vec<Vec3> = bounds.iter().map(Aabb::center).collect();
        let n = centroids.len() as u32;
        // Every triangle many times over: more references than
        // PARALLEL_PARTITION.
        let ids: Vec<u32> = (0..3 * PARALLEL_PARTITION as u32)
            .map(|k| (k * 7919) % n)
            .collect();
        let refs: Vec<PrimRef> = ids
            .iter()
            .map(|&i| PrimRef::new(&bounds[i as usize], i))
            .collect();
        let left = |c: Vec3A| c.x + 0.3 * c.y < 0.1;
        let left3 = |c: Vec3| left(c.into());
        let mut par = refs.clone();
        let (mid, lp, rp) = partition_parallel(&mut par, &mut refs.clone(), left);
        let want: Vec<u32> = ids
            .iter()
            .copied()
            .filter(|&i| left3(centroids[i as usize]))
            .chain(
                ids.iter()
                    .copied()
                    .filter(|&i| !left3(centroids[i as usize])),
            )
            .collect();
        let got: Vec<u32> = par.iter().map(PrimRef::id).collect();
        assert_eq!(got, want);
        assert!(mid > 0 && mid < ids.len());
        // The boxes of each side, from `Aabb`s over the expected order.
        let sides = |ids: &[u32]| {
            ids.iter().fold((Aabb::EMPTY, Aabb::EMPTY), |(b, c), &i| {
                (b.union(bounds[i as usize]), c.grow(centroids[i as usize]))
            })
        };
        assert_eq!((lp, rp), (sides(&want[..mid]), sides(&want[mid..])));
        // The serial partition moves the same references to each side.
        let mut serial = refs.clone();
        let (smid, ls, rs) = partition_serial(&mut serial, left);
        assert_eq!((smid, ls, rs), (mid, lp, rp));
        let mut sl: Vec<u32> = serial[..mid].iter().map(PrimRef::id).collect();
        sl.sort_unstable();
        let mut wl = want[..mid].to_vec();
        wl.sort_unstable();
        assert_eq!(sl, wl);
        let one = rayon::ThreadPoolBuilder::new()
            .num_threads(1)
            .build()
            .unwrap();
        let mut single = refs.clone();
        one.install(|| partition_parallel(&mut single, &mut refs.clone(), left));
        let single: Vec<u32> = single.iter().map(PrimRef::id).collect();
        assert_eq!(single, got);
    }

    #[test]
    fn hybrid_is_balanced_below_the_sah_levels() {
        let scene = Scene::builtin("hairball:20000").unwrap();
        let bvh = Bvh::build(
            &scene.triangles,
            &BuildOptions::hybrid().with_max_leaf_size(1),
        );
        // Median splits halve the count below level 8.
        let bound = 8 + (scene.triangles.len() as f64).log2().ceil() as u32 + 1;
        assert!(bvh.stats.depth <= bound, "depth {}", bvh.stats.depth);
    }

    #[test]
    fn identical_triangles_split_by_median() {
        let t = Triangle::new(Vec3::ZERO, Vec3::X, Vec3::Y);
        let tris = vec![t; 100];
        let bvh = Bvh::build(&tris, &BuildOptions::sah().with_max_leaf_size(4));
        bvh.validate(&tris).unwrap();
        assert!(bvh.stats.depth <= 6);
    }

    /// Triangles with a NaN or infinite coordinate are left out as
    /// degenerate (they once reached the median split's comparison, which
    /// panicked), by every builder, and the others are still found.
    #[test]
    fn triangles_with_non_finite_coordinates_are_left_out() {
        let good = |x: f32| {
            Triangle::new(
                Vec3::new(x, 0.0, 0.0),
                Vec3::new(x + 1.0, 0.0, 0.0),
                Vec3::new(x, 1.0, 0.0),
            )
        };
        let mut tris: Vec<Triangle> = (0..200).map(|i| good(i as f32 * 0.25)).collect();
        for (k, bad) in [f32::NAN, f32::INFINITY, f32::NEG_INFINITY]
            .into_iter()
            .enumerate()
        {
            for j in 0..20 {
                let mut t = good(j as f32);
                match j % 3 {
                    0 => t.a.x = bad,
                    1 => t.b.y = bad,
                    _ => t.c.z = bad,
                }
                tris.insert(7 * (k * 20 + j) % tris.len(), t);
            }
        }
        for builder in Builder::ALL {
            for leaf in [1, 8] {
                let bvh = Bvh::build(&tris, &BuildOptions::new(builder).with_max_leaf_size(leaf));
                bvh.validate(&tris).unwrap();
                assert_eq!(bvh.stats.degenerate_triangles, 60, "{builder:?}");
                let mut kept: Vec<u32> = bvh.prims.clone();
                kept.sort_unstable();
                kept.dedup();
                assert_eq!(kept.len(), 200, "{builder:?}");
                assert!(kept.iter().all(|&p| !tris[p as usize].is_degenerate()));
            }
        }
    }

    #[test]
    fn degenerate_triangles_are_left_out() {
        let good = Triangle::new(Vec3::ZERO, Vec3::X, Vec3::Y);
        let bad = Triangle::new(Vec3::ZERO, Vec3::X, Vec3::X);
        let bvh = Bvh::build(&[bad, good, bad], &BuildOptions::sah());
        assert_eq!(bvh.prims, vec![1]);
        assert_eq!(bvh.stats.degenerate_triangles, 2);
    }
}
