//! Closest and any hit over a wide BVH: every child's box tested in one pass
//! over the node's plane rows (the loops over `W` lanes compile to vector
//! instructions), hit children visited nearest first, a stack of references
//! with entry distances, and popped entries beyond the closest hit skipped.

use super::{WideBvh, WideNode, LEAF};
use crate::geometry::aabb::ROBUST_WIDENING;
use crate::geometry::{BoxRay, Hit, Ray};
use crate::stats::Stats;
use crate::structures::shared::leaf::enter;
use crate::structures::shared::tri_block::intersect_blocks;

/// Entry distances of the `W` children of `n` (`+inf` for a miss or an
/// empty lane): the slab test of [`BoxRay::test`], lane by lane, bit for bit
/// the distances the binary layouts' tests give. `near[a]` and `far[a]` are
/// the plane rows nearer and farther on axis `a` for this ray's direction.
#[inline(always)]
fn test_children<const W: usize>(
    br: &BoxRay,
    near: &[usize; 3],
    far: &[usize; 3],
    n: &WideNode<W>,
    tmin: f32,
    tmax: f32,
) -> [f32; W] {
    let mut tn = [tmin; W];
    let mut tf = [f32::INFINITY; W];
    for a in 0..3 {
        let (o, inv) = (br.org[a], br.inv[a]);
        let (lo, hi) = (&n.planes[near[a]], &n.planes[far[a]]);
        for k in 0..W {
            // A NaN distance (0·inf: origin in the plane, direction along
            // it) keeps the running bound, as the slab test ignores it.
            let t = (lo[k] - o) * inv;
            tn[k] = if t > tn[k] { t } else { tn[k] };
            let t = (hi[k] - o) * inv;
            tf[k] = if t < tf[k] { t } else { tf[k] };
        }
    }
    std::array::from_fn(|k| {
        let f = tf[k] + tf[k].abs() * ROBUST_WIDENING;
        let n = tn[k] - tn[k].abs() * ROBUST_WIDENING;
        let f = if tmax < f { tmax } else { f };
        if n <= f {
            n
        } else {
            f32::INFINITY
        }
    })
}

/// Closest hit (`ANY = false`) or any hit.
#[inline]
pub fn trace<const W: usize, S: Stats, const ANY: bool>(
    w: &WideBvh<W>,
    ray: &Ray,
    stats: &mut S,
) -> Option<Hit> {
    // A stack holds at most W − 1 pending children per level.
    match w.depth as usize * (W - 1) + 1 {
        0..=16 => trace_n::<W, S, ANY, 16>(w, ray, stats),
        17..=32 => trace_n::<W, S, ANY, 32>(w, ray, stats),
        33..=64 => trace_n::<W, S, ANY, 64>(w, ray, stats),
        65..=128 => trace_n::<W, S, ANY, 128>(w, ray, stats),
        129..=256 => trace_n::<W, S, ANY, 256>(w, ray, stats),
        257..=512 => trace_n::<W, S, ANY, 512>(w, ray, stats),
        _ => trace_n::<W, S, ANY, 1024>(w, ray, stats),
    }
}

#[inline]
fn trace_n<const W: usize, S: Stats, const ANY: bool, const N: usize>(
    w: &WideBvh<W>,
    ray: &Ray,
    stats: &mut S,
) -> Option<Hit> {
    if w.is_empty() {
        return None;
    }
    let (br, mut tally) = enter(ray, &w.root_bounds.to_array(), stats)?;
    let near: [usize; 3] = std::array::from_fn(|a| a + 3 * br.neg[a] as usize);
    let far: [usize; 3] = std::array::from_fn(|a| a + 3 * !br.neg[a] as usize);
    let tmin = ray.tmin;
    let mut tmax = ray.tmax;
    let mut best: Option<Hit> = None;
    let mut stack = [(0u32, 0f32); N];
    let mut sp = 0;
    let mut node = w.root;
    'visit: loop {
        tally.nodes += 1;
        if S::LOGS {
            stats.visit(w.canonical_id(node));
        }
        if node & LEAF != 0 {
            if intersect_blocks::<ANY, S>(
                &w.blocks,
                node & !LEAF,
                &w.triangles,
                ray,
                &mut tmax,
                &mut best,
                &mut tally,
                stats,
            ) {
                break;
            }
        } else {
            let n = &w.nodes[node as usize];
            tally.planes += 6 * n.child_count() as u32;
            let d = test_children(&br, &near, &far, n, tmin, tmax);
            let mut hit = [(0f32, 0u32); W];
            let mut m = 0;
            for (&t, &child) in d.iter().zip(&n.children) {
                if t != f32::INFINITY {
                    hit[m] = (t, child);
                    m += 1;
                }
            }
            if m > 0 {
                // Nearest first; equal distances keep lane order.
                for i in 1..m {
                    let x = hit[i];
                    let mut j = i;
                    while j > 0 && hit[j - 1].0 > x.0 {
                        hit[j] = hit[j - 1];
                        j -= 1;
                    }
                    hit[j] = x;
                }
                for &(t, r) in hit[1..m].iter().rev() {
                    stack[sp] = (r, t);
                    sp += 1;
                }
                node = hit[0].1;
                continue;
            }
        }
        // Pop the nearest pending child still in reach: one entered beyond
        // the closest hit would fail its box test now.
        while sp > 0 {
            sp -= 1;
            let (r, t) = stack[sp];
            if t <= tmax {
                node = r;
                continue 'visit;
            }
        }
        break;
    }
    stats.add(tally);
    best
}
