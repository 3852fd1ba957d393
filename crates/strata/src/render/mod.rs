//! Frames for applications ([`FrameRecorder`]) and the batch renderer the CLI and the tests
//! use on top of it ([`Renderer`]):
//! *exact mode*. A picture is recorded and submitted, its statistics waited for, and the frame
//! rendered again while a method reports it incomplete (a fragment pool that overflowed, too few
//! peeling layers) — the method has grown from the measured need by then, so the second frame is
//! complete. The resolved frame is read back and composited over the picture's background on
//! the CPU. `FrameStats` count the submits and blocking readbacks this takes.

pub mod recorder;

pub use recorder::FrameRecorder;

use crate::error::{Error, Result};
use crate::frame::GbufferView;
use crate::frame::{DrawCallback, FrameStats, FrameTargets, Resolved};
use crate::gpu::{readback, Gpu};
use crate::methods::MethodId;
use crate::scene::{linear_to_srgb, srgb_to_linear, Scene};

pub use crate::frame::{Effect, RenderOptions, Tail};

/// Exact mode gives up after this many frames of one picture (each one grows what overflowed,
/// so two suffice unless the scene changed in between).
pub const MAX_EXACT_FRAMES: u32 = 4;

/// A rendered frame before encoding: per pixel linear RGB and the number of fragments composited.
#[derive(Clone, Debug, PartialEq)]
pub struct LinearImage {
    pub width: u32,
    pub height: u32,
    /// Row-major from the top-left: `[r, g, b, fragment count]`.
    pub pixels: Vec<[f32; 4]>,
}

impl LinearImage {
    pub fn counts(&self) -> Vec<u32> {
        self.pixels.iter().map(|p| p[3].round() as u32).collect()
    }

    pub fn max_count(&self) -> u32 {
        self.pixels
            .iter()
            .map(|p| p[3].round() as u32)
            .max()
            .unwrap_or(0)
    }

    /// The picture as 8-bit sRGB: colors for the transparency effects, a heatmap with a legend
    /// for `complexity`.
    pub fn to_rgba8(&self, effect: Effect) -> image::RgbaImage {
        if effect == Effect::Complexity {
            return crate::metrics::complexity_heatmap(
                &self.counts(),
                self.width,
                self.height,
                None,
            );
        }
        let mut img = image::RgbaImage::new(self.width, self.height);
        for (dst, src) in img.pixels_mut().zip(&self.pixels) {
            let e = |c: f32| (linear_to_srgb(c) * 255.0).round() as u8;
            *dst = image::Rgba([e(src[0]), e(src[1]), e(src[2]), 255]);
        }
        img
    }
}

pub use crate::metrics::save_png;

/// Renders a scene with the GPU methods in exact mode. Holds one [`FrameRecorder`] (the scene
/// buffers and each method's resources), so a second picture reuses what the first sized.
pub struct Renderer<'g> {
    gpu: &'g Gpu,
    scene: Scene,
    options: RenderOptions,
    opaque: wgpu::Texture,
    recorder: Option<FrameRecorder>,
}

impl<'g> Renderer<'g> {
    pub fn new(gpu: &'g Gpu, scene: &Scene, options: &RenderOptions) -> Result<Renderer<'g>> {
        options.validate()?;
        let max_dim = gpu.limits.max_texture_dimension_2d;
        if options.width > max_dim || options.height > max_dim {
            return Err(Error::unsupported(format!(
                "size {}x{} exceeds the device's texture limit {max_dim}",
                options.width, options.height
            )));
        }
        scene.validate()?;
        let opaque = gpu.texture_2d(
            "strata.opaque_depth",
            (options.width, options.height),
            wgpu::TextureFormat::Depth32Float,
            wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::TEXTURE_BINDING,
        );
        clear_depth(gpu, &opaque.create_view(&Default::default()), 1.0);
        Ok(Renderer {
            gpu,
            scene: scene.clone(),
            options: options.clone(),
            opaque,
            recorder: None,
        })
    }

    pub fn options(&self) -> &RenderOptions {
        &self.options
    }

    /// The depth texture fragments are tested against (Depth32Float, the frame's size); render
    /// opaque geometry into it to hide fragments behind it.
    pub fn opaque_depth(&self) -> &wgpu::Texture {
        &self.opaque
    }

    /// The recorder behind the renderer, once a picture was rendered (tests poison its buffers).
    pub fn recorder(&self) -> Option<&FrameRecorder> {
        self.recorder.as_ref()
    }

    /// Renders one picture with `method` (an id of the catalogue) and reads it back.
    pub fn render(&mut self, method: &str) -> Result<(LinearImage, FrameStats)> {
        self.render_frame(method.parse()?, None)
    }

    /// Like [`Renderer::render`], with the application issuing the draw calls of every geometry
    /// pass (see [`DrawCallback`]).
    pub fn render_with(
        &mut self,
        method: &str,
        draw: &DrawCallback<'_>,
    ) -> Result<(LinearImage, FrameStats)> {
        self.render_frame(method.parse()?, Some(draw))
    }

    /// The next time step of an animated scene (same triangle count; the camera stays): the
    /// next picture renders it, reusing every pipeline and buffer.
    pub fn set_geometry(&mut self, scene: &Scene) -> Result<()> {
        if let Some(recorder) = &mut self.recorder {
            recorder.set_geometry(scene)?;
        }
        self.scene = scene.clone();
        Ok(())
    }

    /// Renders with a typed method id.
    pub fn render_method(
        &mut self,
        method: MethodId,
        draw: Option<&DrawCallback<'_>>,
    ) -> Result<(LinearImage, FrameStats)> {
        self.render_frame(method, draw)
    }

    fn render_frame(
        &mut self,
        method: MethodId,
        draw: Option<&DrawCallback<'_>>,
    ) -> Result<(LinearImage, FrameStats)> {
        let recorder = match &mut self.recorder {
            Some(r) => {
                r.set_method(method)?;
                r
            }
            None => self.recorder.insert(FrameRecorder::new(
                self.gpu,
                &self.scene,
                method,
                &self.options,
            )?),
        };
        let opaque = self.opaque.create_view(&Default::default());
        // A pipeline draws the opaque objects and their depth itself.
        let targets = FrameTargets {
            color: None,
            opaque_depth: self.options.pipeline.is_none().then_some(&opaque),
        };
        let (mut submits, mut blocking, mut passes, mut overflowed) = (0, 0, 0, false);
        let mut report = None;
        for _ in 0..MAX_EXACT_FRAMES {
            let mut encoder =
                self.gpu
                    .device
                    .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                        label: Some("strata.exact_frame"),
                    });
            recorder.record(&mut encoder, &targets, draw)?;
            self.gpu.queue.submit([encoder.finish()]);
            submits += 1;
            let r = recorder.wait_stats()?;
            blocking += 1;
            passes += r.stats.geometry_passes.unwrap_or(0);
            overflowed |= r.stats.overflow == Some(true) || r.incomplete;
            let incomplete = r.incomplete;
            if incomplete {
                if let Some(why) = r.cannot_complete {
                    return Err(Error::input(why));
                }
            }
            report = Some(r.stats);
            if !incomplete {
                break;
            }
        }
        let mut stats = report.expect("at least one frame");
        if let Some(s) = stats.overflow.as_mut() {
            *s = overflowed;
        }
        stats.geometry_passes = Some(passes);
        let bytes = readback::read_buffer(
            self.gpu,
            recorder.resolved(),
            self.options.pixels() * crate::frame::RESOLVED_BYTES,
        )?;
        blocking += 1;
        stats.submits = submits + 1;
        stats.blocking_readbacks = blocking;
        let resolved: Vec<Resolved> = bytemuck::pod_collect_to_vec(&bytes);
        let (w, h) = (self.options.width, self.options.height);
        let background = self.options.background;
        if let Some(lit) = recorder.lit() {
            let hdr = readback::read_rgba16f(self.gpu, lit.hdr())?;
            stats.blocking_readbacks += 1;
            stats.submits += 1;
            let pixels = lit_pixels(&self.options, &hdr, &resolved);
            return Ok((
                LinearImage {
                    width: w,
                    height: h,
                    pixels,
                },
                stats,
            ));
        }
        let pixels = resolved
            .iter()
            .enumerate()
            .map(|(i, r)| {
                let bg = background.at(i as u32 % w, i as u32 / w);
                let t = 1.0 - r.color[3];
                [
                    r.color[0] + t * bg[0],
                    r.color[1] + t * bg[1],
                    r.color[2] + t * bg[2],
                    r.count as f32,
                ]
            })
            .collect();
        Ok((
            LinearImage {
                width: w,
                height: h,
                pixels,
            },
            stats,
        ))
    }
}

/// The picture of a lit frame from its HDR image (the method presented over the opaque
/// surfaces): over the background, tone-mapped; a G-buffer view as it is (the normal error as a
/// heatmap in hundredths of a degree).
fn lit_pixels(options: &RenderOptions, hdr: &[[f32; 4]], resolved: &[Resolved]) -> Vec<[f32; 4]> {
    let w = options.width;
    let counts = resolved.iter().map(|r| r.count as f32);
    match options.gbuffer_debug {
        Some(GbufferView::NormalError) => {
            let centidegrees: Vec<u32> =
                hdr.iter().map(|p| (p[0] * 100.0).round() as u32).collect();
            let map = crate::metrics::complexity_heatmap(&centidegrees, w, options.height, None);
            map.pixels()
                .zip(counts)
                .map(|(p, n)| {
                    let c = |i: usize| srgb_to_linear(p[i] as f32 / 255.0);
                    [c(0), c(1), c(2), n]
                })
                .collect()
        }
        Some(_) => hdr
            .iter()
            .zip(counts)
            .map(|(p, n)| [p[0], p[1], p[2], n])
            .collect(),
        None => hdr
            .iter()
            .zip(counts)
            .enumerate()
            .map(|(i, (p, n))| {
                let bg = options.background.at(i as u32 % w, i as u32 / w);
                let t = 1.0 - p[3] as f64;
                let over = [0, 1, 2].map(|c| p[c] as f64 + t * bg[c] as f64);
                let [r, g, b] = crate::deferred::encoding::tone_map(options.tonemap, over);
                [r as f32, g as f32, b as f32, n]
            })
            .collect(),
    }
}

/// Clears a depth texture to `value` (a setup step, submitted on its own).
pub fn clear_depth(gpu: &Gpu, view: &wgpu::TextureView, value: f32) {
    let mut enc = gpu
        .device
        .create_command_encoder(&wgpu::CommandEncoderDescriptor {
            label: Some("strata.clear_depth"),
        });
    recorder::clear_depth_pass(&mut enc, view, value);
    gpu.queue.submit([enc.finish()]);
}
