//! The colormap shared by the diff and complexity heatmaps.
//!
//! A dark-to-bright ramp (black → indigo → purple → red-magenta → orange → gold → pale yellow)
//! whose lightness rises monotonically, so the order of values reads the same in colour and in
//! greyscale. The stops below are hand-picked for this crate; between stops the colour is
//! interpolated linearly in 8-bit sRGB.

use std::sync::OnceLock;

/// Colormap stops: (position in [0,1], sRGB 8-bit colour). Positions rise strictly.
const STOPS: [(f32, [u8; 3]); 7] = [
    (0.00, [0, 0, 0]),
    (0.15, [30, 14, 72]),
    (0.35, [104, 28, 130]),
    (0.55, [192, 52, 98]),
    (0.75, [246, 122, 44]),
    (0.90, [250, 200, 64]),
    (1.00, [252, 252, 204]),
];

/// Number of entries in the lookup table that [`colormap`] samples.
const LUT_SIZE: usize = 256;

fn interpolate(t: f32) -> [u8; 3] {
    let t = t.clamp(0.0, 1.0);
    for pair in STOPS.windows(2) {
        let (t0, c0) = pair[0];
        let (t1, c1) = pair[1];
        if t <= t1 {
            let f = (t - t0) / (t1 - t0);
            let mix = |a: u8, b: u8| (a as f32 + (b as f32 - a as f32) * f).round() as u8;
            return [mix(c0[0], c1[0]), mix(c0[1], c1[1]), mix(c0[2], c1[2])];
        }
    }
    STOPS[STOPS.len() - 1].1
}

fn lut() -> &'static [[u8; 3]; LUT_SIZE] {
    static LUT: OnceLock<[[u8; 3]; LUT_SIZE]> = OnceLock::new();
    LUT.get_or_init(|| {
        let mut table = [[0u8; 3]; LUT_SIZE];
        for (i, entry) in table.iter_mut().enumerate() {
            *entry = interpolate(i as f32 / (LUT_SIZE - 1) as f32);
        }
        table
    })
}

/// The crate's heatmap colormap: `t` in \[0,1\] (clamped; NaN reads as 0) to an sRGB 8-bit colour.
/// `colormap(0.0)` is black and `colormap(1.0)` is pale yellow. Sampled from a 256-entry table.
pub fn colormap(t: f32) -> [u8; 3] {
    let t = if t.is_nan() { 0.0 } else { t.clamp(0.0, 1.0) };
    lut()[(t * (LUT_SIZE - 1) as f32).round() as usize]
}

/// Where on the colormap the smallest non-zero value lands. Zero maps to black; 1 maps to
/// `colormap(RAMP_FLOOR)`, a clearly visible indigo, so a single fragment or a 1/255 difference
/// never disappears into the black of "nothing".
pub(crate) const RAMP_FLOOR: f32 = 0.2;

/// Maps `value` on the scale `0..=full` (`full` ≥ 1; larger values saturate): 0 → black, and
/// 1..=full linearly onto `colormap(RAMP_FLOOR..=1.0)`.
pub(crate) fn ramp(value: u32, full: u32) -> [u8; 3] {
    if value == 0 {
        return [0, 0, 0];
    }
    let full = full.max(1);
    let t = value.min(full) as f32 / full as f32;
    colormap(RAMP_FLOOR + (1.0 - RAMP_FLOOR) * t)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn luma(c: [u8; 3]) -> f32 {
        0.2126 * c[0] as f32 + 0.7152 * c[1] as f32 + 0.0722 * c[2] as f32
    }

    #[test]
    fn ends_and_monotonic_lightness() {
        assert_eq!(colormap(0.0), [0, 0, 0]);
        assert_eq!(colormap(1.0), [252, 252, 204]);
        assert_eq!(colormap(-3.0), colormap(0.0));
        assert_eq!(colormap(7.0), colormap(1.0));
        assert_eq!(colormap(f32::NAN), colormap(0.0));
        let mut last = -1.0;
        for i in 0..=255 {
            let l = luma(colormap(i as f32 / 255.0));
            assert!(l >= last, "lightness falls at entry {i}");
            last = l;
        }
    }

    #[test]
    fn ramp_keeps_one_visible() {
        assert_eq!(ramp(0, 10), [0, 0, 0]);
        assert!(luma(ramp(1, 1000)) > 15.0);
        assert_eq!(ramp(10, 10), colormap(1.0));
        assert_eq!(ramp(99, 10), colormap(1.0));
        assert_eq!(ramp(3, 0), colormap(1.0));
    }
}
