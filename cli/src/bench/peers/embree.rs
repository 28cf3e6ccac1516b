//! Embree 3 as a contender, through the `embree` crate over the system
//! library (Debian: `apt install libembree-dev`; build raytree with
//! `--features embree`). Embree builds its own BVH with its default
//! settings and answers with its own triangle test, so its hits are
//! compared with raytree's by distance.

use super::Contender;
use embree::{Geometry, IntersectContext, RayHit, TriangleMesh};
use raytree::error::{Error, Result};
use raytree::geometry::Ray;
use raytree::scene::Scene;
use std::time::Instant;

pub use embree::Device;

/// The scene's triangles in an Embree scene, not yet built.
pub struct Built<'a> {
    scene: embree::Scene<'a>,
}

impl<'a> Built<'a> {
    /// Copies the mesh into Embree's buffers. Embree indexes vertices
    /// with 32 bits, as raytree's meshes do.
    pub fn new(device: &'a Device, scene: &Scene) -> Result<Self> {
        let mesh = &scene.mesh;
        if mesh.positions.is_empty() || mesh.indices.is_empty() {
            return Err(Error::Invalid(format!(
                "{}: no triangles for Embree",
                scene.name
            )));
        }
        let mut tris = TriangleMesh::unanimated(device, mesh.indices.len(), mesh.positions.len());
        {
            let mut v = tris.vertex_buffer.map();
            for (i, p) in mesh.positions.iter().enumerate() {
                v[i] = cgmath::Vector4::new(p.x, p.y, p.z, 0.0);
            }
            let mut ix = tris.index_buffer.map();
            for (i, t) in mesh.indices.iter().enumerate() {
                ix[i] = cgmath::Vector3::new(t[0], t[1], t[2]);
            }
        }
        let mut geometry = Geometry::Triangle(tris);
        geometry.commit();
        let mut built = Built {
            scene: embree::Scene::new(device),
        };
        built.scene.attach_geometry(geometry);
        Ok(built)
    }

    /// Builds Embree's BVH; returns it as a contender with the build time.
    pub fn commit(&'a self) -> (Peer<'a>, f64) {
        let t = Instant::now();
        let committed = self.scene.commit();
        (Peer { scene: committed }, t.elapsed().as_secs_f64())
    }
}

pub struct Peer<'a> {
    scene: embree::CommittedScene<'a>,
}

fn to_embree(r: &Ray) -> embree::Ray {
    let (o, d) = (r.origin(), r.direction());
    embree::sys::RTCRay {
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

impl Contender for Peer<'_> {
    fn closest(&self, r: &Ray) -> Option<f32> {
        let mut ctx = IntersectContext::incoherent();
        let mut rh = RayHit::new(to_embree(r));
        self.scene.intersect(&mut ctx, &mut rh);
        rh.hit.hit().then_some(rh.ray.tfar)
    }
    fn occluded(&self, r: &Ray) -> bool {
        let mut ctx = IntersectContext::incoherent();
        let mut ray = to_embree(r);
        self.scene.occluded(&mut ctx, &mut ray);
        // Embree marks an occluded ray by setting tfar to -inf.
        ray.tfar < 0.0
    }
}
