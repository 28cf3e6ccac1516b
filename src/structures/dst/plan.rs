//! Choosing the carving nodes under a splitting node's child by the SAH of
//! the paper's equation 1:
//!
//! `C = Σ_{j=1..ℓ} (S_{j-1}/S)·C_j + (S_ℓ/S)·C_I·T`
//!
//! where `S` is the splitting node's area, `S_0` the child's region right
//! after the split, `S_j` the region after `j` carving nodes, `C_j = σ·C_I`
//! (σ = 0.3 single-axis, 0.5 dual-axis), `C_I = 1`, and `T` the child's
//! triangle count. Every sequence of up to three carving nodes is tried.

use crate::geometry::Aabb;

/// Relative cost of a single-axis carving node.
pub const SIGMA_SINGLE: f32 = 0.3;
/// Relative cost of a dual-axis carving node.
pub const SIGMA_DUAL: f32 = 0.5;
/// At most this many carving levels follow a splitting node.
pub const MAX_LEVELS: usize = 3;

/// One plane a child's region must lose to match its box: axis, whether it
/// bounds the region from above, and its position.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Plane {
    /// 0 = x, 1 = y, 2 = z.
    pub axis: u8,
    /// Whether the plane is the region's maximum (empty space above it).
    pub max_side: bool,
    /// Position on `axis`, in scene units.
    pub at: f32,
}

/// A carving node to place.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum CarveOp {
    /// The region becomes `lo ..= hi` on `axis`.
    Single {
        /// 0 = x, 1 = y, 2 = z.
        axis: u8,
        /// The region's new minimum on `axis` (its old one if uncarved).
        lo: f32,
        /// The region's new maximum on `axis` (its old one if uncarved).
        hi: f32,
    },
    /// Two planes on two different axes (`a.axis < b.axis`).
    Dual {
        /// The plane on the lower axis.
        a: Plane,
        /// The plane on the higher axis.
        b: Plane,
    },
}

impl CarveOp {
    /// The region `cell` left after this node carves it.
    pub fn apply(&self, cell: &Aabb) -> Aabb {
        let mut c = *cell;
        let mut cut = |p: &Plane| {
            if p.max_side {
                c.max[p.axis as usize] = p.at;
            } else {
                c.min[p.axis as usize] = p.at;
            }
        };
        match self {
            CarveOp::Single { axis, lo, hi } => {
                cut(&Plane {
                    axis: *axis,
                    max_side: false,
                    at: *lo,
                });
                cut(&Plane {
                    axis: *axis,
                    max_side: true,
                    at: *hi,
                });
            }
            CarveOp::Dual { a, b } => {
                cut(a);
                cut(b);
            }
        }
        c
    }

    /// The node's traversal cost `σ` relative to a triangle test:
    /// [`SIGMA_SINGLE`] or [`SIGMA_DUAL`].
    pub fn sigma(&self) -> f32 {
        match self {
            CarveOp::Single { .. } => SIGMA_SINGLE,
            CarveOp::Dual { .. } => SIGMA_DUAL,
        }
    }
}

/// The planes by which `cell` (which contains `target`) is larger.
pub fn excess_planes(cell: &Aabb, target: &Aabb) -> Vec<Plane> {
    let mut v = Vec::new();
    for a in 0..3 {
        if cell.min[a] < target.min[a] {
            v.push(Plane {
                axis: a as u8,
                max_side: false,
                at: target.min[a],
            });
        }
        if cell.max[a] > target.max[a] {
            v.push(Plane {
                axis: a as u8,
                max_side: true,
                at: target.max[a],
            });
        }
    }
    v
}

/// What a conversion may do when it carves.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Rules {
    /// Carve every excess plane (identical partitioning) rather than let
    /// SAH leave some for deeper levels.
    pub complete: bool,
    /// Dual-axis carving nodes are allowed (not in a BIH).
    pub dual: bool,
}

impl Rules {
    /// The identical conversion (§4.2.1).
    pub const IDENTICAL: Rules = Rules {
        complete: true,
        dual: true,
    };
    /// The similar conversion (§4.2.2).
    pub const SIMILAR: Rules = Rules {
        complete: false,
        dual: true,
    };
    /// A BIH with clip nodes: single-axis carving only, identical.
    pub const BIH: Rules = Rules {
        complete: true,
        dual: false,
    };
}

/// The chosen carving nodes, their cost and the region they leave.
#[derive(Clone, Debug)]
pub struct Plan {
    /// The carving nodes, outermost first (at most [`MAX_LEVELS`]).
    pub ops: Vec<CarveOp>,
    /// The child's cost `C` of equation 1 with `C_I = 1`.
    pub cost: f32,
    /// The child's region after the last carving node.
    pub cell: Aabb,
}

/// The cheapest carving under a child whose region is `cell` and whose
/// content is bounded by `target`, with `triangles` triangles, below a
/// splitting node of area `parent_area`, under `rules`. Ties keep fewer nodes, then
/// the first sequence found (single-axis before dual, lower axes first).
pub fn best_plan(
    cell: &Aabb,
    target: &Aabb,
    triangles: u32,
    parent_area: f32,
    rules: Rules,
) -> Plan {
    let planes = excess_planes(cell, target);
    let inv = if parent_area > 0.0 {
        1.0 / parent_area
    } else {
        0.0
    };
    let mut best: Option<Plan> = None;
    let mut ops = Vec::with_capacity(MAX_LEVELS);
    search(
        &planes,
        (1u32 << planes.len()) - 1,
        *cell,
        0.0,
        triangles as f32,
        inv,
        rules,
        &mut ops,
        &mut best,
    );
    best.expect("the empty or complete plan always exists")
}

#[allow(clippy::too_many_arguments)]
fn search(
    planes: &[Plane],
    left: u32,
    cell: Aabb,
    cost: f32,
    tris: f32,
    inv: f32,
    rules: Rules,
    ops: &mut Vec<CarveOp>,
    best: &mut Option<Plan>,
) {
    let complete = rules.complete;
    if left == 0 || !complete {
        let total = cost + cell.area() * inv * tris;
        let better = match best {
            None => true,
            Some(b) => total < b.cost || (total == b.cost && ops.len() < b.ops.len()),
        };
        if (left == 0 || !complete) && better {
            *best = Some(Plan {
                ops: ops.clone(),
                cost: total,
                cell,
            });
        }
    }
    if left == 0 || ops.len() == MAX_LEVELS {
        return;
    }
    let remaining = left.count_ones() as usize;
    // A carving node removes at most two planes: a complete plan must fit
    // the levels left.
    if complete && remaining.div_ceil(2) > MAX_LEVELS - ops.len() {
        return;
    }
    // No plan from here costs less than what is spent already plus the
    // target's own area: prune against the best so far.
    if let Some(b) = best {
        if cost >= b.cost {
            return;
        }
    }
    let node_cost = cell.area() * inv;
    // Single-axis: every remaining plane on one axis.
    for axis in 0..3u8 {
        let on_axis: u32 = (0..planes.len())
            .filter(|&i| left >> i & 1 == 1 && planes[i].axis == axis)
            .fold(0, |m, i| m | 1 << i);
        if on_axis == 0 {
            continue;
        }
        let (mut lo, mut hi) = (cell.min[axis as usize], cell.max[axis as usize]);
        for (i, p) in planes.iter().enumerate() {
            if on_axis >> i & 1 == 1 {
                if p.max_side {
                    hi = p.at;
                } else {
                    lo = p.at;
                }
            }
        }
        let op = CarveOp::Single { axis, lo, hi };
        ops.push(op);
        search(
            planes,
            left & !on_axis,
            op.apply(&cell),
            cost + node_cost * SIGMA_SINGLE,
            tris,
            inv,
            rules,
            ops,
            best,
        );
        ops.pop();
    }
    // Dual-axis: two remaining planes on different axes.
    if !rules.dual {
        return;
    }
    for i in 0..planes.len() {
        for j in i + 1..planes.len() {
            if left >> i & 1 == 0 || left >> j & 1 == 0 || planes[i].axis == planes[j].axis {
                continue;
            }
            let op = CarveOp::Dual {
                a: planes[i],
                b: planes[j],
            };
            ops.push(op);
            search(
                planes,
                left & !(1 << i | 1 << j),
                op.apply(&cell),
                cost + node_cost * SIGMA_DUAL,
                tris,
                inv,
                rules,
                ops,
                best,
            );
            ops.pop();
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;

    #[test]
    fn complete_plans_reach_the_target_within_three_levels() {
        let cell = Aabb::new(Vec3::ZERO, Vec3::splat(10.0));
        // Five excess planes (one side already shared, as after a split).
        let target = Aabb::new(Vec3::new(0.0, 1.0, 2.0), Vec3::new(9.0, 8.0, 7.0));
        let p = best_plan(&cell, &target, 4, cell.area(), Rules::IDENTICAL);
        assert_eq!(p.cell, target);
        assert!(p.ops.len() <= 3);
        let mut c = cell;
        for op in &p.ops {
            c = op.apply(&c);
        }
        assert_eq!(c, target);
    }

    #[test]
    fn nothing_to_carve_costs_the_leaf_only() {
        let b = Aabb::new(Vec3::ZERO, Vec3::ONE);
        let p = best_plan(&b, &b, 3, b.area() * 2.0, Rules::IDENTICAL);
        assert!(p.ops.is_empty());
        assert!((p.cost - 1.5).abs() < 1e-6);
    }

    #[test]
    fn one_plane_per_axis_on_two_axes_prefers_a_dual_node() {
        let cell = Aabb::new(Vec3::ZERO, Vec3::splat(10.0));
        let target = Aabb::new(Vec3::new(2.0, 0.0, 0.0), Vec3::new(10.0, 7.0, 10.0));
        let p = best_plan(&cell, &target, 100, cell.area(), Rules::IDENTICAL);
        assert_eq!(p.ops.len(), 1);
        assert!(matches!(p.ops[0], CarveOp::Dual { .. }));
        // A BIH needs one clip node per axis instead.
        let p = best_plan(&cell, &target, 100, cell.area(), Rules::BIH);
        assert_eq!(p.ops.len(), 2);
        assert!(p.ops.iter().all(|o| matches!(o, CarveOp::Single { .. })));
        assert_eq!(p.cell, target);
    }

    #[test]
    fn similar_plans_may_skip_a_sliver() {
        let cell = Aabb::new(Vec3::ZERO, Vec3::splat(10.0));
        let target = Aabb::new(Vec3::new(0.001, 0.0, 0.0), Vec3::splat(10.0));
        let p = best_plan(&cell, &target, 1, cell.area(), Rules::SIMILAR);
        assert!(p.ops.is_empty(), "{:?}", p.ops);
        assert_eq!(p.cell, cell);
        assert_eq!(
            best_plan(&cell, &target, 1, cell.area(), Rules::IDENTICAL)
                .ops
                .len(),
            1
        );
    }
}
