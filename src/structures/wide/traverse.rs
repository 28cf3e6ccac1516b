//! Closest and any hit over a wide tree (`bvh4`, `bvh8`, `cwbvh`): every
//! child's box tested in one pass, hit children visited nearest first, a
//! stack of references with entry distances, and popped entries beyond the
//! closest hit skipped.
//!
//! There is no separate test of the scene box (the root's children are
//! tested at its first visit), and an any-hit trace pushes entered children
//! in lane order without sorting them (Embree's occlusion traversal does
//! the same): its interval never shrinks, so their order only decides
//! which hit is found first.
//!
//! The kernel is written once over two traits: [`WideTree`] (how a layout
//! stores a node's child boxes and references) and [`Isa`] (the vector
//! instruction set that tests them). [`trace`] runs it on the path
//! [`simd::active`] names: each x86-64 path is the same kernel compiled
//! inside a `#[target_feature]` function, with its own box test in
//! intrinsics. Every path computes the slab test's f32 operations in the
//! same order, so a ray's answer, its visit order and its statistics are the
//! same on every path.

use super::{plain, with_pair, WideNode, LEAF, PAIR};
use crate::geometry::aabb::slab_reciprocals;
use crate::geometry::{Hit, Ray, Triangle};
use crate::stats::{Stats, Tally};
use crate::structures::shared::simd::{self, SimdPath};
use crate::structures::shared::tri_block::{
    intersect_lanes, leaf_triangle, BlockRay, Lanes, TriBlock,
};
use crate::structures::shared::MAX_STACK_DEPTH;
use arrayvec::ArrayVec;

/// A ray's constants for the box tests of one trace: origin, reciprocal
/// direction scaled for the near planes (`inv_near`) and for the far ones
/// (`inv_far`, [`slab_reciprocals`]: no widening per node), and per axis the plane
/// row nearer (`near`) and farther (`far`) along the ray (rows 0–2 are
/// minima, 3–5 maxima).
pub struct NodeRay {
    pub org: [f32; 3],
    pub inv_near: [f32; 3],
    pub inv_far: [f32; 3],
    pub near: [usize; 3],
    pub far: [usize; 3],
    pub tmin: f32,
}

/// The children of one node a ray enters: `count` entries, in lane order,
/// `dist[i]` the entry distance of reference `refs[i]`.
pub struct Entered<const W: usize> {
    pub dist: [f32; W],
    pub refs: [u32; W],
    pub count: usize,
}

/// A vector instruction set's box test of a node's `W` children.
pub trait Isa {
    /// The entry distance of each lane (meaningful where its bit is set)
    /// and a mask of the lanes whose box the ray enters within
    /// `[ray.tmin, tmax]`: the slab test of [`crate::geometry::BoxRay::test`]
    /// on every lane, bit for bit.
    fn test<const W: usize>(r: &NodeRay, planes: &[[f32; W]; 6], tmax: f32) -> ([f32; W], u32);

    /// [`Isa::test`] of a node's `W` children, and the lanes entered
    /// gathered into `e` in lane order (entry distance, `children[k]`), as
    /// [`gather`] does: the x86-64 paths compress the lanes with vector
    /// permutes rather than one lane at a time.
    #[inline(always)]
    fn enter<const W: usize>(
        r: &NodeRay,
        planes: &[[f32; W]; 6],
        children: &[u32; W],
        tmax: f32,
        e: &mut Entered<W>,
    ) {
        let (d, mask) = Self::test::<W>(r, planes, tmax);
        gather(&d, |k| children[k], mask, e);
    }

    /// `p + q·s` for eight quantized planes `q` and a power-of-two scale
    /// `s` (`q·s` is exact, so the one rounding is the addition's, on every
    /// path): a `cwbvh` node's plane row.
    fn dequantize8(p: f32, s: f32, q: &[u8; 8]) -> [f32; 8];

    /// The lanes a leaf pass runs on: one block of four ([`glam::Vec4`]),
    /// or on the paths with 8-lane vectors two blocks at once. The answers
    /// and tallies are the same either way.
    type Leaf: Lanes;
}

/// A wide tree as the kernel reads it.
pub trait WideTree<const W: usize> {
    /// The root's reference (a node index, or `LEAF` | a block index).
    fn root(&self) -> u32;
    /// Whether the tree holds no triangle.
    fn is_empty(&self) -> bool;
    /// Wide levels below the root (the stack holds `W − 1` per level).
    fn depth(&self) -> u32;
    /// The leaves' triangle blocks.
    fn blocks(&self) -> &[TriBlock];
    /// The mesh.
    fn triangles(&self) -> &[Triangle];
    /// Writes into `e` the children of inner node `node` that the ray
    /// enters, in lane order; returns the planes tested (for the
    /// statistics). `e` is the caller's, reused from node to node: returning
    /// it by value cost a copy whose wide load waited on the gather's
    /// narrow stores (a failed store forward) at every node.
    fn enter<I: Isa>(&self, node: u32, r: &NodeRay, tmax: f32, e: &mut Entered<W>) -> u32;
    /// The canonical BVH id of reference `r` (visit logs), with or
    /// without its [`PAIR`] bit.
    fn canonical_id(&self, r: u32) -> u32;
}

impl<const W: usize> Entered<W> {
    /// No child entered.
    pub fn new() -> Self {
        Entered {
            dist: [0.0; W],
            refs: [0; W],
            count: 0,
        }
    }
}

impl<const W: usize> Default for Entered<W> {
    fn default() -> Self {
        Self::new()
    }
}

/// Gathers into `e` the lanes of `mask` (entry distances `d`, the reference
/// of lane `k` given by `refs(k)`, asked only for the lanes gathered) in
/// lane order.
#[inline(always)]
pub fn gather<const W: usize>(
    d: &[f32; W],
    refs: impl Fn(usize) -> u32,
    mut mask: u32,
    e: &mut Entered<W>,
) {
    e.count = 0;
    // `mask` has at most W bits below bit W (W a power of two), so the
    // masked indices are the indices, with no bounds checks.
    debug_assert!(W.is_power_of_two() && mask < 1 << W);
    while mask != 0 {
        let k = mask.trailing_zeros() as usize & (W - 1);
        mask &= mask - 1;
        e.dist[e.count & (W - 1)] = d[k];
        e.refs[e.count & (W - 1)] = refs(k);
        e.count += 1;
    }
}

/// The portable box test: plain loops over the lanes, which the compiler
/// turns into the target's baseline vectors (and wider ones inside the
/// x86-64 paths' functions).
pub struct Portable;

impl Isa for Portable {
    type Leaf = glam::Vec4;
    #[inline(always)]
    fn test<const W: usize>(r: &NodeRay, planes: &[[f32; W]; 6], tmax: f32) -> ([f32; W], u32) {
        let mut tn = [r.tmin; W];
        let mut tf = [f32::INFINITY; W];
        for a in 0..3 {
            let (o, inv_n, inv_f) = (r.org[a], r.inv_near[a], r.inv_far[a]);
            let (lo, hi) = (&planes[r.near[a]], &planes[r.far[a]]);
            for k in 0..W {
                // A NaN distance (0·inf: origin in the plane, direction along
                // it) keeps the running bound, as the slab test ignores it.
                let t = (lo[k] - o) * inv_n;
                tn[k] = if t > tn[k] { t } else { tn[k] };
                let t = (hi[k] - o) * inv_f;
                tf[k] = if t < tf[k] { t } else { tf[k] };
            }
        }
        let mut mask = 0;
        for k in 0..W {
            let f = if tmax < tf[k] { tmax } else { tf[k] };
            mask |= ((tn[k] <= f) as u32) << k;
        }
        (tn, mask)
    }

    #[inline(always)]
    fn dequantize8(p: f32, s: f32, q: &[u8; 8]) -> [f32; 8] {
        q.map(|q| p + q as f32 * s)
    }
}

#[cfg(target_arch = "x86_64")]
mod x86 {
    //! The x86-64 paths' box tests in intrinsics. `max_ps(t, acc)` is
    //! `t > acc ? t : acc` and `min_ps(t, acc)` is `t < acc ? t : acc`,
    //! which keep the running bound on a NaN distance as the portable test
    //! does; no multiply-add is fused, so every lane's distance is the
    //! portable test's bit for bit.
    use super::{Entered, Isa, NodeRay};
    use crate::structures::shared::tri_block::{Lanes, TriBlock};
    use std::arch::x86_64::*;

    /// A node's six plane rows: row `k` starts `k·stride` floats after
    /// `base`. Found by arithmetic from the ray's row numbers, so that no
    /// table of row pointers is stored and loaded again at every node.
    #[derive(Clone, Copy)]
    struct Rows {
        base: *const f32,
        stride: usize,
    }

    impl Rows {
        /// The rows of `planes`, from lane `from` (0, or 4 for the second
        /// half of an 8-wide node's rows on the 4-lane path).
        #[inline(always)]
        fn of<const W: usize>(planes: &[[f32; W]; 6], from: usize) -> Rows {
            debug_assert!(from + 4 <= W);
            Rows {
                // SAFETY: `from + 4 ≤ W`, within the first row.
                base: unsafe { (planes.as_ptr() as *const f32).add(from) },
                stride: W,
            }
        }

        /// Plane row `k` (< 6), from the lane the rows were made at.
        #[inline(always)]
        fn row(self, k: usize) -> *const f32 {
            debug_assert!(k < 6);
            // SAFETY: `k < 6` rows of `stride` floats lie in the node.
            unsafe { self.base.add(k * self.stride) }
        }
    }

    /// For each mask of eight lanes, the lanes set, in order, as 3-bit
    /// indices packed from bit 0 (AVX2's compress by permutation).
    const COMPRESS8: [u32; 256] = {
        let mut table = [0u32; 256];
        let mut mask = 0;
        while mask < 256 {
            let (mut packed, mut at, mut k) = (0u32, 0, 0);
            while k < 8 {
                if mask & (1 << k) != 0 {
                    packed |= (k as u32) << (3 * at);
                    at += 1;
                }
                k += 1;
            }
            table[mask] = packed;
            mask += 1;
        }
        table
    };

    /// Stores compressed lanes into `e`: entry distances `d` and references
    /// `refs`, of which the first `count` are the entered children.
    #[target_feature(enable = "avx2,fma")]
    #[inline]
    fn store8(e: &mut Entered<8>, d: __m256, refs: __m256i, count: u32) {
        // SAFETY: `e.dist` and `e.refs` hold eight lanes of four bytes.
        unsafe {
            _mm256_storeu_ps(e.dist.as_mut_ptr(), d);
            _mm256_storeu_si256(e.refs.as_mut_ptr() as *mut __m256i, refs);
        }
        e.count = count as usize;
    }

    /// The entered lanes of an 8-wide node compressed by a permutation
    /// from [`COMPRESS8`] (AVX2).
    #[target_feature(enable = "avx2,fma")]
    #[inline]
    fn enter8_avx2(r: &NodeRay, p: Rows, children: *const u32, tmax: f32, e: &mut Entered<8>) {
        let (n, f) = test8_avx2(r, p, tmax);
        let mask = _mm256_movemask_ps(_mm256_cmp_ps::<_CMP_LE_OQ>(n, f)) as u32;
        let packed = _mm256_set1_epi32(COMPRESS8[mask as usize & 0xff] as i32);
        let idx = _mm256_and_si256(
            _mm256_srlv_epi32(packed, _mm256_setr_epi32(0, 3, 6, 9, 12, 15, 18, 21)),
            _mm256_set1_epi32(7),
        );
        // SAFETY: `children` points at eight lanes of four bytes.
        let c = unsafe { _mm256_loadu_si256(children as *const __m256i) };
        store8(
            e,
            _mm256_permutevar8x32_ps(n, idx),
            _mm256_permutevar8x32_epi32(c, idx),
            mask.count_ones(),
        );
    }

    /// The entered lanes of an 8-wide node compressed by AVX-512's
    /// `vcompress`.
    #[target_feature(enable = "avx512f,avx512vl,avx512dq,avx512bw,avx2,fma")]
    #[inline]
    fn enter8_avx512(r: &NodeRay, p: Rows, children: *const u32, tmax: f32, e: &mut Entered<8>) {
        let (n, f) = test8_avx2(r, p, tmax);
        let k = _mm256_cmp_ps_mask::<_CMP_LE_OQ>(n, f);
        // SAFETY: `children` points at eight lanes of four bytes.
        let c = unsafe { _mm256_loadu_si256(children as *const __m256i) };
        store8(
            e,
            _mm256_maskz_compress_ps(k, n),
            _mm256_maskz_compress_epi32(k, c),
            (k as u32).count_ones(),
        );
    }

    /// Eight f32 lanes in one AVX register: two leaf blocks per pass of
    /// the block test. Made only by the `Avx2` and `Avx512` paths' leaf
    /// tests, which run only inside `trace_avx2` and `trace_avx512`, that is
    /// where the processor has AVX2 (`simd::active`), and by a unit test
    /// after it has detected AVX2: each intrinsic below relies on that.
    #[derive(Clone, Copy)]
    pub struct Lanes8(__m256);

    macro_rules! avx {
        ($e:expr) => {
            // SAFETY: a `Lanes8` exists only on a processor with AVX2
            // (see its docs).
            unsafe { $e }
        };
    }

    /// A mask of eight lanes (all bits set in a lane that is true), as
    /// `Lanes8`'s comparisons give it; made only where a `Lanes8` is.
    #[derive(Clone, Copy)]
    pub struct Mask8(__m256);

    impl std::ops::BitAnd for Mask8 {
        type Output = Self;
        #[inline(always)]
        fn bitand(self, o: Self) -> Self {
            Mask8(avx!(_mm256_and_ps(self.0, o.0)))
        }
    }

    impl std::ops::BitOr for Mask8 {
        type Output = Self;
        #[inline(always)]
        fn bitor(self, o: Self) -> Self {
            Mask8(avx!(_mm256_or_ps(self.0, o.0)))
        }
    }

    impl std::ops::Not for Mask8 {
        type Output = Self;
        #[inline(always)]
        fn not(self) -> Self {
            avx!({
                let ones = _mm256_castsi256_ps(_mm256_set1_epi32(-1));
                Mask8(_mm256_xor_ps(self.0, ones))
            })
        }
    }

    impl std::ops::Add for Lanes8 {
        type Output = Self;
        #[inline(always)]
        fn add(self, o: Self) -> Self {
            Lanes8(avx!(_mm256_add_ps(self.0, o.0)))
        }
    }

    impl std::ops::Sub for Lanes8 {
        type Output = Self;
        #[inline(always)]
        fn sub(self, o: Self) -> Self {
            Lanes8(avx!(_mm256_sub_ps(self.0, o.0)))
        }
    }

    impl std::ops::Mul for Lanes8 {
        type Output = Self;
        #[inline(always)]
        fn mul(self, o: Self) -> Self {
            Lanes8(avx!(_mm256_mul_ps(self.0, o.0)))
        }
    }

    impl Lanes for Lanes8 {
        const BLOCKS: usize = 2;
        type Mask = Mask8;
        #[inline(always)]
        fn rows(blocks: &[TriBlock], i: usize, j: usize, r: usize) -> Self {
            let (a, b) = (&blocks[i].v[r], &blocks[j].v[r]);
            // SAFETY: `a` and `b` are four floats each; AVX as above.
            Lanes8(unsafe { _mm256_loadu2_m128(b.as_ptr(), a.as_ptr()) })
        }
        #[inline(always)]
        fn splat(x: f32) -> Self {
            Lanes8(avx!(_mm256_set1_ps(x)))
        }
        #[inline(always)]
        fn abs(self) -> Self {
            Lanes8(avx!(_mm256_andnot_ps(_mm256_set1_ps(-0.0), self.0)))
        }
        #[inline(always)]
        fn signum(self) -> Self {
            // `f32::signum`: ±1 with the lane's sign, NaN kept.
            avx!({
                let one = _mm256_or_ps(
                    _mm256_and_ps(self.0, _mm256_set1_ps(-0.0)),
                    _mm256_set1_ps(1.0),
                );
                let nan = _mm256_cmp_ps::<_CMP_UNORD_Q>(self.0, self.0);
                Lanes8(_mm256_blendv_ps(one, self.0, nan))
            })
        }
        #[inline(always)]
        fn min(self, o: Self) -> Self {
            Lanes8(avx!(_mm256_min_ps(self.0, o.0)))
        }
        #[inline(always)]
        fn max(self, o: Self) -> Self {
            Lanes8(avx!(_mm256_max_ps(self.0, o.0)))
        }
        #[inline(always)]
        fn lt(self, o: Self) -> Mask8 {
            Mask8(avx!(_mm256_cmp_ps::<_CMP_LT_OQ>(self.0, o.0)))
        }
        #[inline(always)]
        fn gt(self, o: Self) -> Mask8 {
            Mask8(avx!(_mm256_cmp_ps::<_CMP_GT_OQ>(self.0, o.0)))
        }
        #[inline(always)]
        fn le(self, o: Self) -> Mask8 {
            Mask8(avx!(_mm256_cmp_ps::<_CMP_LE_OQ>(self.0, o.0)))
        }
        #[inline(always)]
        fn ge(self, o: Self) -> Mask8 {
            Mask8(avx!(_mm256_cmp_ps::<_CMP_GE_OQ>(self.0, o.0)))
        }
        #[inline(always)]
        fn eq(self, o: Self) -> Mask8 {
            Mask8(avx!(_mm256_cmp_ps::<_CMP_EQ_OQ>(self.0, o.0)))
        }
        #[inline(always)]
        fn bits(m: Mask8) -> u32 {
            avx!(_mm256_movemask_ps(m.0) as u32)
        }
        #[inline(always)]
        fn lanes(self) -> [f32; 8] {
            let mut out = [0.0; 8];
            // SAFETY: `out` holds eight floats; AVX as above.
            unsafe { _mm256_storeu_ps(out.as_mut_ptr(), self.0) };
            out
        }
    }

    /// SSE4.1: four lanes per instruction.
    pub struct Sse41;
    /// AVX2: eight lanes per instruction.
    pub struct Avx2;
    /// AVX-512 (VL): eight lanes, the comparison into a mask register.
    pub struct Avx512;

    #[target_feature(enable = "sse4.1")]
    #[inline]
    fn test4_sse(r: &NodeRay, p: Rows, tmax: f32) -> (__m128, u32) {
        let mut tn = _mm_set1_ps(r.tmin);
        let mut tf = _mm_set1_ps(f32::INFINITY);
        for a in 0..3 {
            let o = _mm_set1_ps(r.org[a]);
            let (inv_n, inv_f) = (_mm_set1_ps(r.inv_near[a]), _mm_set1_ps(r.inv_far[a]));
            // SAFETY: `p.row(k)` points at four readable floats (a plane
            // row of a node or half of one), as `Rows::of` makes them.
            let (lo, hi) = unsafe {
                (
                    _mm_loadu_ps(p.row(r.near[a])),
                    _mm_loadu_ps(p.row(r.far[a])),
                )
            };
            tn = _mm_max_ps(_mm_mul_ps(_mm_sub_ps(lo, o), inv_n), tn);
            tf = _mm_min_ps(_mm_mul_ps(_mm_sub_ps(hi, o), inv_f), tf);
        }
        let f = _mm_min_ps(_mm_set1_ps(tmax), tf);
        let mask = _mm_movemask_ps(_mm_cmple_ps(tn, f)) as u32;
        (tn, mask)
    }

    #[target_feature(enable = "avx2,fma")]
    #[inline]
    fn test8_avx2(r: &NodeRay, p: Rows, tmax: f32) -> (__m256, __m256) {
        let mut tn = _mm256_set1_ps(r.tmin);
        let mut tf = _mm256_set1_ps(f32::INFINITY);
        for a in 0..3 {
            let o = _mm256_set1_ps(r.org[a]);
            let (inv_n, inv_f) = (_mm256_set1_ps(r.inv_near[a]), _mm256_set1_ps(r.inv_far[a]));
            // SAFETY: `p.row(k)` points at a plane row of eight floats.
            let (lo, hi) = unsafe {
                (
                    _mm256_loadu_ps(p.row(r.near[a])),
                    _mm256_loadu_ps(p.row(r.far[a])),
                )
            };
            tn = _mm256_max_ps(_mm256_mul_ps(_mm256_sub_ps(lo, o), inv_n), tn);
            tf = _mm256_min_ps(_mm256_mul_ps(_mm256_sub_ps(hi, o), inv_f), tf);
        }
        let f = _mm256_min_ps(_mm256_set1_ps(tmax), tf);
        (tn, f)
    }

    #[target_feature(enable = "avx2,fma")]
    #[inline]
    fn test_avx2<const W: usize>(
        r: &NodeRay,
        planes: &[[f32; W]; 6],
        tmax: f32,
    ) -> ([f32; W], u32) {
        let p = Rows::of(planes, 0);
        let mut d = [0.0; W];
        if W == 8 {
            let (n, f) = test8_avx2(r, p, tmax);
            // SAFETY: `d` holds eight floats.
            unsafe { _mm256_storeu_ps(d.as_mut_ptr(), n) };
            (
                d,
                _mm256_movemask_ps(_mm256_cmp_ps::<_CMP_LE_OQ>(n, f)) as u32,
            )
        } else {
            debug_assert_eq!(W, 4);
            let (n, mask) = test4_sse(r, p, tmax);
            // SAFETY: `d` holds four floats.
            unsafe { _mm_storeu_ps(d.as_mut_ptr(), n) };
            (d, mask)
        }
    }

    #[target_feature(enable = "avx512f,avx512vl,avx512dq,avx512bw,avx2,fma")]
    #[inline]
    fn test_avx512<const W: usize>(
        r: &NodeRay,
        planes: &[[f32; W]; 6],
        tmax: f32,
    ) -> ([f32; W], u32) {
        let p = Rows::of(planes, 0);
        let mut d = [0.0; W];
        if W == 8 {
            let (n, f) = test8_avx2(r, p, tmax);
            // SAFETY: `d` holds eight floats.
            unsafe { _mm256_storeu_ps(d.as_mut_ptr(), n) };
            (d, _mm256_cmp_ps_mask::<_CMP_LE_OQ>(n, f) as u32)
        } else {
            debug_assert_eq!(W, 4);
            let (n, mask) = test4_sse(r, p, tmax);
            // SAFETY: `d` holds four floats.
            unsafe { _mm_storeu_ps(d.as_mut_ptr(), n) };
            (d, mask)
        }
    }

    #[target_feature(enable = "sse4.1")]
    #[inline]
    fn test_sse<const W: usize>(r: &NodeRay, planes: &[[f32; W]; 6], tmax: f32) -> ([f32; W], u32) {
        let mut d = [0.0; W];
        let mut mask = 0;
        for half in 0..W / 4 {
            // Each row holds W = 4·(W/4) floats; this half's four start at
            // `4·half`.
            let p = Rows::of(planes, 4 * half);
            let (n, m) = test4_sse(r, p, tmax);
            // SAFETY: `d` holds W floats; this half's four start at `4·half`.
            unsafe { _mm_storeu_ps(d.as_mut_ptr().add(4 * half), n) };
            mask |= m << (4 * half);
        }
        (d, mask)
    }

    #[target_feature(enable = "sse4.1")]
    #[inline]
    fn dequantize8_sse(p: f32, s: f32, q: &[u8; 8]) -> [f32; 8] {
        let (pv, sv) = (_mm_set1_ps(p), _mm_set1_ps(s));
        let mut out = [0.0; 8];
        for half in 0..2 {
            // SAFETY: four of the eight bytes, from `4·half`.
            let b = unsafe {
                _mm_cvtsi32_si128((q.as_ptr().add(4 * half) as *const i32).read_unaligned())
            };
            let v = _mm_add_ps(pv, _mm_mul_ps(_mm_cvtepi32_ps(_mm_cvtepu8_epi32(b)), sv));
            // SAFETY: four of the eight floats, from `4·half`.
            unsafe { _mm_storeu_ps(out.as_mut_ptr().add(4 * half), v) };
        }
        out
    }

    #[target_feature(enable = "avx2,fma")]
    #[inline]
    fn dequantize8_avx2(p: f32, s: f32, q: &[u8; 8]) -> [f32; 8] {
        // SAFETY: `q` holds the eight bytes read.
        let b = unsafe { _mm_loadl_epi64(q.as_ptr() as *const __m128i) };
        let v = _mm256_cvtepi32_ps(_mm256_cvtepu8_epi32(b));
        let v = _mm256_add_ps(_mm256_set1_ps(p), _mm256_mul_ps(v, _mm256_set1_ps(s)));
        let mut out = [0.0; 8];
        // SAFETY: `out` holds eight floats.
        unsafe { _mm256_storeu_ps(out.as_mut_ptr(), v) };
        out
    }

    /// [`Isa::enter`] through `enter8` (a vector compress of eight lanes)
    /// where `W` is 8, else [`Isa::test`] and [`super::gather`].
    #[inline(always)]
    fn enter_by<I: Isa, const W: usize>(
        r: &NodeRay,
        planes: &[[f32; W]; 6],
        children: &[u32; W],
        tmax: f32,
        e: &mut Entered<W>,
        enter8: impl FnOnce(Rows, *const u32, &mut Entered<8>),
    ) {
        if W != 8 {
            let (d, mask) = I::test::<W>(r, planes, tmax);
            return super::gather(&d, |k| children[k], mask, e);
        }
        // SAFETY: W = 8, so `Entered<W>` is `Entered<8>`.
        let e8 = unsafe { &mut *(e as *mut Entered<W> as *mut Entered<8>) };
        enter8(Rows::of(planes, 0), children.as_ptr(), e8);
    }

    impl Isa for Sse41 {
        type Leaf = glam::Vec4;
        #[inline(always)]
        fn test<const W: usize>(r: &NodeRay, planes: &[[f32; W]; 6], tmax: f32) -> ([f32; W], u32) {
            // SAFETY: this path runs only inside `trace_sse41`, which runs
            // only where the processor has SSE4.1 (`simd::active`).
            unsafe { test_sse(r, planes, tmax) }
        }
        #[inline(always)]
        fn dequantize8(p: f32, s: f32, q: &[u8; 8]) -> [f32; 8] {
            // SAFETY: as above.
            unsafe { dequantize8_sse(p, s, q) }
        }
    }

    impl Isa for Avx2 {
        type Leaf = Lanes8;
        #[inline(always)]
        fn test<const W: usize>(r: &NodeRay, planes: &[[f32; W]; 6], tmax: f32) -> ([f32; W], u32) {
            // SAFETY: this path runs only inside `trace_avx2`, which runs
            // only where the processor has AVX2 and FMA.
            unsafe { test_avx2(r, planes, tmax) }
        }
        #[inline(always)]
        fn enter<const W: usize>(
            r: &NodeRay,
            planes: &[[f32; W]; 6],
            children: &[u32; W],
            tmax: f32,
            e: &mut Entered<W>,
        ) {
            enter_by::<Self, W>(r, planes, children, tmax, e, |p, c, e| {
                // SAFETY: as `test`, the processor has AVX2 and FMA; `p`
                // and `c` point at a node's eight-lane rows and references.
                unsafe { enter8_avx2(r, p, c, tmax, e) }
            })
        }
        #[inline(always)]
        fn dequantize8(p: f32, s: f32, q: &[u8; 8]) -> [f32; 8] {
            // SAFETY: as above.
            unsafe { dequantize8_avx2(p, s, q) }
        }
    }

    impl Isa for Avx512 {
        type Leaf = Lanes8;
        #[inline(always)]
        fn test<const W: usize>(r: &NodeRay, planes: &[[f32; W]; 6], tmax: f32) -> ([f32; W], u32) {
            // SAFETY: this path runs only inside `trace_avx512`, which runs
            // only where the processor has AVX-512 F, VL, DQ and BW.
            unsafe { test_avx512(r, planes, tmax) }
        }
        #[inline(always)]
        fn enter<const W: usize>(
            r: &NodeRay,
            planes: &[[f32; W]; 6],
            children: &[u32; W],
            tmax: f32,
            e: &mut Entered<W>,
        ) {
            enter_by::<Self, W>(r, planes, children, tmax, e, |p, c, e| {
                // SAFETY: as `test`, the processor has AVX-512 F, VL, DQ
                // and BW; `p` and `c` point at a node's eight-lane rows and
                // references.
                unsafe { enter8_avx512(r, p, c, tmax, e) }
            })
        }
        #[inline(always)]
        fn dequantize8(p: f32, s: f32, q: &[u8; 8]) -> [f32; 8] {
            // SAFETY: as above (AVX-512 F implies AVX2).
            unsafe { dequantize8_avx2(p, s, q) }
        }
    }
}

pub use crate::structures::shared::leaf::canonical_id;

/// Closest hit (`any = false`) or any hit on SIMD path `path` rather than
/// the active one, so that a test can run every path the processor has.
///
/// # Errors
/// [`crate::error::Error::Invalid`] if this processor cannot run `path`.
pub fn trace_checked<const W: usize, T: WideTree<W>, S: Stats>(
    path: SimdPath,
    w: &T,
    ray: &Ray,
    any: bool,
    stats: &mut S,
) -> crate::error::Result<Option<Hit>> {
    runs_here(path)?;
    Ok(if any {
        trace_on::<W, T, S, true>(path, w, ray, stats)
    } else {
        trace_on::<W, T, S, false>(path, w, ray, stats)
    })
}

/// An error unless this processor runs `path`.
fn runs_here(path: SimdPath) -> crate::error::Result<()> {
    if path.supported() {
        Ok(())
    } else {
        Err(crate::error::Error::Invalid(format!(
            "SIMD path {path} does not run here"
        )))
    }
}

/// [`closest_with_triangle_on`], refusing a path this processor lacks.
pub fn closest_with_triangle_checked<const W: usize, T: WideTree<W>, S: Stats>(
    path: SimdPath,
    w: &T,
    ray: &Ray,
    stats: &mut S,
) -> crate::error::Result<Option<(Hit, Triangle)>> {
    runs_here(path)?;
    Ok(closest_with_triangle_on::<W, T, S>(path, w, ray, stats))
}

/// Closest hit (`ANY = false`) or any hit, on the active SIMD path.
#[inline]
pub fn trace<const W: usize, T: WideTree<W>, S: Stats, const ANY: bool>(
    w: &T,
    ray: &Ray,
    stats: &mut S,
) -> Option<Hit> {
    trace_on::<W, T, S, ANY>(simd::active(), w, ray, stats)
}

/// [`trace`] on `path`, which must be one this processor runs
/// ([`SimdPath::supported`]); an unsupported path runs the portable one.
#[inline]
pub fn trace_on<const W: usize, T: WideTree<W>, S: Stats, const ANY: bool>(
    path: SimdPath,
    w: &T,
    ray: &Ray,
    stats: &mut S,
) -> Option<Hit> {
    dispatch::<W, T, S, ANY, false>(path, w, ray, stats).0
}

/// The closest hit on the active SIMD path and the hit triangle's vertices,
/// read from the leaf that gave the hit (a cache line the trace has just
/// read) rather than from the mesh; bit for bit the mesh's.
#[inline]
pub fn closest_with_triangle<const W: usize, T: WideTree<W>, S: Stats>(
    w: &T,
    ray: &Ray,
    stats: &mut S,
) -> Option<(Hit, Triangle)> {
    closest_with_triangle_on::<W, T, S>(simd::active(), w, ray, stats)
}

/// [`closest_with_triangle`] on `path`, which must be one this processor
/// runs ([`SimdPath::supported`]); an unsupported path runs the portable
/// one.
#[inline]
pub fn closest_with_triangle_on<const W: usize, T: WideTree<W>, S: Stats>(
    path: SimdPath,
    w: &T,
    ray: &Ray,
    stats: &mut S,
) -> Option<(Hit, Triangle)> {
    let (hit, leaf) = dispatch::<W, T, S, false, true>(path, w, ray, stats);
    let hit = hit?;
    let triangle = leaf_triangle(w.blocks(), leaf, hit.prim)
        .unwrap_or_else(|| w.triangles()[hit.prim as usize]);
    Some((hit, triangle))
}

/// The kernel on `path`, and with `LOCATE` the first block of the leaf that
/// gave the closest hit (0 without).
#[inline]
fn dispatch<const W: usize, T: WideTree<W>, S: Stats, const ANY: bool, const LOCATE: bool>(
    path: SimdPath,
    w: &T,
    ray: &Ray,
    stats: &mut S,
) -> (Option<Hit>, u32) {
    match path {
        #[cfg(target_arch = "x86_64")]
        SimdPath::Avx512 => {
            // SAFETY: `simd::active` and `set_active` only name paths the
            // processor supports; tests pass only supported ones.
            unsafe { trace_avx512::<W, T, S, ANY, LOCATE>(w, ray, stats) }
        }
        #[cfg(target_arch = "x86_64")]
        SimdPath::Avx2 => {
            // SAFETY: as above, AVX2 and FMA are present.
            unsafe { trace_avx2::<W, T, S, ANY, LOCATE>(w, ray, stats) }
        }
        #[cfg(target_arch = "x86_64")]
        SimdPath::Sse41 => {
            // SAFETY: as above, SSE4.1 is present.
            unsafe { trace_sse41::<W, T, S, ANY, LOCATE>(w, ray, stats) }
        }
        _ => trace_kernel::<W, T, S, ANY, LOCATE, Portable>(w, ray, stats),
    }
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f,avx512vl,avx512dq,avx512bw,avx2,fma,bmi1,bmi2,lzcnt,popcnt")]
fn trace_avx512<const W: usize, T: WideTree<W>, S: Stats, const ANY: bool, const LOCATE: bool>(
    w: &T,
    ray: &Ray,
    stats: &mut S,
) -> (Option<Hit>, u32) {
    trace_kernel::<W, T, S, ANY, LOCATE, x86::Avx512>(w, ray, stats)
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma,bmi1,bmi2,lzcnt,popcnt")]
fn trace_avx2<const W: usize, T: WideTree<W>, S: Stats, const ANY: bool, const LOCATE: bool>(
    w: &T,
    ray: &Ray,
    stats: &mut S,
) -> (Option<Hit>, u32) {
    trace_kernel::<W, T, S, ANY, LOCATE, x86::Avx2>(w, ray, stats)
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "sse4.1")]
fn trace_sse41<const W: usize, T: WideTree<W>, S: Stats, const ANY: bool, const LOCATE: bool>(
    w: &T,
    ray: &Ray,
    stats: &mut S,
) -> (Option<Hit>, u32) {
    trace_kernel::<W, T, S, ANY, LOCATE, x86::Sse41>(w, ray, stats)
}

/// Entries of the traversal stack: at most `W − 1` pending children per
/// level below the root, and trees are less than [`MAX_STACK_DEPTH`]
/// levels deep (the layouts refuse deeper ones).
const STACK: usize = MAX_STACK_DEPTH * 7 + 1;

#[inline(always)]
fn trace_kernel<
    const W: usize,
    T: WideTree<W>,
    S: Stats,
    const ANY: bool,
    const LOCATE: bool,
    I: Isa,
>(
    w: &T,
    ray: &Ray,
    stats: &mut S,
) -> (Option<Hit>, u32) {
    debug_assert!((w.depth() as usize) * (W - 1) < STACK);
    // A negative or NaN `tmin` (set after `Ray::new`, which refuses it)
    // misses, as at the other structures' root test: the box tests are
    // conservative only from `tmin ≥ 0`.
    if w.is_empty() || !ray.has_traceable_tmin() {
        return (None, 0);
    }
    // No separate test of the scene box: the root's children's boxes are
    // tested at its first visit (a one-leaf tree tests its triangles).
    let mut tally = Tally::default();
    let inv = ray.inv_direction().to_array();
    let neg = inv.map(f32::is_sign_negative);
    let scaled = inv.map(slab_reciprocals);
    let r = NodeRay {
        org: ray.origin().to_array(),
        inv_near: scaled.map(|s| s.0),
        inv_far: scaled.map(|s| s.1),
        near: std::array::from_fn(|a| a + 3 * neg[a] as usize),
        far: std::array::from_fn(|a| a + 3 * !neg[a] as usize),
        tmin: ray.tmin,
    };
    let block_ray = BlockRay::new(ray);
    let mut tmax = ray.tmax;
    let mut best: Option<Hit> = None;
    // Not cleared per ray (an `ArrayVec` leaves its slots uninitialized).
    let mut stack = ArrayVec::<(u32, f32), STACK>::new();
    let mut e = Entered::<W>::new();
    let mut node = w.root();
    // With `LOCATE`: the leaf that gave the closest hit, and that hit's
    // triangle (`u32::MAX` before any).
    let (mut hit_leaf, mut hit_prim) = (0, u32::MAX);
    'visit: loop {
        tally.nodes += 1;
        if S::LOGS {
            stats.visit(w.canonical_id(node));
        }
        if node & LEAF != 0 {
            if intersect_lanes::<I::Leaf, ANY, S>(
                &block_ray,
                w.blocks(),
                node & !(LEAF | PAIR),
                node & PAIR != 0,
                w.triangles(),
                ray,
                &mut tmax,
                &mut best,
                &mut tally,
                stats,
            ) {
                break;
            }
            if LOCATE {
                let prim = best.map_or(u32::MAX, |h| h.prim);
                if prim != hit_prim {
                    (hit_leaf, hit_prim) = (node & !(LEAF | PAIR), prim);
                }
            }
        } else {
            tally.planes += w.enter::<I>(node, &r, tmax, &mut e);
            let m = e.count;
            if m == 1 {
                node = e.refs[0];
                continue;
            }
            if ANY && !S::HITS && m > 1 {
                // Any hit: the order does not matter and the interval never
                // shrinks, so no sort (lane order, the first lane next).
                for i in (1..m).rev() {
                    stack.push((e.refs[i], e.dist[i]));
                }
                node = e.refs[0];
                continue;
            }
            if m == 2 {
                // Nearest first; equal distances keep lane order.
                let near = (e.dist[1] < e.dist[0]) as usize;
                stack.push((e.refs[1 - near], e.dist[1 - near]));
                node = e.refs[near];
                continue;
            }
            if m > 2 {
                // Nearest first; equal distances keep lane order.
                for i in 1..m {
                    let (t, c) = (e.dist[i], e.refs[i]);
                    let mut j = i;
                    while j > 0 && e.dist[j - 1] > t {
                        e.dist[j] = e.dist[j - 1];
                        e.refs[j] = e.refs[j - 1];
                        j -= 1;
                    }
                    e.dist[j] = t;
                    e.refs[j] = c;
                }
                for i in (1..m).rev() {
                    stack.push((e.refs[i], e.dist[i]));
                }
                node = e.refs[0];
                continue;
            }
        }
        // Pop the nearest pending child still in reach: one entered beyond
        // the closest hit would fail its box test now. An any-hit trace
        // (without a hit sink) ends at its first hit and never shrinks the
        // interval, so each of its entries, entered within it, is in reach.
        while let Some((r, t)) = stack.pop() {
            if (ANY && !S::HITS) || t <= tmax {
                node = r;
                continue 'visit;
            }
        }
        break;
    }
    stats.add(tally);
    (best, hit_leaf)
}

impl<const W: usize> WideTree<W> for super::WideBvh<W> {
    #[inline(always)]
    fn root(&self) -> u32 {
        with_pair(self.root, &self.blocks)
    }
    #[inline(always)]
    fn is_empty(&self) -> bool {
        self.blocks.is_empty()
    }
    #[inline(always)]
    fn depth(&self) -> u32 {
        self.depth
    }
    #[inline(always)]
    fn blocks(&self) -> &[TriBlock] {
        &self.blocks
    }
    #[inline(always)]
    fn triangles(&self) -> &[Triangle] {
        &self.triangles
    }
    #[inline(always)]
    fn enter<I: Isa>(&self, node: u32, r: &NodeRay, tmax: f32, e: &mut Entered<W>) -> u32 {
        let n: &WideNode<W> = &self.nodes[node as usize];
        I::enter::<W>(r, &n.planes, &n.children, tmax, e);
        6 * n.child_count() as u32
    }
    fn canonical_id(&self, r: u32) -> u32 {
        canonical_id(&self.node_ids, &self.leaf_ids, plain(r))
    }
}

#[cfg(all(test, target_arch = "x86_64"))]
mod tests {
    use crate::structures::shared::tri_block::tests::lanes_answer_as_the_scalar_leaf_test;

    /// The AVX2 and AVX-512 paths' leaf test, two blocks per pass, answers
    /// as the scalar leaf test (where the processor has AVX2; `Lanes8`
    /// exists only there).
    #[test]
    fn block_pairs_answer_as_the_scalar_leaf_test() {
        if !std::arch::is_x86_feature_detected!("avx2") {
            eprintln!("skipped: no AVX2 on this processor");
            return;
        }
        lanes_answer_as_the_scalar_leaf_test::<super::x86::Lanes8>();
    }
}
