//! Ray reordering for large batches: rays that start near each other and
//! point the same way visit the same nodes and leaves, so tracing a big
//! incoherent batch in such an order keeps those nodes in cache (Pharr,
//! Kolb, Gershbein and Hanrahan 1997, "Rendering complex scenes with
//! memory-coherent ray tracing"; Moon, Byun, Kim, Wong and Yoon 2010,
//! "Cache-oblivious ray reordering"; Garanzha and Loop 2010, "Fast ray
//! sorting and breadth-first packet traversal for GPU ray tracing").
//!
//! The order is a six-dimensional Morton (Z-order) curve over the ray's
//! origin, quantized within the batch's origin bounds, and its unit
//! direction, [`BITS`] bits per coordinate, sorted stably (equal keys keep
//! their index order), so it depends on the rays only. The answer of every
//! ray is its own: the batch queries ([`super::Tracer`], the Python
//! package) trace in this order and read each ray's answer back from its
//! place in it ([`places`]) into the ray's slot,
//! and counters summed over a batch are sums of the same per-ray counts.
//!
//! Measured (`python/bench/bench_raycast.py`, bvh8 on dragon.obj, one
//! thread, 1M rays from random points of a sphere around the mesh towards
//! random points of its box): the trace took 0.40 s in this order against
//! 0.54 s in the given order; 2, 3 and 4 bits per coordinate gave 0.42,
//! 0.42 and 0.39 s. A camera's rays in scanline order took 0.21 s against
//! 0.23 s.

use crate::prelude::Vec3;
use rayon::prelude::*;
use std::sync::atomic::{AtomicU32, Ordering};

/// Bits per coordinate of the sort key (six coordinates: 24 bits).
pub const BITS: u32 = 4;

/// The fewest rays a batch must have to be reordered: below this the
/// batch's nodes fit in the caches anyway and sorting costs more than it
/// saves.
pub const MIN_RAYS: usize = 1 << 14;

/// The order to trace `n` rays in (ray `i`'s origin and direction are
/// `ray(i)`): a permutation of `0..n`, or `None` where the batch is
/// traced as given (fewer than [`MIN_RAYS`] rays, more than `u32`
/// indices can name, or rays coherent as given: most neighbours in the
/// same cell of the key).
///
/// Rays with non-finite or zero parts (which the queries answer as misses)
/// get a key like any other: the order never fails.
pub fn coherent_order(n: usize, ray: impl Fn(usize) -> (Vec3, Vec3) + Sync) -> Option<Vec<u32>> {
    if n < MIN_RAYS || n > u32::MAX as usize {
        return None;
    }
    // The origins' bounds over a sample of the rays (at most about 64K,
    // evenly spaced), non-finite coordinates left out: an origin outside
    // them only falls into an edge cell.
    let step = (n >> 16).max(1);
    let finite = |v: Vec3, fill: f32| Vec3::select(v.is_finite_mask(), v, Vec3::splat(fill));
    let (lo, hi) =
        (0..n)
            .step_by(step)
            .fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(lo, hi), i| {
                let o = ray(i).0;
                (
                    lo.min(finite(o, f32::INFINITY)),
                    hi.max(finite(o, f32::NEG_INFINITY)),
                )
            });
    let cells = (1u32 << BITS) as f32;
    let extent = hi - lo;
    // Zero where the origins share a coordinate (or there are none).
    let scale = Vec3::select(
        extent.cmpgt(Vec3::ZERO) & extent.is_finite_mask(),
        cells / extent,
        Vec3::ZERO,
    );
    let lo = finite(lo, 0.0);
    // Fresh arrays of this size cost a page fault per 4 KiB page written
    // (a tenth of the ordering's time): they go on huge pages.
    let mut keyed: Vec<(u32, u32)> = crate::pages::vec_with_capacity(n);
    (0..n)
        .into_par_iter()
        .with_min_len(4096)
        .map(|i| {
            let (o, d) = ray(i);
            let d = d / d.length();
            let q = [
                (o - lo) * scale,
                // Unit direction from [-1, 1] to [0, cells].
                (d + Vec3::ONE) * (0.5 * cells),
            ];
            (morton6(q), i as u32)
        })
        .collect_into_vec(&mut keyed);
    // Rays given in a coherent order already (a camera's, row by row): most
    // neighbours share their cell, and sorting costs more than it saves.
    if is_coherent(&keyed) {
        return None;
    }
    Some(sort_indices(&keyed))
}

/// Whether most consecutive rays of `keyed` share their cell (key).
/// Measured on dragon.obj (bvh8, 1M rays, one thread): a camera's rays in
/// scanline order took 0.13 s as given and 0.16 s sorted, random rays 0.57
/// s as given and 0.50 s sorted.
fn is_coherent(keyed: &[(u32, u32)]) -> bool {
    let same = keyed
        .par_windows(2)
        .with_min_len(4096)
        .filter(|w| w[0].0 == w[1].0)
        .count();
    2 * same > keyed.len()
}

/// The six coordinates (each in `[0, 2^BITS]`; NaN counts as 0, the top
/// edge as the last cell) as one Morton key, the most significant bits
/// first: bit `b` of coordinate `k` goes to bit `6b + 5 - k`.
#[inline]
fn morton6(q: [Vec3; 2]) -> u32 {
    const TOP: u32 = (1 << BITS) - 1;
    // The bits of a coordinate spread six apart.
    const SPREAD: [u32; 1 << BITS] = {
        let mut t = [0; 1 << BITS];
        let mut v = 0;
        while v < t.len() {
            let mut b = 0;
            while b < BITS {
                t[v] |= ((v as u32 >> b) & 1) << (6 * b);
                b += 1;
            }
            v += 1;
        }
        t
    };
    // `as` saturates (NaN to 0); `min` keeps the top edge in the last cell.
    let c = [q[0].x, q[0].y, q[0].z, q[1].x, q[1].y, q[1].z].map(|v| (v as u32).min(TOP));
    (0..6).fold(0, |key, k| key | SPREAD[c[k] as usize] << (5 - k))
}

/// The indices of `keyed` sorted stably by key (keys below `2^(6 BITS)`):
/// a least-significant-digit radix sort in two passes of `3 BITS` bits,
/// its arrays on huge pages.
fn sort_indices(keyed: &[(u32, u32)]) -> Vec<u32> {
    const DIGIT: u32 = 3 * BITS;
    const BUCKETS: usize = 1 << DIGIT;
    let digit = |key: u32, pass: u32| (key >> (DIGIT * pass)) as usize & (BUCKETS - 1);
    // Where each digit's run starts, both passes counted in one read.
    let mut starts = [vec![0u32; BUCKETS], vec![0u32; BUCKETS]];
    for &(key, _) in keyed {
        starts[0][digit(key, 0)] += 1;
        starts[1][digit(key, 1)] += 1;
    }
    for s in &mut starts {
        let mut sum = 0;
        for c in s.iter_mut() {
            (*c, sum) = (sum, sum + *c);
        }
    }
    let n = keyed.len();
    let mut low: Vec<(u32, u32)> = crate::pages::vec_with_capacity(n);
    low.resize(n, (0, 0));
    for &e in keyed {
        let at = &mut starts[0][digit(e.0, 0)];
        low[*at as usize] = e;
        *at += 1;
    }
    let mut order: Vec<u32> = crate::pages::vec_with_capacity(n);
    order.resize(n, 0);
    for &(key, i) in &low {
        let at = &mut starts[1][digit(key, 1)];
        order[*at as usize] = i;
        *at += 1;
    }
    order
}

/// Where each ray's answer lies when a batch is traced in `order`: entry
/// `i` is the position of ray `i` in `order` (the inverse permutation),
/// made in parallel.
///
/// A query traces `order` a chunk at a time, each chunk's answers into a
/// vector of its own (no array of the whole batch to fill beforehand), then
/// writes its outputs a chunk of rays at a time, reading ray `i`'s answer
/// at `places[i]`: independent loads that the processor overlaps, where
/// scattering each answer straight into the outputs' slots would be a
/// dependent cache miss per output array (measured: four fifths of the
/// Python `cast_rays` overhead on a million rays), and where regrouping the
/// answers by output chunk first was a pass that ran on one thread.
pub fn places(order: &[u32]) -> Vec<u32> {
    let place: Vec<AtomicU32> = (0..order.len())
        .into_par_iter()
        .with_min_len(1 << 14)
        .map(|_| AtomicU32::new(0))
        .collect();
    const PART: usize = 1 << 14;
    order.par_chunks(PART).enumerate().for_each(|(c, ids)| {
        for (j, &i) in ids.iter().enumerate() {
            // Each entry is written once, by one task; `Relaxed` is a plain
            // store, and the join of the parallel loop orders it before the
            // reads below.
            place[i as usize].store((c * PART + j) as u32, Ordering::Relaxed);
        }
    });
    place.into_iter().map(AtomicU32::into_inner).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn rays(n: usize, seed: u64) -> Vec<(Vec3, Vec3)> {
        let mut rng = crate::rng::Pcg32::new(seed, 7);
        (0..n)
            .map(|_| {
                let mut v = || rng.next_f32() * 2.0 - 1.0;
                (Vec3::new(v(), v(), v()) * 10.0, Vec3::new(v(), v(), v()))
            })
            .collect()
    }

    fn is_permutation(order: &[u32]) -> bool {
        let mut seen = vec![false; order.len()];
        order
            .iter()
            .all(|&i| !std::mem::replace(&mut seen[i as usize], true))
    }

    #[test]
    fn small_batches_keep_their_order() {
        let r = rays(MIN_RAYS - 1, 1);
        assert!(coherent_order(r.len(), |i| r[i]).is_none());
    }

    #[test]
    fn coherent_batches_keep_their_order() {
        // A camera's rays, row by row: one origin, directions that change
        // little from one ray to the next.
        let (w, h) = (256, MIN_RAYS / 128);
        let camera: Vec<(Vec3, Vec3)> = (0..w * h)
            .map(|i| {
                let (x, y) = ((i % w) as f32 / w as f32, (i / w) as f32 / h as f32);
                (Vec3::new(1.0, 2.0, 3.0), Vec3::new(x - 0.5, y - 0.5, -1.0))
            })
            .collect();
        assert!(coherent_order(camera.len(), |i| camera[i]).is_none());
        // The same rays shuffled are sorted.
        let mut rng = crate::rng::Pcg32::new(9, 1);
        let mut shuffled = camera.clone();
        for i in (1..shuffled.len()).rev() {
            shuffled.swap(i, rng.below(i as u32 + 1) as usize);
        }
        assert!(coherent_order(shuffled.len(), |i| shuffled[i]).is_some());
    }

    #[test]
    fn the_order_is_a_permutation_and_places_invert_it() {
        let r = rays(MIN_RAYS + 777, 2);
        let order = coherent_order(r.len(), |i| r[i]).unwrap();
        assert_eq!(order.len(), r.len());
        assert!(is_permutation(&order));
        // Deterministic, and not the identity on random rays.
        assert_eq!(coherent_order(r.len(), |i| r[i]).unwrap(), order);
        assert!(order.iter().enumerate().any(|(k, &i)| k != i as usize));
        let place = places(&order);
        assert_eq!(place.len(), r.len());
        for (i, &k) in place.iter().enumerate() {
            assert_eq!(order[k as usize] as usize, i);
        }
        assert!(places(&[]).is_empty());
    }

    #[test]
    fn neighbours_in_the_order_are_close() {
        // Consecutive rays in the order lie much closer (origin and
        // direction) than consecutive rays as given.
        let r = rays(1 << 16, 3);
        let order = coherent_order(r.len(), |i| r[i]).unwrap();
        let gap = |seq: &mut dyn Iterator<Item = usize>| {
            let seq: Vec<usize> = seq.collect();
            seq.windows(2)
                .map(|w| {
                    let (a, b) = (r[w[0]], r[w[1]]);
                    (a.0 - b.0).length() / 10.0 + (a.1.normalize() - b.1.normalize()).length()
                })
                .sum::<f32>()
                / (seq.len() - 1) as f32
        };
        let given = gap(&mut (0..r.len()));
        let sorted = gap(&mut order.iter().map(|&i| i as usize));
        assert!(sorted < 0.35 * given, "{sorted} against {given}");
    }

    #[test]
    fn stable_within_a_cell_and_total_on_bad_rays() {
        // Identical rays (every even index, between random ones) keep
        // their index order; NaN, infinite and zero parts get keys too.
        let mut r = rays(MIN_RAYS, 4);
        let one = (Vec3::ONE, Vec3::X);
        for i in (0..r.len()).step_by(2) {
            r[i] = one;
        }
        r[5] = (Vec3::NAN, Vec3::X);
        r[7] = (Vec3::INFINITY, Vec3::ZERO);
        r[9] = (Vec3::ZERO, Vec3::new(f32::NAN, 1.0, f32::NEG_INFINITY));
        let order = coherent_order(r.len(), |i| r[i]).unwrap();
        assert!(is_permutation(&order));
        let same: Vec<u32> = order
            .iter()
            .copied()
            .filter(|&i| r[i as usize] == one)
            .collect();
        assert_eq!(same.len(), r.len() / 2);
        assert!(same.windows(2).all(|w| w[0] < w[1]));
    }

    #[test]
    fn morton_interleaves_coordinates_most_significant_first() {
        let q = |a: [f32; 6]| morton6([Vec3::new(a[0], a[1], a[2]), Vec3::new(a[3], a[4], a[5])]);
        let top = 1u32 << (6 * BITS - 1);
        assert_eq!(q([8.0, 0.0, 0.0, 0.0, 0.0, 0.0]), top);
        assert_eq!(q([0.0, 0.0, 0.0, 0.0, 0.0, 8.0]), top >> 5);
        assert_eq!(q([1.0, 0.0, 0.0, 0.0, 0.0, 0.0]), 1 << 5);
        assert_eq!(q([16.0; 6]), (1 << (6 * BITS)) - 1);
        assert_eq!(q([f32::NAN; 6]), 0);
    }
}
