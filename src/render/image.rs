//! A grey-scale image of linear values, written as 8-bit sRGB PNG, JPEG or
//! PPM, or as linear 32-bit float OpenEXR, the format chosen by the file's
//! extension. Files are written under a temporary name and renamed, so an
//! error or an interrupt never leaves a partial file; the path `-` writes
//! PNG to standard output.

use crate::error::{Error, Result};
use std::io::{Seek, Write};
use std::path::Path;

/// The formats an [`Image`] is written in, chosen by the file's extension.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ImageFormat {
    /// `.png`: 8-bit grey, sRGB.
    Png,
    /// `.jpg`, `.jpeg`: 8-bit grey, sRGB, quality 95.
    Jpeg,
    /// `.ppm`: binary P6, 8-bit sRGB RGB.
    Ppm,
    /// `.exr`: linear 32-bit float RGB, the values as rendered.
    Exr,
}

impl ImageFormat {
    /// The extensions understood, for messages and help.
    pub const KNOWN: &'static str = ".png, .jpg (or .jpeg), .ppm or .exr";

    /// The format of `path` by its extension (any case); `-`, standard
    /// output, is PNG. An unknown or missing extension is an
    /// [`Error::Invalid`] that names the path and the formats known.
    pub fn of(path: &Path) -> Result<ImageFormat> {
        if is_stdout(path) {
            return Ok(ImageFormat::Png);
        }
        let ext = path
            .extension()
            .map(|e| e.to_string_lossy().to_ascii_lowercase());
        match ext.as_deref() {
            Some("png") => Ok(ImageFormat::Png),
            Some("jpg") | Some("jpeg") => Ok(ImageFormat::Jpeg),
            Some("ppm") => Ok(ImageFormat::Ppm),
            Some("exr") => Ok(ImageFormat::Exr),
            Some(e) => Err(Error::Invalid(format!(
                "{}: unknown image format '.{e}': use {}, or - for PNG on standard output",
                path.display(),
                Self::KNOWN
            ))),
            None => Err(Error::Invalid(format!(
                "{}: no extension to choose the image format by: use {}, or - for PNG on standard output",
                path.display(),
                Self::KNOWN
            ))),
        }
    }
}

/// Whether `path` is `-`, standard output.
pub fn is_stdout(path: &Path) -> bool {
    path.as_os_str() == "-"
}

/// A grey-scale image of linear f32 values (radiance or occlusion, 0 = black).
#[derive(Clone, Debug, PartialEq)]
pub struct Image {
    /// Pixels per row.
    pub width: usize,
    /// Rows.
    pub height: usize,
    /// Linear values, row-major, top row first.
    pub pixels: Vec<f32>,
}

impl Image {
    /// A black image: `width · height` zeros.
    pub fn new(width: usize, height: usize) -> Self {
        Image {
            width,
            height,
            pixels: vec![0.0; width * height],
        }
    }

    /// Sets pixel (`x`, `y`), `y` counted from the top; panics outside the image.
    pub fn set(&mut self, x: usize, y: usize, v: f32) {
        self.pixels[y * self.width + x] = v;
    }

    /// Pixel (`x`, `y`), `y` counted from the top; panics outside the image.
    pub fn get(&self, x: usize, y: usize) -> f32 {
        self.pixels[y * self.width + x]
    }

    /// 8-bit sRGB values, clamped to [0, 1] first (NaN as 0), one per pixel
    /// in [`Self::pixels`] order.
    pub fn to_srgb8(&self) -> Vec<u8> {
        self.pixels
            .iter()
            .map(|&v| {
                let v = if v.is_nan() { 0.0 } else { v.clamp(0.0, 1.0) };
                let s = if v <= 0.003_130_8 {
                    12.92 * v
                } else {
                    1.055 * v.powf(1.0 / 2.4) - 0.055
                };
                (s * 255.0 + 0.5) as u8
            })
            .collect()
    }

    /// The image as PNG bytes (8-bit grey, sRGB).
    pub fn to_png(&self) -> Vec<u8> {
        let mut png = Vec::new();
        image::GrayImage::from_raw(self.width as u32, self.height as u32, self.to_srgb8())
            .expect("buffer matches size")
            .write_to(&mut std::io::Cursor::new(&mut png), image::ImageFormat::Png)
            .expect("PNG encoding into memory");
        png
    }

    /// Writes the image in the format of `path`'s extension (see
    /// [`ImageFormat::of`]); `-` writes PNG to standard output.
    /// [`Error::Invalid`] for an unknown extension, [`Error::Io`] when
    /// writing fails.
    pub fn save(&self, path: &Path) -> Result<()> {
        let format = ImageFormat::of(path)?;
        if is_stdout(path) {
            let mut bytes = std::io::Cursor::new(Vec::new());
            let io = |source| Error::Io {
                path: path.into(),
                source,
            };
            self.write(&mut bytes, format).map_err(io)?;
            let mut out = std::io::stdout().lock();
            return out
                .write_all(bytes.get_ref())
                .and_then(|()| out.flush())
                .map_err(|source| Error::Io {
                    path: "standard output".into(),
                    source,
                });
        }
        write_atomically(path, |w| self.write(w, format))
    }

    /// Encodes the image as `format` into `w`.
    pub fn write<W: Write + Seek>(&self, w: &mut W, format: ImageFormat) -> std::io::Result<()> {
        let (width, height) = (self.width as u32, self.height as u32);
        match format {
            ImageFormat::Ppm => {
                write!(w, "P6\n{} {}\n255\n", self.width, self.height)?;
                let rgb: Vec<u8> = self.to_srgb8().iter().flat_map(|&g| [g, g, g]).collect();
                w.write_all(&rgb)
            }
            ImageFormat::Png => image::GrayImage::from_raw(width, height, self.to_srgb8())
                .expect("buffer matches size")
                .write_to(w, image::ImageFormat::Png)
                .map_err(std::io::Error::other),
            ImageFormat::Jpeg => {
                let grey = image::GrayImage::from_raw(width, height, self.to_srgb8())
                    .expect("buffer matches size");
                image::codecs::jpeg::JpegEncoder::new_with_quality(w, 95)
                    .encode_image(&grey)
                    .map_err(std::io::Error::other)
            }
            ImageFormat::Exr => {
                let rgb: Vec<f32> = self
                    .pixels
                    .iter()
                    .flat_map(|&v| {
                        let v = if v.is_finite() { v } else { 0.0 };
                        [v, v, v]
                    })
                    .collect();
                image::Rgb32FImage::from_raw(width, height, rgb)
                    .expect("buffer matches size")
                    .write_to(w, image::ImageFormat::OpenExr)
                    .map_err(std::io::Error::other)
            }
        }
    }
}

/// Temporary files being written by [`write_atomically`], for
/// [`remove_unfinished_files`].
static UNFINISHED: std::sync::Mutex<Vec<std::path::PathBuf>> = std::sync::Mutex::new(Vec::new());

/// Removes the temporary files of writes still in progress. An interrupt
/// handler calls it before the process exits, so that an interrupted run
/// leaves no partial file behind.
pub fn remove_unfinished_files() {
    let files = UNFINISHED.lock().unwrap_or_else(|e| e.into_inner());
    for f in files.iter() {
        let _ = std::fs::remove_file(f);
    }
}

/// Runs `f` on a temporary file beside `path`, then renames it to `path`.
/// On failure the temporary file is removed and `path` is untouched; on an
/// interrupt, [`remove_unfinished_files`] removes it. Any failure, of `f`
/// or of the file system, is an [`Error::Io`] naming `path`.
pub fn write_atomically(
    path: &Path,
    f: impl FnOnce(&mut std::io::BufWriter<std::fs::File>) -> std::io::Result<()>,
) -> Result<()> {
    let io = |source| Error::Io {
        path: path.into(),
        source,
    };
    let dir = path
        .parent()
        .filter(|p| !p.as_os_str().is_empty())
        .unwrap_or(Path::new("."));
    let name = path.file_name().ok_or_else(|| {
        io(std::io::Error::new(
            std::io::ErrorKind::InvalidInput,
            "not a file name",
        ))
    })?;
    let tmp = dir.join(format!(
        ".{}.tmp{}",
        name.to_string_lossy(),
        std::process::id()
    ));
    let unfinished = || UNFINISHED.lock().unwrap_or_else(|e| e.into_inner());
    unfinished().push(tmp.clone());
    let result = (|| {
        let mut w = std::io::BufWriter::new(std::fs::File::create(&tmp)?);
        f(&mut w)?;
        w.into_inner().map_err(|e| e.into_error())?.sync_all()?;
        std::fs::rename(&tmp, path)
    })();
    if result.is_err() {
        let _ = std::fs::remove_file(&tmp);
    }
    unfinished().retain(|p| *p != tmp);
    result.map_err(io)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_interrupted_write_leaves_nothing() {
        let dir = std::env::temp_dir().join(format!("raytree-int-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let out = dir.join("out.bin");
        // The interrupt handler's cleanup, run while the file is half written.
        let r = write_atomically(&out, |w| {
            use std::io::Write;
            w.write_all(b"half")?;
            w.flush()?;
            assert_eq!(std::fs::read_dir(&dir).unwrap().count(), 1);
            remove_unfinished_files();
            Err(std::io::Error::other("interrupted"))
        });
        assert!(r.is_err());
        assert_eq!(std::fs::read_dir(&dir).unwrap().count(), 0);
        // Other tests may be writing at the same time: only this write's
        // entry must be gone.
        assert!(!UNFINISHED
            .lock()
            .unwrap()
            .iter()
            .any(|p| p.starts_with(&dir)));
        std::fs::remove_dir(&dir).unwrap();
    }

    #[test]
    fn srgb_encoding_endpoints() {
        let mut im = Image::new(3, 1);
        im.set(1, 0, 1.0);
        im.set(2, 0, 5.0);
        assert_eq!(im.to_srgb8(), vec![0, 255, 255]);
    }

    #[test]
    fn failed_write_leaves_nothing() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("x.png");
        let r = write_atomically(&path, |_| Err(std::io::Error::other("boom")));
        assert!(r.is_err());
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 0);
    }

    #[test]
    fn ppm_and_png_are_written() {
        let dir = tempfile::tempdir().unwrap();
        let im = Image::new(4, 2);
        im.save(&dir.path().join("a.ppm")).unwrap();
        im.save(&dir.path().join("a.png")).unwrap();
        let ppm = std::fs::read(dir.path().join("a.ppm")).unwrap();
        assert!(ppm.starts_with(b"P6\n4 2\n255\n"));
        assert_eq!(ppm.len(), 11 + 4 * 2 * 3);
        let png = image::open(dir.path().join("a.png")).unwrap();
        assert_eq!((png.width(), png.height()), (4, 2));
    }

    #[test]
    fn the_extension_chooses_the_format() {
        let dir = tempfile::tempdir().unwrap();
        let mut im = Image::new(8, 4);
        im.set(3, 1, 0.5);
        im.set(7, 3, 1.0);
        for (name, magic) in [
            ("a.png", &b"\x89PNG"[..]),
            ("a.PNG", &b"\x89PNG"[..]),
            ("a.jpg", &b"\xff\xd8\xff"[..]),
            ("a.jpeg", &b"\xff\xd8\xff"[..]),
            ("a.ppm", &b"P6\n"[..]),
            ("a.exr", &b"\x76\x2f\x31\x01"[..]),
        ] {
            let path = dir.path().join(name);
            im.save(&path).unwrap();
            let bytes = std::fs::read(&path).unwrap();
            assert!(bytes.starts_with(magic), "{name}: {:x?}", &bytes[..8]);
            if !name.ends_with("ppm") {
                let back = image::open(&path).unwrap();
                assert_eq!((back.width(), back.height()), (8, 4), "{name}");
            }
        }
        // EXR keeps the linear values.
        let exr = image::open(dir.path().join("a.exr")).unwrap().into_rgb32f();
        assert_eq!(exr.get_pixel(3, 1).0, [0.5; 3]);
        assert_eq!(exr.get_pixel(7, 3).0, [1.0; 3]);
        for bad in ["a.jpgx", "a.gif", "noext", "a.png.txt"] {
            let m = im.save(&dir.path().join(bad)).unwrap_err().to_string();
            assert!(m.contains(bad) && m.contains(".png, .jpg"), "{bad}: {m}");
        }
        assert_eq!(ImageFormat::of(Path::new("-")).unwrap(), ImageFormat::Png);
        let names: Vec<_> = std::fs::read_dir(dir.path())
            .unwrap()
            .map(|e| e.unwrap().file_name().into_string().unwrap())
            .collect();
        assert_eq!(names.len(), 6, "{names:?}");
    }
}
