//! The ray and hit file formats of `raytree trace`.
//!
//! - Ray file: little-endian, no header, 32 bytes per ray: origin x y z,
//!   direction x y z (any length), tmin, tmax, all f32.
//! - Hit file (`--format bin`, the default): 16 bytes per ray: t (f32,
//!   +inf on a miss), triangle index (u32, the scene's global triangle
//!   order, `0xFFFFFFFF` on a miss), barycentrics u and v (f32).
//! - Hit file with geometries (`--format bin-geometry`): 24 bytes per ray:
//!   the same 16 bytes, then the geometry id (u32) and the triangle's index
//!   within that geometry (u32), both `0xFFFFFFFF` on a miss. A scene's
//!   geometries are its files, in the order given, and each triangle
//!   primitive of each mesh instance of a glTF scene
//!   ([`crate::scene::Mesh::geometries`]).
//! - Hit CSV (`--format csv`): a header `ray,t,triangle,u,v,geometry,primitive`
//!   and one line per ray with the same values as the binary files. The
//!   two geometry columns come last, so readers of the first five columns
//!   (by name or by position) read the file as before.

use crate::error::{Error, Result};
use crate::geometry::{Hit, Ray};
use crate::scene::Mesh;
use glam::Vec3;
use std::io::Write;
use std::path::Path;

/// Bytes per ray in a ray file: eight little-endian f32.
pub const RAY_BYTES: usize = 32;
/// Bytes per hit in a hit file: `t`, triangle index, `u`, `v`.
pub const HIT_BYTES: usize = 16;
/// Bytes per ray of a hit file with geometries.
pub const GEOMETRY_HIT_BYTES: usize = 24;
/// The triangle index (and geometry id, and index within the geometry)
/// written for a miss.
pub const MISS: u32 = u32::MAX;

/// A hit with the geometry it lies on: the geometry's id and the
/// triangle's index within it ([`Mesh::geometry_of`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GeometryHit {
    /// The hit, with the global triangle index.
    pub hit: Hit,
    /// The geometry's id.
    pub geometry: u32,
    /// The triangle's index within the geometry.
    pub primitive: u32,
}

impl GeometryHit {
    /// `hit` with its geometry in `mesh`; [`MISS`] for both when its
    /// triangle is not one of the mesh's.
    pub fn new(hit: Hit, mesh: &Mesh) -> GeometryHit {
        let (geometry, primitive) = mesh.geometry_of(hit.prim).unwrap_or((MISS, MISS));
        GeometryHit {
            hit,
            geometry,
            primitive,
        }
    }
}

/// Decodes a ray file's bytes; `path` names it in errors. A size that is not
/// a multiple of 32, or a ray that cannot be traced (non-finite origin or
/// direction, zero direction, NaN interval, negative `tmin`; see
/// [`Ray::invalid_reason`]) is an error naming the ray.
pub fn parse_rays(bytes: &[u8], path: &Path) -> Result<Vec<Ray>> {
    let err = |message: String| Error::Parse {
        path: path.into(),
        line: None,
        message,
    };
    if !bytes.len().is_multiple_of(RAY_BYTES) {
        return Err(err(format!(
            "size {} bytes is not a multiple of {RAY_BYTES} (one ray is origin xyz, direction xyz, tmin, tmax as little-endian f32)",
            bytes.len()
        )));
    }
    bytes
        .chunks_exact(RAY_BYTES)
        .enumerate()
        .map(|(i, c)| {
            let f: [f32; 8] =
                std::array::from_fn(|k| f32::from_le_bytes(c[4 * k..4 * k + 4].try_into().unwrap()));
            let (origin, direction) = (Vec3::new(f[0], f[1], f[2]), Vec3::new(f[3], f[4], f[5]));
            match Ray::invalid_reason(origin, direction, f[6], f[7]) {
                None => Ok(Ray::new(origin, direction, f[6], f[7])),
                Some(why) => Err(err(format!(
                    "ray {i} (byte {}) cannot be traced: {why} (origin {origin:?}, direction {direction:?}, interval [{}, {}])",
                    i * RAY_BYTES,
                    f[6],
                    f[7]
                ))),
            }
        })
        .collect()
}

/// Reads a ray file.
pub fn read_rays(path: &Path) -> Result<Vec<Ray>> {
    let bytes = std::fs::read(path).map_err(|source| Error::Io {
        path: path.into(),
        source,
    })?;
    parse_rays(&bytes, path)
}

/// Encodes rays in the ray file format.
pub fn encode_rays(rays: &[Ray]) -> Vec<u8> {
    let mut out = Vec::with_capacity(rays.len() * RAY_BYTES);
    for r in rays {
        let (o, d) = (r.origin(), r.direction());
        for v in [o.x, o.y, o.z, d.x, d.y, d.z, r.tmin, r.tmax] {
            out.extend_from_slice(&v.to_le_bytes());
        }
    }
    out
}

/// Encodes hits in the binary hit format.
pub fn encode_hits(hits: &[Option<Hit>]) -> Vec<u8> {
    let mut out = Vec::with_capacity(hits.len() * HIT_BYTES);
    for h in hits {
        for word in words(h) {
            out.extend_from_slice(&word.to_le_bytes());
        }
    }
    out
}

/// Encodes hits in the binary hit format with geometries: each hit's
/// geometry in `mesh` and its index within it after the 16 bytes of
/// [`encode_hits`].
pub fn encode_geometry_hits(hits: &[Option<Hit>], mesh: &Mesh) -> Vec<u8> {
    let mut out = Vec::with_capacity(hits.len() * GEOMETRY_HIT_BYTES);
    for h in hits {
        let (geometry, primitive) = geometry_fields(h, mesh);
        for word in words(h).into_iter().chain([geometry, primitive]) {
            out.extend_from_slice(&word.to_le_bytes());
        }
    }
    out
}

/// Decodes a binary hit file (the inverse of [`encode_hits`]); `None` when
/// its size is not a multiple of 16 bytes.
pub fn decode_hits(bytes: &[u8]) -> Option<Vec<Option<Hit>>> {
    if !bytes.len().is_multiple_of(HIT_BYTES) {
        return None;
    }
    Some(bytes.chunks_exact(HIT_BYTES).map(hit_of).collect())
}

/// Decodes a binary hit file with geometries (the inverse of
/// [`encode_geometry_hits`]); `None` when its size is not a multiple of 24
/// bytes.
pub fn decode_geometry_hits(bytes: &[u8]) -> Option<Vec<Option<GeometryHit>>> {
    if !bytes.len().is_multiple_of(GEOMETRY_HIT_BYTES) {
        return None;
    }
    Some(
        bytes
            .chunks_exact(GEOMETRY_HIT_BYTES)
            .map(|c| {
                hit_of(&c[..HIT_BYTES]).map(|hit| GeometryHit {
                    hit,
                    geometry: word(c, 4),
                    primitive: word(c, 5),
                })
            })
            .collect(),
    )
}

/// Writes hits as CSV text, with each hit's geometry in `mesh` and its
/// index within it in the last two columns.
pub fn write_hits_csv(
    w: &mut impl Write,
    hits: &[Option<Hit>],
    mesh: &Mesh,
) -> std::io::Result<()> {
    writeln!(w, "ray,t,triangle,u,v,geometry,primitive")?;
    for (i, h) in hits.iter().enumerate() {
        let (t, prim, u, v) = fields(h);
        let (geometry, primitive) = geometry_fields(h, mesh);
        writeln!(w, "{i},{t},{prim},{u},{v},{geometry},{primitive}")?;
    }
    Ok(())
}

/// The `k`-th little-endian 32-bit word of `c`.
fn word(c: &[u8], k: usize) -> u32 {
    u32::from_le_bytes([c[4 * k], c[4 * k + 1], c[4 * k + 2], c[4 * k + 3]])
}

/// One 16-byte record.
fn hit_of(c: &[u8]) -> Option<Hit> {
    let prim = word(c, 1);
    (prim != MISS).then(|| Hit {
        t: f32::from_bits(word(c, 0)),
        prim,
        u: f32::from_bits(word(c, 2)),
        v: f32::from_bits(word(c, 3)),
    })
}

/// A hit's 16 bytes as four words.
fn words(h: &Option<Hit>) -> [u32; 4] {
    let (t, prim, u, v) = fields(h);
    [t.to_bits(), prim, u.to_bits(), v.to_bits()]
}

fn fields(h: &Option<Hit>) -> (f32, u32, f32, f32) {
    match h {
        Some(h) => (h.t, h.prim, h.u, h.v),
        None => (f32::INFINITY, MISS, 0.0, 0.0),
    }
}

/// A hit's geometry and index within it; [`MISS`] for both on a miss.
fn geometry_fields(h: &Option<Hit>, mesh: &Mesh) -> (u32, u32) {
    h.and_then(|h| mesh.geometry_of(h.prim))
        .unwrap_or((MISS, MISS))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rays_round_trip_and_bad_sizes_are_refused() {
        let rays = vec![
            Ray::new(
                Vec3::new(1.0, 2.0, 3.0),
                Vec3::new(0.0, -0.0, 5.0),
                0.5,
                9.0,
            ),
            Ray::infinite(Vec3::ZERO, Vec3::X),
        ];
        let bytes = encode_rays(&rays);
        assert_eq!(bytes.len(), 64);
        assert_eq!(parse_rays(&bytes, Path::new("r")).unwrap(), rays);
        let e = parse_rays(&bytes[..40], Path::new("r.bin"))
            .unwrap_err()
            .to_string();
        assert!(e.contains("r.bin") && e.contains("multiple of 32"), "{e}");
    }

    #[test]
    fn untraceable_rays_are_named() {
        let bad = encode_rays(&[
            Ray::infinite(Vec3::ZERO, Vec3::X),
            Ray::infinite(Vec3::ZERO, Vec3::ZERO),
        ]);
        let e = parse_rays(&bad, Path::new("r")).unwrap_err().to_string();
        assert!(e.contains("ray 1"), "{e}");
    }

    #[test]
    fn hits_round_trip() {
        let hits = vec![
            None,
            Some(Hit {
                t: 1.5,
                prim: 7,
                u: 0.25,
                v: 0.5,
            }),
        ];
        let bytes = encode_hits(&hits);
        assert_eq!(&bytes[0..8], &[0, 0, 0x80, 0x7f, 0xff, 0xff, 0xff, 0xff]);
        assert_eq!(decode_hits(&bytes).unwrap(), hits);
        let mut csv = Vec::new();
        let mesh = eight_triangles();
        write_hits_csv(&mut csv, &hits, &mesh).unwrap();
        assert_eq!(
            String::from_utf8(csv).unwrap(),
            "ray,t,triangle,u,v,geometry,primitive\n0,inf,4294967295,0,0,4294967295,4294967295\n1,1.5,7,0.25,0.5,1,2\n"
        );
    }

    /// Eight triangles in two geometries of 5 and 3.
    fn eight_triangles() -> Mesh {
        use crate::scene::Geometry;
        let geometry = |name: &str, first_triangle, triangle_count| Geometry {
            name: name.into(),
            first_triangle,
            triangle_count,
        };
        Mesh {
            positions: vec![Vec3::ZERO, Vec3::X, Vec3::Y],
            indices: vec![[0, 1, 2]; 8],
            geometries: vec![geometry("a", 0, 5), geometry("b", 5, 3)],
        }
    }

    #[test]
    fn geometry_hits_round_trip_and_keep_the_first_16_bytes() {
        let mesh = eight_triangles();
        let hit = |prim| Hit {
            t: 2.5,
            prim,
            u: 0.125,
            v: 0.0,
        };
        let hits = vec![Some(hit(4)), None, Some(hit(5)), Some(hit(9))];
        let bytes = encode_geometry_hits(&hits, &mesh);
        assert_eq!(bytes.len(), 4 * GEOMETRY_HIT_BYTES);
        let plain = encode_hits(&hits);
        for (long, short) in bytes.chunks(24).zip(plain.chunks(16)) {
            assert_eq!(&long[..16], short);
        }
        assert_eq!(&bytes[40..48], &[0xff; 8]);
        let back = decode_geometry_hits(&bytes).unwrap();
        assert_eq!(
            back,
            vec![
                Some(GeometryHit::new(hit(4), &mesh)),
                None,
                Some(GeometryHit::new(hit(5), &mesh)),
                Some(GeometryHit::new(hit(9), &mesh)),
            ]
        );
        let got: Vec<_> = back
            .iter()
            .flatten()
            .map(|g| (g.geometry, g.primitive))
            .collect();
        // Triangle 9 is not the mesh's: no geometry.
        assert_eq!(got, [(0, 4), (1, 0), (MISS, MISS)]);
        assert!(decode_geometry_hits(&bytes[..30]).is_none());
    }
}
