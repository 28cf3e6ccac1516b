//! Binned SAH split search (Wald 2007): centroids are sorted into equal-width
//! bins per axis, and the best of the bin boundaries is chosen by sweeping.

use crate::geometry::Aabb;
use glam::Vec3;
use rayon::prelude::*;

/// Bins are filled in parallel above this many triangles.
const PARALLEL_BINNING: usize = 1 << 16;
/// The most bins per axis: the bins live in fixed arrays on the stack, so
/// that a node's split search allocates nothing.
pub const MAX_BINS: usize = 64;

#[derive(Clone, Copy)]
struct Bin {
    bounds: Aabb,
    count: u32,
}

const EMPTY_BIN: Bin = Bin {
    bounds: Aabb::EMPTY,
    count: 0,
};

/// Maps a centroid coordinate on one axis to its bin.
#[derive(Clone, Copy, Debug)]
pub struct BinMap {
    pub axis: usize,
    min: f32,
    scale: f32,
    bins: usize,
}

impl BinMap {
    pub fn bin(&self, c: Vec3) -> usize {
        let k = ((c[self.axis] - self.min) * self.scale) as isize;
        k.clamp(0, self.bins as isize - 1) as usize
    }
}

/// The best split found: triangles whose centroid falls in a bin below
/// `bin` go left.
#[derive(Clone, Copy, Debug)]
pub struct Split {
    pub map: BinMap,
    pub bin: usize,
    /// `1 + (A_L·N_L + A_R·N_R) / A`.
    pub cost: f32,
}

/// Finds the cheapest binned split of `ids`, or `None` if every axis has all
/// centroids in one bin.
pub fn best_split(
    ids: &[u32],
    bounds: &[Aabb],
    centroids: &[Vec3],
    node_area: f32,
    centroid_bounds: &Aabb,
    nbins: usize,
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
    let fill = |chunk: &[u32]| {
        let mut bins = [EMPTY_BIN; 3 * MAX_BINS];
        for &id in chunk {
            let (b, c) = (bounds[id as usize], centroids[id as usize]);
            for (m, map) in maps.iter().enumerate() {
                let bin = &mut bins[m * nbins + map.bin(c)];
                bin.bounds = bin.bounds.union(b);
                bin.count += 1;
            }
        }
        bins
    };
    let bins = if ids.len() >= PARALLEL_BINNING {
        ids.par_chunks(PARALLEL_BINNING / 4)
            .map(fill)
            .reduce_with(|mut a, b| {
                for (x, y) in a.iter_mut().zip(b) {
                    x.bounds = x.bounds.union(y.bounds);
                    x.count += y.count;
                }
                a
            })?
    } else {
        fill(ids)
    };

    let inv_area = if node_area > 0.0 {
        1.0 / node_area
    } else {
        0.0
    };
    let mut best: Option<Split> = None;
    let mut right_cost = [0.0f32; MAX_BINS];
    for (m, map) in maps.iter().enumerate() {
        let axis_bins = &bins[m * nbins..(m + 1) * nbins];
        // Sweep from the right: right_cost[k] = A(bins k..) * N(bins k..).
        let (mut acc, mut n) = (Aabb::EMPTY, 0u32);
        for k in (1..nbins).rev() {
            acc = acc.union(axis_bins[k].bounds);
            n += axis_bins[k].count;
            right_cost[k] = acc.area() * n as f32;
        }
        let (mut acc, mut n) = (Aabb::EMPTY, 0u32);
        for k in 1..nbins {
            acc = acc.union(axis_bins[k - 1].bounds);
            n += axis_bins[k - 1].count;
            if n == 0 || n as usize == ids.len() {
                continue;
            }
            let cost = 1.0 + (acc.area() * n as f32 + right_cost[k]) * inv_area;
            if best.is_none_or(|b| cost < b.cost) {
                best = Some(Split {
                    map: *map,
                    bin: k,
                    cost,
                });
            }
        }
    }
    best
}
