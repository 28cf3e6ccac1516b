//! STACK: the reference traversal (as the stackless paper means it). At an
//! inner node both children's boxes are tested; the nearer hit child is
//! visited next and the farther one pushed. The stack holds node references
//! only: a popped node is always visited, even if its box now lies beyond
//! the closest hit. Ties between the two children go to the left.

use super::{BinaryBvh, NodeRef, LAST, PAIR_PLANES};
use crate::geometry::{Hit, Ray};
use crate::stats::Stats;
use crate::structures::shared::leaf::enter;
use crate::structures::shared::own_box::branch_pick;
use crate::structures::shared::tri_block::{intersect_blocks_with, BlockRay};
use crate::structures::shared::with_stack;

/// Closest hit (`ANY = false`) or any hit (`ANY = true`) over the
/// uncompressed binary BVH, read from its cache-line copy (`lines.rs`).
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
    // The triangle test's constants, once per ray rather than per leaf.
    let tri = BlockRay::new(ray);
    let tmin = ray.tmin;
    let mut tmax = ray.tmax;
    let lines = &bvh.lines;
    let nodes = &lines.nodes[..];
    let blocks = bvh.blocks.blocks();
    let mut best: Option<Hit> = None;
    let mut stack = [0 as NodeRef; N];
    let mut sp = 0;
    let mut node = lines.root;
    loop {
        tally.nodes += 1;
        if S::LOGS {
            stats.visit(lines.canonical_id(node));
        }
        if node & LAST != 0 {
            if intersect_blocks_with::<ANY, S>(
                &tri,
                blocks,
                node & !LAST,
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
            let n = &nodes[node as usize];
            tally.planes += PAIR_PLANES;
            let (hit, t) = br.test_pair_mask(&n.planes, tmin, tmax);
            let [left, right] = n.child;
            if hit == 3 {
                // Both: the nearer first, ties to the left.
                let right_first = t.y < t.x;
                node = branch_pick(right_first, right, left);
                stack[sp] = branch_pick(right_first, left, right);
                sp += 1;
                continue;
            }
            if hit != 0 {
                node = branch_pick(hit == 2, right, left);
                continue;
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
