//! STACK: the reference traversal (as the stackless paper means it). At an
//! inner node both children's boxes are tested; the nearer hit child is
//! visited next and the farther one pushed. The stack holds node references
//! only: a popped node is always visited, even if its box now lies beyond
//! the closest hit. Ties between the two children go to the left.

use super::{
    BinaryBvh, NodeRef, INNER_WORDS, LAST, LEFT_LEAF, OFFSET_MASK, PAIR_PLANES, RIGHT_LEAF,
};
use crate::geometry::{Hit, Ray};
use crate::stats::Stats;
use crate::structures::shared::leaf::enter;
use crate::structures::shared::own_box::Children;
use crate::structures::shared::with_stack;

/// Closest hit (`ANY = false`) or any hit (`ANY = true`) over the
/// uncompressed binary BVH.
#[inline]
pub fn trace<S: Stats, const ANY: bool>(bvh: &BinaryBvh, ray: &Ray, stats: &mut S) -> Option<Hit> {
    with_stack!(bvh.depth, trace_n::<S; ANY>(bvh, ray, stats))
}

#[inline]
fn trace_n<S: Stats, const ANY: bool, const N: usize>(
    bvh: &BinaryBvh,
    ray: &Ray,
    stats: &mut S,
) -> Option<Hit> {
    if bvh.is_empty() {
        return None;
    }
    let (br, mut tally) = enter(ray, &bvh.root_bounds.to_array(), stats)?;
    let tmin = ray.tmin;
    let mut tmax = ray.tmax;
    let words = &bvh.words[..];
    let mut best: Option<Hit> = None;
    let mut stack = [0 as NodeRef; N];
    let mut sp = 0;
    let mut node = bvh.root;
    loop {
        tally.nodes += 1;
        if S::LOGS {
            stats.visit(bvh.canonical_id(node));
        }
        if node & LAST != 0 {
            let first = words[(node & !LAST) as usize];
            if bvh.blocks.intersect::<ANY, S>(
                first,
                &bvh.triangles,
                ray,
                &mut tmax,
                &mut best,
                &mut tally,
                stats,
            ) {
                break;
            }
        } else {
            let at = node as usize;
            let n: &[u32; INNER_WORDS] = words[at..at + INNER_WORDS].try_into().unwrap();
            tally.planes += PAIR_PLANES;
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
            match Children::of(tl, tr) {
                Children::Both { right_first } => {
                    let (near, far) = if right_first {
                        (right, left)
                    } else {
                        (left, right)
                    };
                    node = near;
                    stack[sp] = far;
                    sp += 1;
                    continue;
                }
                Children::One { right: r } => {
                    node = if r { right } else { left };
                    continue;
                }
                Children::None => {}
            }
        }
        if sp == 0 {
            break;
        }
        sp -= 1;
        node = stack[sp];
    }
    stats.add(tally);
    best
}
