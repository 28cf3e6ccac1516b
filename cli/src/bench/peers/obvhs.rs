//! The `obvhs` crate as a contender: its binary BVH traversal over
//! raytree's own tree (the same nodes, so only the traversal differs), over
//! its own PLOC build, and its 8-wide compressed BVH (CWBVH) over its own
//! build. All three call raytree's watertight triangle test, so the
//! triangles answer alike and only trees and traversals differ.

use super::Contender;
use obvhs::bvh2::{node::Bvh2Node, Bvh2};
use obvhs::cwbvh::CwBvh;
use obvhs::ray::RayHit;
use obvhs::BvhBuildParams;
use raytree::bvh::{Bvh, NodeKind};
use raytree::geometry::{Ray, Triangle};
use raytree::scene::Scene;
use std::sync::Arc;
use std::time::{Duration, Instant};

/// The scene's triangles as obvhs takes them.
pub fn triangles(scene: &Scene) -> Vec<obvhs::triangle::Triangle> {
    scene
        .triangles
        .iter()
        .map(|t| obvhs::triangle::Triangle {
            v0: t.a.into(),
            v1: t.b.into(),
            v2: t.c.into(),
        })
        .collect()
}

fn aabb(b: &raytree::geometry::Aabb) -> obvhs::aabb::Aabb {
    obvhs::aabb::Aabb::new(b.min.into(), b.max.into())
}

/// raytree's canonical tree as an obvhs `Bvh2`: the same nodes, the same
/// leaves, each node's children adjacent as obvhs lays them out.
pub fn bvh2_from(bvh: &Bvh) -> Bvh2 {
    let mut nodes = vec![Bvh2Node::new(aabb(&bvh.bounds()), 0, 0)];
    let mut todo = vec![(0u32, 0usize)];
    while let Some((id, at)) = todo.pop() {
        match bvh.nodes[id as usize].kind {
            NodeKind::Leaf { first, count } => {
                nodes[at].prim_count = count;
                nodes[at].first_index = first;
            }
            NodeKind::Inner { left, right, .. } => {
                let first = nodes.len();
                nodes[at].first_index = first as u32;
                for c in [left, right] {
                    nodes.push(Bvh2Node::new(aabb(&bvh.nodes[c as usize].bounds), 0, 0));
                }
                todo.push((left, first));
                todo.push((right, first + 1));
            }
        }
    }
    Bvh2 {
        nodes,
        primitive_indices: bvh.prims.clone(),
        max_depth: bvh.stats.depth as usize + 1,
        ..Default::default()
    }
}

/// A raytree ray as obvhs takes it.
pub fn to_obvhs(r: &Ray) -> obvhs::ray::Ray {
    obvhs::ray::Ray::new(r.origin().into(), r.direction().into(), r.tmin, r.tmax)
}

/// raytree's triangle test at obvhs's current interval end.
fn hit_t(tris: &[Triangle], r: &Ray, prim: u32, tmax: f32) -> f32 {
    tris[prim as usize]
        .intersect(r, r.tmin, tmax)
        .map_or(f32::INFINITY, |h| h.0)
}

/// The two obvhs trees, both traversed through the same two calls.
pub trait Tree: Sync {
    fn primitive_indices(&self) -> &[u32];
    fn closest<F: FnMut(&obvhs::ray::Ray, usize) -> f32>(
        &self,
        ray: obvhs::ray::Ray,
        hit: &mut RayHit,
        f: F,
    ) -> bool;
    fn misses<F: FnMut(&obvhs::ray::Ray, usize) -> f32>(&self, ray: obvhs::ray::Ray, f: F) -> bool;
}

/// Both trees name the two calls alike; one body serves them.
macro_rules! impl_tree {
    ($t:ty) => {
        impl Tree for $t {
            fn primitive_indices(&self) -> &[u32] {
                &self.primitive_indices
            }
            fn closest<F: FnMut(&obvhs::ray::Ray, usize) -> f32>(
                &self,
                ray: obvhs::ray::Ray,
                hit: &mut RayHit,
                f: F,
            ) -> bool {
                self.ray_traverse(ray, hit, f)
            }
            fn misses<F: FnMut(&obvhs::ray::Ray, usize) -> f32>(
                &self,
                ray: obvhs::ray::Ray,
                f: F,
            ) -> bool {
                self.ray_traverse_miss(ray, f)
            }
        }
    };
}

impl_tree!(Bvh2);
impl_tree!(CwBvh);

/// An obvhs tree over raytree's triangles.
pub struct Peer<T> {
    tree: T,
    tris: Arc<[Triangle]>,
}

impl<T: Tree> Contender for Peer<T> {
    fn closest(&self, r: &Ray) -> Option<f32> {
        let mut hit = RayHit::none();
        let ids = self.tree.primitive_indices();
        self.tree
            .closest(to_obvhs(r), &mut hit, |ray, i| {
                hit_t(&self.tris, r, ids[i], ray.tmax)
            })
            .then_some(hit.t)
    }
    fn occluded(&self, r: &Ray) -> bool {
        let ids = self.tree.primitive_indices();
        !self
            .tree
            .misses(to_obvhs(r), |ray, i| hit_t(&self.tris, r, ids[i], ray.tmax))
    }
}

/// obvhs's three contenders with their build times: its traversal over
/// raytree's tree (conversion time), over its own PLOC BVH2, and its CWBVH.
pub fn contenders(scene: &Scene, bvh: &Bvh) -> Vec<(String, f64, Box<dyn Contender>)> {
    let tris = triangles(scene);
    let params = BvhBuildParams::medium_build();
    let mut out: Vec<(String, f64, Box<dyn Contender>)> = Vec::new();
    let t = Instant::now();
    let same = bvh2_from(bvh);
    out.push((
        "obvhs bvh2 same tree".into(),
        t.elapsed().as_secs_f64(),
        Box::new(Peer {
            tree: same,
            tris: scene.triangles.clone(),
        }),
    ));
    let t = Instant::now();
    let ploc = obvhs::bvh2::builder::build_bvh2_from_tris(&tris, params, &mut Duration::default());
    out.push((
        "obvhs bvh2 ploc".into(),
        t.elapsed().as_secs_f64(),
        Box::new(Peer {
            tree: ploc,
            tris: scene.triangles.clone(),
        }),
    ));
    let t = Instant::now();
    let cw = obvhs::cwbvh::builder::build_cwbvh_from_tris(&tris, params, &mut Duration::default());
    out.push((
        "obvhs cwbvh".into(),
        t.elapsed().as_secs_f64(),
        Box::new(Peer {
            tree: cw,
            tris: scene.triangles.clone(),
        }),
    ));
    out
}
