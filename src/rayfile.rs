//! The ray and hit file formats of `raytree trace`.
//!
//! - Ray file: little-endian, no header, 32 bytes per ray: origin x y z,
//!   direction x y z (any length), tmin, tmax, all f32.
//! - Hit file: 16 bytes per ray: t (f32, +inf on a miss), triangle index
//!   (u32, mesh order, `0xFFFFFFFF` on a miss), barycentrics u and v (f32).
//! - Hit CSV: a header `ray,t,triangle,u,v` and one line per ray, with the
//!   same values as the binary file.

use crate::error::{Error, Result};
use crate::geometry::{Hit, Ray};
use glam::Vec3;
use std::io::Write;
use std::path::Path;

/// Bytes per ray in a ray file: eight little-endian f32.
pub const RAY_BYTES: usize = 32;
/// Bytes per hit in a hit file: `t`, triangle index, `u`, `v`.
pub const HIT_BYTES: usize = 16;
/// The triangle index written for a miss.
pub const MISS: u32 = u32::MAX;

/// Decodes a ray file's bytes; `path` names it in errors. A size that is not
/// a multiple of 32, or a ray that cannot be traced (non-finite origin or
/// direction, zero direction, NaN interval) is an error naming the ray.
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
        let (t, prim, u, v) = fields(h);
        out.extend_from_slice(&t.to_le_bytes());
        out.extend_from_slice(&prim.to_le_bytes());
        out.extend_from_slice(&u.to_le_bytes());
        out.extend_from_slice(&v.to_le_bytes());
    }
    out
}

/// Decodes a binary hit file (the inverse of [`encode_hits`]).
pub fn decode_hits(bytes: &[u8]) -> Option<Vec<Option<Hit>>> {
    if !bytes.len().is_multiple_of(HIT_BYTES) {
        return None;
    }
    Some(
        bytes
            .chunks_exact(HIT_BYTES)
            .map(|c| {
                let w = |k: usize| <[u8; 4]>::try_from(&c[4 * k..4 * k + 4]).unwrap();
                let prim = u32::from_le_bytes(w(1));
                (prim != MISS).then(|| Hit {
                    t: f32::from_le_bytes(w(0)),
                    prim,
                    u: f32::from_le_bytes(w(2)),
                    v: f32::from_le_bytes(w(3)),
                })
            })
            .collect(),
    )
}

/// Writes hits as CSV text.
pub fn write_hits_csv(w: &mut impl Write, hits: &[Option<Hit>]) -> std::io::Result<()> {
    writeln!(w, "ray,t,triangle,u,v")?;
    for (i, h) in hits.iter().enumerate() {
        let (t, prim, u, v) = fields(h);
        writeln!(w, "{i},{t},{prim},{u},{v}")?;
    }
    Ok(())
}

fn fields(h: &Option<Hit>) -> (f32, u32, f32, f32) {
    match h {
        Some(h) => (h.t, h.prim, h.u, h.v),
        None => (f32::INFINITY, MISS, 0.0, 0.0),
    }
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
        write_hits_csv(&mut csv, &hits).unwrap();
        assert_eq!(
            String::from_utf8(csv).unwrap(),
            "ray,t,triangle,u,v\n0,inf,4294967295,0,0\n1,1.5,7,0.25,0.5\n"
        );
    }
}
