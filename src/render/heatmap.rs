//! Per-pixel work as a picture, like the dual-split paper's Figure 1: the
//! nodes visited, plane tests or triangle tests of every ray a pixel traced,
//! summed, mapped through a colour scale, with the scale drawn as a bar
//! beneath the image.

use super::image::write_atomically;
use crate::error::Result;
use crate::stats::Tally;
use serde::Serialize;
use std::io::Write;
use std::path::Path;

/// Which counter a heat map shows.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, clap::ValueEnum)]
#[serde(rename_all = "lowercase")]
pub enum Measure {
    /// Nodes visited.
    Nodes,
    /// Ray-plane tests (6 per box, 2 per two-plane node).
    Planes,
    /// Ray-triangle tests.
    Triangles,
}

impl Measure {
    pub fn name(self) -> &'static str {
        match self {
            Measure::Nodes => "nodes",
            Measure::Planes => "planes",
            Measure::Triangles => "triangles",
        }
    }

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
    pub width: usize,
    pub height: usize,
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
    pub measure: Measure,
    /// The value drawn white (and every larger one): by default the 99.5th
    /// percentile of the per-pixel counts, so that a few outliers do not
    /// darken the rest.
    pub scale_top: u32,
    /// The largest per-pixel count.
    pub max: u32,
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
    /// one-pixel gap.
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
        for _ in 0..bar {
            for x in 0..w {
                rgb.extend(colour(x as f32 / (w.max(2) - 1) as f32));
            }
        }
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
}
