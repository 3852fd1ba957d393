//! Pictures and their measures: the linear picture a frame makes, depth-complexity heatmaps and
//! histograms (core), 8-bit pictures and PNG files (feature `png`), and comparing two renders
//! with difference heatmaps and helpers for image tests (`testing`; feature `metrics`).
//!
//! All comparisons work on the 8-bit sRGB-encoded R, G and B channels of the PNGs strata writes;
//! alpha is ignored. The first image of a pair is the reference (this matters only for FLIP).

pub use crate::frame::colormap;
#[cfg(feature = "metrics")]
mod compare;
mod font;
pub mod gpu_histogram;
mod heatmap;
pub mod picture;
#[cfg(feature = "metrics")]
pub mod testing;

pub use colormap::colormap;
#[cfg(feature = "metrics")]
pub use compare::{compare, load_png, pixels_over, Comparison};
#[cfg(feature = "png")]
pub use heatmap::complexity_heatmap;
pub use heatmap::{complexity_heatmap_pixels, LEGEND_MIN_SIZE};
#[cfg(feature = "metrics")]
pub use heatmap::{diff_heatmap, DIFF_SATURATION};
pub use picture::LinearImage;

pub use crate::gpu::timing::median;
#[cfg(feature = "png")]
pub use crate::output::save_png;

/// Depth-complexity histogram: bin `i` counts the pixels with exactly `i` fragments. The result
/// has `max + 1` bins, `max` being the largest count (so memory grows with it); empty input gives
/// no bins.
pub fn depth_complexity_histogram(counts: &[u32]) -> Vec<u64> {
    let Some(&max) = counts.iter().max() else {
        return Vec::new();
    };
    let mut bins = vec![0u64; max as usize + 1];
    for &c in counts {
        bins[c as usize] += 1;
    }
    bins
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn histogram_bins() {
        assert_eq!(depth_complexity_histogram(&[]), Vec::<u64>::new());
        assert_eq!(depth_complexity_histogram(&[0, 0]), vec![2]);
        assert_eq!(
            depth_complexity_histogram(&[0, 3, 1, 3, 3, 0, 1]),
            vec![2, 2, 0, 3]
        );
    }
}
