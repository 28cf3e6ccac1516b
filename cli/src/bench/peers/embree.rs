//! Embree 3 as a contender, through the `embree` crate's bindings to the
//! system library (Debian: `apt install libembree-dev`; build raytree with
//! `--features embree`), at both of the build qualities Embree offers for a
//! static scene:
//!
//! - `medium`, Embree's default: its binned SAH builder;
//! - `high`: `RTC_BUILD_QUALITY_HIGH`, its SAH builder with spatial splits
//!   (on AVX machines `BVH8Triangle4SceneBuilderFastSpatialSAH`).
//!
//! The scene goes through Embree's C API directly (`embree::sys`), because
//! the crate's wrapper does not expose a scene's build quality. Embree
//! builds its own BVH and answers with its own triangle test (not robust
//! mode), so its hits are compared with raytree's by distance.

use super::Contender;
use embree::sys::{self, RTCDevice, RTCScene};
use raytree::error::{Error, Result};
use raytree::geometry::Ray;
use raytree::scene::Scene;
use std::time::Instant;

/// Embree's build qualities for a static scene.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Quality {
    /// `RTC_BUILD_QUALITY_MEDIUM`, the default.
    Medium,
    /// `RTC_BUILD_QUALITY_HIGH`: spatial splits.
    High,
}

impl Quality {
    /// The contender's name in tables.
    pub fn contender(self) -> &'static str {
        match self {
            Quality::Medium => "embree medium",
            Quality::High => "embree high",
        }
    }
}

/// An Embree device and a committed scene of one triangle mesh.
pub struct Peer {
    device: RTCDevice,
    scene: RTCScene,
    /// How it was configured, for the report.
    pub config: String,
}

// SAFETY: Embree's API documents ray queries on a committed scene as
// thread-safe; the handles are only released in `drop`, with `&mut self`.
unsafe impl Sync for Peer {}
// SAFETY: as above; nothing in the handles is tied to the creating thread.
unsafe impl Send for Peer {}

impl Peer {
    /// Copies the scene's mesh into Embree's buffers and builds its BVH at
    /// `quality` on `threads` threads (Embree's device `threads=` setting,
    /// so that a one-thread benchmark times a one-thread build); returns it
    /// with the build time (the scene commit).
    ///
    /// # Errors
    /// [`Error::Invalid`] for a mesh without triangles, or when Embree
    /// refuses (its error code is named).
    pub fn build(scene: &Scene, quality: Quality, threads: usize) -> Result<(Peer, f64)> {
        let mesh = &scene.mesh;
        if mesh.positions.is_empty() || mesh.indices.is_empty() {
            return Err(Error::Invalid(format!(
                "{}: no triangles for Embree",
                scene.name
            )));
        }
        let config = std::ffi::CString::new(format!("threads={threads}"))
            .expect("a thread count has no NUL byte");
        // SAFETY: `config` is a NUL-terminated string that outlives the call.
        let device = unsafe { sys::rtcNewDevice(config.as_ptr()) };
        if device.is_null() {
            return Err(Error::Invalid("Embree: rtcNewDevice failed".into()));
        }
        // SAFETY: `device` is a live device; the new scene and geometry are
        // used only through it. The buffers Embree returns hold `count`
        // items of the stride given, which the copies below fill exactly.
        let scene_h = unsafe {
            let s = sys::rtcNewScene(device);
            let q = match quality {
                Quality::Medium => sys::RTCBuildQuality::MEDIUM,
                Quality::High => sys::RTCBuildQuality::HIGH,
            };
            sys::rtcSetSceneBuildQuality(s, q);
            let g = sys::rtcNewGeometry(device, sys::RTCGeometryType::TRIANGLE);
            let v = sys::rtcSetNewGeometryBuffer(
                g,
                sys::RTCBufferType::VERTEX,
                0,
                sys::RTCFormat::FLOAT3,
                12,
                mesh.positions.len(),
            ) as *mut [f32; 3];
            let ix = sys::rtcSetNewGeometryBuffer(
                g,
                sys::RTCBufferType::INDEX,
                0,
                sys::RTCFormat::UINT3,
                12,
                mesh.indices.len(),
            ) as *mut [u32; 3];
            if v.is_null() || ix.is_null() {
                sys::rtcReleaseGeometry(g);
                sys::rtcReleaseScene(s);
                sys::rtcReleaseDevice(device);
                return Err(Error::Invalid(
                    "Embree: could not allocate the mesh's buffers".into(),
                ));
            }
            for (i, p) in mesh.positions.iter().enumerate() {
                v.add(i).write([p.x, p.y, p.z]);
            }
            for (i, t) in mesh.indices.iter().enumerate() {
                ix.add(i).write([t[0], t[1], t[2]]);
            }
            sys::rtcCommitGeometry(g);
            sys::rtcAttachGeometry(s, g);
            sys::rtcReleaseGeometry(g);
            s
        };
        let t = Instant::now();
        // SAFETY: `scene_h` is a live scene with its geometry attached.
        let error = unsafe {
            sys::rtcCommitScene(scene_h);
            sys::rtcGetDeviceError(device)
        };
        let build_s = t.elapsed().as_secs_f64();
        let peer = Peer {
            device,
            scene: scene_h,
            config: format!(
                "{}: Embree {}, scene build quality {}, {threads} build thread(s), single rays, incoherent context",
                quality.contender(),
                version(device),
                match quality {
                    Quality::Medium => "MEDIUM (binned SAH)",
                    Quality::High => "HIGH (SAH with spatial splits)",
                }
            ),
        };
        if error != sys::RTCError::NONE {
            return Err(Error::Invalid(format!(
                "Embree could not build the scene: {error:?}"
            )));
        }
        Ok((peer, build_s))
    }
}

/// Embree's version, as `major.minor.patch`.
fn version(device: RTCDevice) -> String {
    // SAFETY: a query on a live device.
    let v = unsafe { sys::rtcGetDeviceProperty(device, sys::RTCDeviceProperty::VERSION) };
    format!("{}.{}.{}", v / 10000, (v / 100) % 100, v % 100)
}

impl Drop for Peer {
    fn drop(&mut self) {
        // SAFETY: both handles are live and released once, scene first.
        unsafe {
            sys::rtcReleaseScene(self.scene);
            sys::rtcReleaseDevice(self.device);
        }
    }
}

fn to_embree(r: &Ray) -> sys::RTCRay {
    let (o, d) = (r.origin(), r.direction());
    sys::RTCRay {
        org_x: o.x,
        org_y: o.y,
        org_z: o.z,
        tnear: r.tmin,
        dir_x: d.x,
        dir_y: d.y,
        dir_z: d.z,
        time: 0.0,
        tfar: r.tmax,
        mask: u32::MAX,
        id: 0,
        flags: 0,
    }
}

fn context() -> sys::RTCIntersectContext {
    sys::RTCIntersectContext {
        flags: sys::RTCIntersectContextFlags::INCOHERENT,
        filter: None,
        instID: [u32::MAX; 1],
    }
}

impl Contender for Peer {
    fn closest(&self, r: &Ray) -> Option<f32> {
        let mut ctx = context();
        let mut rh = sys::RTCRayHit {
            ray: to_embree(r),
            hit: sys::RTCHit {
                Ng_x: 0.0,
                Ng_y: 0.0,
                Ng_z: 0.0,
                u: 0.0,
                v: 0.0,
                primID: u32::MAX,
                geomID: u32::MAX,
                instID: [u32::MAX; 1],
            },
        };
        // SAFETY: a committed scene, and a context and ray hit that live
        // through the call.
        unsafe { sys::rtcIntersect1(self.scene, &mut ctx, &mut rh) };
        (rh.hit.geomID != u32::MAX).then_some(rh.ray.tfar)
    }
    fn occluded(&self, r: &Ray) -> bool {
        let mut ctx = context();
        let mut ray = to_embree(r);
        // SAFETY: as above.
        unsafe { sys::rtcOccluded1(self.scene, &mut ctx, &mut ray) };
        // Embree marks an occluded ray by setting tfar to -inf.
        ray.tfar < 0.0
    }
}
