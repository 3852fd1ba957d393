//! Comparing two 8-bit renders: RMSE, PSNR, NVIDIA FLIP and pixel counts, and reading PNGs.

use std::fmt;
use std::path::Path;

use image::{Rgba, RgbaImage};
use serde::{Serialize, Serializer};

use crate::error::{Error, Result};

/// How far apart two images are, as printed by `strata compare` (and written by `--json`).
#[derive(Serialize, Debug, Clone, Copy, PartialEq)]
pub struct Comparison {
    /// Root-mean-square error over all pixels and the R, G, B channels, in \[0,1\] units
    /// (a channel difference of 255 counts as 1.0).
    pub rmse: f64,
    /// Peak signal-to-noise ratio in dB with peak 1.0: `-20·log10(rmse)`. `f64::INFINITY` for
    /// identical images (and for empty ones), which JSON writes as `null`.
    #[serde(serialize_with = "finite_or_null")]
    pub psnr: f64,
    /// Largest |Δ| over all pixels and the R, G, B channels, in 8-bit levels (0..=255).
    pub max_abs_diff: u8,
    /// Mean of the LDR FLIP error map (NVIDIA FLIP, default pixels per degree), 0 = same look.
    pub flip_mean: f64,
    /// Percentage (0..=100) of pixels whose largest channel |Δ| is over 2 levels (2/255).
    pub pct_over_2: f64,
    /// Number of pixels compared (width × height).
    pub pixels: u64,
}

fn finite_or_null<S: Serializer>(
    value: &f64,
    serializer: S,
) -> std::result::Result<S::Ok, S::Error> {
    if value.is_finite() {
        serializer.serialize_f64(*value)
    } else {
        serializer.serialize_none()
    }
}

impl fmt::Display for Comparison {
    /// Human-readable, one metric per line.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(f, "RMSE           {:.6}", self.rmse)?;
        if self.psnr.is_finite() {
            writeln!(f, "PSNR           {:.2} dB", self.psnr)?;
        } else {
            writeln!(f, "PSNR           inf (identical)")?;
        }
        writeln!(f, "max abs diff   {}/255", self.max_abs_diff)?;
        writeln!(f, "FLIP mean      {:.6}", self.flip_mean)?;
        write!(
            f,
            "pixels > 2/255 {:.4}% of {}",
            self.pct_over_2, self.pixels
        )
    }
}

/// Largest |Δ| over the R, G, B channels of two pixels (alpha ignored).
pub(crate) fn max_channel_diff(a: &Rgba<u8>, b: &Rgba<u8>) -> u8 {
    a[0].abs_diff(b[0])
        .max(a[1].abs_diff(b[1]))
        .max(a[2].abs_diff(b[2]))
}

fn check_same_size(a: &RgbaImage, b: &RgbaImage) -> Result<()> {
    if a.dimensions() != b.dimensions() {
        return Err(Error::input(format!(
            "images differ in size: {}x{} vs {}x{}",
            a.width(),
            a.height(),
            b.width(),
            b.height()
        )));
    }
    Ok(())
}

fn rgb_bytes(img: &RgbaImage) -> Vec<u8> {
    img.pixels().flat_map(|p| [p[0], p[1], p[2]]).collect()
}

/// Mean LDR FLIP error of `test` against `reference` (same size, non-empty).
fn flip_mean(reference: &RgbaImage, test: &RgbaImage) -> f64 {
    let (w, h) = reference.dimensions();
    let (ref_rgb, test_rgb) = rayon::join(|| rgb_bytes(reference), || rgb_bytes(test));
    let ref_img = nv_flip::FlipImageRgb8::with_data(w, h, &ref_rgb);
    let test_img = nv_flip::FlipImageRgb8::with_data(w, h, &test_rgb);
    let error = nv_flip::flip(ref_img, test_img, nv_flip::DEFAULT_PIXELS_PER_DEGREE);
    let values = error.to_vec();
    values.iter().map(|&v| v as f64).sum::<f64>() / values.len() as f64
}

/// Compares `b` against the reference `a` on their 8-bit sRGB R, G, B channels (alpha ignored).
/// See [`Comparison`] for the units of each metric. Empty images compare as identical.
///
/// Errors with [`Error::Input`] (`images differ in size: WxH vs WxH`) if the sizes differ.
pub fn compare(a: &RgbaImage, b: &RgbaImage) -> Result<Comparison> {
    check_same_size(a, b)?;
    let pixels = a.width() as u64 * a.height() as u64;
    let mut sum_sq: u64 = 0;
    let mut max_abs_diff = 0u8;
    let mut over_2: u64 = 0;
    for (pa, pb) in a.pixels().zip(b.pixels()) {
        let mut pixel_max = 0u8;
        for c in 0..3 {
            let d = pa[c].abs_diff(pb[c]);
            sum_sq += d as u64 * d as u64;
            pixel_max = pixel_max.max(d);
        }
        max_abs_diff = max_abs_diff.max(pixel_max);
        if pixel_max > 2 {
            over_2 += 1;
        }
    }
    if pixels == 0 {
        return Ok(Comparison {
            rmse: 0.0,
            psnr: f64::INFINITY,
            max_abs_diff: 0,
            flip_mean: 0.0,
            pct_over_2: 0.0,
            pixels: 0,
        });
    }
    let rmse = (sum_sq as f64 / (3 * pixels) as f64).sqrt() / 255.0;
    let psnr = if sum_sq == 0 {
        f64::INFINITY
    } else {
        20.0 * (1.0 / rmse).log10()
    };
    Ok(Comparison {
        rmse,
        psnr,
        max_abs_diff,
        flip_mean: flip_mean(a, b),
        pct_over_2: 100.0 * over_2 as f64 / pixels as f64,
        pixels,
    })
}

/// Number of pixels whose largest R, G, B |Δ| exceeds `threshold` 8-bit levels.
///
/// Errors with [`Error::Input`] if the sizes differ.
pub fn pixels_over(a: &RgbaImage, b: &RgbaImage, threshold: u8) -> Result<u64> {
    check_same_size(a, b)?;
    Ok(a.pixels()
        .zip(b.pixels())
        .filter(|(pa, pb)| max_channel_diff(pa, pb) > threshold)
        .count() as u64)
}

/// The 8-byte signature every PNG file starts with.
const PNG_SIGNATURE: [u8; 8] = [0x89, b'P', b'N', b'G', b'\r', b'\n', 0x1a, b'\n'];

/// Reads a PNG file as 8-bit RGBA (16-bit, grey and palette PNGs are converted).
///
/// Errors with [`Error::Input`], one line naming the path: the file is missing or unreadable,
/// is not a PNG, or is a malformed PNG.
pub fn load_png(path: &Path) -> Result<RgbaImage> {
    let bytes = std::fs::read(path).map_err(|e| {
        if e.kind() == std::io::ErrorKind::NotFound {
            Error::input(format!("{}: no such file", path.display()))
        } else {
            Error::input(format!("{}: cannot read: {e}", path.display()))
        }
    })?;
    if !bytes.starts_with(&PNG_SIGNATURE) {
        return Err(Error::input(format!(
            "{}: not a PNG file (no PNG signature)",
            path.display()
        )));
    }
    let img = image::load_from_memory_with_format(&bytes, image::ImageFormat::Png)
        .map_err(|e| Error::input(format!("{}: malformed PNG: {e}", path.display())))?;
    Ok(img.into_rgba8())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::metrics::{save_png, testing};

    fn solid(w: u32, h: u32, c: [u8; 4]) -> RgbaImage {
        RgbaImage::from_pixel(w, h, Rgba(c))
    }

    /// `image` with pixel (x, y) set to `c`.
    fn with_pixel(image: &RgbaImage, (x, y): (u32, u32), c: [u8; 4]) -> RgbaImage {
        let mut changed = image.clone();
        changed.put_pixel(x, y, Rgba(c));
        changed
    }

    /// A small image with some structure, so FLIP has edges to look at.
    fn pattern(w: u32, h: u32) -> RgbaImage {
        RgbaImage::from_fn(w, h, |x, y| {
            Rgba([(x * 16) as u8, (y * 16) as u8, ((x + y) * 8) as u8, 255])
        })
    }

    #[test]
    fn identical_images() {
        let a = pattern(16, 16);
        let c = compare(&a, &a.clone()).unwrap();
        assert_eq!(c.rmse, 0.0);
        assert!(c.psnr.is_infinite() && c.psnr > 0.0);
        assert_eq!(c.max_abs_diff, 0);
        assert_eq!(c.pct_over_2, 0.0);
        assert!(c.flip_mean.abs() < 1e-6, "flip {}", c.flip_mean);
        assert_eq!(c.pixels, 256);
        let json = serde_json::to_value(c).unwrap();
        assert!(json["psnr"].is_null());
        assert_eq!(json["rmse"], 0.0);
        assert_eq!(json["pixels"], 256);
    }

    #[test]
    fn one_pixel_difference() {
        let a = solid(4, 4, [10, 20, 30, 255]);
        // R +0, G +5, B -3; alpha differs too but is ignored.
        let b = with_pixel(&a, (1, 2), [10, 25, 27, 0]);
        let c = compare(&a, &b).unwrap();
        assert_eq!(c.max_abs_diff, 5);
        assert_eq!(c.pixels, 16);
        assert_eq!(c.pct_over_2, 100.0 / 16.0);
        let rmse = ((25.0_f64 + 9.0) / (16.0 * 3.0)).sqrt() / 255.0;
        assert!((c.rmse - rmse).abs() < 1e-12, "{} vs {rmse}", c.rmse);
        assert!((c.psnr - (-20.0 * rmse.log10())).abs() < 1e-9);
        assert!(c.psnr > 40.0 && c.psnr < 60.0, "psnr {}", c.psnr);
        assert!(
            c.flip_mean > 0.0 && c.flip_mean < 0.1,
            "flip {}",
            c.flip_mean
        );
        assert_eq!(pixels_over(&a, &b, 4).unwrap(), 1);
        assert_eq!(pixels_over(&a, &b, 5).unwrap(), 0);
        let json = serde_json::to_value(c).unwrap();
        assert_eq!(json["max_abs_diff"], 5);
        assert!(json["psnr"].is_f64());
    }

    #[test]
    fn small_difference_not_over_2() {
        let a = solid(2, 2, [100, 100, 100, 255]);
        let b = with_pixel(&a, (0, 0), [102, 98, 100, 255]);
        let c = compare(&a, &b).unwrap();
        assert_eq!(c.max_abs_diff, 2);
        assert_eq!(c.pct_over_2, 0.0);
    }

    #[test]
    fn extreme_and_degenerate_sizes() {
        let black = solid(1, 1, [0, 0, 0, 255]);
        let white = solid(1, 1, [255, 255, 255, 255]);
        let c = compare(&black, &white).unwrap();
        assert_eq!(c.rmse, 1.0);
        assert_eq!(c.psnr, 0.0);
        assert_eq!(c.max_abs_diff, 255);
        assert_eq!(c.pct_over_2, 100.0);
        assert!(c.flip_mean.is_finite());
        let empty = RgbaImage::new(0, 0);
        let c = compare(&empty, &empty).unwrap();
        assert_eq!((c.pixels, c.rmse, c.flip_mean), (0, 0.0, 0.0));
    }

    #[test]
    fn size_mismatch_is_input_error() {
        let a = RgbaImage::new(128, 128);
        let b = RgbaImage::new(64, 64);
        let err = compare(&a, &b).unwrap_err();
        assert!(matches!(err, Error::Input(_)));
        assert_eq!(err.to_string(), "images differ in size: 128x128 vs 64x64");
        assert!(pixels_over(&a, &b, 0).is_err());
    }

    #[test]
    fn display_is_readable() {
        let a = solid(2, 2, [0, 0, 0, 255]);
        let text = compare(&a, &a).unwrap().to_string();
        assert!(text.contains("PSNR           inf"));
        assert!(text.contains("max abs diff   0/255"));
    }

    #[test]
    fn png_round_trip_and_errors() {
        let dir = testing::image_test_dir().join("metrics-unit");
        std::fs::create_dir_all(&dir).unwrap();
        let img = pattern(5, 3);
        let path = dir.join("round-trip.png");
        save_png(&img, &path).unwrap();
        assert_eq!(load_png(&path).unwrap(), img);

        let missing = dir.join("does-not-exist.png");
        let err = load_png(&missing).unwrap_err().to_string();
        assert!(
            err.contains("does-not-exist.png") && err.contains("no such file"),
            "{err}"
        );

        let not_png = dir.join("not-a-png.png");
        std::fs::write(&not_png, b"P3\n1 1\n255\n0 0 0\n").unwrap();
        let err = load_png(&not_png).unwrap_err().to_string();
        assert!(
            err.contains("not-a-png.png") && err.contains("not a PNG"),
            "{err}"
        );

        let truncated = dir.join("truncated.png");
        let bytes = std::fs::read(&path).unwrap();
        std::fs::write(&truncated, &bytes[..bytes.len() / 2]).unwrap();
        let err = load_png(&truncated).unwrap_err();
        assert!(matches!(err, Error::Input(_)));
        let err = err.to_string();
        assert!(
            err.contains("truncated.png") && err.contains("malformed PNG"),
            "{err}"
        );
        assert!(!err.contains('\n'), "{err}");

        let err = save_png(&img, &dir.join("no-such-dir").join("x.png")).unwrap_err();
        assert!(err.to_string().contains("x.png"));
        std::fs::remove_dir_all(&dir).ok();
    }
}
