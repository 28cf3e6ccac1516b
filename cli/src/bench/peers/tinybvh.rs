//! tinybvh's 8-wide CPU layout (`BVH8_CPU`, after Fuetterling et al.,
//! "Accelerated Single Ray Tracing for Wide Vector Units") as a contender,
//! through the `tinybvh-rs` crate (feature `tinybvh`; cargo builds the C++
//! library from source with `-march=native`). Two builds: tinybvh's binned
//! SAH (`Build`) and its spatial-split build (`BuildHQ`), each with leaves
//! split to at most four triangles, collapsed to an 8-wide tree
//! (`MBVH<8>`) and converted to `BVH8_CPU`.
//!
//! `tinybvh-rs` exposes `BVH8_CPU`'s traversal only to Rust code compiled
//! with AVX2 (`cfg(target_feature = "avx2")`), so these contenders exist in
//! a build made with `RUSTFLAGS="-C target-feature=+avx2,+fma"` (raytree's
//! own kernels choose their SIMD path at run time either way). Its rays
//! have no `tmin` and a unit direction: a ray starts at
//! `origin + tmin·direction` and its hit distance is scaled and shifted
//! back, so distances agree with raytree's to rounding. The crate exposes
//! closest hit only, so its AO figure is a closest-hit trace (no early
//! exit).
//!
//! tinybvh-rs 0.1.0-beta.3 mirrors the C++ `tinybvh::Ray` in 64 bytes, but
//! the header it compiles makes that struct 128 (an `Intersection` with 64
//! bytes of user data), so its `Ray::new` and `Intersect` write past the
//! Rust value (a crash on the first thread exit). Rays here are therefore
//! made in place, as the C++ constructor makes them, inside a 128-byte,
//! 64-aligned buffer ([`RayBuf`]) that the C++ side may fill whole.

use super::{Contender, Entry};
use raytree::error::{Error, Result};
use raytree::geometry::Ray;
use raytree::scene::Scene;
use std::time::Instant;
use tinybvh_rs::{bvh, bvh8_cpu, mbvh, Intersector};

/// A `BVH8_CPU` over a scene's triangles.
pub struct Peer {
    bvh: bvh8_cpu::BVH,
}

// SAFETY: `BVH8_CPU::Intersect` is a `const` method that reads the nodes
// and triangles the BVH owns; nothing mutates them after the build.
unsafe impl Sync for Peer {}

/// The contender names, Build then BuildHQ.
pub const NAMES: [&str; 2] = ["tinybvh bvh8_cpu", "tinybvh bvh8_cpu hq"];

/// Builds both contenders with their build times, and the configuration
/// line for the report.
pub fn contenders(scene: &Scene) -> Result<(Vec<Entry<'static>>, String)> {
    let prims: Vec<[f32; 4]> = scene
        .triangles
        .iter()
        .flat_map(|t| [t.a, t.b, t.c].map(|v| [v.x, v.y, v.z, 0.0]))
        .collect();
    let err = |e: tinybvh_rs::Error| Error::Invalid(format!("tinybvh: {e:?}"));
    let mut out: Vec<Entry<'static>> = Vec::new();
    for (name, hq) in NAMES.into_iter().zip([false, true]) {
        let t = Instant::now();
        let mut b = if hq {
            bvh::BVH::new_hq(prims.as_slice().into())
        } else {
            bvh::BVH::new(prims.as_slice().into())
        }
        .map_err(err)?;
        b.split_leaves(4);
        let m = mbvh::BVH::new(&b);
        let cpu = bvh8_cpu::BVH::new(&m).map_err(err)?;
        out.push((
            name.into(),
            t.elapsed().as_secs_f64(),
            Box::new(Peer { bvh: cpu }),
        ));
    }
    let config = "tinybvh (tinybvh-rs 0.1.0-beta.3): BVH8_CPU from Build (binned SAH) and BuildHQ (spatial splits), leaves split to 4 triangles; closest hit only (AO traced as closest hit); rays start at tmin".to_owned();
    Ok((out, config))
}

/// The C++ `tinybvh::Ray`'s 128 bytes: the 64 that tinybvh-rs mirrors,
/// then the intersection's user data.
#[repr(C, align(64))]
struct RayBuf {
    ray: tinybvh_rs::Ray,
    _user: [u8; 64],
}

/// tinybvh's `tinybvh_safercp`: `1/x`, or `±1e30` for `|x| ≤ 1e-12`.
fn safe_rcp(x: f32) -> f32 {
    if x.abs() > 1e-12 {
        1.0 / x
    } else if x >= 0.0 {
        tinybvh_rs::INFINITE
    } else {
        -tinybvh_rs::INFINITE
    }
}

impl Contender for Peer {
    fn closest(&self, r: &Ray) -> Option<f32> {
        let (o, d) = (r.origin(), r.direction());
        let len = d.length();
        let unit = d / len;
        let start = o + d * r.tmin;
        // Distances along the unit direction from `start`.
        let limit = ((r.tmax - r.tmin) * len).min(tinybvh_rs::INFINITE);
        let mut buf = RayBuf {
            ray: tinybvh_rs::Ray {
                origin: start.to_array(),
                // `mask`: RAY_MASK_INTERSECT_ALL.
                padding_0: 0xffff,
                dir: unit.to_array(),
                padding_1: 0,
                r_d: unit.to_array().map(safe_rcp),
                padding_2: 0,
                hit: tinybvh_rs::Intersection {
                    t: limit,
                    u: 0.0,
                    v: 0.0,
                    prim: 0,
                },
            },
            _user: [0; 64],
        };
        self.bvh.intersect(&mut buf.ray);
        let t = buf.ray.hit.t;
        (t < limit).then_some(t / len + r.tmin)
    }
    fn occluded(&self, r: &Ray) -> bool {
        self.closest(r).is_some()
    }
}
