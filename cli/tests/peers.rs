//! `bench peers`: the ray sets are the integrators' own rays, and every
//! contender built into this raytree traces them and answers as raytree's
//! BVH does.

use raytree::prelude::*;
use raytree::render::{render, Integrator, PathSettings};
use raytree_cli::bench::peers::{self, Options, RaySets};

#[test]
fn path_rays_are_the_path_integrators_bounce_rays() {
    let scene = Scene::builtin("chess:3000").unwrap();
    let bvh = Bvh::build(&scene.triangles, &BuildOptions::sah());
    let layout = BinaryBvh::from_bvh(&bvh, scene.triangles.clone()).unwrap();
    let (w, h) = (48, 32);
    let settings = PathSettings::default();
    let rendered = render(
        &layout,
        &scene,
        &Integrator::Path(settings.clone()),
        w,
        h,
        &|_| {},
    );
    let rays = raytree::render::rayset::path_rays(&scene, &layout, w, h, settings.bounces);
    // The integrator counts its eye rays too.
    assert_eq!(rays.len() as u64 + (w * h) as u64, rendered.counters.rays);
    assert!(!rays.is_empty());
}

#[test]
fn every_contender_answers_as_raytree_does() {
    let scene = Scene::builtin("hairball:3000").unwrap();
    let opts = Options {
        width: 64,
        height: 48,
        repeats: 1,
        build_repeats: 2,
        ..Options::quick()
    };
    let r = peers::run_scene(&scene, &opts, &|| {}).unwrap();
    for row in r.rows.iter().filter(|r| r.contender != peers::FASTEST) {
        assert!(
            row.build_s.is_finite() && row.build_s > 0.0,
            "{}: build {} s",
            row.contender,
            row.build_s
        );
    }
    let names: Vec<&str> = r
        .rows
        .iter()
        .map(|r| r.contender.as_str())
        .filter(|&n| n != peers::FASTEST)
        .collect();
    assert_eq!(names, peers::available());
    // The fastest row takes, per workload, the raytree row of least time.
    let fastest = r
        .rows
        .iter()
        .find(|r| r.contender == peers::FASTEST)
        .unwrap();
    for (w, m) in fastest.measures.iter().enumerate() {
        let least = r
            .rows
            .iter()
            .filter(|x| peers::RAYTREE.contains(&x.contender.as_str()))
            .map(|x| x.measures[w].seconds)
            .fold(f64::INFINITY, f64::min);
        assert_eq!(m.seconds, least);
        assert!(peers::RAYTREE.contains(&fastest.picked[w].as_str()));
    }
    assert!(r.configs.iter().any(|c| c.contains("SIMD path")));
    if cfg!(feature = "obvhs") {
        assert!(names.contains(&"obvhs cwbvh"));
    }
    let primary = &r.rows[0].measures[0];
    assert_eq!(primary.rays, 64 * 48);
    for row in &r.rows {
        assert_eq!(row.measures.len(), peers::WORKLOADS.len());
        // The fastest row takes its workloads from several builds.
        assert!(row.contender == peers::FASTEST || (row.build_s.is_finite() && row.build_s >= 0.0));
        for m in &row.measures {
            assert!(m.rays > 0, "{} {}", row.contender, m.workload);
            assert!(m.seconds > 0.0 && m.mrays_per_s.is_finite() && m.speed_vs_stack.is_finite());
            // Contenders sharing raytree's triangle test agree exactly;
            // Embree's own test may differ on a rare grazing ray.
            let least =
                if row.contender.starts_with("embree") || row.contender.starts_with("tinybvh") {
                    0.999
                } else {
                    1.0
                };
            assert!(
                m.agreeing >= least,
                "{} {}: {} agreeing",
                row.contender,
                m.workload,
                m.agreeing
            );
        }
    }
    let md = peers::markdown(&r);
    for name in peers::available() {
        assert!(md.contains(&format!("| {name} |")), "{md}");
    }
    assert!(md.contains(&format!("| **{}** (", peers::FASTEST)), "{md}");
    if cfg!(feature = "embree") {
        assert!(md.contains("raytree fastest vs embree high"), "{md}");
        assert!(md.contains("scene build quality HIGH"), "{md}");
    }
}

#[test]
fn ray_sets_have_the_expected_sizes() {
    let scene = Scene::builtin("chess:3000").unwrap();
    let bvh = Bvh::build(&scene.triangles, &BuildOptions::sah());
    let layout = BinaryBvh::from_bvh(&bvh, scene.triangles.clone()).unwrap();
    let o = Options {
        width: 40,
        height: 30,
        ..Options::quick()
    };
    let sets = RaySets::new(&scene, &layout, &o);
    assert_eq!(sets.primary.len(), 1200);
    let hits = sets
        .primary
        .iter()
        .filter(|r| layout.closest_hit(r, &mut NoStats).is_some())
        .count();
    assert_eq!(sets.ao.len(), hits * o.ao_per_hit as usize);
    let radius = o.ao_radius_fraction * scene.mesh.bounds().extent().length();
    assert!(sets.ao.iter().all(|r| r.tmax == radius));
}
