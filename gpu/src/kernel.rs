//! The WGSL kernels: the shared prelude and one file per traversal.

use raytree::geometry::{ILL_CONDITIONED, TINY_DETERMINANT, TINY_SCALE, WIDENING_STEP};
use raytree::structures::shared::interval::SLACK;
use raytree::structures::shared::leaf::TIE_MARGIN;

const PRELUDE: &str = include_str!("wgsl/prelude.wgsl");
const BVH_STACK: &str = include_str!("wgsl/bvh_stack.wgsl");
const SPARSE_STACK: &str = include_str!("wgsl/sparse_stack.wgsl");
const SPARSE: &str = include_str!("wgsl/sparse.wgsl");
const HAPALA: &str = include_str!("wgsl/hapala.wgsl");
const LAINE: &str = include_str!("wgsl/laine.wgsl");
const IMPLICIT_B: &str = include_str!("wgsl/implicit_b.wgsl");
const DST: &str = include_str!("wgsl/dst.wgsl");
const WIDE: &str = include_str!("wgsl/wide.wgsl");

/// The f64 edge functions of the CPU's triangle test: both products are
/// exact in f64 (24-bit by 24-bit significands), so the difference is
/// rounded once, fused or not, and equals the CPU's bit for bit.
const EDGE_F64: &str = "
fn edge64(p: f32, q: f32, r: f32, t: f32) -> f32 {
    return f32(f64(p) * f64(q) - f64(r) * f64(t));
}
";

const EDGE_F64_CALLS: &str = "u = edge64(cx, by, cy, bx);
        v = edge64(ax, cy, ay, cx);
        w = edge64(bx, ay, by, ax);";

/// A GPU traversal kernel, named after the CPU kernel it mirrors.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Kernel {
    /// STACK over the binary BVH's 52-byte nodes (`structures/bvh/stack.rs`).
    BvhStack,
    /// STACK over the sparse layout's 32-byte own-box nodes (`structures/sparse/stack.rs`).
    SparseStack,
    /// SPARSE, the stackless paper's Algorithm 4 (`structures/sparse/sparse.rs`).
    Sparse,
    /// HAPALA over parent links (`structures/sparse/hapala.rs`).
    Hapala,
    /// IMPLICIT-B, Algorithm 3, over the implicit heap layout (`structures/implicit/traverse.rs`).
    ImplicitB,
    /// The dual-split tree's Algorithm 1 (`structures/dst/traverse.rs`),
    /// identical or similar conversion alike.
    Dst,
    /// LAINE-k with a short stack of `k` entries (`structures/sparse/laine.rs`).
    Laine(u32),
    /// The wide BVHs' traversal (`structures/wide/traverse.rs`) over nodes
    /// of 4 (`bvh4`) or 8 (`bvh8`) children and their triangle blocks.
    Wide(u32),
}

impl Kernel {
    /// The kernel's file, as named in ARCHITECTURE.md.
    pub fn file(&self) -> &'static str {
        match self {
            Kernel::BvhStack => "bvh_stack.wgsl",
            Kernel::SparseStack => "sparse_stack.wgsl",
            Kernel::Sparse => "sparse.wgsl",
            Kernel::Hapala => "hapala.wgsl",
            Kernel::Laine(_) => "laine.wgsl",
            Kernel::ImplicitB => "implicit_b.wgsl",
            Kernel::Dst => "dst.wgsl",
            Kernel::Wide(_) => "wide.wgsl",
        }
    }

    /// The full WGSL source: constants, prelude, kernel; `stack` is the
    /// private stack's size for the stack kernels (entries).
    pub(crate) fn source(&self, stack: usize, f64: bool) -> String {
        let body = match self {
            Kernel::BvhStack => BVH_STACK.to_string(),
            Kernel::SparseStack => SPARSE_STACK.to_string(),
            Kernel::Sparse => SPARSE.to_string(),
            Kernel::Hapala => HAPALA.to_string(),
            Kernel::Laine(k) => LAINE.replace("SHORT_K", &format!("{k}u")),
            Kernel::ImplicitB => IMPLICIT_B.to_string(),
            Kernel::Dst => DST.to_string(),
            Kernel::Wide(w) => format!(
                "const WIDTH: u32 = {w}u;\nconst NODE_WORDS: u32 = {}u;\n{WIDE}",
                wide_node_words(*w)
            ),
        };
        let consts = [
            ("ILL_CONDITIONED", ILL_CONDITIONED),
            ("TINY_SCALE", TINY_SCALE),
            ("TINY_DETERMINANT", TINY_DETERMINANT),
            ("TIE_MARGIN", TIE_MARGIN),
            ("WIDENING_STEP", WIDENING_STEP),
            ("SLACK", SLACK),
            ("MIN_NORMAL", f32::MIN_POSITIVE),
        ]
        .map(|(name, v)| format!("const {name}: f32 = {};\n", hex_f32(v)))
        .concat();
        let prelude = if f64 {
            PRELUDE.replace("EDGE_FALLBACK", EDGE_F64_CALLS) + EDGE_F64
        } else {
            PRELUDE.replace("EDGE_FALLBACK", "return DEFER;")
        };
        format!(
            "{consts}const STACK_SIZE: u32 = {stack}u;\n{prelude}\n{}",
            body.replace("STACK_SIZE", &stack.to_string())
        )
    }
}

/// Words of a `WideNode` record of width `w` (4 or 8), padding included:
/// the stride of the nodes uploaded.
pub(crate) fn wide_node_words(w: u32) -> usize {
    use raytree::structures::wide::WideNode;
    match w {
        4 => std::mem::size_of::<WideNode<4>>() / 4,
        8 => std::mem::size_of::<WideNode<8>>() / 4,
        _ => unreachable!("wide BVHs are 4 or 8 wide"),
    }
}

/// A normal, positive f32 as an exact WGSL hexadecimal float literal.
fn hex_f32(v: f32) -> String {
    assert!(v.is_normal() && v > 0.0);
    let bits = v.to_bits();
    let exp = ((bits >> 23) & 0xff) as i32 - 127;
    let mantissa = (bits & 0x7f_ffff) << 1; // 24 bits: six hex digits
    format!("0x1.{mantissa:06x}p{exp}f")
}

#[cfg(test)]
mod tests {
    use super::*;
    use raytree::geometry::ROBUST_WIDENING;

    #[test]
    fn hex_literals_are_exact() {
        assert_eq!(hex_f32(1.0), "0x1.000000p0f");
        assert_eq!(hex_f32(0.75), "0x1.800000p-1f");
        assert_eq!(hex_f32(TIE_MARGIN), "0x1.000000p-17f");
        // Read back through the literal's definition.
        let s = hex_f32(ROBUST_WIDENING);
        let m = u32::from_str_radix(&s[4..10], 16).unwrap();
        let e: i32 = s[11..s.len() - 1].parse().unwrap();
        let back = (1.0 + m as f64 / (1u64 << 24) as f64) * 2f64.powi(e);
        assert_eq!(back as f32, ROBUST_WIDENING);
    }
}
