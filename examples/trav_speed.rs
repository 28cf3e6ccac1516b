//! Times every BVH traversal on fixed eye and AO ray sets of a built-in scene,
//! one thread, no counting: `cargo run --release --example trav_speed -- chess [algorithm]`.

use raytree::prelude::*;
use raytree::render::rayset;
use raytree::structures::{Built, SparseBvh, StructureKind, TraversalKind, WithAccel};
use std::sync::Arc;
use std::time::Instant;

struct Time<'a>(&'a [Ray], bool);
impl WithAccel for Time<'_> {
    type Output = (f64, usize);
    // Not inlined: callgrind's `--toggle-collect='*Time*run*'` names it.
    #[inline(never)]
    fn run<A: Accel>(self, a: &A) -> (f64, usize) {
        let t = Instant::now();
        let mut n = 0;
        for _ in 0..3 {
            for r in self.0 {
                let h = if self.1 {
                    a.any_hit(r, &mut NoStats)
                } else {
                    a.closest_hit(r, &mut NoStats)
                };
                n += h.is_some() as usize;
            }
        }
        (t.elapsed().as_secs_f64(), n)
    }
}

fn main() {
    let spec = std::env::args().nth(1).unwrap_or("chess".into());
    let scene = Scene::builtin(&spec).unwrap();
    let bvh = Bvh::build(&scene.triangles, &BuildOptions::hybrid());
    let b = BinaryBvh::from_bvh(&bvh, scene.triangles.clone()).unwrap();
    let eye = rayset::eye_rays(&scene, 400, 150, 1);
    let ao = rayset::ao_rays(
        &scene,
        &b,
        &eye,
        8,
        0.045 * scene.mesh.bounds().extent().length(),
    );
    let sp = Arc::new(SparseBvh::from_bvh(&bvh, scene.triangles.clone()).unwrap());
    let only = std::env::args().nth(2);
    for (name, t, s) in [
        ("stack", TraversalKind::Stack, false),
        ("stack-sparse", TraversalKind::Stack, true),
        ("sparse", TraversalKind::Sparse, true),
        ("implicit-a", TraversalKind::ImplicitA, false),
        ("implicit-b", TraversalKind::ImplicitB, false),
        ("laine-0", TraversalKind::Laine0, true),
        ("laine-2", TraversalKind::Laine2, true),
        ("laine-8", TraversalKind::Laine8, true),
        ("hapala", TraversalKind::Hapala, true),
        ("bvh4", TraversalKind::Stack, false),
        ("bvh8", TraversalKind::Stack, false),
        ("cwbvh", TraversalKind::Stack, false),
    ] {
        if only.as_deref().is_some_and(|o| o != name) {
            continue;
        }
        let structure = match name {
            "bvh4" => StructureKind::Bvh4,
            "bvh8" => StructureKind::Bvh8,
            "cwbvh" => StructureKind::Cwbvh,
            _ => StructureKind::Bvh,
        };
        let built = if s {
            Built::sparse(t, sp.clone()).unwrap()
        } else {
            Built::new(structure, t, &bvh, scene.triangles.clone())
                .unwrap()
                .0
        };
        let (te, _) = built.with(Time(&eye, false));
        let (ta, _) = built.with(Time(&ao, true));
        let (tc, _) = built.with(Time(&ao, false));
        println!(
            "{name:14} eye {:.3}  ao-any {:.3}  ao-closest {:.3}",
            te, ta, tc
        );
    }
}
