//! The picture a frame or the reference makes, before encoding.

#[cfg(feature = "png")]
use crate::frame::Effect;
#[cfg(feature = "png")]
use crate::scene::linear_to_srgb;

/// A rendered frame before encoding: per pixel linear RGB and the number of fragments composited.
#[derive(Clone, Debug, PartialEq)]
pub struct LinearImage {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// Row-major from the top-left: `[r, g, b, fragment count]`.
    pub pixels: Vec<[f32; 4]>,
}

impl LinearImage {
    /// Each pixel's fragment count.
    pub fn counts(&self) -> Vec<u32> {
        self.pixels.iter().map(|p| p[3].round() as u32).collect()
    }

    /// The largest fragment count of any pixel.
    pub fn max_count(&self) -> u32 {
        self.pixels
            .iter()
            .map(|p| p[3].round() as u32)
            .max()
            .unwrap_or(0)
    }

    /// The picture as 8-bit sRGB: colors for the transparency effects, a heatmap with a legend
    /// for `complexity`.
    #[cfg(feature = "png")]
    pub fn to_rgba8(&self, effect: Effect) -> image::RgbaImage {
        if effect == Effect::Complexity {
            return super::complexity_heatmap(&self.counts(), self.width, self.height, None);
        }
        let mut img = image::RgbaImage::new(self.width, self.height);
        for (dst, src) in img.pixels_mut().zip(&self.pixels) {
            let e = |c: f32| (linear_to_srgb(c) * 255.0).round() as u8;
            *dst = image::Rgba([e(src[0]), e(src[1]), e(src[2]), 255]);
        }
        img
    }
}
