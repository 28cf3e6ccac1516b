//! The ray-triangle test for the cases f32 cannot decide: triangles tiny
//! against their distance from the ray's origin, coordinates whose products
//! overflow or underflow f32.
//!
//! The three edge functions are the triple products
//! `E(p, q) = det(p - o, q - o, d) = (q - p) · (d × (p - o))` of the ray's
//! own origin `o` and direction `d` (not the sheared frame, whose rounded
//! shear constants move a far ray by more than a small triangle's size),
//! evaluated in double-double arithmetic: `p - o` and `q - p` are exact
//! (two-sum of f64), `d × (p - o)` is a sum of exact products (two-product
//! by fused multiply-add), so the result carries a relative error of about
//! 2⁻¹⁰⁰ of `|d|·|p - o|·|q - p|`. Each edge is evaluated with its two
//! vertices in one canonical order, so two triangles sharing an edge get
//! exactly opposite values: this path is watertight too.

use super::Ray;
use glam::Vec3;

/// An unevaluated sum `hi + lo` with `|lo| <= ulp(hi) / 2`.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Dd {
    hi: f64,
    lo: f64,
}

/// `a + b` exactly, as `s + e` (Knuth's two-sum).
#[inline]
fn two_sum(a: f64, b: f64) -> Dd {
    let s = a + b;
    let bb = s - a;
    let e = (a - (s - bb)) + (b - bb);
    Dd { hi: s, lo: e }
}

/// `a + b` exactly, for `|a| >= |b|`.
#[inline]
fn quick_two_sum(a: f64, b: f64) -> Dd {
    let s = a + b;
    Dd {
        hi: s,
        lo: b - (s - a),
    }
}

/// `a · b` exactly, as `p + e` (the error term by fused multiply-add).
#[inline]
fn two_prod(a: f64, b: f64) -> Dd {
    let p = a * b;
    Dd {
        hi: p,
        lo: a.mul_add(b, -p),
    }
}

impl Dd {
    /// An f32, exactly.
    fn exact(x: f32) -> Dd {
        Dd {
            hi: x as f64,
            lo: 0.0,
        }
    }

    fn add(self, o: Dd) -> Dd {
        let s = two_sum(self.hi, o.hi);
        let t = two_sum(self.lo, o.lo);
        let r = quick_two_sum(s.hi, s.lo + t.hi);
        quick_two_sum(r.hi, r.lo + t.lo)
    }

    fn neg(self) -> Dd {
        Dd {
            hi: -self.hi,
            lo: -self.lo,
        }
    }

    fn mul(self, o: Dd) -> Dd {
        let p = two_prod(self.hi, o.hi);
        quick_two_sum(p.hi, p.lo + (self.hi * o.lo + self.lo * o.hi))
    }

    fn value(self) -> f64 {
        self.hi + self.lo
    }
}

/// `p - o` per axis, exactly.
fn diff(p: Vec3, o: Vec3) -> [Dd; 3] {
    [0, 1, 2].map(|i| two_sum(p[i] as f64, -(o[i] as f64)))
}

fn dot(a: &[Dd; 3], b: &[Dd; 3]) -> Dd {
    a[0].mul(b[0]).add(a[1].mul(b[1])).add(a[2].mul(b[2]))
}

/// `d × p` with `d` exact in f64.
fn cross(d: Vec3, p: &[Dd; 3]) -> [Dd; 3] {
    let d = [0, 1, 2].map(|i| Dd::exact(d[i]));
    [
        d[1].mul(p[2]).add(d[2].mul(p[1]).neg()),
        d[2].mul(p[0]).add(d[0].mul(p[2]).neg()),
        d[0].mul(p[1]).add(d[1].mul(p[0]).neg()),
    ]
}

/// The bit pattern order that makes `edge(p, q) == -edge(q, p)` exact.
fn key(p: Vec3) -> [u32; 3] {
    p.to_array().map(f32::to_bits)
}

/// `det(p - o, q - o, d)`: positive when `q` is counter-clockwise of `p`
/// seen from behind the origin along `d`.
fn edge(p: Vec3, q: Vec3, o: Vec3, d: Vec3) -> Dd {
    if key(p) > key(q) {
        return edge(q, p, o, d).neg();
    }
    dot(&diff(q, p), &cross(d, &diff(p, o)))
}

/// The watertight test over `[tmin, tmax]` (both inclusive) in
/// double-double arithmetic: `(t, u, v)` for the hit point
/// `(1-u-v)·a + u·b + v·c`, or `None`. A hit whose `t` is not a finite f32
/// is a miss.
pub(super) fn intersect(
    a: Vec3,
    b: Vec3,
    c: Vec3,
    ray: &Ray,
    tmin: f32,
    tmax: f32,
) -> Option<(f32, f32, f32)> {
    let (o, d) = (ray.origin(), ray.direction());
    // Weights of a, b and c in the hit point.
    let wa = edge(b, c, o, d);
    let wb = edge(c, a, o, d);
    let wc = edge(a, b, o, d);
    let (ea, eb, ec) = (wa.value(), wb.value(), wc.value());
    if (ea < 0.0 || eb < 0.0 || ec < 0.0) && (ea > 0.0 || eb > 0.0 || ec > 0.0) {
        return None;
    }
    let sum = wa.add(wb).add(wc).value();
    if sum == 0.0 || !sum.is_finite() {
        return None;
    }
    // The plane n·(x - a) = 0 with n = (b - a) × (c - a): t = n·(a - o) / n·d.
    let (ab, ac) = (diff(b, a), diff(c, a));
    let [abx, aby, abz] = ab.map(Dd::value);
    let [acx, acy, acz] = ac.map(Dd::value);
    let n = [
        aby * acz - abz * acy,
        abz * acx - abx * acz,
        abx * acy - aby * acx,
    ]
    .map(|x| Dd { hi: x, lo: 0.0 });
    let dn = [0, 1, 2].map(|i| Dd::exact(d[i]));
    let den = dot(&n, &dn).value();
    if den == 0.0 || !den.is_finite() {
        return None;
    }
    // The interval is checked before rounding to f32: a plane a hair behind
    // the origin has a t that rounds to -0.0, which is not below tmin = 0.
    let t = dot(&n, &diff(a, o)).value() / den;
    if !(t >= tmin as f64 && t <= tmax as f64) {
        return None;
    }
    let t = t as f32;
    if !t.is_finite() {
        return None;
    }
    let u = (eb / sum) as f32;
    let v = (ec / sum) as f32;
    Some((t, u, v))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn two_sum_and_two_prod_are_exact() {
        let s = two_sum(1e20, 1.0);
        assert_eq!(s.hi, 1e20);
        assert_eq!(s.lo, 1.0);
        let p = two_prod(1.0 + f64::EPSILON, 1.0 + f64::EPSILON);
        assert_eq!(p.hi, 1.0 + 2.0 * f64::EPSILON);
        assert_eq!(p.lo, f64::EPSILON * f64::EPSILON);
    }

    #[test]
    fn edges_swap_sign_exactly() {
        let o = Vec3::new(1e21, -3e20, 7e19);
        let d = Vec3::new(-0.7, 0.2, -0.1);
        let p = Vec3::new(1.5, 2.25, -3.0);
        let q = Vec3::new(-1.0, 0.125, 4.0);
        assert_eq!(edge(p, q, o, d), edge(q, p, o, d).neg());
        assert_ne!(edge(p, q, o, d).value(), 0.0);
    }
}
