//! The stackless traversals against STACK and the oracle.

use crate::common;

use rayon::prelude::*;
use raytree::prelude::*;
use raytree::render::rayset;
use raytree::structures::{Built, SparseBvh, StructureKind, TraversalKind, WithAccel};
use std::sync::Arc;

/// Per ray: the closest hit, its visit log, the any hit and its visit log.
type Trace = (Option<Hit>, Vec<u32>, Option<Hit>, Vec<u32>);

struct Logs<'a>(&'a [Ray]);

impl WithAccel for Logs<'_> {
    type Output = Vec<Trace>;
    fn run<A: Accel>(self, a: &A) -> Vec<Trace> {
        raytree::par::map(self.0, &|r| {
            let mut c = VisitLog::default();
            let closest = a.closest_hit(r, &mut c);
            let mut y = VisitLog::default();
            let any = a.any_hit(r, &mut y);
            (closest, c.visits, any, y.visits)
        })
    }
}

/// Eye rays and AO rays of a scene, at least `n` in all.
fn eye_and_ao_rays(scene: &Scene, n: usize) -> Vec<Ray> {
    let bvh = Bvh::build(&scene.triangles, &BuildOptions::sah());
    let layout = BinaryBvh::from_bvh(&bvh, scene.triangles.clone()).unwrap();
    let radius = 0.045 * scene.mesh.bounds().extent().length();
    for spp in 1.. {
        let eye = rayset::eye_rays(scene, 100, 100, spp);
        let mut rays = rayset::ao_rays(scene, &layout, &eye, 8, radius);
        rays.extend(eye);
        if rays.len() >= n {
            return rays;
        }
    }
    unreachable!()
}

fn first_visits(log: &[u32]) -> Vec<u32> {
    let mut seen = std::collections::HashSet::new();
    log.iter().copied().filter(|id| seen.insert(*id)).collect()
}

fn is_subsequence(sub: &[u32], of: &[u32]) -> bool {
    let mut it = of.iter();
    sub.iter().all(|x| it.any(|y| y == x))
}

fn check_config(scene: &Scene, rays: &[Ray], builder: Builder, leaf: usize) {
    let bvh = Bvh::build(
        &scene.triangles,
        &BuildOptions::new(builder).with_max_leaf_size(leaf),
    );
    let what = format!("{} {} leaf {leaf}", scene.name, builder.name());
    let run = |t: TraversalKind| {
        let (b, _) = Built::new(StructureKind::Bvh, t, &bvh, scene.triangles.clone()).unwrap();
        b.with(Logs(rays))
    };
    let stack = run(TraversalKind::Stack);
    let sparse_layout = Arc::new(SparseBvh::from_bvh(&bvh, scene.triangles.clone()).unwrap());
    let stack_sparse = Built::sparse(TraversalKind::Stack, sparse_layout)
        .unwrap()
        .with(Logs(rays));
    // Exactly STACK's node sequence and hits, closest and any.
    for (name, got) in [
        ("stack/sparse", stack_sparse),
        ("implicit-a", run(TraversalKind::ImplicitA)),
        ("implicit-b", run(TraversalKind::ImplicitB)),
        ("sparse", run(TraversalKind::Sparse)),
    ] {
        for (i, (g, s)) in got.iter().zip(&stack).enumerate() {
            assert_eq!(
                g, s,
                "{what}: {name} differs from STACK on ray {i} {:?}",
                rays[i]
            );
        }
    }
    for t in [
        TraversalKind::Laine0,
        TraversalKind::Laine1,
        TraversalKind::Laine2,
        TraversalKind::Laine4,
        TraversalKind::Laine8,
    ] {
        let k = match t {
            TraversalKind::Laine0 => 0,
            TraversalKind::Laine1 => 1,
            TraversalKind::Laine2 => 2,
            TraversalKind::Laine4 => 4,
            _ => 8,
        };
        let got = run(t);
        for (i, (g, s)) in got.iter().zip(&stack).enumerate() {
            assert_eq!(
                g.0,
                s.0,
                "{what}: {} closest hit differs on ray {i}",
                t.name()
            );
            assert_eq!(
                g.2.is_some(),
                s.2.is_some(),
                "{what}: {} any hit differs on ray {i}",
                t.name()
            );
            let first = first_visits(&g.1);
            if k as u32 >= bvh.stats.depth {
                // The short stack never overflows: no restart, STACK exactly.
                assert_eq!(g.1, s.1, "{what}: {} sequence on ray {i}", t.name());
            } else {
                // Restarts re-visit ancestors and cull pending subtrees that
                // STACK still enters: first visits keep STACK's order.
                assert!(
                    is_subsequence(&first, &s.1),
                    "{what}: {} first visits on ray {i}",
                    t.name()
                );
            }
        }
    }
    let hapala = run(TraversalKind::Hapala);
    for (i, (g, s)) in hapala.iter().zip(&stack).enumerate() {
        assert_eq!(g.0, s.0, "{what}: hapala closest hit differs on ray {i}");
        assert_eq!(
            g.2.is_some(),
            s.2.is_some(),
            "{what}: hapala any hit differs on ray {i}"
        );
        // No node is visited twice.
        assert_eq!(
            first_visits(&g.1).len(),
            g.1.len(),
            "{what}: hapala revisits on ray {i}"
        );
    }
}

fn check_scene(spec: &str) {
    let scene = Scene::builtin(spec).unwrap();
    let rays = eye_and_ao_rays(&scene, 50_000);
    for builder in Builder::ALL {
        for leaf in 1..=8 {
            check_config(&scene, &rays, builder, leaf);
        }
    }
}

#[test]
fn chess_stackless_traversals_match_stack() {
    check_scene("chess:3000");
}

#[test]
fn hairball_stackless_traversals_match_stack() {
    check_scene("hairball:3000");
}

#[test]
fn every_traversal_agrees_with_the_oracle() {
    for spec in ["chess:2000", "hairball:2000"] {
        let scene = Scene::builtin(spec).unwrap();
        let rays = common::mixed_rays(&scene, 20_000, 5);
        let oracle = BruteForce::new(scene.triangles.clone());
        let want: Vec<bool> = rays
            .par_iter()
            .map(|r| oracle.any_hit(r, &mut NoStats).is_some())
            .collect();
        let want_t: Vec<Option<f32>> = rays
            .par_iter()
            .map(|r| oracle.closest_hit(r, &mut NoStats).map(|h| h.t))
            .collect();
        for builder in Builder::ALL {
            let bvh = Bvh::build(&scene.triangles, &BuildOptions::new(builder));
            for &t in TraversalKind::all() {
                let (b, _) =
                    Built::new(StructureKind::Bvh, t, &bvh, scene.triangles.clone()).unwrap();
                let got = b.with(Logs(&rays));
                for (i, g) in got.iter().enumerate() {
                    assert_eq!(
                        g.2.is_some(),
                        want[i],
                        "{spec} {}: any hit on ray {i}",
                        t.name()
                    );
                    assert_eq!(
                        g.0.is_some(),
                        want_t[i].is_some(),
                        "{spec} {}: closest hit on ray {i}",
                        t.name()
                    );
                }
            }
        }
    }
}

/// A chain: each inner node has one triangle as its left leaf and the rest
/// of the chain on its right, so the depth is `n - 1`.
fn chain(n: usize) -> (Vec<Triangle>, Bvh) {
    use raytree::bvh::{Node, NodeKind, NO_PARENT};
    let tris: Vec<Triangle> = (0..n)
        .map(|i| {
            let x = i as f32;
            Triangle::new(
                Vec3::new(x, 0.0, 0.0),
                Vec3::new(x, 1.0, 0.0),
                Vec3::new(x, 0.0, 1.0),
            )
        })
        .collect();
    let mut nodes = Vec::new();
    for k in 0..n {
        let bounds = tris[k..]
            .iter()
            .fold(Aabb::EMPTY, |b, t| b.union(t.bounds()));
        let id = nodes.len() as u32;
        let parent = if k == 0 { NO_PARENT } else { id - 2 };
        if k + 1 == n {
            nodes.push(Node {
                bounds,
                parent,
                depth: k as u32,
                kind: NodeKind::Leaf {
                    first: k as u32,
                    count: 1,
                },
            });
        } else {
            nodes.push(Node {
                bounds,
                parent,
                depth: k as u32,
                kind: NodeKind::Inner {
                    left: id + 1,
                    right: id + 2,
                    axis: 0,
                },
            });
            nodes.push(Node {
                bounds: tris[k].bounds(),
                parent: id,
                depth: k as u32 + 1,
                kind: NodeKind::Leaf {
                    first: k as u32,
                    count: 1,
                },
            });
        }
    }
    let mut stats = raytree::bvh::BuildStats {
        max_leaf_size: 1,
        depth: n as u32 - 1,
        ..Default::default()
    };
    stats.nodes = nodes.len();
    stats.leaves = n;
    stats.inner_nodes = n - 1;
    let bvh = Bvh {
        nodes,
        prims: (0..n as u32).collect(),
        stats,
    };
    bvh.validate(&tris).unwrap();
    (tris, bvh)
}

#[test]
fn too_deep_trees_are_clear_errors() {
    let (tris, bvh) = chain(40);
    let tris: Arc<[Triangle]> = tris.into();
    let err = Built::new(
        StructureKind::Bvh,
        TraversalKind::ImplicitB,
        &bvh,
        tris.clone(),
    )
    .err()
    .expect("refused")
    .to_string();
    assert!(err.contains("depth 39") && err.contains("hybrid"), "{err}");
    // The sparse traversals take it; LAINE and SPARSE refuse depth 64 and more.
    for t in [
        TraversalKind::Sparse,
        TraversalKind::Laine2,
        TraversalKind::Hapala,
    ] {
        Built::new(StructureKind::Bvh, t, &bvh, tris.clone()).unwrap();
    }
    let (tris, deep) = chain(70);
    for t in [TraversalKind::Sparse, TraversalKind::Laine0] {
        let err = Built::new(StructureKind::Bvh, t, &deep, tris.clone().into())
            .err()
            .expect("refused")
            .to_string();
        assert!(err.contains("depth 69") && err.contains(t.name()), "{err}");
    }
    // A reservation limit is its own clear error.
    let scene = Scene::builtin("chess:3000").unwrap();
    let bvh = Bvh::build(&scene.triangles, &BuildOptions::hybrid());
    let opts = raytree::structures::LayoutOptions {
        implicit_reservation_limit: 1 << 12,
    };
    let err = Built::with_options(
        StructureKind::Bvh,
        TraversalKind::ImplicitA,
        &bvh,
        scene.triangles.clone(),
        &opts,
    )
    .err()
    .expect("refused")
    .to_string();
    assert!(err.contains("GiB") && err.contains("limit"), "{err}");
}

#[test]
fn state_sizes_follow_figure_5() {
    use raytree::structures::state_bytes;
    assert_eq!(state_bytes(TraversalKind::ImplicitA, 20), 12);
    assert_eq!(state_bytes(TraversalKind::ImplicitB, 20), 8);
    assert_eq!(state_bytes(TraversalKind::Hapala, 20), 8);
    // node, trail, level, popLevel; the kernel's path and one words below
    // k = 4; the short stack's head and entries.
    assert_eq!(state_bytes(TraversalKind::Laine0, 20), 4 + 5 * 8);
    assert_eq!(state_bytes(TraversalKind::Laine2, 20), 4 + 5 * 8 + 4 + 8);
    assert_eq!(state_bytes(TraversalKind::Laine8, 20), 4 + 3 * 8 + 4 + 32);
    assert!(state_bytes(TraversalKind::Laine8, 20) > state_bytes(TraversalKind::Laine0, 20));
    assert!(state_bytes(TraversalKind::Stack, 20) > state_bytes(TraversalKind::Laine8, 20));
    assert_eq!(state_bytes(TraversalKind::Stack, 20), 8 + 4 * 32);
    assert_eq!(state_bytes(TraversalKind::Stack, 40), 8 + 4 * 64);
}
