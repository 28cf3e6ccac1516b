//! Per-pixel work as a picture, like the dual-split paper's Figure 1: the
//! nodes visited, plane tests or triangle tests of every ray a pixel traced,
//! summed, mapped through a colour scale, with the scale drawn as a bar
//! beneath the image and labelled in it: 0 at the left, the middle of the
//! scale at the centre, its top at the right, and the measure's name.

use super::image::write_atomically;
use crate::error::Result;
use crate::stats::Tally;
use serde::Serialize;
use std::io::Write;
use std::path::Path;

/// Which counter a heat map shows.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Measure {
    /// Nodes visited.
    Nodes,
    /// Ray-plane tests (6 per box, 2 per two-plane node).
    Planes,
    /// Ray-triangle tests.
    Triangles,
}

impl crate::names::Named for Measure {
    const WHAT: &'static str = "measure";
    const TABLE: &'static [(Self, &'static str, &'static str)] = &[
        (Measure::Nodes, "nodes", "nodes visited"),
        (
            Measure::Planes,
            "planes",
            "ray-plane tests (6 per box, 2 per two-plane node)",
        ),
        (Measure::Triangles, "triangles", "ray-triangle tests"),
    ];
}

crate::named_from_str!(Measure);

impl Measure {
    /// The measure's name (`nodes`, `planes`, `triangles`).
    pub fn name(self) -> &'static str {
        crate::names::Named::name(self)
    }

    /// The field of `t` this measure counts.
    pub fn of(self, t: &Tally) -> u32 {
        match self {
            Measure::Nodes => t.nodes,
            Measure::Planes => t.planes,
            Measure::Triangles => t.triangles,
        }
    }
}

/// The work of every pixel (all its rays), row-major, top row first.
#[derive(Clone, Debug, PartialEq)]
pub struct WorkImage {
    /// Pixels per row.
    pub width: usize,
    /// Rows.
    pub height: usize,
    /// `width · height` tallies, each summed over the pixel's rays.
    pub pixels: Vec<Tally>,
}

/// Colour-scale anchors, from no work to the most: dark blue through
/// green and yellow to white, increasing in lightness so that the picture
/// reads in grey too.
const ANCHORS: [[f32; 3]; 6] = [
    [0.02, 0.02, 0.10],
    [0.10, 0.15, 0.55],
    [0.05, 0.55, 0.55],
    [0.45, 0.80, 0.20],
    [0.98, 0.85, 0.15],
    [1.00, 1.00, 1.00],
];

/// The colour of `x` in `[0, 1]` as 8-bit RGB.
pub fn colour(x: f32) -> [u8; 3] {
    let x = if x.is_nan() { 0.0 } else { x.clamp(0.0, 1.0) };
    let f = x * (ANCHORS.len() - 1) as f32;
    let i = (f as usize).min(ANCHORS.len() - 2);
    let t = f - i as f32;
    let (a, b) = (ANCHORS[i], ANCHORS[i + 1]);
    std::array::from_fn(|k| ((a[k] + (b[k] - a[k]) * t) * 255.0 + 0.5) as u8)
}

/// What a written heat map shows.
#[derive(Clone, Debug, Serialize)]
pub struct HeatmapInfo {
    /// The counter shown.
    pub measure: Measure,
    /// The value drawn white (and every larger one): by default the 99.5th
    /// percentile of the per-pixel counts, so that a few outliers do not
    /// darken the rest.
    pub scale_top: u32,
    /// The largest per-pixel count.
    pub max: u32,
    /// The mean per-pixel count.
    pub mean: f64,
}

impl WorkImage {
    /// The per-pixel values of `m`.
    pub fn values(&self, m: Measure) -> Vec<u32> {
        self.pixels.iter().map(|t| m.of(t)).collect()
    }

    /// Writes the heat map of `m` as an RGB PNG: the image, then a bar of the
    /// colour scale from 0 (left) to the top of the scale (right, see
    /// [`HeatmapInfo::scale_top`]), `max(8, height/16)` pixels high, under a
    /// one-pixel gap, labelled by [`label_bar`]. [`crate::error::Error::Io`]
    /// when writing fails.
    pub fn save(&self, m: Measure, path: &Path) -> Result<HeatmapInfo> {
        self.save_scaled(m, path, None)
    }

    /// [`Self::save`] with the top of the scale given, so that maps of
    /// several structures share one scale.
    pub fn save_scaled(&self, m: Measure, path: &Path, max: Option<u32>) -> Result<HeatmapInfo> {
        let (png, info) = self.png(m, max);
        write_atomically(path, |out| out.write_all(&png))?;
        Ok(info)
    }

    /// The 99.5th percentile of `m` over the pixels: the default top of
    /// the scale.
    pub fn percentile_top(&self, m: Measure) -> u32 {
        let mut v = self.values(m);
        v.sort_unstable();
        v.get(v.len() * 995 / 1000).copied().unwrap_or(0)
    }

    /// The heat map of [`Self::save_scaled`] as PNG bytes.
    pub fn png(&self, m: Measure, max: Option<u32>) -> (Vec<u8>, HeatmapInfo) {
        let values = self.values(m);
        let largest = values.iter().copied().max().unwrap_or(0);
        let top = max.unwrap_or_else(|| self.percentile_top(m));
        let mean = values.iter().map(|&v| v as f64).sum::<f64>() / values.len().max(1) as f64;
        let bar = (self.height / 16).max(8);
        let (w, h) = (self.width, self.height + 1 + bar);
        let mut rgb = Vec::with_capacity(w * h * 3);
        for &v in &values {
            rgb.extend(colour(v as f32 / top.max(1) as f32));
        }
        rgb.extend(std::iter::repeat_n(0u8, w * 3));
        let bar_start = rgb.len();
        for _ in 0..bar {
            for x in 0..w {
                rgb.extend(colour(x as f32 / (w.max(2) - 1) as f32));
            }
        }
        label_bar(&mut rgb[bar_start..], w, bar, top.max(1), m.name());
        let mut png = Vec::new();
        image::RgbImage::from_raw(w as u32, h as u32, rgb)
            .expect("buffer matches size")
            .write_to(&mut std::io::Cursor::new(&mut png), image::ImageFormat::Png)
            .expect("PNG encoding into memory");
        let info = HeatmapInfo {
            measure: m,
            scale_top: top,
            max: largest,
            mean,
        };
        (png, info)
    }
}

/// A 5×7 bitmap font: each glyph is 7 rows of 5 bits, the high bit left.
fn glyph(c: char) -> Option<[u8; 7]> {
    Some(match c {
        '0' => [0x0E, 0x11, 0x13, 0x15, 0x19, 0x11, 0x0E],
        '1' => [0x04, 0x0C, 0x04, 0x04, 0x04, 0x04, 0x0E],
        '2' => [0x0E, 0x11, 0x01, 0x02, 0x04, 0x08, 0x1F],
        '3' => [0x1F, 0x02, 0x04, 0x02, 0x01, 0x11, 0x0E],
        '4' => [0x02, 0x06, 0x0A, 0x12, 0x1F, 0x02, 0x02],
        '5' => [0x1F, 0x10, 0x1E, 0x01, 0x01, 0x11, 0x0E],
        '6' => [0x06, 0x08, 0x10, 0x1E, 0x11, 0x11, 0x0E],
        '7' => [0x1F, 0x01, 0x02, 0x04, 0x08, 0x08, 0x08],
        '8' => [0x0E, 0x11, 0x11, 0x0E, 0x11, 0x11, 0x0E],
        '9' => [0x0E, 0x11, 0x11, 0x0F, 0x01, 0x02, 0x0C],
        '.' => [0x00, 0x00, 0x00, 0x00, 0x00, 0x0C, 0x0C],
        'k' => [0x10, 0x10, 0x12, 0x14, 0x18, 0x14, 0x12],
        'M' => [0x11, 0x1B, 0x15, 0x15, 0x11, 0x11, 0x11],
        'a' => [0x00, 0x00, 0x0E, 0x01, 0x0F, 0x11, 0x0F],
        'd' => [0x01, 0x01, 0x0D, 0x13, 0x11, 0x11, 0x0F],
        'e' => [0x00, 0x00, 0x0E, 0x11, 0x1F, 0x10, 0x0E],
        'g' => [0x00, 0x0F, 0x11, 0x11, 0x0F, 0x01, 0x0E],
        'i' => [0x04, 0x00, 0x0C, 0x04, 0x04, 0x04, 0x0E],
        'l' => [0x0C, 0x04, 0x04, 0x04, 0x04, 0x04, 0x0E],
        'n' => [0x00, 0x00, 0x16, 0x19, 0x11, 0x11, 0x11],
        'o' => [0x00, 0x00, 0x0E, 0x11, 0x11, 0x11, 0x0E],
        'p' => [0x00, 0x00, 0x1E, 0x11, 0x1E, 0x10, 0x10],
        'r' => [0x00, 0x00, 0x16, 0x19, 0x10, 0x10, 0x10],
        's' => [0x00, 0x00, 0x0E, 0x10, 0x0E, 0x01, 0x1E],
        't' => [0x08, 0x08, 0x1C, 0x08, 0x08, 0x09, 0x06],
        'x' => [0x00, 0x00, 0x11, 0x0A, 0x04, 0x0A, 0x11],
        ' ' => [0; 7],
        _ => return None,
    })
}

/// The pixels of `text` in the 5×7 font at `scale`, one column of space
/// between glyphs: `(width, height, mask)`, row-major. Characters without a
/// glyph are left out.
pub fn text_mask(text: &str, scale: usize) -> (usize, usize, Vec<bool>) {
    let glyphs: Vec<[u8; 7]> = text.chars().filter_map(glyph).collect();
    let scale = scale.max(1);
    let w = (glyphs.len() * 6).saturating_sub(1) * scale;
    let h = 7 * scale;
    let mut mask = vec![false; w * h];
    for (i, g) in glyphs.iter().enumerate() {
        for (row, bits) in g.iter().enumerate() {
            for col in 0..5 {
                if bits & (0x10 >> col) != 0 {
                    for dy in 0..scale {
                        for dx in 0..scale {
                            let x = (i * 6 + col) * scale + dx;
                            mask[(row * scale + dy) * w + x] = true;
                        }
                    }
                }
            }
        }
    }
    (w, h, mask)
}

/// `v` in at most `chars` characters: in full, or in thousands (`k`) or
/// millions (`M`) with one decimal where that fits.
fn short_number(v: u32, chars: usize) -> String {
    let full = v.to_string();
    if full.len() <= chars {
        return full;
    }
    let (x, unit) = if v >= 1_000_000 {
        (v as f64 / 1e6, "M")
    } else {
        (v as f64 / 1e3, "k")
    };
    let one = format!("{x:.1}{unit}");
    if one.len() <= chars {
        one
    } else {
        format!("{x:.0}{unit}")
    }
}

/// The text scale and top row of the labels in a bar `bar` pixels high:
/// the 7-row font as large as fits with a row to spare, centred, at least
/// 1 (a bar of 8 keeps its last row free of text).
pub fn label_layout(bar: usize) -> (usize, usize) {
    let scale = ((bar.saturating_sub(1)) / 7).max(1);
    let top = bar.saturating_sub(7 * scale) / 2;
    (scale, top)
}

/// Labels the colour bar `rgb` (`w` × `bar` RGB pixels, 0 at the left,
/// `top` at the right): the top of the scale at the right edge, 0 at the
/// left, the middle value at the centre and the measure's `name` between 0
/// and the middle, each drawn only where it fits without touching another.
/// Text is black over the light part of the scale and white over the dark.
pub fn label_bar(rgb: &mut [u8], w: usize, bar: usize, top: u32, name: &str) {
    let (scale, y0) = label_layout(bar);
    let glyph_w = 6 * scale;
    let chars = (w / 3 / glyph_w).max(1);
    let labels = [
        (
            short_number(top, chars),
            Anchor::Right(w.saturating_sub(scale)),
        ),
        ("0".to_string(), Anchor::Left(scale)),
        (short_number(top / 2, chars), Anchor::Centre(w / 2)),
        (name.to_string(), Anchor::Centre(w / 4)),
    ];
    let mut taken: Vec<(usize, usize)> = Vec::new();
    for (text, anchor) in labels {
        let (tw, th, mask) = text_mask(&text, scale);
        if tw == 0 || th + y0 > bar || tw + 2 * scale > w {
            continue;
        }
        let x0 = match anchor {
            Anchor::Left(x) => x,
            Anchor::Right(x) => x.saturating_sub(tw),
            Anchor::Centre(x) => x.saturating_sub(tw / 2),
        };
        if x0 + tw > w {
            continue;
        }
        let gap = 2 * glyph_w / 3;
        let (lo, hi) = (x0.saturating_sub(gap), x0 + tw + gap);
        if taken.iter().any(|&(a, b)| lo < b && a < hi) {
            continue;
        }
        taken.push((x0, x0 + tw));
        for y in 0..th {
            for x in 0..tw {
                if mask[y * tw + x] {
                    let px = ((y0 + y) * w + x0 + x) * 3;
                    let c = &mut rgb[px..px + 3];
                    let luma = 0.2126 * c[0] as f32 + 0.7152 * c[1] as f32 + 0.0722 * c[2] as f32;
                    let ink = if luma > 110.0 { 0 } else { 255 };
                    c.copy_from_slice(&[ink; 3]);
                }
            }
        }
    }
}

enum Anchor {
    Left(usize),
    Right(usize),
    Centre(usize),
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn scale_runs_from_dark_to_white_and_brightens() {
        assert_eq!(colour(0.0), [5, 5, 26]);
        assert_eq!(colour(1.0), [255, 255, 255]);
        assert_eq!(colour(f32::NAN), colour(0.0));
        let luma = |c: [u8; 3]| 0.2126 * c[0] as f32 + 0.7152 * c[1] as f32 + 0.0722 * c[2] as f32;
        let mut last = -1.0;
        for i in 0..=100 {
            let l = luma(colour(i as f32 / 100.0));
            assert!(l > last, "lightness falls at {i}");
            last = l;
        }
    }

    /// A work image of `w` × `h` pixels whose node counts rise to the right.
    fn ramp(w: usize, h: usize) -> WorkImage {
        WorkImage {
            width: w,
            height: h,
            pixels: (0..w * h)
                .map(|i| Tally {
                    nodes: (i % w) as u32 * 10,
                    ..Default::default()
                })
                .collect(),
        }
    }

    /// The text pixels of a heat map's bar: those that differ from the
    /// bare scale.
    fn ink_of(png: &[u8], w: usize, h: usize) -> (usize, Vec<bool>) {
        let img = image::load_from_memory(png).unwrap().to_rgb8();
        let bar = img.height() as usize - h - 1;
        let mut ink = vec![false; w * bar];
        for y in 0..bar {
            for x in 0..w {
                let want = colour(x as f32 / (w.max(2) - 1) as f32);
                ink[y * w + x] = img.get_pixel(x as u32, (h + 1 + y) as u32).0 != want;
            }
        }
        (bar, ink)
    }

    /// Whether `text` is drawn at column `x0` of the bar's ink, exactly.
    fn drawn_at(ink: &[bool], w: usize, bar: usize, text: &str, x0: usize) -> bool {
        let (scale, y0) = label_layout(bar);
        let (tw, th, mask) = text_mask(text, scale);
        (0..th).all(|y| (0..tw).all(|x| ink[(y0 + y) * w + x0 + x] == mask[y * tw + x]))
    }

    #[test]
    fn the_bar_is_labelled_with_the_scale_and_the_measure() {
        // 200 wide, 48 high: an 8-row bar, text at scale 1 in rows 0 to 6.
        let (w, h) = (200, 48);
        let (png, info) = ramp(w, h).png(Measure::Nodes, Some(1990));
        assert_eq!(info.scale_top, 1990);
        let (bar, ink) = ink_of(&png, w, h);
        assert_eq!(bar, 8);
        assert_eq!(label_layout(bar), (1, 0));
        // The top of the scale, right-aligned one pixel from the edge.
        let (tw, _, _) = text_mask("1990", 1);
        assert!(drawn_at(&ink, w, bar, "1990", w - 1 - tw));
        // 0 at the left, the middle at the centre, the name at a quarter.
        assert!(drawn_at(&ink, w, bar, "0", 1));
        let (mw, _, _) = text_mask("995", 1);
        assert!(drawn_at(&ink, w, bar, "995", w / 2 - mw / 2));
        let (nw, _, _) = text_mask("nodes", 1);
        assert!(drawn_at(&ink, w, bar, "nodes", w / 4 - nw / 2));
        // Nothing else is drawn, and the last row is bare scale.
        let glyph_pixels: usize = ["1990", "0", "995", "nodes"]
            .iter()
            .map(|t| text_mask(t, 1).2.iter().filter(|&&b| b).count())
            .sum();
        assert_eq!(ink.iter().filter(|&&b| b).count(), glyph_pixels);
        assert!(ink[7 * w..].iter().all(|&b| !b));
        // Ink contrasts with the scale: black on the light right end.
        let img = image::load_from_memory(&png).unwrap().to_rgb8();
        let (x, y) = (
            (0..w).rev().find(|&x| ink[3 * w + x]).unwrap(),
            (h + 1 + 3) as u32,
        );
        assert_eq!(img.get_pixel(x as u32, y).0, [0, 0, 0]);
    }

    #[test]
    fn labels_shrink_or_step_aside_in_small_bars_and_grow_in_tall_ones() {
        // 64 wide: numbers in thousands, the name left out where it does
        // not fit.
        assert_eq!(short_number(123_456, 4), "123k");
        assert_eq!(short_number(12_345, 5), "12345");
        assert_eq!(short_number(12_345, 4), "12k");
        assert_eq!(short_number(1_234_567, 4), "1.2M");
        let (png, _) = ramp(64, 48).png(Measure::Triangles, Some(12_345));
        let (bar, ink) = ink_of(&png, 64, 48);
        let (tw, _, _) = text_mask("12k", 1);
        assert!(drawn_at(&ink, 64, bar, "12k", 63 - tw));
        assert!(drawn_at(&ink, 64, bar, "0", 1));
        // A tall image: a taller bar and doubled text.
        let (png, _) = ramp(300, 256).png(Measure::Planes, Some(40));
        let (bar, ink) = ink_of(&png, 300, 256);
        assert_eq!((bar, label_layout(bar)), (16, (2, 1)));
        let (tw, _, _) = text_mask("40", 2);
        assert!(drawn_at(&ink, 300, bar, "40", 300 - 2 - tw));
        assert!(drawn_at(
            &ink,
            300,
            bar,
            "planes",
            75 - text_mask("planes", 2).0 / 2
        ));
        // Tiny images get no text rather than a crash.
        for (w, h) in [(1, 1), (3, 2), (8, 8)] {
            let _ = ramp(w, h).png(Measure::Nodes, None);
        }
    }

    #[test]
    fn every_label_character_has_a_glyph() {
        for t in ["0123456789.kM", "nodes", "planes", "triangles"] {
            assert!(t.chars().all(|c| glyph(c).is_some()), "{t}");
        }
    }
}
