//! SPARSE (Barringer and Akenine-Möller 2013, Algorithm 4): Algorithm 3 over
//! a tree with parent links. The node pointer replaces the heap index;
//! ascending follows parent links while `levelIndex` is even, then moves to
//! the sibling. Visits exactly the nodes STACK visits, in the same order.

use super::leaf::{enter, intersect_leaf, test_children};
use crate::accel::sparse_bvh::{sibling, SparseBvh};
use crate::geometry::{Hit, Ray};
use crate::stats::Stats;

/// `levelIndex` is 64 bits wide: trees up to depth 63.
#[inline]
pub fn sparse<S: Stats, const ANY: bool>(sp: &SparseBvh, ray: &Ray, stats: &mut S) -> Option<Hit> {
    if sp.is_empty() {
        return None;
    }
    let nodes = &sp.nodes[..];
    let (br, mut tally) = enter(ray, &nodes[0].bounds, stats)?;
    let tmin = ray.tmin;
    let mut tmax = ray.tmax;
    let mut best = None;
    let (mut node, mut level_index) = (0u32, 0u64);
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
                level_index <<= 1;
                node = if tr < tl { l + 1 } else { l };
                continue;
            }
            if hit_l || hit_r {
                // One child rejected: its slot counts as done.
                level_index = (level_index << 1) + 1;
                node = if hit_l { l } else { l + 1 };
                continue;
            }
        }
        level_index += 1;
        while level_index & 1 == 0 {
            node = sp.parent(node);
            level_index >>= 1;
        }
        if node == 0 {
            break;
        }
        node = sibling(node);
    }
    stats.add(tally);
    best
}
