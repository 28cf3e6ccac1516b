//! LAINE-k (Laine 2010, "Restart trail for stackless BVH traversal"): a
//! trail of one bit per level says which subtrees are finished; when the
//! short stack of `K` entries is empty, traversal restarts at the root and
//! descends along the trail. Children are ordered by distance as in STACK,
//! and distances do not depend on the current closest hit, so a restart
//! takes the same turns.
//!
//! The trail, level and pop level are 64 bits (root at bit 63): trees up to
//! depth 63.

use super::SparseLayout;
use crate::geometry::{Hit, Ray};
use crate::stats::Stats;
use crate::structures::shared::own_box::{BinaryNode, Children, Step};

const ROOT_LEVEL: u64 = 1 << 63;

/// Closest hit (`ANY = false`) or any hit, with a short stack of `K`.
#[inline]
pub fn trace<L: SparseLayout, S: Stats, const ANY: bool, const K: usize>(
    sp: &L,
    ray: &Ray,
    stats: &mut S,
) -> Option<Hit> {
    if sp.is_empty() {
        return None;
    }
    let mut w = sp.walk::<ANY, S>(ray, stats)?;
    let mut node = 0u32;
    let (mut trail, mut level, mut pop_level) = (0u64, ROOT_LEVEL, 0u64);
    // Short stack; when full, the oldest entry is dropped.
    let mut short = [0u32; 8];
    let mut head = 0usize;
    loop {
        match w.step(node as usize, BinaryNode::target, || sp.id(node), stats) {
            Step::Inner { left, children } => match children {
                Children::Both { right_first } => {
                    let (near, far) = if right_first {
                        (left + 1, left)
                    } else {
                        (left, left + 1)
                    };
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
                Children::One { right } => {
                    level >>= 1;
                    if level != pop_level {
                        trail |= level;
                        node = left + right as u32;
                        continue;
                    }
                    // At the pop level with one child hit: the far child
                    // (the pop target) is culled now; the near one is done.
                }
                Children::None => {}
            },
            Step::Leaf => {}
            Step::Done => break,
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
    w.finish(stats)
}
