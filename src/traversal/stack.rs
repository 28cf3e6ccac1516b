//! STACK: the reference traversal (as the stackless paper means it). At an
//! inner node both children's boxes are tested; the nearer hit child is
//! visited next and the farther one pushed. The stack holds node references
//! only: a popped node is always visited, even if its box now lies beyond
//! the closest hit.

use crate::accel::binary_bvh::{
    BinaryBvh, NodeRef, INNER_WORDS, LAST, LEFT_LEAF, OFFSET_MASK, RIGHT_LEAF,
};
use crate::geometry::{BoxRay, Hit, Ray};
use crate::stats::{Stats, Tally};
use crate::traversal::MAX_STACK_DEPTH;

/// Closest hit (`ANY = false`) or any hit (`ANY = true`) over the
/// uncompressed binary BVH. Ties between the two children go to the left.
#[inline]
pub fn trace<S: Stats, const ANY: bool>(bvh: &BinaryBvh, ray: &Ray, stats: &mut S) -> Option<Hit> {
    if bvh.is_empty() {
        return None;
    }
    let br = BoxRay::new(ray);
    let tmin = ray.tmin;
    let mut tmax = ray.tmax;
    let mut tally = Tally {
        planes: 6,
        ..Tally::default()
    };
    if br.test(&bvh.root_bounds.to_array(), tmin, tmax) == f32::INFINITY {
        stats.add(tally);
        return None;
    }
    let words = &bvh.words[..];
    let mut best: Option<Hit> = None;
    let mut stack = [0 as NodeRef; MAX_STACK_DEPTH];
    let mut sp = 0;
    let mut node = bvh.root;
    loop {
        tally.nodes += 1;
        if S::LOGS {
            stats.visit(bvh.canonical_id(node));
        }
        if node & LAST != 0 {
            let mut i = words[(node & !LAST) as usize] as usize;
            loop {
                let entry = bvh.index[i];
                let prim = entry & !LAST;
                tally.triangles += 1;
                if let Some(h) = bvh.triangles[prim as usize].hit(ray, tmin, tmax, prim) {
                    if ANY {
                        stats.add(tally);
                        return Some(h);
                    }
                    if h.beats(&best) {
                        tmax = h.t;
                        best = Some(h);
                    }
                }
                if entry & LAST != 0 {
                    break;
                }
                i += 1;
            }
        } else {
            let at = node as usize;
            let n: &[u32; INNER_WORDS] = words[at..at + INNER_WORDS].try_into().unwrap();
            tally.planes += 12;
            let boxes: [f32; 12] = std::array::from_fn(|k| f32::from_bits(n[k]));
            let [tl, tr] = br.test_pair(&boxes, tmin, tmax);
            let link = n[12];
            let l = link & OFFSET_MASK;
            let left = l | ((link & LEFT_LEAF != 0) as u32) << 31;
            let r = l + if link & LEFT_LEAF != 0 {
                1
            } else {
                INNER_WORDS as u32
            };
            let right = r | ((link & RIGHT_LEAF != 0) as u32) << 31;
            let hit_l = tl != f32::INFINITY;
            let hit_r = tr != f32::INFINITY;
            if hit_l || hit_r {
                let right_first = tr < tl;
                let (near, far) = if right_first {
                    (right, left)
                } else {
                    (left, right)
                };
                node = near;
                if hit_l && hit_r {
                    stack[sp] = far;
                    sp += 1;
                }
                continue;
            }
        }
        if sp == 0 {
            stats.add(tally);
            return best;
        }
        sp -= 1;
        node = stack[sp];
    }
}
