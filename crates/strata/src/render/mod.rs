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
use crate::frame::{Band, DrawCallback, FrameStats, FrameTargets, Resolved, BAND_ALIGN};
use crate::gpu::{readback, Gpu};
use crate::methods::downlevel::{is_downlevel, DownlevelFrame};
use crate::methods::peeling::PeelingOptions;
use crate::methods::MethodId;
use crate::scene::{srgb_to_linear, Scene};

pub use crate::frame::{Effect, RenderOptions};
pub use crate::methods::kbuffer::Tail;

/// Exact mode gives up after this many frames of one picture (each one grows what overflowed,
/// so two suffice unless the scene changed in between).
pub const MAX_EXACT_FRAMES: u32 = 4;

/// The largest picture the batch renderer makes: 8192×8192, whose [`LinearImage`] takes 1 GiB
/// of host memory (and its PNG 256 MiB more). Larger ones are refused before anything is made.
pub const MAX_PICTURE_PIXELS: u64 = 8192 * 8192;

#[cfg(feature = "png")]
pub use crate::metrics::save_png;
pub use crate::metrics::LinearImage;

/// Renders a scene with the GPU methods in exact mode. Holds one [`FrameRecorder`] (the scene
/// buffers and each method's resources), so a second picture reuses what the first sized.
pub struct Renderer<'g> {
    gpu: &'g Gpu,
    scene: Scene,
    options: RenderOptions,
    opaque: wgpu::Texture,
    /// Whether [`Renderer::opaque_depth`] was handed out (the application may have drawn
    /// into it, which banded pictures cannot use).
    opaque_lent: std::cell::Cell<bool>,
    /// A cleared depth texture of one band's size, for banded pictures.
    band_opaque: Option<wgpu::Texture>,
    max_band_rows: Option<u32>,
    /// What the last picture that outgrew a binding needed and what a binding holds.
    shortfall: Option<(u64, u64)>,
    recorder: Option<FrameRecorder>,
    /// On a downlevel device: f2b through render targets, in place of the recorder.
    downlevel: Option<DownlevelFrame>,
    /// The time set by [`Renderer::set_time`]: the GPU moves the scene there (the CPU scene
    /// stays at its own time).
    time: Option<f32>,
}

impl<'g> Renderer<'g> {
    /// A renderer of `scene` with `options` (validated), refusing sizes over the device's largest texture.
    pub fn new(gpu: &'g Gpu, scene: &Scene, options: &RenderOptions) -> Result<Renderer<'g>> {
        options.validate()?;
        let max_dim = gpu.limits.max_texture_dimension_2d;
        if options.frame.width > max_dim || options.frame.height > max_dim {
            return Err(Error::unsupported(format!(
                "size {}x{} exceeds the device's texture limit {max_dim}",
                options.frame.width, options.frame.height
            )));
        }
        if options.pixels() > MAX_PICTURE_PIXELS {
            return Err(Error::unsupported(format!(
                "--size {}x{} is {} pixels, more than strata renders in one picture ({MAX_PICTURE_PIXELS}, 8192x8192: 1 GiB of image in host memory)",
                options.frame.width,
                options.frame.height,
                options.pixels()
            )));
        }
        scene.validate()?;
        let opaque = gpu.texture_2d(
            "strata.opaque_depth",
            (options.frame.width, options.frame.height),
            wgpu::TextureFormat::Depth32Float,
            wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::TEXTURE_BINDING,
        );
        clear_depth(gpu, &opaque.create_view(&Default::default()), 1.0);
        Ok(Renderer {
            gpu,
            scene: scene.clone(),
            options: options.clone(),
            opaque,
            opaque_lent: std::cell::Cell::new(false),
            band_opaque: None,
            max_band_rows: None,
            shortfall: None,
            recorder: None,
            downlevel: None,
            time: None,
        })
    }

    /// The options pictures are rendered with.
    pub fn options(&self) -> &RenderOptions {
        &self.options
    }

    /// The depth texture fragments are tested against (Depth32Float, the frame's size); render
    /// opaque geometry into it to hide fragments behind it.
    pub fn opaque_depth(&self) -> &wgpu::Texture {
        self.opaque_lent.set(true);
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
        self.downlevel = None;
        self.scene = scene.clone();
        self.time = None;
        Ok(())
    }

    /// Moves the scene to time `t` (frames) for the next pictures: moving objects move on the
    /// GPU (nothing is rebuilt or uploaded) and a camera path moves the camera.
    pub fn set_time(&mut self, t: f32) {
        if let Some(recorder) = &mut self.recorder {
            recorder.set_time(t);
        }
        // The downlevel frame uploads the scene as the CPU moved it.
        self.downlevel = None;
        if let Some(path) = &self.scene.camera_path {
            self.scene.camera = Some(path.camera_at(t));
        }
        self.time = Some(t);
    }

    /// Moves the camera for the next pictures (a camera path); pipelines and buffers are kept.
    pub fn set_camera(&mut self, camera: &crate::scene::Camera) {
        if let Some(recorder) = &mut self.recorder {
            recorder.set_camera(camera);
        }
        if let Some(downlevel) = &mut self.downlevel {
            downlevel.set_camera(self.gpu, camera);
        }
        self.scene.camera = Some(*camera);
    }

    /// Renders with a typed method id.
    pub fn render_method(
        &mut self,
        method: MethodId,
        draw: Option<&DrawCallback<'_>>,
    ) -> Result<(LinearImage, FrameStats)> {
        self.render_frame(method, draw)
    }

    /// Renders pictures whose per-pixel buffers fit in bands of at most `rows` rows (rounded
    /// down to a multiple of [`BAND_ALIGN`], at least that), even when the whole picture would
    /// fit (`None`: bands only when it does not).
    pub fn set_max_band_rows(&mut self, rows: Option<u32>) {
        self.max_band_rows = rows.map(|r| (r / BAND_ALIGN * BAND_ALIGN).max(BAND_ALIGN));
    }

    fn render_frame(
        &mut self,
        method: MethodId,
        draw: Option<&DrawCallback<'_>>,
    ) -> Result<(LinearImage, FrameStats)> {
        if is_downlevel(self.gpu) {
            return self.render_downlevel(method, draw);
        }
        // A shortfall describes the picture that measured it, never a later one.
        self.shortfall = None;
        let (w, h) = (self.options.frame.width, self.options.frame.height);
        let fits = self.options.pixels() <= recorder::max_resolved_pixels(self.gpu);
        let rows = match self.max_band_rows {
            Some(rows) if rows < h => rows,
            _ if fits => {
                let options = self.options.clone();
                let opaque = self.opaque.create_view(&Default::default());
                match self.render_picture(method, draw, &options, &opaque) {
                    // A method's buffers outgrew a binding: bands will hold them.
                    Err(e) if outgrew_binding(&e) && h > BAND_ALIGN && !self.opaque_lent.get() => {
                        self.smaller_bands(h, &e)?
                    }
                    done => return done,
                }
            }
            _ => {
                let rows = (recorder::max_resolved_pixels(self.gpu) / w as u64) as u32;
                (rows / BAND_ALIGN * BAND_ALIGN).max(BAND_ALIGN)
            }
        };
        self.render_bands(method, draw, rows)
    }

    /// The picture in horizontal bands of `rows` rows, each a frame of its own whose projection
    /// is cropped to it; bands halve while a method's per-pixel buffers outgrow a binding.
    fn render_bands(
        &mut self,
        method: MethodId,
        draw: Option<&DrawCallback<'_>>,
        mut rows: u32,
    ) -> Result<(LinearImage, FrameStats)> {
        let (w, h) = (self.options.frame.width, self.options.frame.height);
        if self.opaque_lent.get() {
            return Err(Error::unsupported(format!(
                "{w}x{h} is rendered in bands of {rows} rows, which cannot take the application's opaque depth (Renderer::opaque_depth); use a smaller size"
            )));
        }
        let mut pixels = Vec::with_capacity(self.options.pixels() as usize);
        let mut total: Option<FrameStats> = None;
        let mut top = 0;
        while top < h {
            let band_rows = rows.min(h - top);
            let mut options = self.options.clone();
            options.frame.height = band_rows;
            options.frame.band = Some(Band {
                full_height: h,
                top,
            });
            let opaque = self.band_depth(w, band_rows);
            match self.render_picture(method, draw, &options, &opaque) {
                Ok((image, stats)) => {
                    pixels.extend(image.pixels);
                    total = Some(match total {
                        None => stats,
                        Some(sum) => merge_band(sum, stats),
                    });
                    top += band_rows;
                }
                Err(e) if outgrew_binding(&e) => {
                    if rows == BAND_ALIGN {
                        return Err(Error::unsupported(format!(
                            "{w}x{h} does not fit even in bands of {BAND_ALIGN} rows: {e}"
                        )));
                    }
                    rows = self.smaller_bands(band_rows, &e)?;
                }
                Err(e) => return Err(e),
            }
        }
        let mut stats = total.expect("a picture has rows");
        stats.height = h;
        Ok((
            LinearImage {
                width: w,
                height: h,
                pixels,
            },
            stats,
        ))
    }

    /// The rows of the next bands after a picture (or band) of `rows` rows outgrew a binding
    /// with `e`: where the frame said what it needed, the rows that need what a binding holds
    /// at the frame's average density — refused at once when even a band of [`BAND_ALIGN`]
    /// rows needs more on average, since some band then needs at least that much — else half.
    fn smaller_bands(&mut self, rows: u32, e: &Error) -> Result<u32> {
        let (w, h) = (self.options.frame.width, self.options.frame.height);
        let align = |r: u64| ((r / BAND_ALIGN as u64 * BAND_ALIGN as u64) as u32).max(BAND_ALIGN);
        let Some((need, limit)) = self.shortfall.take().filter(|&(need, _)| need > 0) else {
            return Ok(align(rows as u64 / 2));
        };
        let per_band = need as f64 * BAND_ALIGN as f64 / rows as f64;
        if per_band > limit as f64 {
            return Err(Error::unsupported(format!(
                "{w}x{h} does not fit even in bands of {BAND_ALIGN} rows: {e}; a band of {BAND_ALIGN} rows needs {:.1} times what one binding holds, on average",
                per_band / limit as f64
            )));
        }
        Ok(align(rows as u64 * limit / need).min(align(rows as u64 / 2)))
    }

    /// A cleared depth texture of one band's size (kept while the size stays).
    fn band_depth(&mut self, width: u32, rows: u32) -> wgpu::TextureView {
        if !matches!(&self.band_opaque, Some(t) if (t.width(), t.height()) == (width, rows)) {
            let texture = self.gpu.texture_2d(
                "strata.opaque_depth.band",
                (width, rows),
                wgpu::TextureFormat::Depth32Float,
                wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::TEXTURE_BINDING,
            );
            clear_depth(self.gpu, &texture.create_view(&Default::default()), 1.0);
            self.band_opaque = Some(texture);
        }
        self.band_opaque
            .as_ref()
            .expect("made above")
            .create_view(&Default::default())
    }

    /// One picture (the whole one or a band) with `options` in exact mode, over `opaque`.
    fn render_picture(
        &mut self,
        method: MethodId,
        draw: Option<&DrawCallback<'_>>,
        options: &RenderOptions,
        opaque: &wgpu::TextureView,
    ) -> Result<(LinearImage, FrameStats)> {
        let recorder = match &mut self.recorder {
            Some(r) => {
                r.set_method(method)?;
                if r.options().frame.band != options.frame.band
                    || r.options().frame.height != options.frame.height
                {
                    r.set_frame_options(&options.frame)?;
                }
                r
            }
            None => {
                let r = self.recorder.insert(FrameRecorder::new(
                    self.gpu,
                    &self.scene,
                    method,
                    options,
                )?);
                if let Some(t) = self.time {
                    r.set_time(t);
                    r.set_camera(&self.scene.camera_or_framing());
                }
                r
            }
        };
        // A pipeline draws the opaque objects and their depth itself; a multisampled frame gets
        // the cleared one only when it was lent (nothing to test against otherwise).
        let opaque_used = options.build.msaa <= 1 || self.opaque_lent.get();
        let targets = FrameTargets {
            color: None,
            opaque_depth: (options.build.lighting.pipeline.is_none() && opaque_used)
                .then_some(opaque),
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
            passes += r.stats.geometry_passes;
            overflowed |= r.stats.overflow == Some(true) || r.incomplete;
            let incomplete = r.incomplete;
            if incomplete {
                if let Some(short) = r.cannot_complete {
                    self.shortfall = short.binding;
                    return Err(Error::input(short.why));
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
        stats.geometry_passes = passes;
        let bytes = readback::read_buffer(
            self.gpu,
            recorder.resolved(),
            options.pixels() * crate::frame::RESOLVED_BYTES,
        )?;
        blocking += 1;
        stats.submits = submits + 1;
        stats.blocking_readbacks = blocking;
        let resolved: Vec<Resolved> = bytemuck::pod_collect_to_vec(&bytes);
        let (w, h) = (options.frame.width, options.frame.height);
        if let Some(lit) = recorder.lit() {
            let hdr = readback::read_rgba16f(self.gpu, lit.hdr())?;
            stats.blocking_readbacks += 1;
            stats.submits += 1;
            let pixels = lit_pixels(options, &hdr, &resolved);
            return Ok((
                LinearImage {
                    width: w,
                    height: h,
                    pixels,
                },
                stats,
            ));
        }
        Ok((over_background(options, &resolved), stats))
    }

    /// A picture on a downlevel device ([`DownlevelFrame`]: f2b or wboit through render
    /// targets), f2b peeling more layers while a frame finds fragments behind its last; the
    /// statistics count the fragments from the pixels' counts once a frame is complete.
    fn render_downlevel(
        &mut self,
        method: MethodId,
        draw: Option<&DrawCallback<'_>>,
    ) -> Result<(LinearImage, FrameStats)> {
        let gpu = self.gpu;
        if draw.is_some() {
            return Err(Error::unsupported(format!(
                "{method} on a downlevel device draws the scene itself: it takes no draw callback"
            )));
        }
        let peeling = match &mut self.downlevel {
            Some(p) if p.method() == method => p,
            _ => {
                let scene = match self.time {
                    Some(t) => self.scene.at_time(t),
                    None => self.scene.clone(),
                };
                self.downlevel = None;
                self.downlevel
                    .insert(DownlevelFrame::new(gpu, &scene, method, &self.options)?)
            }
        };
        let opaque = self.opaque.create_view(&Default::default());
        let targets = FrameTargets {
            color: None,
            opaque_depth: Some(&opaque),
        };
        let (mut submits, mut passes) = (0, 0);
        if method == MethodId::F2b
            && self
                .options
                .frame
                .family::<PeelingOptions>()
                .layers
                .is_none()
        {
            // One counting pass tells the layers, where growing from the probe would take
            // several frames.
            let deepest = peeling.count_layers(gpu, &opaque)?;
            peeling.set_layers(deepest.max(1));
            submits += 1;
            passes += 1;
        }
        let mut stats = loop {
            let mut encoder = gpu
                .device
                .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                    label: Some("strata.exact_frame"),
                });
            peeling.record(gpu, &mut encoder, &targets)?;
            gpu.queue.submit([encoder.finish()]);
            submits += 1;
            let stats = peeling.wait_stats(gpu)?;
            passes += stats.geometry_passes;
            // Only an incomplete f2b frame that will peel more layers renders again.
            let grows = method == MethodId::F2b && peeling.layers() > peeling.last_layers();
            if stats.exact != Some(false) || !grows {
                break stats;
            }
        };
        let resolved = peeling.read_resolved(gpu)?;
        let stored: u64 = resolved.iter().map(|r| r.count as u64).sum();
        let deepest = resolved.iter().map(|r| r.count).max().unwrap_or(0);
        stats.fragments_stored = Some(stored);
        // An exact frame (f2b's complete one) and every frame of a weighted method (wboit's
        // sums take every fragment) composited every fragment.
        let weighted = method.descriptor().family == crate::methods::Family::Weighted;
        let complete = stats.exact == Some(true) || weighted;
        if complete {
            stats.fragments_generated = Some(stored);
            stats.fragments_dropped = Some(0);
            stats.max_depth_complexity = Some(deepest);
        }
        stats.geometry_passes = passes;
        stats.submits = submits + 1;
        stats.blocking_readbacks = submits + 1;
        Ok((over_background(&self.options, &resolved), stats))
    }
}

/// The picture `resolved` (a frame of `options`) makes over the options' background.
fn over_background(options: &RenderOptions, resolved: &[Resolved]) -> LinearImage {
    let (w, h) = (options.frame.width, options.frame.height);
    let background = options.frame.background;
    let top = options.frame.band.map_or(0, |b| b.top);
    let pixels = resolved
        .iter()
        .enumerate()
        .map(|(i, r)| {
            let bg = background.at(i as u32 % w, top + i as u32 / w);
            let [c, t] = [r.color, r.transmittance];
            [
                c[0] + t[0] * bg[0],
                c[1] + t[1] * bg[1],
                c[2] + t[2] * bg[2],
                r.count as f32,
            ]
        })
        .collect();
    LinearImage {
        width: w,
        height: h,
        pixels,
    }
}

/// Whether an error is a buffer over the device's largest storage binding, which smaller bands
/// avoid: one refused when allocated ([`Gpu::storage_buffer`]) or a pool that would have to
/// outgrow it (a method's `cannot_complete`).
fn outgrew_binding(e: &Error) -> bool {
    match e {
        Error::Unsupported(why) | Error::Input(why) => why.contains(crate::error::OVER_BINDING),
        Error::Runtime(_) | Error::DeviceLost(_) => false,
    }
}

/// The statistics of a picture so far with those of its next band: counts and times summed,
/// maxima kept, allocations the largest band's.
fn merge_band(mut sum: FrameStats, band: FrameStats) -> FrameStats {
    let add = |a: Option<u64>, b: Option<u64>| match (a, b) {
        (Some(a), Some(b)) => Some(a + b),
        (a, b) => a.or(b),
    };
    sum.fragments_generated = add(sum.fragments_generated, band.fragments_generated);
    sum.fragments_stored = add(sum.fragments_stored, band.fragments_stored);
    sum.fragments_dropped = add(sum.fragments_dropped, band.fragments_dropped);
    sum.lock_failures = add(sum.lock_failures, band.lock_failures);
    sum.max_depth_complexity = sum.max_depth_complexity.max(band.max_depth_complexity);
    sum.bytes_allocated = sum.bytes_allocated.max(band.bytes_allocated);
    sum.geometry_passes += band.geometry_passes;
    sum.overflow = match (sum.overflow, band.overflow) {
        (Some(a), Some(b)) => Some(a || b),
        (a, b) => a.or(b),
    };
    sum.gpu_ms_total = match (sum.gpu_ms_total, band.gpu_ms_total) {
        (Some(a), Some(b)) => Some(a + b),
        _ => None,
    };
    if let (Some(total), Some(more)) = (sum.gpu_ms.as_mut(), band.gpu_ms) {
        for (pass, ms) in more {
            *total.entry(pass).or_default() += ms;
        }
    }
    sum.family = match (sum.family.take(), band.family) {
        (Some(a), Some(b)) => Some(a.stat().with_band(&b).unwrap_or(a)),
        (a, b) => a.or(b),
    };
    let both = |a: Option<bool>, b: Option<bool>| match (a, b) {
        (Some(a), Some(b)) => Some(a && b),
        (a, b) => a.or(b),
    };
    sum.exact = both(sum.exact, band.exact);
    sum.exact_k_nearest = both(sum.exact_k_nearest, band.exact_k_nearest);
    sum.submits += band.submits;
    sum.blocking_readbacks += band.blocking_readbacks;
    sum.bands = Some(sum.bands.unwrap_or(1) + 1);
    sum
}

/// The picture of a lit frame from its HDR image (the method presented over the opaque
/// surfaces): over the background, tone-mapped; a G-buffer view as it is (the normal error as a
/// heatmap in hundredths of a degree).
fn lit_pixels(options: &RenderOptions, hdr: &[[f32; 4]], resolved: &[Resolved]) -> Vec<[f32; 4]> {
    let w = options.frame.width;
    let counts = resolved.iter().map(|r| r.count as f32);
    match options.build.lighting.gbuffer_debug {
        Some(GbufferView::NormalError) => {
            let centidegrees: Vec<u32> =
                hdr.iter().map(|p| (p[0] * 100.0).round() as u32).collect();
            let map = crate::metrics::complexity_heatmap_pixels(
                &centidegrees,
                w,
                options.frame.height,
                None,
            );
            map.iter()
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
                let bg = options.frame.background.at(i as u32 % w, i as u32 / w);
                let t = 1.0 - p[3] as f64;
                let over = [0, 1, 2].map(|c| p[c] as f64 + t * bg[c] as f64);
                let [r, g, b] =
                    crate::deferred::encoding::tone_map(options.build.lighting.tonemap, over);
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
