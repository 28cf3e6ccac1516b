//! HAPALA (Hapala, Davidovič, Wald, Havran and Slusallek 2011): stackless
//! traversal over parent links. The near child is chosen by the sign of the
//! ray direction on the node's split axis alone (left is the lower side),
//! so that on the way back up the sibling to visit next is known without
//! testing boxes again. Its visiting order differs from STACK's.

use super::{sibling, SparseBvh};
use crate::geometry::{Hit, Ray};
use crate::stats::Stats;
use crate::structures::shared::leaf::enter;
use crate::structures::shared::own_box::{branch_pick, OwnBoxNode};

#[derive(Clone, Copy, PartialEq, Eq)]
enum From {
    /// `cur` is a near child, not yet tested.
    Parent,
    /// `cur` is a far child, not yet tested.
    Sibling,
    /// `cur`'s subtree is finished.
    Child,
}

/// Closest hit (`ANY = false`) or any hit.
#[inline]
pub fn trace<S: Stats, const ANY: bool>(sp: &SparseBvh, ray: &Ray, stats: &mut S) -> Option<Hit> {
    if sp.is_empty() {
        return None;
    }
    let nodes = &sp.nodes[..];
    let (br, mut tally) = enter(ray, &nodes[0].bounds, stats)?;
    let d = ray.direction().to_array();
    let tmin = ray.tmin;
    let mut tmax = ray.tmax;
    let mut best = None;
    // The near child: left if the direction is positive on the split axis
    // (a zero component goes right, as in the reference code).
    let near_child = |n: u32| {
        let left = nodes[n as usize].target();
        branch_pick(d[sp.axis(n) & 3] > 0.0, left, left + 1)
    };
    tally.nodes += 1;
    if S::LOGS {
        stats.visit(sp.ids[0]);
    }
    if nodes[0].is_leaf() {
        sp.blocks.intersect::<ANY, S>(
            nodes[0].target(),
            &sp.triangles,
            ray,
            &mut tmax,
            &mut best,
            &mut tally,
            stats,
        );
    } else {
        let mut cur = near_child(0);
        let mut from = From::Parent;
        loop {
            if from == From::Child {
                if cur == 0 {
                    break;
                }
                let p = sp.parent(cur);
                if cur == near_child(p) {
                    cur = sibling(cur);
                    from = From::Sibling;
                } else {
                    cur = p;
                }
                continue;
            }
            // Arriving at an untested child: test its box now, with the
            // ray as short as it has become.
            let n = &nodes[cur as usize];
            tally.planes += OwnBoxNode::PLANES;
            let hit = br.test(&n.bounds, tmin, tmax) != f32::INFINITY;
            if hit && !n.is_leaf() {
                tally.nodes += 1;
                if S::LOGS {
                    stats.visit(sp.ids[cur as usize]);
                }
                cur = near_child(cur);
                from = From::Parent;
                continue;
            }
            if hit {
                tally.nodes += 1;
                if S::LOGS {
                    stats.visit(sp.ids[cur as usize]);
                }
                if sp.blocks.intersect::<ANY, S>(
                    n.target(),
                    &sp.triangles,
                    ray,
                    &mut tmax,
                    &mut best,
                    &mut tally,
                    stats,
                ) {
                    break;
                }
            }
            if from == From::Parent {
                cur = sibling(cur);
                from = From::Sibling;
            } else {
                cur = sp.parent(cur);
                from = From::Child;
            }
        }
    }
    stats.add(tally);
    best
}
