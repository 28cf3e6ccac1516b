//! LAINE-k (Laine 2010, "Restart trail for stackless BVH traversal"): a
//! trail of one bit per level says which subtrees are finished; when the
//! short stack of `K` entries is empty, traversal restarts at the root and
//! descends along the trail. Children are ordered by distance as in STACK,
//! and distances do not depend on the current closest hit, so a restart
//! takes the same turns.
//!
//! The trail, level and pop level are 64 bits (root at bit 63): trees up to
//! depth 63.

use super::leaf::{enter, intersect_leaf, test_children};
use crate::accel::sparse_bvh::SparseBvh;
use crate::geometry::{Hit, Ray};
use crate::stats::Stats;

const ROOT_LEVEL: u64 = 1 << 63;

#[inline]
pub fn laine<S: Stats, const ANY: bool, const K: usize>(
    sp: &SparseBvh,
    ray: &Ray,
    stats: &mut S,
) -> Option<Hit> {
    if sp.is_empty() {
        return None;
    }
    let nodes = &sp.nodes[..];
    let (br, mut tally) = enter(ray, &nodes[0].bounds, stats)?;
    let tmin = ray.tmin;
    let mut tmax = ray.tmax;
    let mut best = None;
    let mut node = 0u32;
    let (mut trail, mut level, mut pop_level) = (0u64, ROOT_LEVEL, 0u64);
    // Short stack; when full, the oldest entry is dropped.
    let mut short = [0u32; 8];
    let mut head = 0usize;
    loop {
        let n = &nodes[node as usize];
        tally.nodes += 1;
        if S::LOGS {
            stats.visit(sp.ids[node as usize]);
        }
        if n.is_leaf() {
            if intersect_leaf::<ANY>(
                &sp.index,
                &sp.triangles,
                n.target(),
                ray,
                &mut tmax,
                &mut best,
                &mut tally,
            ) {
                break;
            }
        } else {
            tally.planes += 12;
            let l = n.target();
            let [tl, tr] = test_children(&br, nodes, l as usize, tmin, tmax);
            let (hit_l, hit_r) = (tl != f32::INFINITY, tr != f32::INFINITY);
            if hit_l && hit_r {
                let (near, far) = if tr < tl { (l + 1, l) } else { (l, l + 1) };
                level >>= 1;
                if trail & level != 0 {
                    node = far;
                } else {
                    node = near;
                    if K > 0 {
                        if head < K {
                            short[head] = far;
                            head += 1;
                        } else {
                            short.copy_within(1..K, 0);
                            short[K - 1] = far;
                        }
                    }
                }
                continue;
            }
            if hit_l || hit_r {
                level >>= 1;
                if level != pop_level {
                    trail |= level;
                    node = if hit_l { l } else { l + 1 };
                    continue;
                }
                // At the pop level with one child hit: the far child
                // (the pop target) is culled now; the near one is done.
            }
        }
        // Pop: mark this level finished; the carry runs through the
        // finished levels to the deepest pending one.
        trail &= level.wrapping_neg();
        trail = trail.wrapping_add(level);
        if trail & ROOT_LEVEL != 0 {
            break;
        }
        level = trail & trail.wrapping_neg();
        pop_level = level;
        if K > 0 && head > 0 {
            head -= 1;
            node = short[head];
        } else {
            node = 0;
            level = ROOT_LEVEL;
        }
    }
    stats.add(tally);
    best
}
