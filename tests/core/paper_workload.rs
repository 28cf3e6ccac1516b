//! The stackless paper's workload as its tracer ran it (issue 26): its
//! camera, its stratified eye jitter, its closest-hit AO rays; and every
//! traversal still rendering the same image in that form.

use crate::common;

use rayon::prelude::*;
use raytree::prelude::*;
use raytree::render::{rayset, AoQuery, AoSettings, Image, Integrator, Sampling, PAPER_TMIN};
use raytree::scene::Fov;
use raytree::structures::{Built, WithAccel};

type D3 = [f64; 3];

fn sub(a: D3, b: D3) -> D3 {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}
fn add(a: D3, b: D3) -> D3 {
    [a[0] + b[0], a[1] + b[1], a[2] + b[2]]
}
fn mul(a: D3, s: f64) -> D3 {
    [a[0] * s, a[1] * s, a[2] * s]
}
fn dot(a: D3, b: D3) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}
fn cross(a: D3, b: D3) -> D3 {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}
fn normalize(a: D3) -> D3 {
    mul(a, 1.0 / dot(a, a).sqrt())
}
fn d3(v: Vec3) -> D3 {
    [v.x as f64, v.y as f64, v.z as f64]
}

/// The stackless paper's tracer's camera (`Camera::lookAt` and
/// `generateRay` of its supplemental code), in f64: the ray direction for
/// pixel coordinates (`px`, `py`) in `[0, w)×[0, h)`, `py` down.
struct Original {
    view: D3,
    right: D3,
    up: D3,
    // Kept for the tests' own checks.
    forward: D3,
    cam_right: D3,
    cam_up: D3,
    ex: f64,
    ey: f64,
}

impl Original {
    fn look_at(eye: D3, target: D3, up: D3, fov: f64, w: f64, h: f64) -> Self {
        let forward = normalize(sub(target, eye));
        let right = normalize(cross(forward, up));
        let cam_up = cross(right, forward);
        let ex = (0.5 * fov).to_radians().tan();
        let ey = (0.5 * fov * (h / w)).to_radians().tan();
        Original {
            view: add(sub(forward, mul(right, ex)), mul(cam_up, ey)),
            right: mul(right, 2.0 / w * ex),
            up: mul(cam_up, -2.0 / h * ey),
            forward,
            cam_right: right,
            cam_up,
            ex,
            ey,
        }
    }

    fn direction(&self, px: f64, py: f64) -> D3 {
        normalize(add(add(self.view, mul(self.right, px)), mul(self.up, py)))
    }

    /// Pixel coordinates of a direction: where it crosses the image plane.
    fn pixel(&self, d: D3, w: f64, h: f64) -> (f64, f64) {
        let f = dot(d, self.forward);
        let x = dot(d, self.cam_right) / f / self.ex;
        let y = dot(d, self.cam_up) / f / self.ey;
        ((x + 1.0) * 0.5 * w, (1.0 - y) * 0.5 * h)
    }
}

fn paper_original() -> Original {
    Original::look_at(
        [300.0, 100.0, 300.0],
        [0.0, 10.0, 0.0],
        [0.0, 1.0, 0.0],
        50.0,
        800.0,
        300.0,
    )
}

#[test]
fn the_paper_camera_gives_the_original_tracers_directions() {
    let cam = Camera::stackless_chess();
    assert_eq!(cam.fov, Fov::Paper(50.0));
    let orig = paper_original();
    let (w, h) = (800.0f64, 300.0f64);
    let mut rng = raytree::rng::Pcg32::new(26, 1);
    let mut samples: Vec<(f64, f64)> = vec![
        (0.0, 0.0),
        (800.0, 0.0),
        (0.0, 300.0),
        (800.0, 300.0),
        (400.0, 150.0),
        (0.5, 0.5),
        (799.5, 299.5),
        (123.25, 77.75),
    ];
    for _ in 0..2000 {
        samples.push((
            (rng.next_f32() * 800.0) as f64,
            (rng.next_f32() * 300.0) as f64,
        ));
    }
    for (px, py) in samples {
        let want = orig.direction(px, py);
        let got = cam
            .ray((px / w) as f32, (py / h) as f32, (w / h) as f32)
            .direction();
        assert!((d3(got).iter().map(|c| c * c).sum::<f64>() - 1.0).abs() < 1e-6);
        let err = sub(d3(got), want)
            .iter()
            .fold(0.0f64, |m, c| m.max(c.abs()));
        assert!(err < 1e-6, "pixel ({px}, {py}): {got} against {want:?}");
    }

    // The view the paper's numbers say: 50° across the middle row, 18.75°
    // down the middle column (non-square pixels), not the 102° across of a
    // vertical 50°.
    let angle = |a: Vec3, b: Vec3| a.dot(b).clamp(-1.0, 1.0).acos().to_degrees();
    let d = |x: f32, y: f32| cam.ray(x, y, 800.0 / 300.0).direction();
    assert!((angle(d(0.0, 0.5), d(1.0, 0.5)) - 50.0).abs() < 1e-3);
    assert!((angle(d(0.5, 0.0), d(0.5, 1.0)) - 18.75).abs() < 1e-3);
    let old = Camera::new(cam.eye, cam.target, cam.up, 50.0);
    let od = |x: f32, y: f32| old.ray(x, y, 800.0 / 300.0).direction();
    assert!(angle(od(0.0, 0.5), od(1.0, 0.5)) > 100.0);
}

#[test]
fn horizontal_and_vertical_angles_mean_what_they_say() {
    let eye = Vec3::new(1.0, 2.0, 9.0);
    let angle = |a: Vec3, b: Vec3| a.dot(b).clamp(-1.0, 1.0).acos().to_degrees();
    for aspect in [0.4f32, 1.0, 8.0 / 3.0] {
        for a in [10.0f32, 50.0, 120.0] {
            let mut c = Camera::new(eye, Vec3::ZERO, Vec3::Y, a);
            let d = |c: &Camera, x, y| c.ray(x, y, aspect).direction();
            assert!((angle(d(&c, 0.5, 0.0), d(&c, 0.5, 1.0)) - a).abs() < 1e-2);
            c.fov = Fov::Horizontal(a);
            assert!((angle(d(&c, 0.0, 0.5), d(&c, 1.0, 0.5)) - a).abs() < 1e-2);
            // Square pixels: a pixel's step is the same across and down.
            let (ex, ey) = c.fov.extents(aspect);
            assert!((ex / aspect - ey).abs() < 1e-5 * ey);
        }
    }
    // Angles that are no angle of a camera.
    for a in [0.0, 180.0, f32::NAN, f32::INFINITY, -5.0] {
        assert!(!Fov::Horizontal(a).is_valid(1.0), "{a}");
        assert!(!Fov::Vertical(a).is_valid(1.0), "{a}");
    }
    // The paper's angle scaled by a tall image's height/width passes 180°.
    assert!(Fov::Paper(50.0).is_valid(800.0 / 300.0));
    assert!(!Fov::Paper(50.0).is_valid(1.0 / 8.0));
}

#[test]
fn the_paper_view_is_given_to_its_chess_scenes() {
    let mut chess = Scene::builtin("chess:3000").unwrap();
    assert!(chess.is_stackless_chess());
    // The default view stays the vertical 50°, so that images are unchanged.
    assert_eq!(chess.camera.fov, Fov::Vertical(50.0));
    assert!(chess.use_stackless_view());
    assert_eq!(chess.camera, Camera::stackless_chess());
    let mut hair = Scene::builtin("hairball:2000").unwrap();
    let before = hair.camera;
    assert!(!hair.use_stackless_view());
    assert_eq!(hair.camera, before);
    if let Some(p) = common::shared_scene("battlefield.obj") {
        let mut s = Scene::load(&p).unwrap();
        assert!(s.use_stackless_view());
        assert_eq!(s.camera, Camera::stackless_chess());
    }
}

/// Every pixel's 16 eye rays, as the integrator traces them in the paper's
/// form, lie one in each cell of the pixel's 4×4 grid; in any other square
/// count k² one in each cell of k×k.
#[test]
fn stratified_eye_rays_fill_every_cell_of_every_pixel_once() {
    let mut scene = Scene::builtin("chess:3000").unwrap();
    scene.use_stackless_view();
    let bvh = Bvh::build(&scene.triangles, &BuildOptions::sah());
    let accel = BinaryBvh::from_bvh(&bvh, scene.triangles.clone()).unwrap();
    let (w, h) = (40usize, 15usize);
    let orig = Original::look_at(
        [300.0, 100.0, 300.0],
        [0.0, 10.0, 0.0],
        [0.0, 1.0, 0.0],
        50.0,
        w as f64,
        h as f64,
    );
    for n in [16u32, 4, 9] {
        let k = n.isqrt() as usize;
        let s = AoSettings {
            eye_rays: n,
            ao_rays: 0,
            ..AoSettings::paper(32.0)
        };
        let (eye, _) = rayset::ao_workload(&scene, &accel, &s, w, h);
        assert_eq!(eye.len(), w * h * n as usize);
        for (p, rays) in eye.chunks(n as usize).enumerate() {
            let (x, y) = (p % w, p / w);
            let mut cells = vec![0u32; k * k];
            for (ray, _) in rays {
                assert_eq!(ray.tmin, PAPER_TMIN);
                let (px, py) = orig.pixel(d3(ray.direction()), w as f64, h as f64);
                // Well inside the pixel and the cell, or the rounding of f32
                // directions could blur the count.
                let (fx, fy) = ((px - x as f64) * k as f64, (py - y as f64) * k as f64);
                assert!(
                    fx > -1e-3 && fx < k as f64 + 1e-3 && fy > -1e-3 && fy < k as f64 + 1e-3,
                    "pixel ({x}, {y}): sample at ({px}, {py})"
                );
                let (cx, cy) = (
                    (fx.clamp(0.0, k as f64 - 1e-9)) as usize,
                    (fy.clamp(0.0, k as f64 - 1e-9)) as usize,
                );
                cells[cy * k + cx] += 1;
            }
            assert!(
                cells.iter().all(|&c| c == 1),
                "n {n}, pixel ({x}, {y}): {cells:?}"
            );
        }
    }
    // Independent jitter does not stratify: some pixel has two of its 16
    // samples in one cell.
    let s = AoSettings {
        eye_rays: 16,
        ao_rays: 0,
        sampling: Sampling::Independent,
        ..AoSettings::paper(32.0)
    };
    let (eye, _) = rayset::ao_workload(&scene, &accel, &s, w, h);
    let clumped = eye.chunks(16).enumerate().any(|(p, rays)| {
        let mut cells = [0u32; 16];
        for (ray, _) in rays {
            let (px, py) = orig.pixel(d3(ray.direction()), w as f64, h as f64);
            let cx = (((px - (p % w) as f64) * 4.0) as usize).min(3);
            let cy = (((py - (p / w) as f64) * 4.0) as usize).min(3);
            cells[cy * 4 + cx] += 1;
        }
        cells.iter().any(|&c| c > 1)
    });
    assert!(clumped);
}

/// The paper's AO rays on the paper's view of chess, found by every
/// structure and traversal, agree with the brute-force oracle's closest hit
/// within the radius; and their occlusion is the any-hit occlusion.
struct AoAgrees<'a> {
    oracle: &'a BruteForce,
    rays: &'a [Ray],
    want: &'a [Option<Hit>],
}

impl WithAccel for AoAgrees<'_> {
    type Output = Result<(), String>;
    fn run<A: Accel>(self, a: &A) -> Result<(), String> {
        raytree::par::try_for_each_index(self.rays.len(), &|i| {
            let (r, want) = (&self.rays[i], self.want[i]);
            let got = a.closest_hit(r, &mut NoStats);
            if !common::same_closest(got, want, self.oracle, r) {
                return Err(format!(
                    "AO ray {i} {r:?}: closest {got:?}, oracle {want:?}"
                ));
            }
            if let Some(h) = got {
                if !(h.t >= PAPER_TMIN && h.t <= 32.0) {
                    return Err(format!("AO ray {i}: t {} outside [1e-3, 32]", h.t));
                }
            }
            let any = a.any_hit(r, &mut NoStats);
            if any.is_some() != want.is_some() {
                return Err(format!("AO ray {i}: any-hit {any:?}, oracle {want:?}"));
            }
            Ok(())
        })
    }
}

#[test]
fn paper_ao_rays_agree_with_the_oracle_for_every_traversal() {
    let mut scene = Scene::builtin("chess:3000").unwrap();
    scene.use_stackless_view();
    let bvh = Bvh::build(&scene.triangles, &BuildOptions::new(Builder::Hybrid));
    let accel = BinaryBvh::from_bvh(&bvh, scene.triangles.clone()).unwrap();
    let s = AoSettings::paper(32.0);
    let (eye, ao) = rayset::ao_workload(&scene, &accel, &s, 24, 9);
    for (r, range) in &eye {
        for a in &ao[range.clone()] {
            // From the eye ray's hit point itself, over [1e-3, radius].
            assert_eq!((a.tmin, a.tmax), (PAPER_TMIN, 32.0));
            let hit = accel.closest_hit(r, &mut NoStats).unwrap();
            assert_eq!(a.origin(), r.at(hit.t));
            assert!((a.direction().length() - 1.0).abs() < 1e-5);
        }
    }
    let oracle = BruteForce::new(scene.triangles.clone());
    let want: Vec<Option<Hit>> = ao
        .par_iter()
        .map(|r| oracle.closest_hit(r, &mut NoStats))
        .collect();
    let hits = want.iter().filter(|h| h.is_some()).count();
    assert!(
        ao.len() > 20_000 && hits > ao.len() / 20 && hits < ao.len(),
        "{} AO rays, {hits} occluded",
        ao.len()
    );
    for builder in [Builder::Hybrid, Builder::Sah] {
        let bvh = Bvh::build(&scene.triangles, &BuildOptions::new(builder));
        for (s, t) in common::configurations() {
            let (built, _) = Built::new(s, t, &bvh, scene.triangles.clone()).unwrap();
            let r = built.with(AoAgrees {
                oracle: &oracle,
                rays: &ao,
                want: &want,
            });
            if let Err(e) = r {
                panic!("{} / {} / {}: {e}", s.name(), t.name(), builder.name());
            }
        }
    }
}

#[test]
fn every_traversal_renders_the_same_image_in_the_papers_form() {
    let mut scene = Scene::builtin("chess:3000").unwrap();
    scene.use_stackless_view();
    let (w, h) = (24, 9);
    let mut images = Vec::new();
    for (query, builders) in [
        (AoQuery::Closest, &[Builder::Hybrid, Builder::Sah][..]),
        (AoQuery::Any, &[Builder::Hybrid][..]),
    ] {
        let s = AoSettings {
            query,
            ..AoSettings::paper(32.0)
        };
        for &builder in builders {
            let bvh = Bvh::build(&scene.triangles, &BuildOptions::new(builder));
            let mut reference: Option<Image> = None;
            for (k, t) in common::configurations() {
                let (built, _) = Built::new(k, t, &bvh, scene.triangles.clone()).unwrap();
                let plain = built
                    .render(&scene, &Integrator::Ao(s.clone()), w, h, &|_| {})
                    .image;
                let phased = built.render_ao_phased(&scene, &s, w, h, true).image;
                let what = format!(
                    "{query:?} / {} / {} / {}",
                    k.name(),
                    t.name(),
                    builder.name()
                );
                assert!(plain == phased, "{what}: phased render differs");
                match &reference {
                    None => reference = Some(plain),
                    Some(r) => assert!(*r == plain, "{what}: differs from bvh/stack"),
                }
            }
            images.push(reference.unwrap());
        }
    }
    // Sky and board both in view, some pixels occluded.
    let img = &images[0];
    assert!(img.pixels.contains(&1.0));
    assert!(img.pixels.iter().any(|&v| v < 0.9));
    // The two queries see nearly the same occlusion (their rays start a
    // hair apart), never a different picture.
    let mean = |i: &Image| i.pixels.iter().map(|&v| v as f64).sum::<f64>() / i.pixels.len() as f64;
    assert!((mean(&images[0]) - mean(&images[2])).abs() < 0.02);
}

/// On the paper's own mesh seen through the paper's camera: the share of
/// eye rays that hit matches the original tracer's ray count (45.1M rays at
/// 800×300 with 16 eye and 16 AO rays per hit, so 67.2% of eye rays hit),
/// and no hit sees a triangle from its back, so the normal facing the eye
/// that raytree's AO spreads about is the original's unflipped normal.
/// (The built-in chess's lathe pieces are wound both ways, which is why
/// raytree keeps the facing normal.) Skipped without the shared scenes.
#[test]
fn the_paper_view_of_battlefield_hits_as_the_original_did() {
    let Some(p) = common::shared_scene("battlefield.obj") else {
        eprintln!("no ../shared/scenes/battlefield.obj: skipped");
        return;
    };
    let mut scene = Scene::load(&p).unwrap();
    assert!(scene.use_stackless_view());
    let bvh = Bvh::build(&scene.triangles, &BuildOptions::new(Builder::Hybrid));
    let accel = BinaryBvh::from_bvh(&bvh, scene.triangles.clone()).unwrap();
    let s = AoSettings {
        ao_rays: 0,
        ..AoSettings::paper(32.0)
    };
    let (eye, _) = rayset::ao_workload(&scene, &accel, &s, 160, 60);
    let (mut hits, mut back) = (0usize, 0usize);
    for (r, _) in &eye {
        if let Some(h) = accel.closest_hit(r, &mut NoStats) {
            hits += 1;
            if scene.triangles[h.prim as usize].normal().dot(r.direction()) > 0.0 {
                back += 1;
            }
        }
    }
    let original = (45.1e6 / (800.0 * 300.0 * 16.0) - 1.0) / 16.0;
    let share = hits as f64 / eye.len() as f64;
    assert!(
        (share - original).abs() < 0.005,
        "{share} against {original}"
    );
    assert_eq!(back, 0);
}
