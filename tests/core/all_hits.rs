//! The all-hits queries (every hit along a ray, and their count) of every
//! structure and traversal equal the brute-force oracle's, hit for hit.

use crate::common;
use raytree::prelude::*;
use raytree::stats::Counters;
use raytree::structures::{Built, WithAccel};

struct Lists<'a>(&'a [Ray]);
impl WithAccel for Lists<'_> {
    type Output = (Vec<Vec<Hit>>, Vec<u32>);
    fn run<A: Accel>(self, a: &A) -> Self::Output {
        let lists = self.0.iter().map(|r| a.list_hits(r)).collect();
        let counts = self.0.iter().map(|r| a.count_hits(r)).collect();
        (lists, counts)
    }
}

#[test]
fn every_structure_lists_the_oracles_hits() {
    for spec in ["chess:2000", "hairball:2000", "atrium:2000"] {
        let scene = Scene::builtin(spec).unwrap();
        let rays = common::mixed_rays(&scene, 3000, 29);
        let oracle = BruteForce::new(scene.triangles.clone());
        let want: Vec<Vec<Hit>> = rays.iter().map(|r| oracle.list_hits(r)).collect();
        // The oracle's lists hold its closest hit first, and many rays cross
        // several surfaces.
        for (r, w) in rays.iter().zip(&want) {
            assert_eq!(w.first().copied(), oracle.closest_hit(r, &mut NoStats));
        }
        assert!(want.iter().filter(|w| w.len() >= 2).count() > rays.len() / 20);
        for builder in Builder::ALL {
            let bvh = Bvh::build(&scene.triangles, &BuildOptions::new(builder));
            for (s, t) in common::configurations() {
                let (built, _) = Built::new(s, t, &bvh, scene.triangles.clone()).unwrap();
                let (lists, counts) = built.with(Lists(&rays));
                for (i, r) in rays.iter().enumerate() {
                    assert_eq!(
                        lists[i],
                        want[i],
                        "{spec} {builder:?} {}/{}: ray {i} {r:?}",
                        s.name(),
                        t.name()
                    );
                    assert_eq!(counts[i] as usize, want[i].len());
                }
            }
        }
    }
}

#[test]
fn batches_list_and_count_hits_with_counters() {
    let scene = Scene::builtin("hairball:2000").unwrap();
    let rays = common::mixed_rays(&scene, 2000, 31);
    let bvh = Bvh::build(&scene.triangles, &BuildOptions::sah());
    let oracle = BruteForce::new(scene.triangles.clone());
    for name in [
        "bvh",
        "bvh/implicit-b",
        "bvh/laine-2",
        "dst",
        "htree",
        "cbvh",
    ] {
        let tracer = raytree::structures::tracer(name, &bvh, scene.triangles.clone()).unwrap();
        let mut counted = Counters::default();
        let lists = tracer.list_hits(&rays, Some(&mut counted));
        assert_eq!(lists.offsets.len(), rays.len() + 1);
        let mut counts = vec![0; rays.len()];
        let mut counted_too = Counters::default();
        tracer
            .count_hits(&rays, &mut counts, Some(&mut counted_too))
            .unwrap();
        assert_eq!(counted.rays, rays.len() as u64);
        assert_eq!(counted, counted_too, "{name}: same work for both queries");
        assert!(counted.triangles > 0);
        for (i, r) in rays.iter().enumerate() {
            assert_eq!(
                lists.of(i),
                oracle.list_hits(r).as_slice(),
                "{name}: ray {i}"
            );
            assert_eq!(counts[i] as usize, lists.of(i).len());
        }
        assert!(tracer.count_hits(&rays, &mut counts[1..], None).is_err());
    }
}
