//! Binned SAH split search (Wald 2007): centroids are sorted into equal-width
//! bins per axis, and the best of the bin boundaries is chosen by sweeping.

use crate::geometry::Aabb;
use arrayvec::ArrayVec;
use glam::{BVec4A, IVec3, Vec3, Vec3A, Vec4};
use rayon::prelude::*;

/// A triangle reference while building: the triangle's box, with its index
/// in the fourth lane of the lower corner. The build partitions these
/// references themselves, so that every pass over a node reads its
/// references in order from one array (32 bytes each) rather than
/// gathering boxes and centroids by index from two.
#[derive(Clone, Copy, Debug)]
#[repr(C, align(32))]
pub struct PrimRef {
    /// The box's lower corner; lane 3 holds the index's bits.
    lo: Vec4,
    /// The box's upper corner; lane 3 is 0.
    hi: Vec4,
}

impl PrimRef {
    /// The reference to triangle `id`, whose box is `b`.
    #[inline(always)]
    pub fn new(b: &Aabb, id: u32) -> Self {
        PrimRef {
            lo: b.min.extend(f32::from_bits(id)),
            hi: b.max.extend(0.0),
        }
    }

    /// The triangle's index.
    #[inline(always)]
    pub fn id(&self) -> u32 {
        self.lo.w.to_bits()
    }

    /// The lower corner, for minima and maxima only: its fourth lane holds
    /// the index's bits.
    #[inline(always)]
    pub fn min(&self) -> Vec3A {
        Vec3A::from_vec4(self.lo)
    }

    /// The upper corner.
    #[inline(always)]
    pub fn max(&self) -> Vec3A {
        Vec3A::from_vec4(self.hi)
    }

    /// The box.
    #[inline(always)]
    pub fn bounds(&self) -> Aabb {
        Aabb::new(self.lo.truncate(), self.hi.truncate())
    }

    /// The lower corner with its fourth lane cleared, for arithmetic (and
    /// for boxes that arithmetic will meet: an index's bits are a subnormal
    /// float, slow in any vector arithmetic lane).
    #[inline(always)]
    pub fn lower(&self) -> Vec3A {
        let lo = Vec4::select(BVec4A::new(true, true, true, false), self.lo, Vec4::ZERO);
        Vec3A::from_vec4(lo)
    }

    /// The box's centre, [`Aabb::center`] bit for bit (the index's lane is
    /// cleared first, so that no arithmetic meets its bits).
    #[inline(always)]
    pub fn centroid(&self) -> Vec3A {
        let lo = Vec4::select(BVec4A::new(true, true, true, false), self.lo, Vec4::ZERO);
        Vec3A::from_vec4((lo + self.hi) * 0.5)
    }
}

/// Bins are filled in parallel above this many triangles.
const PARALLEL_BINNING: usize = 1 << 16;
/// The most bins per axis: the bins live in fixed arrays on the stack, so
/// that a node's split search allocates nothing.
pub const MAX_BINS: usize = 64;

/// A bin: the box of its triangles (corners in SSE registers, so that a
/// union is two instructions) and their count.
#[derive(Clone, Copy)]
struct Bin {
    min: Vec3A,
    max: Vec3A,
    count: u32,
}

const EMPTY_BIN: Bin = Bin {
    min: Vec3A::INFINITY,
    max: Vec3A::NEG_INFINITY,
    count: 0,
};

impl Bin {
    #[inline(always)]
    fn add(&mut self, min: Vec3A, max: Vec3A) {
        self.min = self.min.min(min);
        self.max = self.max.max(max);
        self.count += 1;
    }

    #[inline(always)]
    fn join(&mut self, o: &Bin) {
        self.min = self.min.min(o.min);
        self.max = self.max.max(o.max);
        self.count += o.count;
    }

    /// [`Aabb::area`] of the box, bit for bit, for a bin holding at least
    /// one triangle: its box is then not empty (`min ≤ max` on every axis,
    /// the build having left out non-finite triangles), so `Aabb::area`'s
    /// emptiness test and the clamp of its extent at 0 change nothing and
    /// are left out; the products and sums are the same f32 operations in
    /// the same order. (The sweep computes two areas per bin boundary.)
    ///
    /// The corners' fourth lanes are 0 (bins are filled with
    /// [`PrimRef::lower`], not [`PrimRef::min`]), so the vector
    /// subtraction never meets a triangle index's bits: read as a float,
    /// an index is subnormal, and arithmetic on it takes the processor's
    /// slow path (2.5 times the whole build's time, measured).
    #[inline(always)]
    fn area(&self) -> f32 {
        debug_assert!(self.count > 0 && self.min.cmple(self.max).all());
        let e = self.max - self.min;
        2.0 * (e.x * e.y + e.y * e.z + e.z * e.x)
    }
}

/// The bins of up to three axes, `3·nbins` of them, `nbins` per axis.
type Bins = ArrayVec<Bin, { 3 * MAX_BINS }>;

/// Maps a centroid coordinate on one axis to its bin.
#[derive(Clone, Copy, Debug)]
pub struct BinMap {
    pub axis: usize,
    min: f32,
    scale: f32,
    bins: usize,
}

impl BinMap {
    /// The bin of centroid `c`: the definition that the vector form in
    /// [`best_split`] and [`Split::goes_left`] reproduce (tested below).
    #[cfg_attr(not(test), allow(dead_code))]
    pub fn bin(&self, c: Vec3) -> usize {
        let k = ((c[self.axis] - self.min) * self.scale) as isize;
        k.clamp(0, self.bins as isize - 1) as usize
    }
}

/// How the SAH counts a leaf's intersection cost: per triangle (blocks of
/// one, the textbook cost), or per block of `2^shift` triangles, the
/// leaves' triangles being tested a block at a time (Embree's
/// `sahBlockSize`: a leaf of 5 to 8 triangles costs two blocks of four).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Blocks {
    shift: u32,
}

impl Blocks {
    /// Blocks of `size` triangles, a power of two (1 to 16).
    pub fn of(size: usize) -> Self {
        assert!(
            super::BuildOptions::SAH_BLOCKS.contains(&size),
            "sah_block must be 1, 2, 4, 8 or 16"
        );
        Blocks {
            shift: size.trailing_zeros(),
        }
    }

    /// Triangles per block.
    pub fn size(self) -> usize {
        1 << self.shift
    }

    /// The intersection cost of `n` triangles: `⌈n / size⌉`, which is `n`
    /// itself, bit for bit, for blocks of one.
    #[inline(always)]
    pub fn cost(self, n: u32) -> f32 {
        ((n >> self.shift) + (n & ((1 << self.shift) - 1) != 0) as u32) as f32
    }
}

/// The best split found: triangles whose centroid falls in a bin below
/// `bin` go left.
#[derive(Clone, Copy, Debug)]
pub struct Split {
    pub map: BinMap,
    pub bin: usize,
    /// `1 + (A_L·C(N_L) + A_R·C(N_R)) / A`, `C` the [`Blocks::cost`] of
    /// the search (`C(N) = N` for blocks of one).
    pub cost: f32,
}

impl Split {
    /// Whether centroid `c` goes left: `self.map.bin(c) < self.bin` without
    /// the conversion to an integer. Equal for every `c`: the bin boundary
    /// is an integer between 1 and the last bin, truncation keeps a value
    /// on its side, and NaN (bin 0) goes left.
    #[inline(always)]
    pub fn goes_left(&self, c: Vec3A) -> bool {
        let m = &self.map;
        let v = (c[m.axis] - m.min) * m.scale;
        v < self.bin as f32 || v.is_nan()
    }
}

/// `v as isize` clamped to `0..nbins` per lane, as [`BinMap::bin`] does:
/// NaN gives 0, values beyond the last bin the last. On x86-64 one
/// truncating conversion for all lanes (SSE2, always present).
#[inline(always)]
fn truncate_to_bins(v: Vec3A, nbins: usize) -> IVec3 {
    let last = nbins as i32 - 1;
    #[cfg(target_arch = "x86_64")]
    {
        use std::arch::x86_64::{_mm_cvttps_epi32, _mm_min_ps, _mm_set1_ps, _mm_storeu_si128};
        // min(last, v) keeps NaN (the second operand), which converts to
        // i32::MIN and so clamps to 0; +inf and large values become `last`.
        let mut k = [0i32; 4];
        // SAFETY: SSE and SSE2 are part of the x86-64 baseline, so these
        // intrinsics exist on every processor this code runs on; `k` is 16
        // bytes, written unaligned.
        unsafe {
            let clamped = _mm_min_ps(_mm_set1_ps(last as f32), v.into());
            _mm_storeu_si128(k.as_mut_ptr().cast(), _mm_cvttps_epi32(clamped));
        }
        IVec3::new(k[0], k[1], k[2]).clamp(IVec3::ZERO, IVec3::splat(last))
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        v.as_ivec3().clamp(IVec3::ZERO, IVec3::splat(last))
    }
}

/// Nodes of at most this many triangles fill only the bins their
/// centroids fall in, found from a mask of the bins hit (64 measured a
/// little faster than 32 and 128 on dragon.obj).
const SMALL_NODE: usize = 64;

/// One axis's filled bins, in increasing order: their indices and the bins.
/// Two lists rather than one of pairs: a pair assembled on the stack and
/// copied in was read back across two stores (a failed store forward) at
/// every push.
#[derive(Default)]
struct Filled {
    keys: ArrayVec<usize, MAX_BINS>,
    bins: ArrayVec<Bin, MAX_BINS>,
}

impl Filled {
    fn clear(&mut self) {
        self.keys.clear();
        self.bins.clear();
    }

    fn push(&mut self, k: usize, bin: Bin) {
        self.keys.push(k);
        self.bins.push(bin);
    }
}

/// The SAH sweep over one axis's filled bins `filled`, keeping in `best`
/// the cheapest boundary seen (the first on ties).
///
/// Only filled bins are visited: the boundaries that empty bins separate
/// cost the same (a union with an empty box is exact), and the first of
/// them, right after a filled bin, is the one a sweep over every bin keeps.
/// So the costs, and the split chosen, are those of the full sweep, bit
/// for bit.
fn sweep(map: &BinMap, filled: &Filled, inv_area: f32, blocks: Blocks, best: &mut Option<Split>) {
    let bins = &filled.bins[..];
    let mut right_cost = [0.0f32; MAX_BINS];
    // From the right: right_cost[j] = A(bins[j..]) * N(bins[j..]).
    let mut acc = EMPTY_BIN;
    for j in (1..bins.len()).rev() {
        acc.join(&bins[j]);
        right_cost[j] = acc.area() * blocks.cost(acc.count);
    }
    let mut acc = EMPTY_BIN;
    for j in 1..bins.len() {
        acc.join(&bins[j - 1]);
        let cost = 1.0 + (acc.area() * blocks.cost(acc.count) + right_cost[j]) * inv_area;
        if best.is_none_or(|b| cost < b.cost) {
            *best = Some(Split {
                map: *map,
                bin: filled.keys[j - 1] + 1,
                cost,
            });
        }
    }
}

/// Finds the cheapest binned split of `refs`, intersection costs counted
/// in `blocks`, or `None` if every axis has all centroids in one bin.
pub fn best_split(
    refs: &[PrimRef],
    node_area: f32,
    centroid_bounds: &Aabb,
    nbins: usize,
    blocks: Blocks,
) -> Option<Split> {
    let extent = centroid_bounds.extent();
    let mut maps = [BinMap {
        axis: 0,
        min: 0.0,
        scale: 0.0,
        bins: nbins,
    }; 3];
    let mut axes = 0;
    for axis in 0..3 {
        if extent[axis] > 0.0 {
            maps[axes] = BinMap {
                axis,
                min: centroid_bounds.min[axis],
                scale: nbins as f32 * (1.0 - 1e-6) / extent[axis],
                bins: nbins,
            };
            axes += 1;
        }
    }
    let maps = &maps[..axes];
    if maps.is_empty() {
        return None;
    }
    // Every axis's bin at once: the f32 operations of `BinMap::bin`, in
    // vector lanes (an axis without a map gets scale 0 and is not read).
    let (mut lo, mut scale) = (Vec3A::ZERO, Vec3A::ZERO);
    for map in maps {
        lo[map.axis] = map.min;
        scale[map.axis] = map.scale;
    }
    let bins_of = |c: Vec3A| truncate_to_bins((c - lo) * scale, nbins);
    let inv_area = if node_area > 0.0 {
        1.0 / node_area
    } else {
        0.0
    };
    let mut best: Option<Split> = None;
    let mut filled = Filled::default();
    if refs.len() <= SMALL_NODE {
        // Few triangles: each axis's filled bins found from a mask of the
        // bins hit, and only those filled, rather than `3·nbins` bins
        // cleared and scanned. (A bin's box and count do not depend on the
        // order its triangles are added in.)
        let ks: ArrayVec<IVec3, SMALL_NODE> = refs.iter().map(|r| bins_of(r.centroid())).collect();
        let mut slot_of = [0u8; MAX_BINS];
        for map in maps {
            let a = map.axis;
            // Bin indices are below `nbins` ≤ 64 (`truncate_to_bins`).
            let mut hit = 0u64;
            for k in &ks {
                hit |= 1 << (k[a] as u32 & 63);
            }
            filled.clear();
            while hit != 0 {
                let k = hit.trailing_zeros() as usize;
                hit &= hit - 1;
                slot_of[k] = filled.keys.len() as u8;
                filled.push(k, EMPTY_BIN);
            }
            for (k, r) in ks.iter().zip(refs) {
                filled.bins[slot_of[k[a] as usize & (MAX_BINS - 1)] as usize]
                    .add(r.lower(), r.max());
            }
            sweep(map, &filled, inv_area, blocks, &mut best);
        }
        return best;
    }
    let fill = |bins: &mut Bins, chunk: &[PrimRef]| {
        for r in chunk {
            let (min, max) = (r.lower(), r.max());
            let k = bins_of(r.centroid());
            for (m, map) in maps.iter().enumerate() {
                bins[m * nbins + k[map.axis] as usize].add(min, max);
            }
        }
    };
    // Filled in place: the bins are kilobytes, and a moved array is a copy.
    let mut bins = Bins::new();
    if refs.len() >= PARALLEL_BINNING {
        bins = refs
            .par_chunks(PARALLEL_BINNING / 4)
            .map(|chunk| {
                let mut bins = Bins::new();
                bins.extend(std::iter::repeat_n(EMPTY_BIN, maps.len() * nbins));
                fill(&mut bins, chunk);
                bins
            })
            .reduce_with(|mut a, b| {
                for (x, y) in a.iter_mut().zip(&b) {
                    x.join(y);
                }
                a
            })?;
    } else {
        bins.extend(std::iter::repeat_n(EMPTY_BIN, maps.len() * nbins));
        fill(&mut bins, refs);
    }
    for (m, map) in maps.iter().enumerate() {
        let axis_bins = &bins[m * nbins..(m + 1) * nbins];
        filled.clear();
        for (k, b) in axis_bins.iter().enumerate() {
            if b.count > 0 {
                filled.push(k, *b);
            }
        }
        sweep(map, &filled, inv_area, blocks, &mut best);
    }
    best
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::Pcg32;

    /// The split search as first written: every bin of every axis filled
    /// with `BinMap::bin` in `Aabb`s, and swept in full.
    fn full_sweep(
        ids: &[u32],
        bounds: &[Aabb],
        centroids: &[Vec3],
        node_area: f32,
        cb: &Aabb,
        nbins: usize,
        block: u32,
    ) -> Option<(usize, usize, u32)> {
        let c = |n: u32| n.div_ceil(block) as f32;
        let extent = cb.extent();
        let maps: Vec<BinMap> = (0..3)
            .filter(|&a| extent[a] > 0.0)
            .map(|axis| BinMap {
                axis,
                min: cb.min[axis],
                scale: nbins as f32 * (1.0 - 1e-6) / extent[axis],
                bins: nbins,
            })
            .collect();
        let inv_area = if node_area > 0.0 {
            1.0 / node_area
        } else {
            0.0
        };
        let mut best: Option<(usize, usize, f32)> = None;
        for map in &maps {
            let mut bins = vec![(Aabb::EMPTY, 0u32); nbins];
            for &id in ids {
                let b = &mut bins[map.bin(centroids[id as usize])];
                b.0 = b.0.union(bounds[id as usize]);
                b.1 += 1;
            }
            let mut right = vec![0.0f32; nbins];
            let (mut acc, mut n) = (Aabb::EMPTY, 0);
            for k in (1..nbins).rev() {
                acc = acc.union(bins[k].0);
                n += bins[k].1;
                right[k] = acc.area() * c(n);
            }
            let (mut acc, mut n) = (Aabb::EMPTY, 0);
            for k in 1..nbins {
                acc = acc.union(bins[k - 1].0);
                n += bins[k - 1].1;
                if n == 0 || n as usize == ids.len() {
                    continue;
                }
                let cost = 1.0 + (acc.area() * c(n) + right[k]) * inv_area;
                if best.is_none_or(|b| cost < b.2) {
                    best = Some((map.axis, k, cost));
                }
            }
        }
        best.map(|(a, k, c)| (a, k, c.to_bits()))
    }

    /// The search over filled bins only, with vector bin indices, the
    /// sorted path for small nodes and the parallel fill, chooses the
    /// split a full sweep chooses, at the same cost bit for bit; and
    /// `goes_left` sends every centroid where `bin` does. Nodes of 2 to
    /// 70000 triangles, clustered and coincident centroids, 2 to 64 bins,
    /// costs per triangle and per block of 2, 4 and 16.
    #[test]
    fn split_search_equals_the_full_sweep() {
        let mut rng = Pcg32::new(11, 5);
        for case in 0..400 {
            let n = match case % 5 {
                0 => 2 + rng.below(8) as usize,
                1 => 10 + rng.below(30) as usize,
                2 => 33 + rng.below(300) as usize,
                3 => 1000 + rng.below(3000) as usize,
                _ if case % 50 == 4 => 70_000,
                _ => 2 + rng.below(100) as usize,
            };
            // (case / 7: the 70,000-triangle cases, case % 50 == 4, meet
            // every bin count too.)
            let nbins = [2, 7, 16, 32, 64][(case / 7) % 5];
            // Clustered: a few distinct centroids on some axes.
            let snap = case % 3 == 0;
            let mut bounds = Vec::with_capacity(n);
            for _ in 0..n {
                let mut c = Vec3::new(
                    rng.range(-10.0, 10.0),
                    rng.range(-1.0, 1.0),
                    rng.range(0.0, 100.0),
                );
                if snap {
                    c = (c * 0.5).round();
                }
                let h = Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) * 0.5;
                bounds.push(Aabb::new(c - h, c + h));
            }
            let centroids: Vec<Vec3> = bounds.iter().map(Aabb::center).collect();
            let ids: Vec<u32> = (0..n as u32).rev().collect();
            let (b, cb) = ids.iter().fold((Aabb::EMPTY, Aabb::EMPTY), |(b, cb), &i| {
                (b.union(bounds[i as usize]), cb.grow(centroids[i as usize]))
            });
            // (case / 11: the 70,000-triangle cases meet every block size.)
            let block = [1, 1, 4, 2, 16][(case / 11) % 5];
            let want = full_sweep(&ids, &bounds, &centroids, b.area(), &cb, nbins, block);
            let refs: Vec<PrimRef> = ids
                .iter()
                .map(|&i| PrimRef::new(&bounds[i as usize], i))
                .collect();
            for (r, &i) in refs.iter().zip(&ids) {
                assert_eq!(r.id(), i);
                assert_eq!(r.bounds(), bounds[i as usize]);
                assert_eq!(Vec3::from(r.centroid()), centroids[i as usize]);
            }
            let got = best_split(&refs, b.area(), &cb, nbins, Blocks::of(block as usize));
            assert_eq!(
                got.map(|s| (s.map.axis, s.bin, s.cost.to_bits())),
                want,
                "case {case}: {n} triangles, {nbins} bins, blocks of {block}"
            );
            if let Some(s) = got {
                for c in &centroids {
                    assert_eq!(s.goes_left(Vec3A::from(*c)), s.map.bin(*c) < s.bin);
                }
            }
        }
    }

    /// `Blocks::cost` is `⌈n / size⌉` (and `n` for blocks of one) over
    /// the whole range of counts.
    #[test]
    fn block_costs_round_up() {
        for size in [1usize, 2, 4, 8, 16] {
            let b = Blocks::of(size);
            assert_eq!(b.size(), size);
            for n in (0..300).chain([u32::MAX - 17, u32::MAX - 1, u32::MAX]) {
                assert_eq!(b.cost(n), n.div_ceil(size as u32) as f32, "{n} / {size}");
            }
        }
        assert_eq!(Blocks::of(1).cost(123_457).to_bits(), 123_457f32.to_bits());
        assert_eq!(Blocks::of(4).cost(5), 2.0);
    }

    /// The vector truncation equals `BinMap::bin` on the values the
    /// scalar cast treats specially: NaN, infinities, negatives, the
    /// bin edges and values far beyond the last bin.
    #[test]
    fn vector_bins_equal_the_scalar_cast() {
        let map = |scale| BinMap {
            axis: 0,
            min: 0.0,
            scale,
            bins: 32,
        };
        for v in [
            f32::NAN,
            f32::INFINITY,
            f32::NEG_INFINITY,
            -0.0,
            -0.5,
            -40.0,
            0.0,
            0.999_999,
            1.0,
            30.999_998,
            31.0,
            32.0,
            1e9,
            3e38,
        ] {
            let k = truncate_to_bins(Vec3A::splat(v), 32);
            let want = map(1.0).bin(Vec3::new(v, 0.0, 0.0));
            assert_eq!(k.to_array(), [want as i32; 3], "{v}");
            for b in 1..32 {
                let s = Split {
                    map: map(1.0),
                    bin: b,
                    cost: 0.0,
                };
                assert_eq!(
                    s.goes_left(Vec3A::new(v, 0.0, 0.0)),
                    want < b,
                    "{v} against {b}"
                );
            }
        }
    }
}
