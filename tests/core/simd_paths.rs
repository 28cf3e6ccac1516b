//! Every SIMD path this processor has runs the wide kernels (`bvh4`, `bvh8`,
//! `cwbvh`) to the oracle's answers, and to the portable path's node
//! sequence and statistics ray for ray: the paths differ in instruction
//! width only. The closest hit with its triangle read from the leaf
//! (`closest_hit_triangle`, the kernel's `LOCATE` form) is checked on every
//! path too: the same hit, the mesh's triangle, the same visits.

use crate::common;

use rayon::prelude::*;
use raytree::prelude::*;
use raytree::stats::VisitLog;
use raytree::structures::{simd, Bvh4, Bvh8, CwBvh, SimdPath};

/// A wide structure traced on a chosen path.
trait OnPath: Sync {
    fn on(&self, path: SimdPath, ray: &Ray, any: bool, log: &mut VisitLog) -> Option<Hit>;
    fn located(&self, path: SimdPath, ray: &Ray, log: &mut VisitLog) -> Option<(Hit, Triangle)>;
}

impl<const W: usize> OnPath for raytree::structures::WideBvh<W> {
    fn on(&self, path: SimdPath, ray: &Ray, any: bool, log: &mut VisitLog) -> Option<Hit> {
        self.trace_on(path, ray, any, log).unwrap()
    }
    fn located(&self, path: SimdPath, ray: &Ray, log: &mut VisitLog) -> Option<(Hit, Triangle)> {
        self.closest_hit_triangle_on(path, ray, log).unwrap()
    }
}

impl OnPath for CwBvh {
    fn on(&self, path: SimdPath, ray: &Ray, any: bool, log: &mut VisitLog) -> Option<Hit> {
        self.trace_on(path, ray, any, log).unwrap()
    }
    fn located(&self, path: SimdPath, ray: &Ray, log: &mut VisitLog) -> Option<(Hit, Triangle)> {
        self.closest_hit_triangle_on(path, ray, log).unwrap()
    }
}

fn check(
    name: &str,
    s: &dyn OnPath,
    triangles: &[Triangle],
    oracle: &BruteForce,
    rays: &[Ray],
    want: &[Option<Hit>],
) {
    let paths = simd::supported();
    let bad: Vec<String> = rays
        .par_iter()
        .enumerate()
        .filter_map(|(i, r)| {
            for any in [false, true] {
                let mut first: Option<(Option<Hit>, VisitLog)> = None;
                for &p in &paths {
                    let mut log = VisitLog::default();
                    let got = s.on(p, r, any, &mut log);
                    if !any && !common::same_closest(got, want[i], oracle, r) {
                        return Some(format!("{p}: ray {i} closest {got:?}, oracle {:?}", want[i]));
                    }
                    if any && got.is_some() != want[i].is_some() {
                        return Some(format!("{p}: ray {i} any {got:?}, oracle {:?}", want[i]));
                    }
                    if !any {
                        // The located form: the same hit and visits, and the
                        // hit's triangle as the mesh holds it.
                        let mut located_log = VisitLog::default();
                        let located = s.located(p, r, &mut located_log);
                        if located.map(|(h, _)| h) != got
                            || located_log.visits != log.visits
                            || located_log.counters != log.counters
                        {
                            return Some(format!(
                                "{p}: ray {i} closest_hit_triangle {located:?}, closest {got:?}"
                            ));
                        }
                        if let Some((h, t)) = located {
                            if t != triangles[h.prim as usize] {
                                return Some(format!(
                                    "{p}: ray {i} leaf triangle {t:?}, mesh {:?}",
                                    triangles[h.prim as usize]
                                ));
                            }
                        }
                    }
                    match &first {
                        None => first = Some((got, log)),
                        Some((h, l)) => {
                            if *h != got || l.visits != log.visits || l.counters != log.counters {
                                return Some(format!(
                                    "{p}: ray {i} (any {any}) differs from the portable path: {got:?} after {} visits, portable {h:?} after {}",
                                    log.visits.len(),
                                    l.visits.len()
                                ));
                            }
                        }
                    }
                }
            }
            None
        })
        .collect();
    assert!(
        bad.is_empty(),
        "{name}: {} of {} rays wrong on some path ({:?}); first: {}",
        bad.len(),
        rays.len(),
        paths,
        bad[0]
    );
}

#[test]
fn every_simd_path_gives_the_oracles_answers_and_the_same_visits() {
    assert!(simd::supported().contains(&SimdPath::Portable));
    for spec in ["chess:20000", "hairball:10000", "atrium:10000"] {
        let scene = Scene::builtin(spec).unwrap();
        let rays = common::mixed_rays(&scene, 6000, 11);
        let oracle = BruteForce::new(scene.triangles.clone());
        let want: Vec<Option<Hit>> = rays
            .par_iter()
            .map(|r| oracle.closest_hit(r, &mut NoStats))
            .collect();
        for builder in [Builder::Sah, Builder::Sbvh] {
            let bvh = Bvh::build(&scene.triangles, &BuildOptions::new(builder));
            let t = || scene.triangles.clone();
            check(
                &format!("{spec} {builder:?} bvh4"),
                &Bvh4::from_bvh(&bvh, t()).unwrap(),
                &scene.triangles,
                &oracle,
                &rays,
                &want,
            );
            check(
                &format!("{spec} {builder:?} bvh8"),
                &Bvh8::from_bvh(&bvh, t()).unwrap(),
                &scene.triangles,
                &oracle,
                &rays,
                &want,
            );
            check(
                &format!("{spec} {builder:?} cwbvh"),
                &CwBvh::from_bvh(&bvh, t()).unwrap(),
                &scene.triangles,
                &oracle,
                &rays,
                &want,
            );
        }
    }
}

#[test]
fn a_path_this_processor_lacks_is_refused() {
    let scene = Scene::builtin("chess:1000").unwrap();
    let bvh = Bvh::build(&scene.triangles, &BuildOptions::sah());
    let b8 = Bvh8::from_bvh(&bvh, scene.triangles.clone()).unwrap();
    let rays = common::mixed_rays(&scene, 1, 3);
    let r = rays[0];
    for p in SimdPath::ALL {
        let got = b8.trace_on(p, &r, false, &mut NoStats);
        assert_eq!(got.is_ok(), p.supported(), "{p}");
        if !p.supported() {
            assert!(simd::set_active(p).is_err());
        }
    }
}
