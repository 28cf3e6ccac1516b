//! STACK over the sparse layout's own-box nodes (the algorithm of the
//! uncompressed BVH's STACK): the same algorithm on the nodes the stackless
//! traversals use, so that timing ratios compare algorithms, not layouts.

use super::SparseLayout;
use crate::geometry::{Hit, Ray};
use crate::stats::Stats;
use crate::structures::shared::own_box::{branch_pick, BinaryNode, Children, Step};
use crate::structures::shared::with_stack;

/// Closest hit (`ANY = false`) or any hit (`ANY = true`).
#[inline]
pub fn trace<L: SparseLayout, S: Stats, const ANY: bool>(
    sp: &L,
    ray: &Ray,
    stats: &mut S,
) -> Option<Hit> {
    with_stack!(sp.sparse().depth, trace_n::<L, S; ANY>(sp, ray, stats))
}

#[inline]
fn trace_n<L: SparseLayout, S: Stats, const ANY: bool, const N: usize>(
    sp: &L,
    ray: &Ray,
    stats: &mut S,
) -> Option<Hit> {
    if sp.is_empty() {
        return None;
    }
    let mut w = sp.walk::<ANY, S>(ray, stats)?;
    let mut stack = [0u32; N];
    let mut top = 0;
    let mut node = 0u32;
    loop {
        match w.step(node as usize, BinaryNode::target, || sp.id(node), stats) {
            Step::Inner { left, children } => match children {
                Children::Both { right_first } => {
                    node = branch_pick(right_first, left + 1, left);
                    stack[top] = branch_pick(right_first, left, left + 1);
                    top += 1;
                    continue;
                }
                Children::One { right } => {
                    node = branch_pick(right, left + 1, left);
                    continue;
                }
                Children::None => {}
            },
            Step::Leaf => {}
            Step::Done => break,
        }
        if top == 0 {
            break;
        }
        top -= 1;
        node = stack[top];
    }
    w.finish(stats)
}
