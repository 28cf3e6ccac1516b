//! SPARSE (Barringer and Akenine-Möller 2013, Algorithm 4): Algorithm 3 over
//! a tree with parent links. The node pointer replaces the heap index;
//! ascending follows parent links while `levelIndex` is even, then moves to
//! the sibling. Visits exactly the nodes STACK visits, in the same order.

use super::{sibling, SparseBvh};
use crate::geometry::{Hit, Ray};
use crate::stats::Stats;
use crate::structures::shared::own_box::{Children, Step, Walk};

/// Closest hit (`ANY = false`) or any hit. `levelIndex` is 64 bits wide:
/// trees up to depth 63.
#[inline]
pub fn trace<S: Stats, const ANY: bool>(sp: &SparseBvh, ray: &Ray, stats: &mut S) -> Option<Hit> {
    if sp.is_empty() {
        return None;
    }
    let mut w = Walk::<ANY>::enter(ray, &sp.nodes, 0, &sp.blocks, &sp.triangles, stats)?;
    let (mut node, mut level_index) = (0u32, 0u64);
    loop {
        match w.step(
            node as usize,
            |n| n.target(),
            || sp.ids[node as usize],
            stats,
        ) {
            Step::Inner { left, children } => match children {
                Children::Both { right_first } => {
                    level_index <<= 1;
                    node = left + right_first as u32;
                    continue;
                }
                Children::One { right } => {
                    // One child rejected: its slot counts as done.
                    level_index = (level_index << 1) + 1;
                    node = left + right as u32;
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
        for _ in 0..up {
            node = sp.parent(node);
        }
        if node == 0 {
            break;
        }
        node = sibling(node);
    }
    w.finish(stats)
}
