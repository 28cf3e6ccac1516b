//! The sparse layout as the stackless paper's own tracer stores it (its
//! supplemental `bvh.h`: `Node { kind, parent, first, last, Aabb left,
//! right }`, 64 bytes in a 64-byte aligned array): the same slots, sibling
//! pairs and parent links as [`SparseBvh`], but each node holds its two
//! children's boxes ([`ChildBoxNode`]), so that a step reads one cache line
//! instead of a node and then its children's pair.
//!
//! STACK, SPARSE and LAINE-k run over it unchanged ([`super::SparseLayout`])
//! and visit exactly the nodes they visit over the own-box nodes, in the
//! same order. The original's `kind` and `last` words are not needed here
//! (the leaf bit and sibling adjacency say them); their 8 bytes hold skip
//! links to the ancestors 2 and 4 levels up, which SPARSE's ascent follows
//! instead of single parent links: the same ancestor, fewer dependent
//! loads. SPARSE's ratio to STACK on these nodes, one thread, `examples/
//! paper_speed <scene> stack-paired,sparse-paired`, builds alternated: on
//! the `hairball` preset's rays 1.125/1.148/1.132 with parent links alone,
//! 1.099/1.094/1.025 with both skip links (the 2-level link alone gave most of
//! the gain); on battlefield's matched paper workload 1.086/1.093
//! against 1.056/0.991. It is derived from a [`SparseBvh`], whose leaf blocks,
//! triangles and ids it shares; a saved file holds that layout's arrays
//! and derives the 64-byte nodes again when loaded.

use super::{SparseBvh, SparseLayout, PARENT_MASK};
use crate::geometry::Ray;
use crate::stats::Stats;
use crate::structures::shared::own_box::{ChildBoxNode, Walk};
use std::sync::Arc;

/// The sparse layout in 64-byte nodes that hold their children's boxes
/// (see the module docs).
#[derive(Clone, Debug)]
pub struct PairedBvh {
    nodes: Vec<ChildBoxNode>,
    /// The root's own box (`[min xyz, max xyz]`), which no node holds.
    root: [f32; 6],
    sparse: Arc<SparseBvh>,
}

impl PairedBvh {
    /// The 64-byte nodes of `sparse`'s slots: each inner node's record
    /// holds its children's boxes per axis, `[lo_left, lo_right, hi_left,
    /// hi_right]`; links and parent words are `sparse`'s.
    pub fn from_sparse(sparse: Arc<SparseBvh>) -> Self {
        let own = &sparse.nodes;
        // One record per slot, asked onto huge pages before it is written.
        let mut nodes: Vec<ChildBoxNode> = crate::pages::vec_with_capacity(own.len());
        nodes.extend(own.iter().map(|n| {
            let mut planes = [0.0; 12];
            if !n.is_leaf() {
                let (l, r) = (&own[n.target() as usize], &own[n.target() as usize + 1]);
                for a in 0..3 {
                    planes[4 * a..4 * a + 4].copy_from_slice(&[
                        l.bounds[a],
                        r.bounds[a],
                        l.bounds[a + 3],
                        r.bounds[a + 3],
                    ]);
                }
            }
            ChildBoxNode {
                planes,
                link: n.link,
                extra: n.extra,
                skip: [0; 2],
            }
        }));
        // The ancestor `k` levels above `n`, or 0 (the root) where the root
        // comes first: an ascent never goes past the root, so such a link
        // is never followed.
        let above = |mut a: u32, k: u32| {
            for _ in 0..k {
                if a == 0 {
                    return 0;
                }
                a = own[a as usize].extra & PARENT_MASK;
            }
            a
        };
        for (n, node) in nodes.iter_mut().enumerate().skip(1) {
            node.skip = [above(n as u32, 2), above(n as u32, 4)];
        }
        crate::pages::advise(&nodes);
        PairedBvh {
            nodes,
            root: own[0].bounds,
            sparse,
        }
    }

    /// The own-box layout it was derived from (leaf blocks, triangles, ids).
    pub fn sparse_arc(&self) -> &Arc<SparseBvh> {
        &self.sparse
    }

    /// The nodes, as the traversals read them (root at slot 0).
    pub fn nodes(&self) -> &[ChildBoxNode] {
        &self.nodes
    }
}

impl SparseLayout for PairedBvh {
    type Node = ChildBoxNode;
    #[inline(always)]
    fn sparse(&self) -> &SparseBvh {
        &self.sparse
    }
    #[inline(always)]
    fn walk<'a, const ANY: bool, S: Stats>(
        &'a self,
        ray: &'a Ray,
        stats: &mut S,
    ) -> Option<Walk<'a, ANY, ChildBoxNode>> {
        Walk::enter(
            ray,
            &self.nodes,
            &self.root,
            &self.sparse.blocks,
            &self.sparse.triangles,
            stats,
        )
    }
    #[inline(always)]
    fn parent(&self, n: u32) -> u32 {
        self.nodes[n as usize].extra & PARENT_MASK
    }
    /// Up the skip links: 4 levels at a time, then 2, then 1.
    #[inline(always)]
    fn ancestor(&self, mut n: u32, mut up: u32) -> u32 {
        while up >= 4 {
            n = self.nodes[n as usize].skip[1];
            up -= 4;
        }
        if up >= 2 {
            n = self.nodes[n as usize].skip[0];
            up -= 2;
        }
        if up == 1 {
            n = self.parent(n);
        }
        n
    }
    /// 64 bytes per node.
    fn node_bytes(&self) -> usize {
        std::mem::size_of_val(&self.nodes[..])
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bvh::{BuildOptions, Bvh};
    use crate::geometry::Aabb;
    use crate::scene::Scene;
    use crate::stats::VisitLog;
    use crate::structures::sparse::{Laine, OnSparse, Sparse, StackOnSparse};
    use crate::structures::Accel;

    fn layouts() -> (Scene, Arc<SparseBvh>, Arc<PairedBvh>) {
        let scene = Scene::builtin("chess:4000").unwrap();
        let bvh = Bvh::build(&scene.triangles, &BuildOptions::hybrid());
        let sp = Arc::new(SparseBvh::from_bvh(&bvh, scene.triangles.clone()).unwrap());
        let pa = Arc::new(PairedBvh::from_sparse(sp.clone()));
        (scene, sp, pa)
    }

    /// Every inner record holds exactly its children's own boxes, links
    /// and parents are the own-box layout's, and a node is 64 bytes.
    #[test]
    fn records_hold_the_childrens_boxes() {
        let (_, sp, pa) = layouts();
        assert_eq!(pa.node_bytes(), 64 * sp.node_count());
        for (i, (p, o)) in pa.nodes.iter().zip(&sp.nodes).enumerate() {
            assert_eq!((p.link, p.extra), (o.link, o.extra));
            if i > 0 {
                assert_eq!(pa.parent(i as u32), sp.parent(i as u32));
            }
            if o.is_leaf() {
                assert_eq!(p.planes, [0.0; 12]);
                continue;
            }
            let l = o.target() as usize;
            for (k, child) in [l, l + 1].into_iter().enumerate() {
                let b: Vec<f32> = (0..6)
                    .map(|j| p.planes[4 * (j % 3) + 2 * (j / 3) + k])
                    .collect();
                assert_eq!(Aabb::from_array(&b.try_into().unwrap()), {
                    Aabb::from_array(&sp.nodes[child].bounds)
                });
            }
        }
    }

    /// The skip links reach the ancestor that as many parent links reach,
    /// for every node and every ascent that stays in the tree.
    #[test]
    fn skip_links_reach_the_parent_links_ancestor() {
        for spec in ["chess:4000", "hairball:3000"] {
            let scene = Scene::builtin(spec).unwrap();
            let bvh = Bvh::build(&scene.triangles, &BuildOptions::hybrid());
            let sp = Arc::new(SparseBvh::from_bvh(&bvh, scene.triangles.clone()).unwrap());
            let pa = PairedBvh::from_sparse(sp.clone());
            let mut deepest = 0;
            for n in 1..sp.node_count() as u32 {
                let (mut a, mut up) = (n, 0);
                while a != 0 {
                    a = sp.parent(a);
                    up += 1;
                    assert_eq!(pa.ancestor(n, up), a, "{spec}: node {n}, {up} up");
                }
                deepest = deepest.max(up);
            }
            assert!(deepest >= 10, "{spec}: depth {deepest}");
        }
    }

    /// STACK, SPARSE and LAINE-k over the 64-byte nodes visit the nodes they
    /// visit over the own-box nodes, in the same order, and find the same
    /// hits.
    #[test]
    fn visits_and_hits_equal_the_own_box_layouts() {
        let (scene, sp, pa) = layouts();
        let eye = crate::render::rayset::eye_rays(&scene, 24, 16, 1);
        let b = Bvh::build(&scene.triangles, &BuildOptions::hybrid());
        let bin = crate::structures::BinaryBvh::from_bvh(&b, scene.triangles.clone()).unwrap();
        let ao = crate::render::rayset::ao_rays(&scene, &bin, &eye, 4, 30.0);
        fn check<
            A: crate::structures::sparse::SparseAlgorithm<SparseBvh>
                + crate::structures::sparse::SparseAlgorithm<PairedBvh>,
        >(
            sp: &Arc<SparseBvh>,
            pa: &Arc<PairedBvh>,
            rays: &[Ray],
        ) -> usize {
            let (a, b) = (
                OnSparse::<A, SparseBvh>::new(sp.clone()).unwrap(),
                OnSparse::<A, PairedBvh>::new(pa.clone()).unwrap(),
            );
            let mut hits = 0;
            for r in rays {
                for any in [false, true] {
                    let (mut la, mut lb) = (VisitLog::default(), VisitLog::default());
                    let (ha, hb) = if any {
                        (a.any_hit(r, &mut la), b.any_hit(r, &mut lb))
                    } else {
                        (a.closest_hit(r, &mut la), b.closest_hit(r, &mut lb))
                    };
                    assert_eq!(ha, hb);
                    assert_eq!(la.visits, lb.visits);
                    hits += ha.is_some() as usize;
                }
            }
            hits
        }
        let rays: Vec<Ray> = eye.iter().chain(&ao).copied().collect();
        for hits in [
            check::<StackOnSparse>(&sp, &pa, &rays),
            check::<Sparse>(&sp, &pa, &rays),
            check::<Laine<0>>(&sp, &pa, &rays),
            check::<Laine<2>>(&sp, &pa, &rays),
        ] {
            assert!(hits > rays.len() / 4, "{hits} hits of {}", 2 * rays.len());
        }
    }
}
