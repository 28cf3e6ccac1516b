//! Leaves whose triangles are tested four at a time: a leaf's triangles are
//! copied side by side into blocks of [`LANES`] (vertex coordinates as nine
//! rows of four lanes), and the watertight test (Woop, Benthin and Wald
//! 2013) runs on all lanes in one pass of vector arithmetic.
//!
//! The lanes compute exactly the f32 operations of
//! [`crate::geometry::Triangle::intersect`], in the same order, so a lane's
//! answer is bit for bit the scalar test's; a lane the f32 test cannot decide
//! (an edge function exactly zero, an ill-conditioned or overflowing
//! configuration) is handed to the scalar test, which takes its exact
//! paths. Lanes are then taken in leaf order with the leaf list's rules (the
//! tie rule, any hit, every hit), so a leaf answers as
//! [`super::leaf::intersect_leaf`] does, ray for ray.

use super::leaf::{take_hit, LAST};
use crate::geometry::{Hit, Ray, Triangle, ILL_CONDITIONED, TINY_DETERMINANT, TINY_SCALE};
use crate::stats::{Stats, Tally};
use glam::{BVec4A, Vec4};
use std::ops::{Add, BitAnd, BitOr, Mul, Not, Sub};

/// Triangles per block.
pub const LANES: usize = 4;
/// The entry of an unused lane (after the leaf's last triangle).
pub(crate) const EMPTY: u32 = u32::MAX;

/// Four triangles: `v[3·vertex + axis][lane]` (vertices a, b, c; axes x, y,
/// z) and their entries in the sign-terminated leaf list (`LAST` on the
/// leaf's last triangle; `u32::MAX` in unused lanes after it). 160 bytes.
#[derive(Clone, Copy, Debug, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
#[repr(C, align(16))]
pub struct TriBlock {
    /// Vertex coordinates, one row per vertex axis, one lane per triangle.
    pub v: [[f32; LANES]; 9],
    /// Mesh triangle indices, the leaf's last with [`LAST`] set.
    pub prims: [u32; LANES],
}

impl TriBlock {
    /// Lanes in use (1 to 4): unused lanes come after the used ones.
    #[inline(always)]
    pub fn count(&self) -> usize {
        self.used().count_ones() as usize
    }

    /// Bit `l` set for each lane `l` in use.
    #[inline(always)]
    pub fn used(&self) -> u32 {
        #[cfg(target_arch = "x86_64")]
        {
            // One compare of the four entries (SSE2, the x86-64 baseline):
            // the compiler had tested them one at a time.
            use std::arch::x86_64::{
                _mm_castsi128_ps, _mm_cmpeq_epi32, _mm_movemask_ps, _mm_set1_epi32,
            };
            let p: std::arch::x86_64::__m128i = bytemuck::cast(self.prims);
            // SAFETY: SSE and SSE2 are part of the x86-64 baseline, so these
            // intrinsics exist on every processor this code runs on.
            let empty = unsafe {
                _mm_movemask_ps(_mm_castsi128_ps(_mm_cmpeq_epi32(
                    p,
                    _mm_set1_epi32(EMPTY as i32),
                )))
            };
            (empty as u32) ^ 0xf
        }
        #[cfg(not(target_arch = "x86_64"))]
        {
            let mut mask = 0;
            for (l, &p) in self.prims.iter().enumerate() {
                mask |= ((p != EMPTY) as u32) << l;
            }
            mask
        }
    }
}

/// Appends the blocks of a leaf whose triangles are `prims` (mesh indices,
/// at least one) and returns the first block's index.
pub fn push_leaf(blocks: &mut Vec<TriBlock>, prims: &[u32], triangles: &[Triangle]) -> u32 {
    assert!(!prims.is_empty(), "a leaf has triangles");
    let first = blocks.len() as u32;
    for (j, chunk) in prims.chunks(LANES).enumerate() {
        let mut b = TriBlock {
            v: [[0.0; LANES]; 9],
            prims: [EMPTY; LANES],
        };
        for (l, &p) in chunk.iter().enumerate() {
            let t = &triangles[p as usize];
            for (vi, vert) in [t.a, t.b, t.c].into_iter().enumerate() {
                for axis in 0..3 {
                    b.v[3 * vi + axis][l] = vert[axis];
                }
            }
            b.prims[l] = p;
            if j * LANES + l + 1 == prims.len() {
                b.prims[l] |= LAST;
            }
        }
        blocks.push(b);
    }
    first
}

/// The vertices of triangle `prim` as the leaf whose first block is `first`
/// holds them (bit for bit the mesh's, [`push_leaf`]), or `None` if that
/// leaf does not hold it. A closest-hit query reads them here, from a leaf
/// it has just tested, rather than from the mesh.
pub fn leaf_triangle(blocks: &[TriBlock], first: u32, prim: u32) -> Option<Triangle> {
    for b in &blocks[first as usize..] {
        for l in 0..LANES {
            let p = b.prims[l];
            if p == EMPTY {
                return None;
            }
            if p & !LAST == prim {
                let vertex = |vi: usize| {
                    glam::Vec3::new(b.v[3 * vi][l], b.v[3 * vi + 1][l], b.v[3 * vi + 2][l])
                };
                return Some(Triangle {
                    a: vertex(0),
                    b: vertex(1),
                    c: vertex(2),
                });
            }
            if p & LAST != 0 {
                return None;
            }
        }
    }
    None
}

/// A sign-terminated leaf list's triangles copied into blocks
/// ([`TriBlock`]), each leaf starting a new block, for the structures whose
/// leaves are addressed by their position in the list (BVH, sparse,
/// implicit, dual-split tree, BIH, H-tree, Compact BVH): `start[p]` is the first block of the leaf
/// that begins at list position `p`. Derived from the list and the mesh
/// when a structure is built or loaded; not part of the saved files.
///
/// Bytes: 160 per block of up to four triangles and 4 per list entry (the
/// map), against 36 per triangle and 4 per entry for the list and the mesh.
#[derive(Clone, Debug, Default)]
pub struct LeafBlocks {
    blocks: Vec<TriBlock>,
    start: Vec<u32>,
}

impl LeafBlocks {
    /// The blocks of every leaf of `index` (a sign-terminated list of
    /// indices into `triangles`).
    pub fn new(index: &[u32], triangles: &[Triangle]) -> Self {
        // A leaf of n triangles takes ceil(n / LANES) blocks: the whole list
        // is reserved at once (on huge pages) and never moved.
        let leaves = index.iter().filter(|&&e| e & LAST != 0).count();
        let mut blocks = crate::pages::vec_with_capacity(index.len() / LANES + leaves);
        let mut start = vec![EMPTY; index.len()];
        let mut prims = Vec::new();
        let mut first = 0;
        for (p, &e) in index.iter().enumerate() {
            prims.push(e & !LAST);
            if e & LAST != 0 {
                start[first] = push_leaf(&mut blocks, &prims, triangles);
                prims.clear();
                first = p + 1;
            }
        }
        crate::pages::advise(&blocks);
        LeafBlocks { blocks, start }
    }

    /// Bytes of the blocks and of the map from list positions to blocks.
    pub fn bytes(&self) -> usize {
        std::mem::size_of_val(&self.blocks[..]) + self.start.len() * 4
    }

    /// The first block of the leaf that begins at list position `first`.
    #[inline(always)]
    pub fn start_of(&self, first: u32) -> u32 {
        self.start[first as usize]
    }

    /// The blocks, in leaf order.
    #[inline(always)]
    pub fn blocks(&self) -> &[TriBlock] {
        &self.blocks
    }

    /// [`intersect_blocks`] on the leaf that begins at list position `first`.
    #[inline(always)]
    #[allow(clippy::too_many_arguments)]
    pub fn intersect<const ANY: bool, S: Stats>(
        &self,
        first: u32,
        triangles: &[Triangle],
        ray: &Ray,
        tmax: &mut f32,
        best: &mut Option<Hit>,
        tally: &mut Tally,
        stats: &mut S,
    ) -> bool {
        intersect_blocks::<ANY, S>(
            &self.blocks,
            self.start[first as usize],
            triangles,
            ray,
            tmax,
            best,
            tally,
            stats,
        )
    }
}

/// Tests the triangles of the leaf whose blocks start at `first` against
/// `[ray.tmin, *tmax]`, with the rules of [`super::leaf::intersect_leaf`]:
/// closest hit (`ANY = false`: `best` and `tmax` updated, ties to the
/// smaller index), any hit (`true` returned on the first), or every hit to a
/// sink that wants them ([`Stats::HITS`]).
///
/// The four lanes run in `glam::Vec4` (SSE2 on x86-64, NEON on aarch64, no
/// `unsafe`); the outcome of each lane is a bit in a mask, and a block whose
/// lanes all miss costs no per-lane work. Lanes the f32 test cannot decide
/// go to the scalar test; lanes that hit within the interval as it was when
/// the block began are then taken in leaf order against the current one.
#[inline(always)]
#[allow(clippy::too_many_arguments)]
pub fn intersect_blocks<const ANY: bool, S: Stats>(
    blocks: &[TriBlock],
    first: u32,
    triangles: &[Triangle],
    ray: &Ray,
    tmax: &mut f32,
    best: &mut Option<Hit>,
    tally: &mut Tally,
    stats: &mut S,
) -> bool {
    intersect_blocks_with::<ANY, S>(
        &BlockRay::new(ray),
        blocks,
        first,
        triangles,
        ray,
        tmax,
        best,
        tally,
        stats,
    )
}

/// A ray's constants for [`intersect_blocks_with`], computed once per ray
/// rather than once per leaf: its axes in the watertight test's order, its
/// shear and its origin on those axes, and `tmin`.
#[derive(Clone, Copy, Debug)]
pub struct BlockRay {
    k: [usize; 3],
    s: [f32; 3],
    o: [f32; 3],
    tmin: f32,
}

impl BlockRay {
    /// The constants of `ray`.
    #[inline(always)]
    pub fn new(ray: &Ray) -> Self {
        // `Ray::new` makes each axis 0, 1 or 2; the clamp (a compare and a
        // move) only tells the compiler so, where `% 3` cost a multiply
        // sequence per axis.
        let k = ray.k.map(|k| usize::from(k).min(2));
        let o = ray.origin().to_array();
        BlockRay {
            k,
            s: ray.shear.to_array(),
            o: k.map(|a| o[a]),
            tmin: ray.tmin,
        }
    }
}

/// The lanes one pass of the block test runs on: one block's four
/// triangles ([`Vec4`]), or two consecutive blocks of a leaf as eight (the
/// wide kernel's AVX2 and AVX-512 paths). Every operation is lane by lane,
/// in f32, as the scalar test computes it; comparisons give lane masks
/// ([`Lanes::Mask`], false on NaN), combined in vector registers and turned
/// into bits (bit `l` for lane `l`) once per decision.
pub trait Lanes: Copy + Add<Output = Self> + Sub<Output = Self> + Mul<Output = Self> {
    /// Blocks per pass (1 or 2).
    const BLOCKS: usize;
    /// A lane mask.
    type Mask: Copy
        + BitAnd<Output = Self::Mask>
        + BitOr<Output = Self::Mask>
        + Not<Output = Self::Mask>;
    /// Row `r` of block `i` in lanes 0–3 and, with two blocks per pass, of
    /// block `j` in lanes 4–7.
    fn rows(blocks: &[TriBlock], i: usize, j: usize, r: usize) -> Self;
    /// `x` in every lane.
    fn splat(x: f32) -> Self;
    /// `f32::abs` of each lane.
    fn abs(self) -> Self;
    /// `f32::signum` of each lane.
    fn signum(self) -> Self;
    /// The lesser of each lane pair (either where one is NaN: callers use it
    /// only where a NaN lane's answer does not matter).
    fn min(self, o: Self) -> Self;
    /// The greater of each lane pair (NaN as [`Lanes::min`]).
    fn max(self, o: Self) -> Self;
    /// Lanes where `self < o`.
    fn lt(self, o: Self) -> Self::Mask;
    /// Lanes where `self > o`.
    fn gt(self, o: Self) -> Self::Mask;
    /// Lanes where `self <= o`.
    fn le(self, o: Self) -> Self::Mask;
    /// Lanes where `self >= o`.
    fn ge(self, o: Self) -> Self::Mask;
    /// Lanes where `self == o`.
    fn eq(self, o: Self) -> Self::Mask;
    /// Bit `l` set for each lane `l` of `m` set.
    fn bits(m: Self::Mask) -> u32;
    /// The lanes, the first `4 · BLOCKS` meaningful.
    fn lanes(self) -> [f32; 8];
}

impl Lanes for Vec4 {
    const BLOCKS: usize = 1;
    type Mask = BVec4A;
    #[inline(always)]
    fn rows(blocks: &[TriBlock], i: usize, _j: usize, r: usize) -> Self {
        Vec4::from_array(blocks[i].v[r])
    }
    #[inline(always)]
    fn splat(x: f32) -> Self {
        Vec4::splat(x)
    }
    #[inline(always)]
    fn abs(self) -> Self {
        Vec4::abs(self)
    }
    #[inline(always)]
    fn signum(self) -> Self {
        Vec4::signum(self)
    }
    #[inline(always)]
    fn min(self, o: Self) -> Self {
        Vec4::min(self, o)
    }
    #[inline(always)]
    fn max(self, o: Self) -> Self {
        Vec4::max(self, o)
    }
    #[inline(always)]
    fn lt(self, o: Self) -> BVec4A {
        self.cmplt(o)
    }
    #[inline(always)]
    fn gt(self, o: Self) -> BVec4A {
        self.cmpgt(o)
    }
    #[inline(always)]
    fn le(self, o: Self) -> BVec4A {
        self.cmple(o)
    }
    #[inline(always)]
    fn ge(self, o: Self) -> BVec4A {
        self.cmpge(o)
    }
    #[inline(always)]
    fn eq(self, o: Self) -> BVec4A {
        self.cmpeq(o)
    }
    #[inline(always)]
    fn bits(m: BVec4A) -> u32 {
        m.bitmask()
    }
    #[inline(always)]
    fn lanes(self) -> [f32; 8] {
        let a = self.to_array();
        [a[0], a[1], a[2], a[3], 0.0, 0.0, 0.0, 0.0]
    }
}

/// [`intersect_blocks`] with the ray's constants computed beforehand
/// (`br` is [`BlockRay::new`] of `ray`), one block per pass.
#[inline(always)]
#[allow(clippy::too_many_arguments)]
pub fn intersect_blocks_with<const ANY: bool, S: Stats>(
    br: &BlockRay,
    blocks: &[TriBlock],
    first: u32,
    triangles: &[Triangle],
    ray: &Ray,
    tmax: &mut f32,
    best: &mut Option<Hit>,
    tally: &mut Tally,
    stats: &mut S,
) -> bool {
    intersect_lanes::<Vec4, ANY, S>(
        br, blocks, first, false, triangles, ray, tmax, best, tally, stats,
    )
}

/// [`intersect_blocks_with`] on lanes `L`: a pass tests `L::BLOCKS`
/// consecutive blocks of the leaf at once (the last pass of a leaf with an
/// odd number of blocks leaves lanes 4–7 unused). The answers, the lanes
/// taken and the tally are those of one block per pass: a lane is a
/// candidate against the interval at the pass's start and taken, in leaf
/// order, against the current one.
#[inline(always)]
#[allow(clippy::too_many_arguments)]
pub fn intersect_lanes<L: Lanes, const ANY: bool, S: Stats>(
    br: &BlockRay,
    blocks: &[TriBlock],
    first: u32,
    pair: bool,
    triangles: &[Triangle],
    ray: &Ray,
    tmax: &mut f32,
    best: &mut Option<Hit>,
    tally: &mut Tally,
    stats: &mut S,
) -> bool {
    #[cfg(feature = "scalar-leaves")]
    {
        let _ = (br, pair);
        return scalar_blocks::<ANY, S>(blocks, first, triangles, ray, tmax, best, tally, stats);
    }
    #[cfg_attr(feature = "scalar-leaves", allow(unreachable_code))]
    let [kx, ky, kz] = br.k;
    let [sx, sy, sz] = br.s.map(L::splat);
    let [ox, oy, oz] = br.o.map(L::splat);
    let tmin = L::splat(br.tmin);
    let mut i = first as usize;
    // Whether the pass's first block is followed by another of the leaf, as
    // the caller expects it ([`pair_hint`]; after the first pass, read from
    // the block).
    let mut hint = pair;
    loop {
        // A block whose last lane is used and not the leaf's last is
        // followed by another of the same leaf.
        let more = L::BLOCKS == 2 && pair_hint(blocks, i as u32);
        if L::BLOCKS == 2 && hint != more {
            // A wrong expectation: the pass again on the right blocks.
            hint = more;
            continue;
        }
        // The pass's blocks from the expectation, which the caller had
        // before this leaf's first block arrived from memory: the second
        // block's rows are then loaded at once rather than after the first
        // block's entries (which the check above confirms, in the shadow
        // of those loads).
        let j = if L::BLOCKS == 2 && hint { i + 1 } else { i };
        let row = |r: usize| L::rows(blocks, i, j, r);
        // Vertex coordinates relative to the origin, on the ray's axes,
        // sheared: the f32 operations of `Triangle::intersect`, in order.
        let (a_x, a_y, a_z) = (row(kx) - ox, row(ky) - oy, row(kz) - oz);
        let (b_x, b_y, b_z) = (row(3 + kx) - ox, row(3 + ky) - oy, row(3 + kz) - oz);
        let (c_x, c_y, c_z) = (row(6 + kx) - ox, row(6 + ky) - oy, row(6 + kz) - oz);
        let ax = a_x - sx * a_z;
        let ay = a_y - sy * a_z;
        let bx = b_x - sx * b_z;
        let by = b_y - sy * b_z;
        let cx = c_x - sx * c_z;
        let cy = c_y - sy * c_z;
        let u = cx * by - cy * bx;
        let v = ax * cy - ay * cx;
        let w = bx * ay - by * ax;
        let det = u + v + w;
        let m = ax.abs() + ay.abs() + a_z.abs();
        let zero = L::splat(0.0);
        let det_abs = det.abs();
        // The scalar test's exact paths: an edge function exactly zero, an
        // ill-conditioned triangle (the negated comparisons take NaN too).
        let exact = u.eq(zero) | v.eq(zero) | w.eq(zero);
        let conditioned =
            det_abs.ge(m * m * L::splat(ILL_CONDITIONED)) & m.ge(L::splat(TINY_SCALE));
        // Edge functions of mixed signs, or a zero determinant: a miss. By
        // the least and the greatest of the three (a lane with a NaN among
        // them has a NaN determinant, so it is not `conditioned`: it takes
        // the exact path whatever `outside` says).
        let outside = (u.min(v).min(w).lt(zero) & u.max(v).max(w).gt(zero)) | det.eq(zero);
        // Lanes in use: every lane of a block followed by another, then the
        // used lanes of the pass's last block.
        // The pass's last block ends the leaf where its last lane is unused
        // (`EMPTY` has the `LAST` bit) or is the leaf's last triangle.
        let used = if more {
            0xf | blocks[j].used() << LANES
        } else {
            blocks[j].used()
        };
        let n = used.count_ones() as usize;
        let last = blocks[j].prims[LANES - 1] & LAST != 0;
        // Most passes: every used lane a certain miss (outside, decided in
        // f32). Nothing more to compute.
        let missed = L::bits(outside & conditioned & !exact);
        if missed & used == used {
            tally.triangles += n as u32;
            if last {
                return false;
            }
            i = j + 1;
            hint = L::BLOCKS == 2 && pair_hint(blocks, i as u32);
            continue;
        }
        let t_scaled = u * (sz * a_z) + v * (sz * b_z) + w * (sz * c_z);
        // Overflow, a determinant too small for 1/det, or T zero or
        // subnormal (its sign may be lost): exact paths too.
        let t_mag = t_scaled.abs();
        let inf = L::splat(f32::INFINITY);
        let finite = det_abs.ge(L::splat(TINY_DETERMINANT))
            & det_abs.lt(inf)
            & t_mag.ge(L::splat(f32::MIN_POSITIVE))
            & t_mag.lt(inf);
        let precise = exact | !conditioned | (!outside & !finite);
        // T flipped by det's sign, against the interval at the pass's start
        // (a lane beyond it is beyond any later, smaller one too).
        let t_abs = t_scaled * det.signum();
        let within = t_abs.ge(tmin * det_abs) & t_abs.le(L::splat(*tmax) * det_abs);
        let candidates = within & !outside & finite;
        let precise = L::bits(precise) & used;
        let mut todo = (L::bits(candidates) & used) | precise;
        let (v, w, det, t_scaled) = (v.lanes(), w.lanes(), det.lanes(), t_scaled.lanes());
        let t_abs = t_abs.lanes();
        while todo != 0 {
            let l = todo.trailing_zeros() as usize & 7;
            todo &= todo - 1;
            let blk = if l < LANES { i } else { j };
            let prim = blocks[blk].prims[l & (LANES - 1)] & !LAST;
            let hit = if precise & (1 << l) != 0 {
                triangles[prim as usize].hit(ray, ray.tmin, *tmax, prim)
            } else {
                let d = det[l].abs();
                if t_abs[l] > *tmax * d {
                    None
                } else {
                    let rcp = 1.0 / det[l];
                    Some(Hit {
                        t: t_scaled[l] * rcp,
                        prim,
                        u: v[l] * rcp,
                        v: w[l] * rcp,
                    })
                }
            };
            if let Some(h) = hit {
                if take_hit::<ANY, S>(h, tmax, best, stats) {
                    tally.triangles += l as u32 + 1;
                    return true;
                }
            }
        }
        tally.triangles += n as u32;
        if last {
            return false;
        }
        i = j + 1;
        hint = L::BLOCKS == 2 && pair_hint(blocks, i as u32);
    }
}

/// Whether the leaf whose blocks start at `first` has a second block: what
/// [`intersect_lanes`] expects as `pair` (a layout keeps it beside the
/// leaf's reference, so that the test knows it before the block is read).
#[inline(always)]
pub fn pair_hint(blocks: &[TriBlock], first: u32) -> bool {
    blocks[first as usize].prims[LANES - 1] & LAST == 0
}

/// The `scalar-leaves` experiment: the blocks' triangles tested one at a
/// time, in leaf order, with the scalar watertight test and the leaf
/// list's rules ([`super::leaf::intersect_leaf`]'s loop over the blocks'
/// lanes).
#[cfg(feature = "scalar-leaves")]
#[inline(always)]
#[allow(clippy::too_many_arguments)]
fn scalar_blocks<const ANY: bool, S: Stats>(
    blocks: &[TriBlock],
    first: u32,
    triangles: &[Triangle],
    ray: &Ray,
    tmax: &mut f32,
    best: &mut Option<Hit>,
    tally: &mut Tally,
    stats: &mut S,
) -> bool {
    let mut i = first as usize;
    loop {
        for &entry in &blocks[i].prims {
            if entry == EMPTY {
                break;
            }
            let prim = entry & !LAST;
            tally.triangles += 1;
            if let Some(h) = triangles[prim as usize].hit(ray, ray.tmin, *tmax, prim) {
                if take_hit::<ANY, S>(h, tmax, best, stats) {
                    return true;
                }
            }
            if entry & LAST != 0 {
                return false;
            }
        }
        i += 1;
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use crate::rng::Pcg32;
    use crate::stats::{HitList, NoStats};
    use crate::structures::shared::leaf::intersect_leaf;
    use glam::Vec3;

    /// Leaves of 1 to 9 triangles at scales from 1e-6 to 1e6, with shared
    /// edges, coplanar overlaps and edge-on triangles, and rays through
    /// them: the blocks answer exactly as the scalar leaf test, for closest
    /// hit, any hit and every hit.
    #[test]
    fn blocks_answer_as_the_scalar_leaf_test() {
        lanes_answer_as_the_scalar_leaf_test::<Vec4>();
    }

    /// The test above on lanes `L`: leaves of up to 9 triangles take up to
    /// three blocks, so two blocks per pass meet a full pair and a last
    /// pass of one block.
    pub(crate) fn lanes_answer_as_the_scalar_leaf_test<L: Lanes>() {
        let mut rng = Pcg32::new(7, 3);
        let mut f = || rng.next_f32() * 2.0 - 1.0;
        let mut checked = 0;
        for case in 0..4000 {
            let scale = 10f32.powi(case % 13 - 6);
            let n = 1 + case as usize % 9;
            let p = |f: &mut dyn FnMut() -> f32| Vec3::new(f(), f(), f()) * scale;
            let mut tris = Vec::new();
            for i in 0..n {
                let t = match i % 4 {
                    // A neighbour sharing the previous triangle's edge.
                    1 if i > 0 => {
                        let q: &Triangle = &tris[i - 1];
                        Triangle::new(q.b, q.a, p(&mut f))
                    }
                    // A copy: an exact tie.
                    2 if i > 0 => tris[i - 1],
                    // Edge-on: the three points on a line through the origin's region.
                    3 => {
                        let a = p(&mut f);
                        Triangle::new(a, a * 2.0, a * 3.0 + Vec3::splat(scale * 1e-7))
                    }
                    _ => Triangle::new(p(&mut f), p(&mut f), p(&mut f)),
                };
                tris.push(t);
            }
            let prims: Vec<u32> = (0..n as u32).collect();
            let mut index = prims.clone();
            *index.last_mut().unwrap() |= LAST;
            let mut blocks = Vec::new();
            let first = push_leaf(&mut blocks, &prims, &tris);
            for _ in 0..8 {
                let target = tris[rng_index(&mut f, n)].centroid() + p(&mut f) * 0.01;
                let origin = p(&mut f) * 3.0;
                let ray = Ray::new(origin, target - origin, 0.0, f32::INFINITY);
                for any in [false, true] {
                    let scalar = run(
                        any,
                        |tm, b, ta| {
                            if any {
                                intersect_leaf::<true, NoStats>(
                                    &index,
                                    &tris,
                                    0,
                                    &ray,
                                    tm,
                                    b,
                                    ta,
                                    &mut NoStats,
                                )
                            } else {
                                intersect_leaf::<false, NoStats>(
                                    &index,
                                    &tris,
                                    0,
                                    &ray,
                                    tm,
                                    b,
                                    ta,
                                    &mut NoStats,
                                )
                            }
                        },
                        &ray,
                    );
                    let block = run(
                        any,
                        |tm, b, ta| {
                            if any {
                                intersect_lanes::<L, true, NoStats>(
                                    &BlockRay::new(&ray),
                                    &blocks,
                                    first,
                                    pair_hint(&blocks, first),
                                    &tris,
                                    &ray,
                                    tm,
                                    b,
                                    ta,
                                    &mut NoStats,
                                )
                            } else {
                                intersect_lanes::<L, false, NoStats>(
                                    &BlockRay::new(&ray),
                                    &blocks,
                                    first,
                                    pair_hint(&blocks, first),
                                    &tris,
                                    &ray,
                                    tm,
                                    b,
                                    ta,
                                    &mut NoStats,
                                )
                            }
                        },
                        &ray,
                    );
                    assert_eq!(block, scalar, "case {case} any {any}: {tris:?} {ray:?}");
                }
                let (mut sa, mut sb) =
                    (HitList::<NoStats>::default(), HitList::<NoStats>::default());
                let (mut tm, mut b, mut ta) = (ray.tmax, None, Tally::default());
                intersect_leaf::<false, _>(
                    &index, &tris, 0, &ray, &mut tm, &mut b, &mut ta, &mut sa,
                );
                let (mut tm, mut b, mut ta) = (ray.tmax, None, Tally::default());
                // A wrong expectation of the second block costs a retry,
                // never an answer.
                intersect_lanes::<L, false, _>(
                    &BlockRay::new(&ray),
                    &blocks,
                    first,
                    !pair_hint(&blocks, first),
                    &tris,
                    &ray,
                    &mut tm,
                    &mut b,
                    &mut ta,
                    &mut sb,
                );
                assert_eq!(sa.hits, sb.hits, "case {case}: every hit");
                checked += sa.hits.len();
            }
        }
        assert!(checked > 1000, "too few hits to mean anything: {checked}");
    }

    fn rng_index(f: &mut dyn FnMut() -> f32, n: usize) -> usize {
        (((f() + 1.0) * 0.5 * n as f32) as usize).min(n - 1)
    }

    /// Runs a leaf test from a fresh state: (stopped, tmax, best, tally).
    fn run(
        _any: bool,
        test: impl Fn(&mut f32, &mut Option<Hit>, &mut Tally) -> bool,
        ray: &Ray,
    ) -> (bool, f32, Option<Hit>, Tally) {
        let (mut tmax, mut best, mut tally) = (ray.tmax, None, Tally::default());
        let stop = test(&mut tmax, &mut best, &mut tally);
        (stop, tmax, best, tally)
    }
}
