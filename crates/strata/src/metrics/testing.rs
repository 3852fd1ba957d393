//! Helpers for image tests: compare with a tolerance and, on failure, leave the actual image, the
//! expected one and a diff heatmap under `target/image-tests/` and say where.

use std::path::{Path, PathBuf};

use image::RgbaImage;

use super::{compare, diff_heatmap, pixels_over, save_png, Comparison, DIFF_SATURATION};

/// Where failing image tests write their images: `<target>/image-tests`, where `<target>` is
/// `$CARGO_TARGET_DIR` when set (a relative value is taken from the workspace root), else
/// `target/` in the workspace root (the nearest directory above this crate holding
/// `Cargo.lock`), else `strata-target/` in the system temporary directory.
pub fn image_test_dir() -> PathBuf {
    target_dir().join("image-tests")
}

fn workspace_root() -> Option<PathBuf> {
    let manifest = Path::new(env!("CARGO_MANIFEST_DIR"));
    manifest
        .ancestors()
        .find(|dir| dir.join("Cargo.lock").is_file())
        .map(Path::to_path_buf)
}

fn target_dir() -> PathBuf {
    let root = workspace_root();
    match std::env::var_os("CARGO_TARGET_DIR").filter(|v| !v.is_empty()) {
        Some(dir) => {
            let dir = PathBuf::from(dir);
            match root {
                Some(root) if dir.is_relative() => root.join(dir),
                _ => dir,
            }
        }
        None => match root {
            Some(root) => root.join("target"),
            None => std::env::temp_dir().join("strata-target"),
        },
    }
}

/// Keeps a test name safe as a file name: anything but ASCII letters, digits, `-`, `_` and `.`
/// becomes `_` (so `module::case` gives `module__case`).
fn file_stem(name: &str) -> String {
    let stem: String = name
        .chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || c == '-' || c == '_' || c == '.' {
                c
            } else {
                '_'
            }
        })
        .collect();
    if stem.is_empty() {
        "unnamed".to_string()
    } else {
        stem
    }
}

/// Writes `<name>-actual.png`, `<name>-expected.png` and `<name>-diff.png` and returns a phrase
/// saying where they went (or why they could not be written).
fn write_failure_images(name: &str, actual: &RgbaImage, expected: &RgbaImage) -> String {
    let dir = image_test_dir();
    if let Err(e) = std::fs::create_dir_all(&dir) {
        return format!("could not create {}: {e}", dir.display());
    }
    let stem = file_stem(name);
    let files = [
        (format!("{stem}-actual.png"), actual.clone()),
        (format!("{stem}-expected.png"), expected.clone()),
        (format!("{stem}-diff.png"), diff_heatmap(actual, expected)),
    ];
    let mut errors = Vec::new();
    for (file, img) in &files {
        if let Err(e) = save_png(img, &dir.join(file)) {
            errors.push(e.to_string());
        }
    }
    if errors.is_empty() {
        format!(
            "wrote {}/{stem}-{{actual,expected,diff}}.png (diff saturates at {DIFF_SATURATION}/255)",
            dir.display()
        )
    } else {
        format!("could not write the images: {}", errors.join("; "))
    }
}

/// Checks `actual` against `expected`: it passes when at most `max_fraction_over` (a fraction in
/// \[0,1\], not a percentage) of the pixels have a largest R, G, B |Δ| over `max_channel_diff`
/// 8-bit levels, and returns the full [`Comparison`] (FLIP against `expected`) for further
/// checks.
///
/// On failure (or a size mismatch) it writes `target/image-tests/<name>-actual.png`,
/// `<name>-expected.png` and `<name>-diff.png` (a [`diff_heatmap`]; see [`image_test_dir`]) and
/// returns a message saying what failed and where the images are, ready for `panic!`/`expect`.
pub fn check_image(
    name: &str,
    actual: &RgbaImage,
    expected: &RgbaImage,
    max_channel_diff: u8,
    max_fraction_over: f64,
) -> std::result::Result<Comparison, String> {
    if actual.dimensions() != expected.dimensions() {
        let written = write_failure_images(name, actual, expected);
        return Err(format!(
            "image test `{name}`: actual is {}x{} but expected is {}x{}; {written}",
            actual.width(),
            actual.height(),
            expected.width(),
            expected.height()
        ));
    }
    let comparison = compare(expected, actual).map_err(|e| format!("image test `{name}`: {e}"))?;
    let over = pixels_over(expected, actual, max_channel_diff)
        .map_err(|e| format!("image test `{name}`: {e}"))?;
    let fraction = if comparison.pixels == 0 {
        0.0
    } else {
        over as f64 / comparison.pixels as f64
    };
    if fraction <= max_fraction_over {
        return Ok(comparison);
    }
    let written = write_failure_images(name, actual, expected);
    Err(format!(
        "image test `{name}`: {over} of {} pixels ({:.4}%) have max channel |Δ| > {max_channel_diff}/255, \
         allowed {:.4}%; max |Δ| {}/255, RMSE {:.6}, FLIP mean {:.6}; {written}",
        comparison.pixels,
        fraction * 100.0,
        max_fraction_over * 100.0,
        comparison.max_abs_diff,
        comparison.rmse,
        comparison.flip_mean,
    ))
}

#[cfg(test)]
mod tests {
    use super::*;
    use image::Rgba;

    #[test]
    fn target_dir_is_in_workspace_or_env() {
        let dir = image_test_dir();
        assert!(dir.ends_with("image-tests"));
        if std::env::var_os("CARGO_TARGET_DIR").is_none() {
            let root = workspace_root().expect("workspace root with Cargo.lock");
            assert!(root.join("Cargo.lock").is_file());
            assert_eq!(dir, root.join("target").join("image-tests"));
        }
        assert_eq!(file_stem("a::b c/d"), "a__b_c_d");
        assert_eq!(file_stem(""), "unnamed");
    }

    #[test]
    fn passes_within_tolerance() {
        let expected = RgbaImage::from_pixel(10, 10, Rgba([50, 60, 70, 255]));
        let mut actual = expected.clone();
        actual.put_pixel(0, 0, Rgba([50, 60, 90, 255])); // 1 % of pixels, |Δ| 20
        actual.put_pixel(1, 0, Rgba([51, 60, 70, 255])); // within the per-channel bound
        let c = check_image("metrics-selftest-pass", &actual, &expected, 1, 0.01).unwrap();
        assert_eq!(c.max_abs_diff, 20);
        assert!(check_image("metrics-selftest-pass", &actual, &actual, 0, 0.0).is_ok());
    }

    #[test]
    fn failure_writes_three_files() {
        let name = "metrics-selftest-failure";
        let dir = image_test_dir();
        let paths: Vec<PathBuf> = ["actual", "expected", "diff"]
            .iter()
            .map(|kind| dir.join(format!("{name}-{kind}.png")))
            .collect();
        for p in &paths {
            std::fs::remove_file(p).ok();
        }
        let expected = RgbaImage::from_pixel(8, 8, Rgba([0, 0, 0, 255]));
        let mut actual = expected.clone();
        actual.put_pixel(3, 3, Rgba([0, 40, 0, 255]));
        actual.put_pixel(4, 4, Rgba([0, 0, 3, 255]));
        let err = check_image(name, &actual, &expected, 2, 0.0).unwrap_err();
        assert!(err.contains(name), "{err}");
        assert!(err.contains("2 of 64 pixels"), "{err}");
        assert!(err.contains("> 2/255"), "{err}");
        assert!(err.contains("max |Δ| 40/255"), "{err}");
        assert!(err.contains(&dir.display().to_string()), "{err}");
        for p in &paths {
            assert!(p.is_file(), "{} not written", p.display());
        }
        let actual_back = crate::metrics::load_png(&paths[0]).unwrap();
        assert_eq!(actual_back, actual);
        let diff = crate::metrics::load_png(&paths[2]).unwrap();
        assert_eq!(diff.get_pixel(0, 0), &Rgba([0, 0, 0, 255]));
        assert_ne!(diff.get_pixel(4, 4), &Rgba([0, 0, 0, 255]));
        for p in &paths {
            std::fs::remove_file(p).ok();
        }
    }

    #[test]
    fn size_mismatch_fails_and_writes() {
        let name = "metrics-selftest-size";
        let err =
            check_image(name, &RgbaImage::new(4, 4), &RgbaImage::new(4, 5), 255, 1.0).unwrap_err();
        assert!(err.contains("4x4") && err.contains("4x5"), "{err}");
        let dir = image_test_dir();
        for kind in ["actual", "expected", "diff"] {
            let p = dir.join(format!("{name}-{kind}.png"));
            assert!(p.is_file(), "{} not written", p.display());
            std::fs::remove_file(p).ok();
        }
    }
}
