//! The dual-split tree's node encoding (Lin et al. 2019, §4.1): a 32-bit
//! word with a 6-bit header (bits 26–31) and a 26-bit offset (bits 0–25);
//! nodes with planes add two f32 plane positions (12 bytes in all), plain
//! leaves are the word alone (4 bytes).
//!
//! Header bits, b5 (bit 31) down to b0 (bit 26):
//!
//! | node | b5 | b4 | b3 b2 | b1 b0 |
//! |---|---|---|---|---|
//! | splitting | 0 | 0 | axis (00 x, 01 y, 10 z) | size of the first child in words (01 or 11) |
//! | single-axis carving | 0 | 1 | leaf, 0 | axis |
//! | plain leaf | 0 | 1 | 1, 1 | unused |
//! | dual-axis carving | 1 | leaf | axes (00 xy, 01 xz, 11 yz) | corner |
//!
//! The corner of a dual-axis node says which side each plane bounds: bit 0
//! for the first axis, bit 1 for the second; 0 means the plane is the
//! minimum of the non-empty region (empty below it), 1 its maximum (empty
//! above). The offset of an inner node is the word distance from the node
//! to its first child (children follow their parent); the offset of a leaf
//! is the position of its first triangle in the index list.

use crate::error::{Error, Result};
use crate::structures::shared::interval::face_code;

/// Planes a split or carving node stores after its header word (a 12-byte
/// node: §4.1).
pub(super) const NODE_PLANES: usize = 2;
/// Bits of the offset field.
pub(super) const OFFSET_BITS: u32 = 26;
pub(super) const OFFSET_MASK: u32 = (1 << OFFSET_BITS) - 1;

/// A decoded node.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum DstNode {
    /// Two planes on `axis`: the first child's maximum and the second
    /// child's minimum. `first_words` is the first child's size (1 or 3).
    Split {
        /// The splitting axis: 0 = x, 1 = y, 2 = z.
        axis: u8,
        /// `[first child's maximum, second child's minimum]` on `axis`, in
        /// scene units.
        planes: [f32; 2],
        /// Words of the first child (1 or 3): the second child follows it.
        first_words: u8,
        /// Words from this node to its first child (26 bits).
        offset: u32,
    },
    /// The non-empty region is `planes[0] ..= planes[1]` on `axis`.
    CarveSingle {
        /// The carving axis: 0 = x, 1 = y, 2 = z.
        axis: u8,
        /// `[minimum, maximum]` of the non-empty region on `axis`, in scene units.
        planes: [f32; 2],
        /// Whether the node is a leaf: `offset` then indexes the triangle list.
        leaf: bool,
        /// Words to the only child, or for a leaf its first triangle's
        /// position in the index list (26 bits).
        offset: u32,
    },
    /// Plane `k` bounds axis `axes[k]`, as its minimum (`max_side[k] =
    /// false`) or maximum.
    CarveDual {
        /// The two axes, ascending: xy, xz or yz (`[0, 1]`, `[0, 2]`, `[1, 2]`).
        axes: [u8; 2],
        /// Per plane, whether it is the region's maximum on its axis (the
        /// header's corner bits, Figure 5).
        max_side: [bool; 2],
        /// Plane positions on `axes[0]` and `axes[1]`, in scene units.
        planes: [f32; 2],
        /// Whether the node is a leaf: `offset` then indexes the triangle list.
        leaf: bool,
        /// Words to the only child, or for a leaf its first triangle's
        /// position in the index list (26 bits).
        offset: u32,
    },
    /// Triangles from `offset` in the index list.
    Leaf {
        /// Position of the leaf's first triangle in the index list (26 bits).
        offset: u32,
    },
}

/// Header of a plain leaf.
pub(super) const LEAF_HEADER: u32 = 0b01_1100;

/// Whether header `h` is a splitting node's.
#[inline(always)]
pub(super) const fn is_split(h: u32) -> bool {
    h & 0b11_0000 == 0
}

/// A carving node's two planes as region faces (`2·axis + max_side`, see
/// [`crate::structures::shared::interval::face_code`]) and its leaf bit: the
/// traversal decodes single- and dual-axis nodes alike by one table lookup
/// of the header, [`CARVE_FACES`], instead of branching on their kind.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) struct CarveFaces {
    pub faces: [u8; 2],
    pub leaf: bool,
}

/// [`CarveFaces`] by header; entries of other headers are unused.
pub(super) const CARVE_FACES: [CarveFaces; 64] = carve_faces();

const fn carve_faces() -> [CarveFaces; 64] {
    let mut table = [CarveFaces {
        faces: [0, 1],
        leaf: false,
    }; 64];
    let mut h = 0;
    while h < 64 {
        if h & 0b10_0000 != 0 {
            let axes = pair_axes(h as u32 >> 2 & 0b11);
            table[h] = CarveFaces {
                faces: [
                    face_code(axes[0] as usize, h & 1 != 0) as u8,
                    face_code(axes[1] as usize, h & 2 != 0) as u8,
                ],
                leaf: h & 0b1_0000 != 0,
            };
        } else if h & 0b1_0000 != 0 && h & 0b100 == 0 && h & 0b11 != 3 {
            let a = h & 0b11;
            table[h] = CarveFaces {
                faces: [face_code(a, false) as u8, face_code(a, true) as u8],
                leaf: h & 0b1000 != 0,
            };
        }
        h += 1;
    }
    table
}

/// The paper's codes of the dual-axis pairs.
pub(super) const PAIRS: [([u8; 2], u32); 3] = [([0, 1], 0b00), ([0, 2], 0b01), ([1, 2], 0b11)];

/// The axes of dual-axis pair `code`; the unused code 0b10 reads as yz.
const fn pair_axes(code: u32) -> [u8; 2] {
    let mut i = 0;
    while i < PAIRS.len() {
        if PAIRS[i].1 == code {
            return PAIRS[i].0;
        }
        i += 1;
    }
    [1, 2]
}

impl DstNode {
    /// Words this node takes: 1 for a plain leaf, 3 otherwise.
    pub fn words(&self) -> usize {
        match self {
            DstNode::Leaf { .. } => 1,
            _ => 3,
        }
    }

    /// Whether the node holds triangles: a plain leaf or a carving leaf.
    pub fn is_leaf(&self) -> bool {
        match *self {
            DstNode::Leaf { .. } => true,
            DstNode::CarveSingle { leaf, .. } | DstNode::CarveDual { leaf, .. } => leaf,
            DstNode::Split { .. } => false,
        }
    }

    /// Appends the node's words (1 or 3). An offset that does not fit 26
    /// bits is an [`Error::Limit`] naming the limit.
    pub fn encode(&self, out: &mut Vec<u32>) -> Result<()> {
        let (header, offset, planes) = match *self {
            DstNode::Split {
                axis,
                planes,
                first_words,
                offset,
            } => {
                debug_assert!(axis < 3 && (first_words == 1 || first_words == 3));
                (
                    (axis as u32) << 2 | first_words as u32,
                    offset,
                    Some(planes),
                )
            }
            DstNode::CarveSingle {
                axis,
                planes,
                leaf,
                offset,
            } => (
                0b01_0000 | (leaf as u32) << 3 | axis as u32,
                offset,
                Some(planes),
            ),
            DstNode::CarveDual {
                axes,
                max_side,
                planes,
                leaf,
                offset,
            } => {
                let code = PAIRS
                    .iter()
                    .find(|p| p.0 == axes)
                    .map(|p| p.1)
                    .expect("axes are one of xy, xz, yz");
                let corner = max_side[0] as u32 | (max_side[1] as u32) << 1;
                (
                    0b10_0000 | (leaf as u32) << 4 | code << 2 | corner,
                    offset,
                    Some(planes),
                )
            }
            DstNode::Leaf { offset } => (0b01_1100, offset, None),
        };
        if offset > OFFSET_MASK {
            return Err(Error::Limit(format!(
                "dual-split tree offset {offset} does not fit the node's {OFFSET_BITS}-bit offset field (at most {OFFSET_MASK}); the tree or its triangle index list is too large for this encoding; use a smaller scene, or a structure without this limit (bvh, cbvh)"
            )));
        }
        out.push(header << OFFSET_BITS | offset);
        if let Some([a, b]) = planes {
            out.push(a.to_bits());
            out.push(b.to_bits());
        }
        Ok(())
    }

    /// Decodes untrusted words: `None` unless `words` starts with a whole,
    /// well-formed node (a known header with its unused bits clear, a
    /// first-child size of 1 or 3, an axis below 3, a known axis pair), so
    /// that encoding the result gives back exactly those words.
    pub fn try_decode(words: &[u32]) -> Option<DstNode> {
        let h = *words.first()? >> OFFSET_BITS;
        let (well_formed, len) = if h & 0b10_0000 != 0 {
            ((h >> 2) & 0b11 != 0b10, 3)
        } else if h & 0b1_0000 == 0 {
            ((h >> 2) & 0b11 != 3 && matches!(h & 0b11, 1 | 3), 3)
        } else if h & 0b100 != 0 {
            (h == 0b01_1100, 1)
        } else {
            (h & 0b11 != 3, 3)
        };
        (well_formed && words.len() >= len).then(|| Self::decode(words))
    }

    /// Decodes the node whose header word is `words[0]`, from a tree this
    /// crate encoded (see [`Self::try_decode`] for untrusted words).
    #[inline(always)]
    pub fn decode(words: &[u32]) -> DstNode {
        let w = words[0];
        let h = w >> OFFSET_BITS;
        let offset = w & OFFSET_MASK;
        let planes = || [f32::from_bits(words[1]), f32::from_bits(words[2])];
        if h & 0b10_0000 != 0 {
            let code = (h >> 2) & 0b11;
            let axes = pair_axes(code);
            DstNode::CarveDual {
                axes,
                max_side: [h & 1 != 0, h & 2 != 0],
                planes: planes(),
                leaf: h & 0b1_0000 != 0,
                offset,
            }
        } else if h & 0b1_0000 == 0 {
            DstNode::Split {
                axis: ((h >> 2) & 0b11) as u8,
                planes: planes(),
                first_words: (h & 0b11) as u8,
                offset,
            }
        } else if h & 0b100 != 0 {
            DstNode::Leaf { offset }
        } else {
            DstNode::CarveSingle {
                axis: (h & 0b11) as u8,
                planes: planes(),
                leaf: h & 0b1000 != 0,
                offset,
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_kind_round_trips_bit_for_bit() {
        let mut nodes = vec![DstNode::Leaf { offset: 12345 }];
        for axis in 0..3 {
            for first_words in [1, 3] {
                nodes.push(DstNode::Split {
                    axis,
                    planes: [1.5, -2.0],
                    first_words,
                    offset: 7,
                });
            }
            for leaf in [false, true] {
                nodes.push(DstNode::CarveSingle {
                    axis,
                    planes: [-0.0, f32::MAX],
                    leaf,
                    offset: OFFSET_MASK,
                });
            }
        }
        for (axes, _) in PAIRS {
            for corner in 0..4 {
                for leaf in [false, true] {
                    nodes.push(DstNode::CarveDual {
                        axes,
                        max_side: [corner & 1 != 0, corner & 2 != 0],
                        planes: [3.0, 4.0],
                        leaf,
                        offset: 99,
                    });
                }
            }
        }
        // 3 split axes × 2 sizes, 3 × 2 single, 12 × 2 dual, a leaf.
        assert_eq!(nodes.len(), 1 + 6 + 6 + 24);
        let mut words = Vec::new();
        for n in &nodes {
            n.encode(&mut words).unwrap();
        }
        let mut at = 0;
        for n in &nodes {
            let d = DstNode::decode(&words[at..]);
            assert_eq!(&d, n);
            at += d.words();
        }
        assert_eq!(at, words.len());
        // Exactly the documented headers.
        assert_eq!(words[0] >> OFFSET_BITS, 0b01_1100);
    }

    #[test]
    fn the_carving_table_matches_the_decoder_for_every_header() {
        let mut carving = 0;
        for h in 0..64u32 {
            let words = [h << OFFSET_BITS, 0, 0];
            let Some(node) = DstNode::try_decode(&words) else {
                continue;
            };
            assert_eq!(
                is_split(h),
                matches!(node, DstNode::Split { .. }),
                "{h:06b}"
            );
            assert_eq!(h == LEAF_HEADER, matches!(node, DstNode::Leaf { .. }));
            let want = match node {
                DstNode::CarveSingle { axis, leaf, .. } => CarveFaces {
                    faces: [2 * axis, 2 * axis + 1],
                    leaf,
                },
                DstNode::CarveDual {
                    axes,
                    max_side,
                    leaf,
                    ..
                } => CarveFaces {
                    faces: [
                        2 * axes[0] + max_side[0] as u8,
                        2 * axes[1] + max_side[1] as u8,
                    ],
                    leaf,
                },
                _ => continue,
            };
            assert_eq!(CARVE_FACES[h as usize], want, "header {h:06b}");
            carving += 1;
        }
        // 3 single-axis and 12 dual-axis kinds, each leaf or not.
        assert_eq!(carving, 30);
    }

    #[test]
    fn offsets_beyond_26_bits_are_refused() {
        let mut w = Vec::new();
        let e = DstNode::Leaf { offset: 1 << 26 }
            .encode(&mut w)
            .unwrap_err()
            .to_string();
        assert!(e.contains("26-bit"), "{e}");
        assert!(w.is_empty());
    }
}
