//! IMPLICIT-A and IMPLICIT-B (Barringer and Akenine-Möller 2013, Algorithms
//! 2 and 3) over the implicit heap layout: no stack; the state is a few
//! integers from which the next node's heap position is computed, and
//! ascending is one count-trailing-zeros and shifts. Both visit exactly the
//! nodes STACK visits, in the same order.

use super::ImplicitBvh;
use crate::geometry::{Hit, Ray};
use crate::stats::Stats;
use crate::structures::shared::own_box::{branch_pick, Children, Step, Walk};

/// The walk over `im`'s slots from the root (heap position 0, slot 1);
/// `None` when the ray misses the root's box.
#[inline(always)]
fn enter<'a, const ANY: bool, S: Stats>(
    im: &'a ImplicitBvh,
    ray: &'a Ray,
    stats: &mut S,
) -> Option<Walk<'a, ANY>> {
    let slots = im.slots();
    Walk::enter(
        ray,
        slots,
        &slots[1].bounds,
        &im.blocks,
        &im.triangles,
        stats,
    )
}

/// Algorithm 2: `levelStart` (2^depth), `levelIndex` (the left-first index
/// within the level) and `swapMask` (bit i set if level depth-i-1 took the
/// right child first). The node is
/// `levelStart + levelIndex - 1 + swapMask - 2·(levelIndex ∧ swapMask)`.
#[inline]
pub fn implicit_a<S: Stats, const ANY: bool>(
    im: &ImplicitBvh,
    ray: &Ray,
    stats: &mut S,
) -> Option<Hit> {
    if im.is_empty() {
        return None;
    }
    let slots = im.slots();
    let mut w = enter::<ANY, S>(im, ray, stats)?;
    let (mut level_start, mut level_index, mut swap_mask) = (1u32, 0u32, 0u32);
    loop {
        let node = level_start
            .wrapping_add(level_index)
            .wrapping_sub(1)
            .wrapping_add(swap_mask)
            .wrapping_sub(2 * (level_index & swap_mask));
        // Heap position p lives in slot p + 1; its children in slots 2p+2, 2p+3.
        let slot = node as usize + 1;
        match w.step(slot, |_| 2 * node + 2, || slots[slot].extra, stats) {
            Step::Inner { children, .. } => match children {
                Children::Both { right_first } => {
                    level_start <<= 1;
                    level_index <<= 1;
                    swap_mask = branch_pick(right_first, swap_mask << 1 | 1, swap_mask << 1);
                    continue;
                }
                Children::One { right } => {
                    // One child rejected: levelIndex moves past it, and the
                    // swap bit (right-first, then flipped) ends up set when
                    // the left child is the one taken.
                    level_start <<= 1;
                    level_index = (level_index << 1) + 1;
                    swap_mask = branch_pick(right, swap_mask << 1, swap_mask << 1 | 1);
                    continue;
                }
                Children::None => {}
            },
            Step::Leaf => {}
            Step::Done => break,
        }
        level_index += 1;
        let up = level_index.trailing_zeros();
        level_start >>= up;
        level_index >>= up;
        swap_mask >>= up;
        if level_start <= 1 {
            break;
        }
    }
    w.finish(stats)
}

/// Algorithm 3 with the combined index of §2.2: `index = levelStart +
/// levelIndexDynamic` (the node is `index - 1`) and the left-first
/// `levelIndex`, whose trailing zeros say how far to ascend. After an
/// ascent the dynamic index switches to the sibling (its low bit flips).
#[inline]
pub fn implicit_b<S: Stats, const ANY: bool>(
    im: &ImplicitBvh,
    ray: &Ray,
    stats: &mut S,
) -> Option<Hit> {
    if im.is_empty() {
        return None;
    }
    let slots = im.slots();
    let mut w = enter::<ANY, S>(im, ray, stats)?;
    let (mut index, mut level_index) = (1u32, 0u32);
    loop {
        // Node `index - 1` lives in slot `index`.
        match w.step(
            index as usize,
            |_| 2 * index,
            || slots[index as usize].extra,
            stats,
        ) {
            Step::Inner { children, .. } => match children {
                Children::Both { right_first } => {
                    index = branch_pick(right_first, index << 1 | 1, index << 1);
                    level_index <<= 1;
                    continue;
                }
                Children::One { right } => {
                    index = branch_pick(right, index << 1 | 1, index << 1);
                    level_index = (level_index << 1) + 1;
                    continue;
                }
                Children::None => {}
            },
            Step::Leaf => {}
            Step::Done => break,
        }
        level_index += 1;
        let up = level_index.trailing_zeros();
        index >>= up;
        level_index >>= up;
        if index <= 1 {
            break;
        }
        index ^= 1;
    }
    w.finish(stats)
}
