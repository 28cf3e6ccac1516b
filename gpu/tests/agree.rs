//! Every GPU kernel against the CPU's traversal of the same structure, ray
//! for ray: the same closest-hit triangle (t within a relative 1e-6), the
//! same any-hit answer and the same counters, on the oracle's mixed ray
//! kinds (tests/core/common.rs) over built-in scenes and shared meshes.
//!
//! Without an adapter the tests print why and pass, unless
//! `RAYTREE_REQUIRE_GPU` is set (CI sets it; lavapipe is installed there).

#[path = "../../tests/core/common.rs"]
mod common;

use raytree::prelude::*;
use raytree::stats::Tally;
use raytree::structures::{Built, SparseBvh, StructureKind, TraversalKind, WithAccel};
use raytree_gpu::{Gpu, GpuAccel, Query, REQUIRE_GPU_ENV};
use std::sync::Arc;
use std::sync::OnceLock;

/// The adapter, opened once for all tests (None: skip).
fn gpu() -> Option<&'static Gpu> {
    static GPU: OnceLock<Option<Gpu>> = OnceLock::new();
    GPU.get_or_init(|| match Gpu::new() {
        Ok(g) => {
            eprintln!("GPU tests on {}", g.describe());
            Some(g)
        }
        Err(e) => {
            if std::env::var_os(REQUIRE_GPU_ENV).is_some() {
                panic!("{e}, and {REQUIRE_GPU_ENV} is set");
            }
            eprintln!("skipping the GPU tests: {e}");
            None
        }
    })
    .as_ref()
}

/// The CPU's answers and per-ray counters.
struct Cpu<'a>(&'a [Ray], bool);

impl WithAccel for Cpu<'_> {
    type Output = Vec<(Option<Hit>, Tally)>;
    fn run<A: Accel>(self, a: &A) -> Self::Output {
        self.0
            .iter()
            .map(|r| {
                let mut c = Counters::default();
                let h = if self.1 {
                    a.any_hit(r, &mut c)
                } else {
                    a.closest_hit(r, &mut c)
                };
                let tally = Tally {
                    nodes: c.nodes as u32,
                    planes: c.planes as u32,
                    triangles: c.triangles as u32,
                };
                (h, tally)
            })
            .collect()
    }
}

/// The traversals over the sparse layout with GPU kernels.
const ON_SPARSE: &[TraversalKind] = &[
    TraversalKind::Stack,
    TraversalKind::Sparse,
    TraversalKind::Hapala,
    TraversalKind::Laine0,
    TraversalKind::Laine1,
    TraversalKind::Laine2,
    TraversalKind::Laine4,
    TraversalKind::Laine8,
];

/// Checks every kernel on `scene` with `n` mixed rays, over both builders.
fn check_scene(gpu: &Gpu, scene: &Scene, n: usize) {
    let rays = common::mixed_rays(scene, n, 11);
    for builder in [Builder::Sah, Builder::Hybrid] {
        let bvh = Bvh::build(&scene.triangles, &BuildOptions::new(builder));
        let tris = scene.triangles.clone();
        let what = |t: &str| format!("{} {t}/{}", scene.name, builder.name());
        let (binary, _) =
            Built::new(StructureKind::Bvh, TraversalKind::Stack, &bvh, tris.clone()).unwrap();
        check(gpu, &binary, &rays, &what("stack-binary"));
        if builder == Builder::Hybrid {
            // IMPLICIT-B over the hybrid builder's implicit layout, as the paper.
            let (implicit, _) = Built::new(
                StructureKind::Bvh,
                TraversalKind::ImplicitB,
                &bvh,
                tris.clone(),
            )
            .unwrap();
            check(gpu, &implicit, &rays, &what("implicit-b"));
        }
        for kind in [
            StructureKind::Dst,
            StructureKind::DstSimilar,
            StructureKind::Bvh4,
            StructureKind::Bvh8,
        ] {
            let (dst, _) = Built::new(kind, TraversalKind::Stack, &bvh, tris.clone()).unwrap();
            check(gpu, &dst, &rays, &what(kind.name()));
        }
        let sparse = Arc::new(SparseBvh::from_bvh(&bvh, tris).unwrap());
        for &t in ON_SPARSE {
            let built = Built::sparse(t, sparse.clone()).unwrap();
            check(gpu, &built, &rays, &what(&format!("{}-sparse", t.name())));
        }
    }
}

fn check(gpu: &Gpu, built: &Built, rays: &[Ray], what: &str) {
    let accel = GpuAccel::new(gpu, built).unwrap();
    for any in [false, true] {
        let query = if any { Query::Any } else { Query::Closest };
        let got = accel.trace(rays, query).unwrap();
        let want = built.with(Cpu(rays, any));
        let mut bad = Vec::new();
        for (i, (g, (w, wt))) in got.answers.iter().zip(&want).enumerate() {
            let same_hit = match (g.hit, *w) {
                (None, None) => true,
                (Some(g), Some(w)) => {
                    g.prim == w.prim && (any || (g.t - w.t).abs() <= 1e-6 * w.t.abs())
                }
                _ => false,
            };
            if !same_hit || g.tally != *wt {
                bad.push(format!(
                    "ray {i} {:?}: GPU {:?} {:?}, CPU {w:?} {wt:?}",
                    rays[i], g.hit, g.tally
                ));
            }
        }
        // Deferred rays by kind (common::mixed_rays: kind i % 7).
        let mut by_kind = [0usize; 7];
        for (i, a) in got.answers.iter().enumerate() {
            by_kind[i % 7] += a.deferred as usize;
        }
        eprintln!(
            "{what} {}: {} rays, {} deferred to the CPU (by ray kind {by_kind:?}), {} disagree",
            if any { "any" } else { "closest" },
            rays.len(),
            got.deferred,
            bad.len()
        );
        assert!(
            bad.is_empty(),
            "{what} {query:?}: {} of {} rays disagree; first: {}",
            bad.len(),
            rays.len(),
            bad[0]
        );
        // Deferral is for the rare rays f32 cannot decide, not a way out.
        assert!(
            got.deferred * 5 <= rays.len(),
            "{what}: {} of {} rays deferred",
            got.deferred,
            rays.len()
        );
    }
}

#[test]
fn builtin_scenes_agree_with_the_cpu() {
    let Some(gpu) = gpu() else { return };
    for spec in ["chess:2000", "hairball:3000", "atrium:6000"] {
        check_scene(gpu, &Scene::builtin(spec).unwrap(), 3000);
    }
}

#[test]
fn shared_meshes_agree_with_the_cpu() {
    let Some(gpu) = gpu() else { return };
    for name in ["teapot.obj", "bunny.obj"] {
        // The workspace's ../shared/scenes, as the core tests read it.
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("../../shared/scenes")
            .join(name);
        match path.exists().then_some(path) {
            Some(p) => check_scene(gpu, &Scene::load(p).unwrap(), 3000),
            None => eprintln!("skipping {name}: ../shared/scenes is not present"),
        }
    }
}
