//! SPARSE (Barringer and Akenine-Möller 2013, Algorithm 4): Algorithm 3 over
//! a tree with parent links. The node pointer replaces the heap index;
//! ascending follows parent links while `levelIndex` is even, then moves to
//! the sibling. Visits exactly the nodes STACK visits, in the same order.

use super::{sibling, SparseLayout};
use crate::geometry::{Hit, Ray};
use crate::stats::Stats;
use crate::structures::shared::own_box::{branch_pick, BinaryNode, Children, Step};

/// Closest hit (`ANY = false`) or any hit. `levelIndex` is 64 bits wide:
/// trees up to depth 63.
#[inline]
pub fn trace<L: SparseLayout, S: Stats, const ANY: bool>(
    sp: &L,
    ray: &Ray,
    stats: &mut S,
) -> Option<Hit> {
    if sp.is_empty() {
        return None;
    }
    let mut w = sp.walk::<ANY, S>(ray, stats)?;
    let (mut node, mut level_index) = (0u32, 0u64);
    loop {
        match w.step(node as usize, BinaryNode::target, || sp.id(node), stats) {
            Step::Inner { left, children } => match children {
                Children::Both { right_first } => {
                    level_index <<= 1;
                    node = branch_pick(right_first, left + 1, left);
                    continue;
                }
                Children::One { right } => {
                    // One child rejected: its slot counts as done.
                    level_index = (level_index << 1) + 1;
                    node = branch_pick(right, left + 1, left);
                    continue;
                }
                Children::None => {}
            },
            Step::Leaf => {}
            Step::Done => break,
        }
        level_index += 1;
        // Up as many levels as `levelIndex` has trailing zeros: the count
        // known before the first step, so that the loop's exit is no guess.
        let up = level_index.trailing_zeros();
        level_index >>= up;
        node = sp.ancestor(node, up);
        if node == 0 {
            break;
        }
        node = sibling(node);
    }
    w.finish(stats)
}
