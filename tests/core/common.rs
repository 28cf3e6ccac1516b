//! Ray sets and helpers shared by the integration tests.
#![allow(dead_code)]

use raytree::prelude::*;
use raytree::rng::Pcg32;
use raytree::structures::{StructureKind, TraversalKind, WithAccel};

/// A point of triangle `t` at barycentrics drawn from `rng`.
pub fn point_on(t: &Triangle, rng: &mut Pcg32) -> Vec3 {
    let (mut u, mut v) = (rng.next_f32(), rng.next_f32());
    if u + v > 1.0 {
        (u, v) = (1.0 - u, 1.0 - v);
    }
    t.a + (t.b - t.a) * u + (t.c - t.a) * v
}

/// A random unit vector.
pub fn unit(rng: &mut Pcg32) -> Vec3 {
    loop {
        let v = Vec3::new(
            rng.range(-1.0, 1.0),
            rng.range(-1.0, 1.0),
            rng.range(-1.0, 1.0),
        );
        if v.length_squared() > 1e-4 && v.length_squared() <= 1.0 {
            return v.normalize();
        }
    }
}

/// A point outside the scene box, on a sphere around it.
pub fn outside(bounds: &Aabb, rng: &mut Pcg32) -> Vec3 {
    bounds.center() + unit(rng) * (bounds.extent().length() * 0.75 + 1e-3)
}

/// `n` rays of every kind the foundation issue names, mixed: from outside at
/// random triangle points, from inside in random directions, axis-parallel
/// (zero components, both signs of zero), aimed exactly at vertices and edge
/// points, stopping short of the surface, starting past it, and with
/// unnormalized directions of lengths from 1e-3 to 1e3.
pub fn mixed_rays(scene: &Scene, n: usize, seed: u64) -> Vec<Ray> {
    let mut rng = Pcg32::new(seed, 99);
    let tris = &scene.triangles;
    let bounds = scene.mesh.bounds();
    let mut rays = Vec::with_capacity(n);
    for i in 0..n {
        let t = &tris[rng.below(tris.len() as u32) as usize];
        let o = outside(&bounds, &mut rng);
        let scale = 10f32.powf(rng.range(-3.0, 3.0));
        let ray = match i % 7 {
            0 => Ray::infinite(o, point_on(t, &mut rng) - o),
            1 => {
                let p = bounds.min
                    + bounds.extent() * Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32());
                Ray::infinite(p, unit(&mut rng) * scale)
            }
            2 => {
                // Axis-parallel through a triangle point: zero components.
                let p = point_on(t, &mut rng);
                let axis = rng.below(3) as usize;
                let sign = if rng.below(2) == 0 { 1.0 } else { -1.0 };
                let mut d = Vec3::ZERO;
                if rng.below(2) == 0 {
                    d = -d; // negative zeros
                }
                d[axis] = sign * scale;
                let mut start = p;
                start[axis] -= sign * bounds.extent()[axis].max(1.0) * 2.0;
                Ray::infinite(start, d)
            }
            3 => {
                // Exactly at a vertex, or a point of an edge.
                let target = match rng.below(3) {
                    0 => t.a,
                    1 => (t.a + t.b) * 0.5,
                    _ => t.b + (t.c - t.b) * rng.next_f32(),
                };
                Ray::infinite(o, (target - o) * scale)
            }
            4 => {
                // Stops short of the aimed-at point.
                let d = point_on(t, &mut rng) - o;
                Ray::new(o, d, 0.0, rng.range(0.0, 1.0))
            }
            5 => {
                // Starts past some of the geometry.
                let d = point_on(t, &mut rng) - o;
                Ray::new(o, d, rng.range(0.5, 1.5), f32::INFINITY)
            }
            _ => Ray::infinite(o, (point_on(t, &mut rng) - o) * scale),
        };
        rays.push(ray);
    }
    rays
}

/// The shared scenes directory, if present.
pub fn shared_scene(name: &str) -> Option<std::path::PathBuf> {
    let p = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../shared/scenes")
        .join(name);
    p.exists().then_some(p)
}

/// The same closest hit, up to what f32 coordinates can tell apart: see
/// [`BruteForce::confirms`].
pub fn same_closest(got: Option<Hit>, want: Option<Hit>, oracle: &BruteForce, r: &Ray) -> bool {
    oracle.confirms(got, want, r)
}

/// A visitor that checks a structure's closest and any hits against the
/// oracle on every ray.
pub struct Agrees<'a> {
    pub oracle: &'a BruteForce,
    pub rays: &'a [Ray],
}

impl WithAccel for Agrees<'_> {
    type Output = Result<(), String>;
    fn run<A: Accel>(self, a: &A) -> Result<(), String> {
        for (i, r) in self.rays.iter().enumerate() {
            let want = self.oracle.closest_hit(r, &mut NoStats);
            let got = a.closest_hit(r, &mut NoStats);
            if !same_closest(got, want, self.oracle, r) {
                return Err(format!("ray {i} {r:?}: closest {got:?}, oracle {want:?}"));
            }
            let any = a.any_hit(r, &mut NoStats);
            if any.is_some() != want.is_some() {
                return Err(format!("ray {i} {r:?}: any {any:?}, oracle {want:?}"));
            }
        }
        Ok(())
    }
}

/// The BVH builds every structure is checked over: each builder, and the
/// SAH, SBVH and LBVH builders with leaf costs in blocks of 4 triangles
/// ([`BuildOptions::sah_block`]), named for messages.
pub fn build_variants() -> Vec<(String, BuildOptions)> {
    let mut v: Vec<_> = raytree::bvh::Builder::ALL
        .iter()
        .map(|&b| (b.name().to_string(), BuildOptions::new(b)))
        .collect();
    for b in [
        BuildOptions::sah(),
        BuildOptions::sbvh(),
        BuildOptions::new(raytree::bvh::Builder::Lbvh),
    ] {
        let name = format!("{}+block4", b.builder.name());
        v.push((name, b.with_sah_block(4)));
    }
    v
}

/// Every structure, and for `bvh` every traversal.
pub fn configurations() -> Vec<(StructureKind, TraversalKind)> {
    let mut v: Vec<_> = TraversalKind::all()
        .iter()
        .map(|&t| (StructureKind::Bvh, t))
        .collect();
    for &s in StructureKind::all() {
        if s != StructureKind::Bvh {
            v.push((s, TraversalKind::Stack));
        }
    }
    v
}

/// Every structure and traversal built from `bvh` agrees with `oracle` on
/// every ray; the error names the configuration.
pub fn every_configuration_agrees(
    bvh: &Bvh,
    tris: &std::sync::Arc<[Triangle]>,
    oracle: &BruteForce,
    rays: &[Ray],
) -> Result<(), String> {
    for (s, t) in configurations() {
        let (built, _) = raytree::structures::Built::new(s, t, bvh, tris.clone())
            .map_err(|e| format!("{}/{}: {e}", s.name(), t.name()))?;
        built
            .with(Agrees { oracle, rays })
            .map_err(|e| format!("{}/{}: {e}", s.name(), t.name()))?;
    }
    Ok(())
}
