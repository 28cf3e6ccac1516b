//! An industrial plant like Powerplant: a grid of works, each a building
//! with windows and a railed roof, a smokestack, tanks, pipe runs on
//! supports and a conveyor truss. Regular and large: the size sets how many
//! works are built (about 7k triangles each), so `plant:12M` is a site of
//! over a thousand works like the 12.7M-triangle Powerplant.
//!
//! Works are added one part at a time until the requested triangle count is
//! reached, so the count is met to within one part (a few thousand
//! triangles) and a small size is a partly built first work.

use super::shapes::{push_box, push_lathe, push_tube};
use crate::rng::Pcg32;
use crate::scene::{Camera, Mesh, Scene};
use glam::Vec3;

const SEED: u64 = 0x504c_414e;
/// Each work stands on a square lot this wide, in metres.
const LOT: f32 = 40.0;
/// Expected triangles per work, to lay the lots out as a square.
const WORK_TRIANGLES: f64 = 7_000.0;
const PIPE_SIDES: usize = 12;

const STACK: &[(f32, f32)] = &[
    (2.2, 0.0),
    (2.0, 0.3),
    (2.05, 0.31),
    (2.05, 0.33),
    (1.8, 0.34),
    (1.6, 0.65),
    (1.7, 0.66),
    (1.7, 0.68),
    (1.5, 0.69),
    (1.35, 0.97),
    (1.5, 0.98),
    (1.5, 1.0),
    (1.2, 1.0),
    (1.2, 0.9),
];
const TANK: &[(f32, f32)] = &[
    (0.0, 0.0),
    (1.0, 0.0),
    (1.0, 0.75),
    (0.92, 0.87),
    (0.7, 0.96),
    (0.38, 1.0),
    (0.0, 1.01),
];

/// The parts made so far and the triangle count to stop at.
struct Site {
    mesh: Mesh,
    target: usize,
    sphere: Vec<(f32, f32)>,
}

impl Site {
    fn full(&self) -> bool {
        self.mesh.indices.len() >= self.target
    }
}

pub fn scene(target_triangles: usize) -> Scene {
    let cols = (target_triangles as f64 / WORK_TRIANGLES)
        .sqrt()
        .ceil()
        .max(1.0) as usize;
    let sphere: Vec<(f32, f32)> = (0..=12)
        .map(|k| {
            let a = std::f32::consts::PI * k as f32 / 12.0;
            (a.sin() * (k % 12 != 0) as u8 as f32, -a.cos())
        })
        .collect();
    let mut site = Site {
        mesh: Mesh::default(),
        target: target_triangles,
        sphere,
    };
    let mut work = 0usize;
    while !site.full() {
        let (row, col) = (work / cols, work % cols);
        let origin = Vec3::new(col as f32 * LOT, 0.0, row as f32 * LOT);
        let mut rng = Pcg32::new(SEED, work as u64);
        build_work(&mut site, &mut rng, origin);
        work += 1;
    }
    let bounds = site.mesh.bounds();
    let extent = bounds.extent();
    let span = extent.x.max(extent.z);
    // From beyond one corner, raised, looking across the site.
    let eye = Vec3::new(
        bounds.min.x - 0.15 * span - 10.0,
        0.3 * span + 25.0,
        bounds.max.z + 0.15 * span + 10.0,
    );
    let target = Vec3::new(bounds.center().x, 0.0, bounds.center().z);
    let camera = Camera::new(eye, target, Vec3::Y, 50.0);
    Scene::new("plant", site.mesh, camera)
}

/// One work on the lot at `o`, part by part, stopping when the site is full.
fn build_work(site: &mut Site, rng: &mut Pcg32, o: Vec3) {
    if site.full() {
        return;
    }
    push_box(
        &mut site.mesh,
        o + Vec3::new(0.5, -0.3, 0.5),
        o + Vec3::new(LOT - 0.5, 0.0, LOT - 0.5),
    );
    // The building: 12-20 m by 10-16 m, 8-20 m tall, in the lot's west half.
    let size = Vec3::new(
        rng.range(12.0, 20.0),
        rng.range(8.0, 20.0),
        rng.range(10.0, 16.0),
    );
    let lo = o + Vec3::new(2.0, 0.0, 2.0);
    let hi = lo + size;
    if site.full() {
        return;
    }
    push_box(&mut site.mesh, lo, hi);
    push_windows(site, lo, hi);
    if site.full() {
        return;
    }
    push_railing(site, lo, hi);
    // The smokestack, east of the building.
    let stack_at = o + Vec3::new(rng.range(26.0, 34.0), 0.0, rng.range(6.0, 12.0));
    let stack_height = rng.range(25.0, 50.0);
    if site.full() {
        return;
    }
    let stack: Vec<(f32, f32)> = STACK.iter().map(|&(r, y)| (r / stack_height, y)).collect();
    push_lathe(&mut site.mesh, &stack, 32, stack_at, stack_height);
    // Tanks in a row along the lot's south side: cylinders with domed tops
    // and spheres on legs.
    let tanks = 2 + rng.below(3) as usize;
    for t in 0..tanks {
        if site.full() {
            return;
        }
        let at = o + Vec3::new(4.0 + t as f32 * 8.0, 0.0, 30.0);
        let r = rng.range(2.0, 3.5);
        if rng.below(2) == 0 {
            let h = rng.range(5.0, 10.0);
            let profile: Vec<(f32, f32)> = TANK.iter().map(|&(pr, py)| (pr * r / h, py)).collect();
            push_lathe(&mut site.mesh, &profile, 24, at, h);
        } else {
            let center = at + Vec3::Y * (r + 1.5);
            push_lathe(&mut site.mesh, &site.sphere, 24, center, r);
            for (dx, dz) in [(-1.0, -1.0), (1.0, -1.0), (-1.0, 1.0), (1.0, 1.0)] {
                let leg = at + Vec3::new(dx, 0.0, dz) * (0.6 * r);
                push_box(
                    &mut site.mesh,
                    leg - Vec3::new(0.15, 0.0, 0.15),
                    leg + Vec3::new(0.15, r + 1.5, 0.15),
                );
            }
        }
    }
    // Pipe runs between the building, the stack and the tanks, on supports.
    let pipes = 8 + rng.below(9) as usize;
    for _ in 0..pipes {
        if site.full() {
            return;
        }
        let start = lo
            + Vec3::new(
                size.x,
                rng.range(1.0, size.y.min(8.0)),
                rng.range(0.5, size.z - 0.5),
            );
        let end = o + Vec3::new(
            rng.range(3.0, 36.0),
            rng.range(0.5, 3.0),
            rng.range(26.0, 38.0),
        );
        let radius = rng.range(0.12, 0.45);
        push_pipe(&mut site.mesh, rng, start, end, radius);
    }
    // A conveyor truss from the building's roof to the stack.
    if site.full() {
        return;
    }
    let from = Vec3::new(hi.x, hi.y - 1.0, (lo.z + hi.z) * 0.5);
    let to = stack_at + Vec3::new(-2.0, (hi.y + 6.0).min(stack_height - 2.0), 0.0);
    push_truss(site, from, to);
}

/// Window frames: a sill box every 2 m along each facade, one row a floor.
fn push_windows(site: &mut Site, lo: Vec3, hi: Vec3) {
    let floors = ((hi.y - lo.y) / 4.0) as usize;
    for f in 0..floors {
        if site.full() {
            return;
        }
        let mesh = &mut site.mesh;
        let y = lo.y + 1.2 + 4.0 * f as f32;
        let nx = ((hi.x - lo.x) / 2.0) as usize;
        for i in 0..nx {
            let x = lo.x + 1.0 + 2.0 * i as f32;
            push_box(
                mesh,
                Vec3::new(x - 0.6, y, lo.z - 0.15),
                Vec3::new(x + 0.6, y + 0.12, lo.z),
            );
            push_box(
                mesh,
                Vec3::new(x - 0.6, y, hi.z),
                Vec3::new(x + 0.6, y + 0.12, hi.z + 0.15),
            );
        }
        let nz = ((hi.z - lo.z) / 2.0) as usize;
        for i in 0..nz {
            let z = lo.z + 1.0 + 2.0 * i as f32;
            push_box(
                mesh,
                Vec3::new(lo.x - 0.15, y, z - 0.6),
                Vec3::new(lo.x, y + 0.12, z + 0.6),
            );
            push_box(
                mesh,
                Vec3::new(hi.x, y, z - 0.6),
                Vec3::new(hi.x + 0.15, y + 0.12, z + 0.6),
            );
        }
    }
}

/// A roof railing: posts every metre and two rails on each side.
fn push_railing(site: &mut Site, lo: Vec3, hi: Vec3) {
    let y = hi.y;
    let corners = [
        Vec3::new(lo.x, y, lo.z),
        Vec3::new(hi.x, y, lo.z),
        Vec3::new(hi.x, y, hi.z),
        Vec3::new(lo.x, y, hi.z),
    ];
    for k in 0..4 {
        if site.full() {
            return;
        }
        let mesh = &mut site.mesh;
        let (a, b) = (corners[k], corners[(k + 1) % 4]);
        let posts = (a.distance(b) as usize).max(1);
        for p in 0..posts {
            let at = a + (b - a) * (p as f32 / posts as f32);
            push_box(
                mesh,
                at - Vec3::new(0.03, 0.0, 0.03),
                at + Vec3::new(0.03, 1.0, 0.03),
            );
        }
        for h in [0.5, 1.0] {
            let (l, u) = (a.min(b), a.max(b));
            push_box(
                mesh,
                l + Vec3::new(-0.03, h - 0.04, -0.03),
                u + Vec3::new(0.03, h, 0.03),
            );
        }
    }
}

/// A pipe from `a` to `b` in three or four straight legs along the axes,
/// with short chamfers at its corners and supports under it every 4 m.
fn push_pipe(mesh: &mut Mesh, rng: &mut Pcg32, a: Vec3, b: Vec3, radius: f32) {
    let rise = rng.range(4.0, 9.0).max(a.y);
    let corners = [
        a,
        Vec3::new(a.x + 1.0, rise, a.z),
        Vec3::new(b.x, rise, a.z),
        Vec3::new(b.x, rise, b.z),
        b,
    ];
    let mut path = vec![corners[0]];
    for w in corners.windows(3) {
        let (p, c, n) = (w[0], w[1], w[2]);
        let cut = (4.0 * radius)
            .min(0.45 * p.distance(c))
            .min(0.45 * c.distance(n));
        path.push(c + (p - c).normalize_or_zero() * cut);
        path.push(c + (n - c).normalize_or_zero() * cut);
    }
    path.push(corners[4]);
    path.dedup_by(|x, y| x.distance(*y) < 1e-3);
    if path.len() < 2 {
        return;
    }
    push_tube(mesh, &path, radius, PIPE_SIDES);
    // Supports under the horizontal run at the rise height.
    let (s, e) = (corners[2], corners[3]);
    let run = s.distance(e);
    let n = (run / 4.0) as usize;
    for k in 1..=n {
        let at = s + (e - s) * (k as f32 / (n + 1) as f32);
        push_box(
            mesh,
            Vec3::new(at.x - 0.1, 0.0, at.z - 0.1),
            Vec3::new(at.x + 0.1, at.y - radius, at.z + 0.1),
        );
    }
}

/// A square truss 1.2 m wide from `a` to `b`: four chords, and a frame and
/// a diagonal brace every metre.
fn push_truss(site: &mut Site, a: Vec3, b: Vec3) {
    let axis = (b - a).normalize_or(Vec3::X);
    let side = axis.cross(Vec3::Y).normalize_or(Vec3::Z) * 0.6;
    let up = side.cross(axis).normalize() * 0.6;
    let offsets = [side + up, -side + up, -side - up, side - up];
    for off in offsets {
        push_tube(&mut site.mesh, &[a + off, b + off], 0.05, 4);
    }
    let bays = (a.distance(b) as usize).max(1);
    for k in 0..bays {
        if site.full() {
            return;
        }
        let mesh = &mut site.mesh;
        let p = a + (b - a) * (k as f32 / bays as f32);
        let q = a + (b - a) * ((k + 1) as f32 / bays as f32);
        for c in 0..4 {
            let (o0, o1) = (offsets[c], offsets[(c + 1) % 4]);
            push_tube(mesh, &[p + o0, p + o1], 0.03, 4);
            push_tube(mesh, &[p + o0, q + o1], 0.03, 4);
        }
    }
}
