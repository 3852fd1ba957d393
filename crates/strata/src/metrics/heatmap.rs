//! Heatmaps: per-pixel image difference and per-pixel fragment count (depth complexity), the
//! latter with a legend drawn in its bottom-right corner.

#[cfg(feature = "png")]
use image::RgbaImage;

use super::colormap::ramp;
use super::font::{self, GLYPH_H};

/// A max-channel difference of this many 8-bit levels (32/255) or more saturates the diff
/// heatmap.
#[cfg(feature = "metrics")]
pub const DIFF_SATURATION: u8 = 32;

/// Images smaller than this on either side get no legend.
pub const LEGEND_MIN_SIZE: u32 = 48;

fn opaque([r, g, b]: [u8; 3]) -> [u8; 4] {
    [r, g, b, 255]
}

/// Difference heatmap of two images: each pixel's max channel |Δ| over R, G and B (alpha is
/// ignored) mapped through [`colormap`](super::colormap::colormap).
///
/// Scale: no difference is black; a difference of 1/255 is already a visible dark indigo
/// (`colormap(0.2)`), and the colour rises linearly to pale yellow at [`DIFF_SATURATION`]
/// (32/255), where it saturates. If the sizes differ, the output covers both images and every
/// pixel that lies outside either one is drawn saturated. Output is sRGB 8-bit with alpha 255.
#[cfg(feature = "metrics")]
pub fn diff_heatmap(a: &RgbaImage, b: &RgbaImage) -> RgbaImage {
    let width = a.width().max(b.width());
    let height = a.height().max(b.height());
    let full = DIFF_SATURATION as u32;
    RgbaImage::from_fn(width, height, |x, y| {
        let d = match (a.get_pixel_checked(x, y), b.get_pixel_checked(x, y)) {
            (Some(pa), Some(pb)) => super::compare::max_channel_diff(pa, pb) as u32,
            _ => full,
        };
        image::Rgba(opaque(ramp(d, full)))
    })
}

/// Depth-complexity heatmap: `counts` holds one fragment count per pixel, row-major from the top
/// left, `width * height` of them.
///
/// Scale: 0 fragments is black; 1..=max map linearly onto [`colormap`](super::colormap::colormap) from a
/// visible dark indigo (`colormap(0.2)`) to pale yellow, and counts above max saturate. `max` is
/// `max_count` when given, else the largest count in the image; either way at least 1.
///
/// A legend sits in the bottom-right corner: a colour bar from 0 to max with ticks labelled 0,
/// max/2 (integer division; left out when max < 2) and max in a 3x5 bitmap font, on a
/// dark semi-opaque box. The font scales with the image (one font unit is `min(w, h) / 160`
/// pixels, at least 1), so the legend reads the same from 64x64 to 4096x4096. There is no legend
/// on images under [`LEGEND_MIN_SIZE`] pixels on a side; if the labels cannot fit at the smallest
/// font, the middle label is dropped, and failing that the legend. Output is sRGB 8-bit with
/// alpha 255.
///
/// # Panics
/// If `counts.len() != width * height`.
#[cfg(feature = "png")]
pub fn complexity_heatmap(
    counts: &[u32],
    width: u32,
    height: u32,
    max_count: Option<u32>,
) -> RgbaImage {
    let pixels = complexity_heatmap_pixels(counts, width, height, max_count);
    RgbaImage::from_raw(width, height, pixels.into_iter().flatten().collect())
        .expect("one pixel per count")
}

/// `complexity_heatmap`'s pixels (feature `png`), row-major from the top left, without the `image` crate.
///
/// # Panics
/// If `counts.len() != width * height`.
pub fn complexity_heatmap_pixels(
    counts: &[u32],
    width: u32,
    height: u32,
    max_count: Option<u32>,
) -> Vec<[u8; 4]> {
    assert_eq!(
        counts.len() as u64,
        width as u64 * height as u64,
        "complexity_heatmap: {} counts for a {width}x{height} image",
        counts.len()
    );
    let max = max_count
        .unwrap_or_else(|| counts.iter().copied().max().unwrap_or(0))
        .max(1);
    let mut canvas = Canvas {
        width,
        height,
        pixels: counts.iter().map(|&c| opaque(ramp(c, max))).collect(),
    };
    if let Some(layout) = legend_layout(width, height, max) {
        draw_legend(&mut canvas, &layout, max);
    }
    canvas.pixels
}

/// The pixels a legend is drawn into, row-major from the top left.
struct Canvas {
    width: u32,
    height: u32,
    pixels: Vec<[u8; 4]>,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct Rect {
    pub x: u32,
    pub y: u32,
    pub w: u32,
    pub h: u32,
}

impl Rect {
    fn right(&self) -> u32 {
        self.x + self.w
    }
    fn bottom(&self) -> u32 {
        self.y + self.h
    }
}

#[derive(Debug, Clone)]
pub(crate) struct Label {
    pub value: u32,
    pub text: String,
    /// Where the text lies, in pixels.
    pub rect: Rect,
}

/// Where every part of the legend goes, in image pixels.
#[derive(Debug, Clone)]
pub(crate) struct LegendLayout {
    /// Pixels per font unit.
    pub scale: u32,
    /// Top of the scale (the last label's value).
    pub max: u32,
    pub boxr: Rect,
    pub bar: Rect,
    /// Thickness in pixels of the frame drawn just outside the bar.
    pub frame: u32,
    pub tick_len: u32,
    pub labels: Vec<Label>,
}

impl LegendLayout {
    /// Pixel column of the tick for `value` (in `0..=max`).
    pub fn tick_x(&self, value: u32) -> u32 {
        self.bar.x + value_to_column(value, self.max, self.bar.w)
    }
}

/// Bar column (0-based, within the bar) where `value` of `0..=max` sits.
fn value_to_column(value: u32, max: u32, bar_w: u32) -> u32 {
    let span = (bar_w.max(1) - 1) as u64;
    ((value as u64 * span + max as u64 / 2) / max as u64) as u32
}

/// Count shown by bar column `col` (the inverse of [`value_to_column`], rounded).
fn column_to_value(col: u32, max: u32, bar_w: u32) -> u32 {
    if bar_w <= 1 {
        return max;
    }
    let span = (bar_w - 1) as u64;
    ((col as u64 * max as u64 + span / 2) / span) as u32
}

/// Lays the legend out at font scale `s`, with or without the middle label; `None` when it does
/// not fit in the image.
fn try_layout(width: u32, height: u32, max: u32, s: u32, with_mid: bool) -> Option<LegendLayout> {
    let pad = 2 * s;
    let margin = 2 * s;
    let bar_h = 4 * s;
    let tick_len = s;
    let text_gap = s;
    let label_gap = 4 * s;
    let text_h = GLYPH_H * s;
    let min_bar_w = 32 * s;

    let mut values = vec![0];
    if with_mid {
        values.push(max / 2);
    }
    values.push(max);
    let texts: Vec<String> = values.iter().map(|v| v.to_string()).collect();
    let widths: Vec<u32> = texts.iter().map(|t| font::text_width(t) * s).collect();

    let box_h = pad + bar_h + tick_len + text_gap + text_h + pad;
    let max_bar_w = width.checked_sub(margin + 2 * pad)?;
    if box_h + margin > height {
        return None;
    }

    // Places the labels under a bar of width `bar_w`: the first left-aligned at its tick, the
    // last right-aligned, any middle one centred; then checks that neighbours keep their gap.
    let place = |bar_w: u32| -> Option<Vec<u32>> {
        let n = values.len();
        let mut spans = Vec::with_capacity(n);
        for (i, (&v, &w)) in values.iter().zip(&widths).enumerate() {
            if w > bar_w {
                return None;
            }
            let tick = value_to_column(v, max, bar_w);
            let x = if i == 0 {
                0
            } else if i == n - 1 {
                bar_w - w
            } else {
                tick.saturating_sub(w / 2).min(bar_w - w)
            };
            spans.push(x);
        }
        for i in 1..n {
            let prev_end = spans[i - 1] + widths[i - 1];
            if prev_end + label_gap > spans[i] {
                return None;
            }
        }
        Some(spans)
    };

    let mut bar_w =
        min_bar_w.max(widths.iter().sum::<u32>() + label_gap * (values.len() as u32 - 1));
    let spans = loop {
        if bar_w > max_bar_w {
            return None;
        }
        if let Some(spans) = place(bar_w) {
            break spans;
        }
        bar_w += 1;
    };

    let box_w = bar_w + 2 * pad;
    let boxr = Rect {
        x: width - margin - box_w,
        y: height - margin - box_h,
        w: box_w,
        h: box_h,
    };
    let bar = Rect {
        x: boxr.x + pad,
        y: boxr.y + pad,
        w: bar_w,
        h: bar_h,
    };
    let text_y = bar.bottom() + tick_len + text_gap;
    let labels = values
        .iter()
        .zip(texts)
        .zip(widths)
        .zip(spans)
        .map(|(((&value, text), w), x)| Label {
            value,
            text,
            rect: Rect {
                x: bar.x + x,
                y: text_y,
                w,
                h: text_h,
            },
        })
        .collect();
    Some(LegendLayout {
        scale: s,
        max,
        boxr,
        bar,
        frame: (s / 2).max(1),
        tick_len,
        labels,
    })
}

/// The legend's layout for a `width` x `height` heatmap whose scale tops out at `max` (≥ 1), or
/// `None` when the image is too small for one.
pub(crate) fn legend_layout(width: u32, height: u32, max: u32) -> Option<LegendLayout> {
    if width < LEGEND_MIN_SIZE || height < LEGEND_MIN_SIZE {
        return None;
    }
    let max = max.max(1);
    let preferred = (width.min(height) / 160).max(1);
    let mid_options: &[bool] = if max >= 2 { &[true, false] } else { &[false] };
    for &with_mid in mid_options {
        for s in (1..=preferred).rev() {
            if let Some(layout) = try_layout(width, height, max, s, with_mid) {
                return Some(layout);
            }
        }
    }
    None
}

/// Fills `r` (clipped to the image) with `f(old) -> new`.
fn shade_rect(img: &mut Canvas, r: Rect, mut f: impl FnMut([u8; 4]) -> [u8; 4]) {
    let x1 = r.right().min(img.width);
    let y1 = r.bottom().min(img.height);
    for y in r.y.min(y1)..y1 {
        for x in r.x.min(x1)..x1 {
            let p = &mut img.pixels[(y * img.width + x) as usize];
            *p = f(*p);
        }
    }
}

fn fill_rect(img: &mut Canvas, r: Rect, color: [u8; 4]) {
    shade_rect(img, r, |_| color);
}

const FRAME_COLOR: [u8; 4] = [150, 150, 150, 255];
const TICK_COLOR: [u8; 4] = [220, 220, 220, 255];
const TEXT_COLOR: [u8; 4] = [240, 240, 240, 255];
/// The legend box lets this fraction (out of 256) of the heatmap show through.
const BOX_SHOW_THROUGH: u16 = 64;

fn draw_legend(img: &mut Canvas, layout: &LegendLayout, max: u32) {
    let s = layout.scale;
    // Dark semi-opaque box: 75 % black over the heatmap.
    shade_rect(img, layout.boxr, |p| {
        let dim = |c: u8| ((c as u16 * BOX_SHOW_THROUGH) / 256) as u8;
        [dim(p[0]), dim(p[1]), dim(p[2]), 255]
    });
    // Frame around the bar, so the black "0" end stays visible on the dark box.
    let bar = layout.bar;
    let f = layout.frame;
    fill_rect(
        img,
        Rect {
            x: bar.x - f,
            y: bar.y - f,
            w: bar.w + 2 * f,
            h: bar.h + 2 * f,
        },
        FRAME_COLOR,
    );
    // The colour bar, one column per displayed count.
    for col in 0..bar.w {
        let value = column_to_value(col, max, bar.w);
        let color = opaque(ramp(value, max));
        fill_rect(
            img,
            Rect {
                x: bar.x + col,
                y: bar.y,
                w: 1,
                h: bar.h,
            },
            color,
        );
    }
    let tick_w = (s / 2).max(1);
    for label in &layout.labels {
        let x = (layout.tick_x(label.value).saturating_sub(tick_w / 2)).min(bar.right() - tick_w);
        fill_rect(
            img,
            Rect {
                x,
                y: bar.bottom(),
                w: tick_w,
                h: layout.tick_len,
            },
            TICK_COLOR,
        );
        let origin = label.rect;
        font::for_each_cell(&label.text, |cx, cy| {
            fill_rect(
                img,
                Rect {
                    x: origin.x + cx * s,
                    y: origin.y + cy * s,
                    w: s,
                    h: s,
                },
                TEXT_COLOR,
            );
        });
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::metrics::colormap::{colormap, RAMP_FLOOR};
    use image::{Rgba, RgbaImage};

    fn opaque(rgb: [u8; 3]) -> Rgba<u8> {
        Rgba(super::opaque(rgb))
    }

    fn inside(inner: Rect, outer: Rect) -> bool {
        inner.x >= outer.x
            && inner.y >= outer.y
            && inner.right() <= outer.right()
            && inner.bottom() <= outer.bottom()
    }

    #[test]
    fn diff_heatmap_scale() {
        let a = RgbaImage::from_pixel(4, 1, Rgba([100, 100, 100, 255]));
        let mut b = a.clone();
        b.put_pixel(1, 0, Rgba([101, 100, 100, 0])); // 1/255, alpha ignored
        b.put_pixel(2, 0, Rgba([100, 132, 100, 255])); // 32/255: saturated
        b.put_pixel(3, 0, Rgba([100, 100, 0, 255])); // far beyond: saturated
        let h = diff_heatmap(&a, &b);
        assert_eq!(h.get_pixel(0, 0), &Rgba([0, 0, 0, 255]));
        let one = h.get_pixel(1, 0);
        assert_ne!(one, &Rgba([0, 0, 0, 255]));
        let full = opaque(colormap(1.0));
        assert_eq!(h.get_pixel(2, 0), &full);
        assert_eq!(h.get_pixel(3, 0), &full);
        assert!(h.pixels().all(|p| p[3] == 255));
    }

    #[test]
    fn diff_heatmap_size_mismatch_covers_both() {
        let a = RgbaImage::new(3, 2);
        let b = RgbaImage::new(2, 4);
        let h = diff_heatmap(&a, &b);
        assert_eq!(h.dimensions(), (3, 4));
        let full = opaque(colormap(1.0));
        assert_eq!(h.get_pixel(0, 0), &Rgba([0, 0, 0, 255]));
        assert_eq!(h.get_pixel(2, 0), &full);
        assert_eq!(h.get_pixel(0, 3), &full);
    }

    #[test]
    fn complexity_colors_outside_legend() {
        let (w, h) = (300, 100);
        let mut counts = vec![0u32; (w * h) as usize];
        counts[1] = 1;
        counts[2] = 8;
        counts[3] = 4;
        let img = complexity_heatmap(&counts, w, h, None);
        assert_eq!(img.dimensions(), (w, h));
        assert!(img.pixels().all(|p| p[3] == 255));
        assert_eq!(img.get_pixel(0, 0), &Rgba([0, 0, 0, 255]));
        assert_eq!(img.get_pixel(1, 0), &opaque(ramp(1, 8)));
        assert_eq!(img.get_pixel(2, 0), &opaque(colormap(1.0)));
        let mid = colormap(RAMP_FLOOR + (1.0 - RAMP_FLOOR) * 0.5);
        assert_eq!(img.get_pixel(3, 0), &opaque(mid));
        // An explicit max saturates counts above it.
        let img = complexity_heatmap(&counts, w, h, Some(4));
        assert_eq!(img.get_pixel(2, 0), &opaque(colormap(1.0)));
        assert_eq!(img.get_pixel(3, 0), &opaque(colormap(1.0)));
    }

    #[test]
    fn legend_drawn_or_skipped_without_panic() {
        for &(w, h) in &[
            (1, 1),
            (47, 47),
            (47, 300),
            (48, 48),
            (64, 64),
            (300, 100),
            (100, 300),
            (333, 257),
        ] {
            for &max in &[
                None,
                Some(0),
                Some(1),
                Some(2),
                Some(3),
                Some(1000),
                Some(u32::MAX),
            ] {
                let n = (w * h) as usize;
                let counts: Vec<u32> = (0..n as u32).map(|i| i % 5).collect();
                let img = complexity_heatmap(&counts, w, h, max);
                assert_eq!(img.dimensions(), (w, h));
                assert!(img.pixels().all(|p| p[3] == 255));
            }
        }
        // No legend under 48 pixels: the image is the bare heatmap.
        let counts = vec![3u32; 47 * 47];
        let img = complexity_heatmap(&counts, 47, 47, None);
        assert!(img.pixels().all(|p| p == &opaque(colormap(1.0))));
        // A legend at 64x64: the bottom-right corner is no longer uniform.
        let counts = vec![3u32; 64 * 64];
        let img = complexity_heatmap(&counts, 64, 64, None);
        assert!(img.pixels().any(|p| p != &opaque(colormap(1.0))));
        assert_eq!(img.get_pixel(0, 0), &opaque(colormap(1.0)));
    }

    #[test]
    fn empty_image() {
        let img = complexity_heatmap(&[], 0, 0, None);
        assert_eq!(img.dimensions(), (0, 0));
        let img = complexity_heatmap(&[], 0, 100, Some(5));
        assert_eq!(img.dimensions(), (0, 100));
    }

    #[test]
    #[should_panic(expected = "counts for a")]
    fn count_length_mismatch_panics() {
        complexity_heatmap(&[1, 2, 3], 2, 2, None);
    }

    #[test]
    fn legend_layout_fits_and_labels_do_not_overlap() {
        let sizes = [
            (48, 48),
            (64, 64),
            (100, 64),
            (300, 100),
            (256, 256),
            (320, 240),
            (1024, 768),
            (1920, 1080),
            (4096, 4096),
            (4096, 64),
            (64, 4096),
        ];
        let maxes = [
            1,
            2,
            3,
            5,
            9,
            10,
            11,
            99,
            100,
            101,
            255,
            999,
            1000,
            12345,
            1_000_000,
            u32::MAX,
        ];
        for &(w, h) in &sizes {
            let image = Rect { x: 0, y: 0, w, h };
            for &max in &maxes {
                let Some(l) = legend_layout(w, h, max) else {
                    // Only huge labels on the smallest images may drop the legend.
                    assert!(
                        w.min(h) < 64 || max > 1_000_000,
                        "no legend at {w}x{h} max {max}"
                    );
                    continue;
                };
                let ctx = format!("{w}x{h} max {max}");
                assert!(inside(l.boxr, image), "box outside image: {ctx}");
                assert!(inside(l.bar, l.boxr), "bar outside box: {ctx}");
                assert!(l.bar.x >= l.boxr.x + l.frame, "{ctx}");
                let values: Vec<u32> = l.labels.iter().map(|lb| lb.value).collect();
                assert_eq!(values.first(), Some(&0), "{ctx}");
                assert_eq!(values.last(), Some(&max), "{ctx}");
                if max >= 2 && w.min(h) >= 64 && max <= 1000 {
                    assert_eq!(values, vec![0, max / 2, max], "{ctx}");
                }
                for lb in &l.labels {
                    assert!(inside(lb.rect, l.boxr), "label outside box: {ctx}");
                    assert!(lb.rect.y >= l.bar.bottom() + l.tick_len, "{ctx}");
                    let tick = l.tick_x(lb.value);
                    assert!(tick >= l.bar.x && tick < l.bar.right(), "{ctx}");
                    assert_eq!(lb.text, lb.value.to_string());
                }
                for pair in l.labels.windows(2) {
                    assert!(
                        pair[0].rect.right() < pair[1].rect.x,
                        "labels overlap: {ctx}: {:?}",
                        l.labels
                    );
                }
                // The legend is a modest part of the picture and grows with it.
                assert!(l.boxr.h * 3 <= h, "legend too tall: {ctx}");
                if w.min(h) >= 1024 && max <= 1000 {
                    assert!(l.scale >= 6, "legend font too small: {ctx}");
                }
            }
        }
    }

    #[test]
    fn legend_bar_spans_zero_to_max() {
        let (w, h, max) = (320, 240, 10);
        let counts = vec![0u32; (w * h) as usize];
        let img = complexity_heatmap(&counts, w, h, Some(max));
        let l = legend_layout(w, h, max).unwrap();
        let y = l.bar.y + l.bar.h / 2;
        assert_eq!(img.get_pixel(l.bar.x, y), &Rgba([0, 0, 0, 255]));
        assert_eq!(img.get_pixel(l.bar.right() - 1, y), &opaque(colormap(1.0)));
        // Ticks sit at their values.
        for lb in &l.labels {
            assert_eq!(
                column_to_value(l.tick_x(lb.value) - l.bar.x, max, l.bar.w),
                lb.value
            );
        }
    }
}
