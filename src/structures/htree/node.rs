//! The H-tree's node encoding: a 32-bit header word, then the node's planes
//! as `f32` words.
//!
//! | kind | bits 30–31 | bits 28–29 | bits 0–27 | then | bytes |
//! |---|---|---|---|---|---|
//! | split | 00 | axis | word offset of the second child | first child's max, second child's min | 12 |
//! | bound | 01 | 0 | bits 0–5: face mask | one plane per face, in mask order | 4 + 4·faces |
//! | leaf | 10 | bits 0–29: first triangle in the index list | | | 4 |
//!
//! A split node's first child follows its three words; its second child is
//! `offset` words after the node. A bound node's one child follows its
//! planes. Face `k` of the mask (bit `k`) is `[min x, min y, min z, max x,
//! max y, max z][k]`: a bound node stores only the faces by which its cell
//! is larger than its child's box, so the full-box node (mask `0b111111`,
//! 28 bytes) is Havran's bounding-box node and the other 62 masks are
//! cheaper "types" of bounding node.

use crate::error::{Error, Result};

/// Planes a split node stores after its header word (12 bytes).
pub(super) const SPLIT_PLANES: usize = 2;
/// Header bits holding a split node's second-child offset.
pub(super) const OFFSET_BITS: u32 = 28;
pub(super) const OFFSET_MASK: u32 = (1 << OFFSET_BITS) - 1;
/// Header bits holding a leaf's index-list position.
pub(super) const LEAF_MASK: u32 = (1 << 30) - 1;

const KIND_SPLIT: u32 = 0;
const KIND_BOUND: u32 = 1;
const KIND_LEAF: u32 = 2;

/// A decoded node.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum HNode {
    /// Two planes on `axis`: the first child's maximum and the second
    /// child's minimum; the second child is `second` words on.
    Split {
        /// The splitting axis: 0 = x, 1 = y, 2 = z.
        axis: u8,
        /// `[first child's maximum, second child's minimum]` on `axis`, in
        /// scene units; they may overlap.
        planes: [f32; 2],
        /// Words from this node to its second child (28 bits).
        second: u32,
    },
    /// The faces in `mask` (see the module documentation), `planes[..n]`
    /// with `n = mask.count_ones()`.
    Bound {
        /// Bit `k` set: face `k` of `[min x, min y, min z, max x, max y,
        /// max z]` is stored (1 to 63).
        mask: u8,
        /// The stored faces' positions in mask order, in scene units; the
        /// entries past `mask.count_ones()` are unused.
        planes: [f32; 6],
    },
    /// Triangles from `offset` in the index list.
    Leaf {
        /// Position of the leaf's first triangle in the index list (30 bits).
        offset: u32,
    },
}

impl HNode {
    /// Words the node takes.
    pub fn words(&self) -> usize {
        match self {
            HNode::Split { .. } => 3,
            HNode::Bound { mask, .. } => 1 + mask.count_ones() as usize,
            HNode::Leaf { .. } => 1,
        }
    }

    /// Appends the node's words; an offset beyond its field is an
    /// [`Error::Limit`] naming the limit.
    pub fn encode(&self, out: &mut Vec<u32>) -> Result<()> {
        let too_big = |what: &str, v: u32, max: u32| {
            Err(Error::Limit(format!(
                "H-tree {what} {v} does not fit its field (at most {max}); the tree is too large for this encoding; use a smaller scene, or a structure without this limit (bvh, cbvh)"
            )))
        };
        match *self {
            HNode::Split {
                axis,
                planes,
                second,
            } => {
                if second > OFFSET_MASK {
                    return too_big("child offset", second, OFFSET_MASK);
                }
                debug_assert!(axis < 3);
                out.push(KIND_SPLIT << 30 | (axis as u32) << OFFSET_BITS | second);
                out.extend(planes.map(f32::to_bits));
            }
            HNode::Bound { mask, planes } => {
                debug_assert!(mask != 0 && mask < 64);
                out.push(KIND_BOUND << 30 | mask as u32);
                out.extend(
                    planes[..mask.count_ones() as usize]
                        .iter()
                        .map(|p| p.to_bits()),
                );
            }
            HNode::Leaf { offset } => {
                if offset > LEAF_MASK {
                    return too_big("index-list position", offset, LEAF_MASK);
                }
                out.push(KIND_LEAF << 30 | offset);
            }
        }
        Ok(())
    }

    /// Decodes untrusted words: `None` unless `words` starts with a whole,
    /// well-formed node (a known kind, an axis below 3, a non-empty face
    /// mask, unused bits clear), so that encoding the result gives back
    /// exactly those words.
    pub fn try_decode(words: &[u32]) -> Option<HNode> {
        let w = *words.first()?;
        let (well_formed, len) = match w >> 30 {
            KIND_SPLIT => (w >> OFFSET_BITS & 3 != 3, 3),
            KIND_BOUND => (
                w & !(KIND_BOUND << 30) < 64 && w & 63 != 0,
                1 + (w & 63).count_ones() as usize,
            ),
            KIND_LEAF => (true, 1),
            _ => (false, 1),
        };
        (well_formed && words.len() >= len).then(|| Self::decode(words))
    }

    /// Decodes the node whose header is `words[0]`, from a tree this crate
    /// encoded (see [`Self::try_decode`] for untrusted words).
    #[inline(always)]
    pub fn decode(words: &[u32]) -> HNode {
        let w = words[0];
        match w >> 30 {
            KIND_SPLIT => HNode::Split {
                axis: (w >> OFFSET_BITS & 3) as u8,
                planes: [f32::from_bits(words[1]), f32::from_bits(words[2])],
                second: w & OFFSET_MASK,
            },
            KIND_BOUND => {
                let mask = (w & 63) as u8;
                let mut planes = [0.0; 6];
                for (j, p) in planes
                    .iter_mut()
                    .take(mask.count_ones() as usize)
                    .enumerate()
                {
                    *p = f32::from_bits(words[1 + j]);
                }
                HNode::Bound { mask, planes }
            }
            _ => HNode::Leaf {
                offset: w & LEAF_MASK,
            },
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_kind_and_mask_round_trips() {
        let mut nodes = vec![HNode::Leaf { offset: 0 }, HNode::Leaf { offset: LEAF_MASK }];
        for axis in 0..3 {
            nodes.push(HNode::Split {
                axis,
                planes: [1.0, -0.0],
                second: OFFSET_MASK,
            });
        }
        for mask in 1..64u8 {
            let mut planes = [0.0; 6];
            for (j, p) in planes
                .iter_mut()
                .take(mask.count_ones() as usize)
                .enumerate()
            {
                *p = j as f32 + 0.5;
            }
            nodes.push(HNode::Bound { mask, planes });
        }
        let mut words = vec![];
        for n in &nodes {
            n.encode(&mut words).unwrap();
        }
        let mut at = 0;
        for n in &nodes {
            let d = HNode::decode(&words[at..]);
            assert_eq!(&d, n);
            at += d.words();
        }
        assert_eq!(at, words.len());
        // 2 leaves, 3 splits and the 63 masks (6 × 2⁵ faces in all).
        assert_eq!(words.len(), 2 + 3 * 3 + 63 + 6 * 32);
    }

    #[test]
    fn offsets_beyond_their_fields_are_refused() {
        let mut w = vec![];
        let e = HNode::Split {
            axis: 0,
            planes: [0.0; 2],
            second: OFFSET_MASK + 1,
        }
        .encode(&mut w)
        .unwrap_err();
        assert!(e.to_string().contains("at most 268435455"), "{e}");
        assert!(HNode::Leaf {
            offset: LEAF_MASK + 1
        }
        .encode(&mut w)
        .is_err());
        assert!(w.is_empty());
    }
}
