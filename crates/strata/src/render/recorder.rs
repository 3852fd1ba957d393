//! [`FrameRecorder`]: real-time frames on the application's device, queue and encoder.
//!
//! ```no_run
//! # fn demo(device: wgpu::Device, queue: wgpu::Queue, color: &wgpu::TextureView,
//! #         depth: &wgpu::TextureView) -> strata::Result<()> {
//! use strata::frame::FrameTargets;
//! use strata::{gpu::Gpu, methods::MethodId, scene::loaders, FrameRecorder, RenderOptions};
//!
//! let gpu = Gpu::from_device(device, queue);
//! let scene = loaders::load_scene("builtin:spheres?layers=8")?;
//! let options = RenderOptions::sized(1280, 720);
//! let mut oit = FrameRecorder::new(&gpu, &scene, MethodId::KplusHeap, &options)?;
//! loop {
//!     // oit.set_camera(&camera) when the view moves; oit.resize(w, h) with the window;
//!     // oit.set_frame_options(&frame) for another k, effect, tail, ... (`FrameOptions`).
//!     let mut encoder = gpu.device.create_command_encoder(&Default::default());
//!     // ... the application's opaque pass writes `color` and `depth` ...
//!     let targets = FrameTargets {
//!         color: Some((color, wgpu::TextureFormat::Rgba8UnormSrgb)),
//!         opaque_depth: Some(depth),
//!     };
//!     oit.record(&mut encoder, &targets, None)?;
//!     gpu.queue.submit([encoder.finish()]);
//!     for stats in oit.poll_stats() {
//!         // a frame or more late, tagged with stats.frame
//!         let _ = stats.gpu_ms_total;
//!     }
//! #   break;
//! }
//! # Ok(()) }
//! ```
//!
//! `record` adds the method's passes and the present pass to the encoder and schedules the
//! statistics readback for after its submission; it never submits and never waits. Submit every
//! encoder a frame was recorded into: a dropped one keeps its statistics slot in flight, and
//! once all four are, frames go without statistics. Construction and `resize` submit one clear
//! of the internal "nothing opaque" depth (setup, not steady state). Feedback
//! (a pool that overflowed, a depth complexity for peeling) applies to the next frame.

use std::collections::BTreeMap;

use crate::deferred::LitFrame;
use crate::error::{Error, Result};
use crate::frame::application::AppShader;
use crate::frame::present::{Present, PresentParams};
use crate::frame::stats::StatsRing;
use crate::frame::{
    AutoKStats, DrawCallback, Effect, FrameContext, FrameOptions, FrameStats, FrameTargets,
    MethodStats, ReadbackList, Recorded, RenderOptions, SceneGpu, Totals, TOTAL_WORDS,
};
use crate::gpu::readback::{Segment, Segments};
use crate::gpu::timing::Timer;
use crate::gpu::Gpu;
use crate::methods::kbuffer::{predict, DEFAULT_K};
use crate::methods::{self, Method, MethodId};
use crate::metrics::gpu_histogram::{self, GpuHistogram};
use crate::order::TriangleOrder;
use crate::raster::{ComputeRaster, Raster};
use crate::scene::{Camera, CameraPath, Scene};

mod report;
mod targets;
pub use crate::gpu::passes::clear_depth_pass;
pub(crate) use targets::max_resolved_pixels;
use targets::{
    check_application_options, check_size, check_targets, no_opaque_depth, output_buffer,
    per_pixel_context,
};

/// How long `wait_stats` waits for mapping callbacks once the GPU is idle.
const STATS_TIMEOUT: std::time::Duration = std::time::Duration::from_secs(30);
/// How long [`FrameRecorder::wait_stats`] waits for a mapping once the queue is idle (another
/// thread polling the device may still be running the callbacks).
const STATS_IDLE_TIMEOUT: std::time::Duration = std::time::Duration::from_secs(1);

/// A frame waiting for its statistics.
struct Pending {
    frame: u64,
    method: MethodId,
    recorded: Recorded,
    /// Each stage's words in the frame's readback: the totals, the timer's timestamps (and the
    /// passes they time), the method's words, the histogram's bins.
    totals: Segment,
    timestamps: Option<(Segment, Vec<&'static str>)>,
    method_words: Segment,
    histogram_words: Option<Segment>,
    /// With `--raster compute`: its counters, and the item capacity the frame ran with.
    raster_words: Option<(Segment, u64)>,
    /// With `--order`: its Kendall pair counts, and its bytes.
    order_words: Option<(Segment, u64)>,
    auto_k: Option<AutoKStats>,
    /// The frame options it was recorded with: its statistics report these, whatever the
    /// recorder's options are when they are read back (found by `bench soak`: a resize between
    /// a frame and its readback gave the frame the new size).
    options: crate::frame::FrameOptions,
}

/// Statistics of one frame, with whether exact mode must render it again.
pub struct FrameReport {
    /// The frame's statistics.
    pub stats: FrameStats,
    /// The frame lost fragments a larger pool or more layers would have kept: exact mode renders it again.
    pub incomplete: bool,
    /// Why no later frame can be complete either.
    pub cannot_complete: Option<crate::frame::Shortfall>,
}

/// A frame context lent from the recorder's fields (a macro rather than a method, so that the
/// method or histogram it is handed to can be borrowed from another field at the same time).
macro_rules! frame_context {
    ($recorder:ident, $name:expr, $encoder:expr, $frame:expr, $draw:expr, $readback:expr, $raster:expr) => {
        FrameContext {
            method: $name,
            gpu: &$recorder.gpu,
            scene: &$recorder.scene,
            options: &$recorder.options,
            k: $recorder.frame_k,
            encoder: $encoder,
            timer: &mut $recorder.timer,
            frame_group: &$frame.group,
            opaque_depth: &$frame.opaque,
            output: &$recorder.output,
            draw: $draw,
            readback: $readback,
            raster: $raster,
        }
    };
}

/// Records frames of one scene with one method (switchable) into the application's encoders.
pub struct FrameRecorder {
    gpu: Gpu,
    scene: SceneGpu,
    /// The caller's options, as given.
    options: RenderOptions,
    /// The k of the frame being recorded: the options' `k`, or with `--k auto` the chosen one.
    frame_k: Option<u32>,
    method: MethodId,
    methods: BTreeMap<MethodId, Box<dyn Method>>,
    timer: Timer,
    output: wgpu::Buffer,
    present: Present,
    ring: StatsRing<Pending>,
    frame: u64,
    /// Depth cleared to 1.0 (once, when made) for frames without an opaque depth.
    no_opaque: wgpu::Texture,
    /// The GPU depth-complexity histogram, when it is on.
    histogram: Option<GpuHistogram>,
    /// The latest histogram that came back (its frame and bins), which `--k auto` picks from.
    last_histogram: Option<(u64, Vec<u64>)>,
    /// With `options.pipeline`: the lit opaque objects (the method's scene holds the rest).
    lit: Option<LitFrame>,
    /// With `--raster compute`: the compute rasterizer.
    raster: Option<ComputeRaster>,
    /// With `--order`: the submission order, rebuilt every frame.
    order: Option<TriangleOrder>,
    /// The scene's camera path, which [`FrameRecorder::set_time`] follows.
    camera_path: Option<CameraPath>,
}

/// Group 0 of a frame being recorded and the opaque depth it binds.
struct OpenFrame {
    group: wgpu::BindGroup,
    opaque: wgpu::TextureView,
}

impl FrameRecorder {
    /// A recorder of `scene` with `method`; what this device cannot make (a limit it lacks) is
    /// refused in one line ([`crate::gpu::validated`]).
    pub fn new(
        gpu: &Gpu,
        scene: &Scene,
        method: MethodId,
        options: &RenderOptions,
    ) -> Result<FrameRecorder> {
        crate::gpu::validated(gpu, "strata's frame", || {
            Self::made(gpu, scene, method, options, None)
        })
    }

    /// A recorder for an application that draws its transparent geometry with its own shader
    /// and buffers ([`AppShader`]; see [`crate::frame::application`]): no scene, only the
    /// options (size, method, k, budget, …). strata builds each geometry pass's pipeline from
    /// the shader, and every [`FrameRecorder::record`] calls the application's draw callback
    /// once per geometry pass. Methods that cannot take an application's shader, and options
    /// that need strata's own geometry (`--raster compute`, `--order`, `--temporal`,
    /// `--k auto`, a lit pipeline, the translucency effect), are refused in one line.
    pub fn for_application(
        gpu: &Gpu,
        method: MethodId,
        options: &RenderOptions,
        shader: AppShader,
    ) -> Result<FrameRecorder> {
        method.descriptor().check_app_shaders()?;
        check_application_options(options)?;
        crate::gpu::validated(gpu, "strata's frame", || {
            Self::made(gpu, &Scene::default(), method, options, Some(shader))
        })
    }

    fn made(
        gpu: &Gpu,
        scene: &Scene,
        method: MethodId,
        options: &RenderOptions,
        application: Option<AppShader>,
    ) -> Result<FrameRecorder> {
        options.validate()?;
        if crate::methods::downlevel::is_downlevel(gpu) {
            return Err(crate::methods::downlevel::refusal(gpu, method));
        }
        check_size(gpu, options)?;
        let (mut scene_gpu, lit) = match options.build.lighting.pipeline {
            None if application.is_some() => {
                (SceneGpu::new_allow_empty(gpu, scene, options)?, None)
            }
            None => (SceneGpu::new(gpu, scene, options)?, None),
            Some(pipeline) => {
                scene.validate()?;
                let (opaque, transparent) = scene.split_by_opacity();
                (
                    SceneGpu::new_allow_empty(gpu, &transparent, options)?,
                    Some(LitFrame::new(gpu, pipeline, &opaque, options)?),
                )
            }
        };
        if application.is_some() {
            scene_gpu.update(gpu, &crate::frame::application::depth_camera(), options);
        }
        scene_gpu.application = application.map(std::sync::Arc::new);
        scene_gpu.raster_layout =
            (options.build.raster == Raster::Compute).then(|| crate::raster::raster_layout(gpu));
        let raster = (options.build.raster == Raster::Compute)
            .then(|| ComputeRaster::new(gpu, &scene_gpu, options));
        let order = attach_order(gpu, options, &mut scene_gpu)?;
        let mut recorder = FrameRecorder {
            output: output_buffer(gpu, options)?,
            no_opaque: no_opaque_depth(gpu, options),
            gpu: gpu.clone(),
            scene: scene_gpu,
            options: options.clone(),
            frame_k: options.frame.k,
            method,
            methods: BTreeMap::new(),
            timer: Timer::new(gpu),
            present: Present::new(gpu),
            ring: StatsRing::default(),
            frame: 0,
            histogram: None,
            last_histogram: None,
            lit,
            raster,
            order,
            camera_path: scene.camera_path.clone(),
        };
        recorder.set_method(method)?;
        Ok(recorder)
    }

    /// The options the recorder was made with, and the current frame options.
    pub fn options(&self) -> &RenderOptions {
        &self.options
    }

    /// The method the recorder records.
    pub fn method(&self) -> MethodId {
        self.method
    }

    /// The frame number the next `record` gets.
    pub fn next_frame(&self) -> u64 {
        self.frame
    }

    /// Switches method; its pipelines are built on first use and kept.
    pub fn set_method(&mut self, method: MethodId) -> Result<()> {
        let triangles = self.scene.triangle_count as u64;
        method
            .descriptor()
            .admit(&self.options, &self.scene.blend_modes, triangles)?;
        if self.scene.application.is_some() {
            method.descriptor().check_app_shaders()?;
        }
        if !self.methods.contains_key(&method) {
            let m = crate::gpu::validated(&self.gpu, method.as_str(), || {
                methods::create(method, &self.gpu, &self.scene, &self.options)
            })?;
            self.methods.insert(method, m);
        }
        self.method = method;
        Ok(())
    }

    /// Replaces the scene's geometry for the next frames (an animated scene's next time step):
    /// written in place when the triangle count is unchanged, else the scene buffers are
    /// rebuilt (pipelines are kept either way). Materials and lights stay those of the first
    /// scene when the count is unchanged.
    pub fn set_geometry(&mut self, scene: &Scene) -> Result<()> {
        let gpu = self.gpu.clone();
        gpu.guarded("replacing the geometry", || self.replace_geometry(scene))
    }

    fn replace_geometry(&mut self, scene: &Scene) -> Result<()> {
        let split;
        let scene = match &mut self.lit {
            None => scene,
            Some(lit) => {
                split = scene.split_by_opacity();
                lit.set_geometry(&split.0)?;
                &split.1
            }
        };
        if !self.scene.update_geometry(&self.gpu, scene)? {
            let camera = self.scene.camera;
            let mut rebuilt = SceneGpu::new_allow_empty(&self.gpu, scene, &self.options)?;
            // The pipelines were made with the first layouts: keep binding through them.
            rebuilt.frame_layout = self.scene.frame_layout.clone();
            rebuilt.raster_layout = self.scene.raster_layout.clone();
            rebuilt.update(&self.gpu, &camera, &self.options);
            self.scene = rebuilt;
            self.order = attach_order(&self.gpu, &self.options, &mut self.scene)?;
        } else if let Some(order) = &self.order {
            order.set_centroids(&self.gpu, &self.scene.centroids);
            if let Some(animation) = &mut self.scene.animation {
                animation.bind(&self.gpu, &self.scene.vertices, Some(order.centroids()));
            }
        }
        self.camera_path = scene.camera_path.clone();
        Ok(())
    }

    /// Moves the scene to time `t` (frames) for the next frames: its moving objects move on
    /// the GPU when the next frame is recorded (no mesh is rebuilt or uploaded), and a camera
    /// path moves the camera ([`FrameRecorder::set_camera`] afterwards overrides it).
    pub fn set_time(&mut self, t: f32) {
        self.scene.set_time(t);
        if let Some(lit) = &mut self.lit {
            lit.set_time(t);
        }
        if let Some(path) = &self.camera_path {
            let camera = path.camera_at(t);
            self.set_camera(&camera);
        }
    }

    /// The time the next frame shows (the scene's own time until [`FrameRecorder::set_time`]).
    pub fn time(&self) -> Option<f32> {
        self.scene.animation.as_ref().map(|a| a.time())
    }

    /// Turns the GPU depth-complexity histogram on or off for the next frames: one more count
    /// geometry pass and a binning pass per frame; the bins arrive with the frame's statistics
    /// (`FrameStats::depth_histogram`).
    pub fn set_histogram(&mut self, on: bool) {
        if !on {
            self.histogram = None;
        } else if self.histogram.is_none() {
            self.histogram = Some(GpuHistogram::new(&self.gpu, &self.scene));
        }
    }

    /// Moves the camera for the next frames.
    pub fn set_camera(&mut self, camera: &Camera) {
        self.scene.update(&self.gpu, camera, &self.options);
        if let Some(lit) = &mut self.lit {
            lit.set_camera(camera, &self.options);
        }
    }

    /// The lit opaque frame, with `options.pipeline` (its HDR image and depth).
    pub fn lit(&self) -> Option<&LitFrame> {
        self.lit.as_ref()
    }

    /// Changes the frame size; pipelines are kept and per-pixel buffers follow on the next frame.
    pub fn resize(&mut self, width: u32, height: u32) -> Result<()> {
        let gpu = self.gpu.clone();
        gpu.guarded("resizing the frame", || self.resized(width, height))
    }

    fn resized(&mut self, width: u32, height: u32) -> Result<()> {
        let mut options = self.options.clone();
        options.frame.width = width;
        options.frame.height = height;
        options.validate()?;
        check_size(&self.gpu, &options)?;
        self.output = output_buffer(&self.gpu, &options)?;
        self.no_opaque = no_opaque_depth(&self.gpu, &options);
        self.options = options;
        let camera = self.scene.camera;
        self.set_camera(&camera);
        Ok(())
    }

    /// The options of the next frames: size, effect, k and every family's parameters, order,
    /// temporal culling. What the recorder was made with ([`crate::frame::BuildOptions`]) stays;
    /// another rasterizer, sample count or pipeline needs another recorder.
    pub fn set_frame_options(&mut self, frame: &FrameOptions) -> Result<()> {
        let gpu = self.gpu.clone();
        gpu.guarded("changing the frame's options", || {
            self.take_frame_options(frame)
        })
    }

    fn take_frame_options(&mut self, frame: &FrameOptions) -> Result<()> {
        let options = RenderOptions {
            build: self.options.build.clone(),
            frame: frame.clone(),
        };
        options.validate()?;
        if self.scene.application.is_some() {
            check_application_options(&options)?;
        }
        let triangles = self.scene.triangle_count as u64;
        self.method
            .descriptor()
            .admit(&options, &self.scene.blend_modes, triangles)?;
        let old = &self.options.frame;
        if (frame.width, frame.height) != (old.width, old.height) {
            self.resized(frame.width, frame.height)?;
        }
        let old = &self.options.frame;
        if (frame.order, frame.order_seed) != (old.order, old.order_seed) {
            self.order = attach_order(&self.gpu, &options, &mut self.scene)?;
        }
        self.frame_k = frame.k;
        self.options = options;
        let camera = self.scene.camera;
        self.set_camera(&camera);
        Ok(())
    }

    /// The per-pixel result of the last recorded frame ([`crate::frame::Resolved`]; COPY_SRC).
    pub fn resolved(&self) -> &wgpu::Buffer {
        &self.output
    }

    /// The last submitted frame's picture over the options' background, read back (a blocking
    /// readback: screenshots and checks, not the real-time loop).
    pub fn picture(&self) -> Result<crate::LinearImage> {
        self.gpu.guarded("reading the frame back", || {
            let bytes = self.options.pixels() * crate::frame::RESOLVED_BYTES;
            let raw = crate::gpu::readback::read_buffer(&self.gpu, &self.output, bytes)?;
            let resolved: Vec<crate::frame::Resolved> = bytemuck::pod_collect_to_vec(&raw);
            Ok(super::over_background(&self.options, &resolved))
        })
    }

    /// The buffers the current method keeps between frames (for tests that poison them).
    pub fn method_resources(&self) -> Vec<&crate::gpu::ResourceCache> {
        self.methods[&self.method].resources()
    }

    /// Fills the current method's buffers, the resolved frame and the totals with garbage
    /// before the next frame (tests: a correct frame reads nothing it did not write).
    pub fn poison(&self) {
        for cache in self.method_resources() {
            cache.poison(&self.gpu);
        }
        if let Some(raster) = &self.raster {
            raster.resources().poison(&self.gpu);
        }
        for b in [&self.output, &self.scene.totals] {
            self.gpu
                .queue
                .write_buffer(b, 0, &crate::gpu::garbage(b.size()));
        }
    }

    /// Records one frame into `encoder`; returns its frame number. On a lost device, or when
    /// wgpu reports an error on the way (an allocation the device cannot make), the error names
    /// it ([`Error::DeviceLost`], [`Gpu::guarded`]) and the encoder should be dropped.
    pub fn record(
        &mut self,
        encoder: &mut wgpu::CommandEncoder,
        targets: &FrameTargets<'_>,
        draw: Option<&DrawCallback<'_>>,
    ) -> Result<u64> {
        let gpu = self.gpu.clone();
        gpu.guarded("recording a frame", || {
            self.record_frame(encoder, targets, draw)
        })
    }

    fn record_frame(
        &mut self,
        encoder: &mut wgpu::CommandEncoder,
        targets: &FrameTargets<'_>,
        draw: Option<&DrawCallback<'_>>,
    ) -> Result<u64> {
        self.check_targets(targets)?;
        if self.scene.application.is_some() && draw.is_none() {
            return Err(Error::input(
                "an application's recorder draws the application's geometry: pass its draw callback to record",
            ));
        }
        let auto_k = self.choose_k()?;
        let lit_depth = match (&self.lit, targets.opaque_depth) {
            (Some(_), Some(_)) => {
                return Err(Error::input(
                    "with a pipeline strata draws the opaque objects and their depth itself: pass no opaque depth",
                ))
            }
            (Some(lit), None) => Some(lit.depth().create_view(&Default::default())),
            (None, _) => None,
        };
        if draw.is_some() {
            self.method.descriptor().check_draw_callback()?;
        }
        if let Some(raster) = &mut self.raster {
            if draw.is_some() {
                return Err(Error::unsupported(
                    "--raster compute rasterizes the scene's own triangles: an application's draw callback needs --raster hw",
                ));
            }
            raster.prepare(&self.gpu, &self.options, &self.scene)?;
        }
        if let (Some(order), Some(_)) = (&self.order, draw) {
            return Err(Error::unsupported(format!(
                "--order {} resubmits the scene's own triangles: an application's draw callback draws its own",
                order.order().name()
            )));
        }
        let frame = self.start_frame(encoder, lit_depth.as_ref().or(targets.opaque_depth))?;
        let (width, height) = (self.options.frame.width, self.options.frame.height);
        self.scene.set_draw_bands(width, height);
        if let Some(animation) = &mut self.scene.animation {
            animation.record(&self.gpu, encoder, &mut self.timer);
        }
        if self.method.descriptor().sorts_centroids {
            self.scene.refresh_centroids();
        }
        if let Some(order) = &self.order {
            order.record(
                &self.gpu,
                encoder,
                &mut self.timer,
                &self.scene.camera,
                self.frame,
            );
        }
        if let Some(lit) = &mut self.lit {
            lit.record(encoder, &mut self.timer);
        }
        let mut readback = ReadbackList::default();
        let size = (self.options.frame.width, self.options.frame.height);
        let recorded = self.with_method(encoder, &frame, &mut readback, draw, |m, ctx| {
            let recorded = m.record(ctx).map_err(|e| per_pixel_context(e, size))?;
            // The ledger's backstop: every method checks before it allocates.
            ctx.check_budget(recorded.bytes_allocated)?;
            Ok(recorded)
        })?;
        let histogram = self.record_histogram(encoder, &frame, draw)?;
        Ok(self.finish_frame(
            encoder,
            targets.color,
            (recorded, auto_k),
            readback,
            histogram,
        ))
    }

    /// With `--k auto`: sets the frame's k from the latest histogram that came back (the first
    /// frame guesses within the budget) and keeps the histogram on.
    fn choose_k(&mut self) -> Result<Option<AutoKStats>> {
        let Some(robustness) = self.options.frame.k_auto else {
            self.frame_k = self.options.frame.k;
            return Ok(None);
        };
        if self.histogram.is_none() {
            self.histogram = Some(GpuHistogram::new(&self.gpu, &self.scene));
        }
        let last = self.last_histogram.as_ref();
        let choice = predict::choose_k(
            self.method,
            last.map(|h| h.1.as_slice()),
            robustness,
            DEFAULT_K,
            &self.options,
        )?;
        self.frame_k = Some(choice.k);
        Ok(Some(AutoKStats {
            robustness_target: robustness,
            budget_mb: self.options.frame.budget_mb,
            k_budget: choice.k_budget,
            histogram_frame: last.map(|h| h.0),
            predicted_robustness: last.map(|_| choice.predicted_robustness),
            achieved_robustness: None,
        }))
    }

    /// The histogram's passes, when it is on (returns whether it ran); its bins are the last
    /// words read back.
    fn record_histogram(
        &mut self,
        encoder: &mut wgpu::CommandEncoder,
        frame: &OpenFrame,
        draw: Option<&DrawCallback<'_>>,
    ) -> Result<Option<ReadbackList>> {
        let Some(histogram) = self.histogram.as_mut() else {
            return Ok(None);
        };
        let mut readback = ReadbackList::default();
        let mut ctx = frame_context!(self, "histogram", encoder, frame, draw, &mut readback, None);
        histogram.record(&mut ctx)?;
        Ok(Some(readback))
    }

    /// Clears the totals, starts the timer and binds group 0 for a frame.
    fn start_frame(
        &mut self,
        encoder: &mut wgpu::CommandEncoder,
        opaque_depth: Option<&wgpu::TextureView>,
    ) -> Result<OpenFrame> {
        let opaque = match opaque_depth {
            Some(v) => v.clone(),
            None => self.no_opaque.create_view(&Default::default()),
        };
        // What the checks before could not see of the application's depth view (an aspect, a
        // format the binding refuses) is an error here, before anything is recorded.
        let group = crate::gpu::validated(&self.gpu, "the opaque depth", || {
            Ok(self.scene.frame_group(&self.gpu, &opaque))
        })?;
        encoder.clear_buffer(&self.scene.totals, 0, None);
        self.timer.reset();
        Ok(OpenFrame { group, opaque })
    }

    /// Refuses targets that do not fit the frame, before anything is recorded.
    fn check_targets(&self, targets: &FrameTargets<'_>) -> Result<()> {
        check_targets(&self.gpu, &self.options, targets)
    }

    /// Runs `f` on the current method with a frame context.
    fn with_method<R>(
        &mut self,
        encoder: &mut wgpu::CommandEncoder,
        frame: &OpenFrame,
        readback: &mut ReadbackList,
        draw: Option<&DrawCallback<'_>>,
        f: impl FnOnce(&mut dyn Method, &mut FrameContext<'_>) -> Result<R>,
    ) -> Result<R> {
        let method = self
            .methods
            .get_mut(&self.method)
            .expect("set_method created it");
        let raster = self
            .raster
            .as_mut()
            .map(|r| r as &mut dyn crate::frame::ComputeCapture);
        let name = self.method.as_str();
        let mut ctx = frame_context!(self, name, encoder, frame, draw, readback, raster);
        f(method.as_mut(), &mut ctx)
    }

    /// Records the present pass and the statistics readback, each stage's words a segment of
    /// it; returns the frame number.
    fn finish_frame(
        &mut self,
        encoder: &mut wgpu::CommandEncoder,
        color: Option<(&wgpu::TextureView, wgpu::TextureFormat)>,
        (recorded, auto_k): (Recorded, Option<AutoKStats>),
        readback: ReadbackList,
        histogram: Option<ReadbackList>,
    ) -> u64 {
        self.present_into(encoder, color, recorded.k, true);
        let mut segments = Segments::default();
        let mut totals = ReadbackList::default();
        totals.words(&self.scene.totals, 0, TOTAL_WORDS);
        let totals = segments.push(totals);
        let timestamps = self.timer.resolve(encoder).map(|((buffer, at, n), names)| {
            let mut list = ReadbackList::default();
            list.words(&buffer, at, n);
            (segments.push(list), names)
        });
        let raster_words = self.raster.as_ref().and_then(|raster| {
            let mut list = ReadbackList::default();
            raster
                .read_counters(&mut list)
                .then(|| (segments.push(list), raster.frame_capacity()))
        });
        let order_words = self.order.as_ref().map(|order| {
            let mut list = ReadbackList::default();
            order.read_counters(&mut list);
            (segments.push(list), order.bytes())
        });
        let method_words = segments.push(readback);
        let histogram_words = histogram.map(|list| segments.push(list));
        let frame = self.frame;
        self.frame += 1;
        self.ring.record(
            &self.gpu,
            encoder,
            segments.entries(),
            Pending {
                frame,
                method: self.method,
                recorded,
                totals,
                timestamps,
                method_words,
                histogram_words,
                raster_words,
                order_words,
                auto_k,
                options: self.options.frame.clone(),
            },
        );
        frame
    }

    /// Composites the last resolved frame OVER `color` (with a lit pipeline, over its image,
    /// then tone-maps into `color`); `k` scales the complexity heatmap, `timed` times the pass.
    fn present_into(
        &mut self,
        encoder: &mut wgpu::CommandEncoder,
        color: Option<(&wgpu::TextureView, wgpu::TextureFormat)>,
        k: Option<u32>,
        timed: bool,
    ) {
        let gpu = &self.gpu;
        // With a pipeline the method presents over the lit image (not over a G-buffer view),
        // and the tone map writes the application's target.
        let hdr = self.lit.as_ref().map(|lit| {
            (
                lit.hdr().create_view(&Default::default()),
                lit.hdr().format(),
            )
        });
        let present_to = match &hdr {
            Some(_) if self.options.build.lighting.gbuffer_debug.is_some() => None,
            Some((view, format)) => Some((view, *format)),
            None => color,
        };
        if let Some((view, format)) = present_to {
            let params = PresentParams {
                size: [self.options.frame.width, self.options.frame.height],
                complexity: (self.options.frame.effect == Effect::Complexity) as u32,
                complexity_full: k.unwrap_or(64).max(1),
            };
            let tinted = self
                .scene
                .blend_modes
                .contains(&crate::scene::Blend::Multiply);
            if tinted && hdr.is_some() {
                if let Some(lit) = &mut self.lit {
                    lit.background_under(encoder, &mut self.timer);
                }
            }
            let stamps = match timed {
                true => self.timer.render_pass("present"),
                false => None,
            };
            self.present.record(
                gpu,
                encoder,
                view,
                format,
                &self.output,
                params,
                tinted,
                stamps,
            );
        }
        if let (Some(lit), Some((view, format))) = (&mut self.lit, color) {
            lit.tonemap(encoder, &mut self.timer, view, format);
        }
    }

    /// Statistics of every frame whose readback has completed, oldest first. Never blocks.
    pub fn poll_stats(&mut self) -> Vec<FrameStats> {
        let done = self.ring.poll(&self.gpu);
        self.decode(done).into_iter().map(|r| r.stats).collect()
    }

    /// Frames that recorded no statistics because every readback slot was still in flight.
    pub fn skipped_stats(&self) -> u64 {
        self.ring.skipped
    }

    /// A one-shot render (headless, a screenshot): records and submits frames, without
    /// touching `targets.color`, until one is complete — a pool or the peeled layers grown from
    /// what the previous frame measured, as exact mode does — then composites that frame OVER
    /// `targets.color` in one more submission and returns its statistics (`submits` and
    /// `blocking_readbacks` count what it took). Blocks; not for real time, where growth costs
    /// at most one frame and that frame says `complete: false`.
    pub fn render_once(
        &mut self,
        targets: &FrameTargets<'_>,
        draw: Option<&DrawCallback<'_>>,
    ) -> Result<FrameStats> {
        let hidden = FrameTargets {
            color: None,
            opaque_depth: targets.opaque_depth,
        };
        self.check_targets(targets)?;
        let mut submits = 0;
        for _ in 0..super::MAX_EXACT_FRAMES {
            let mut encoder = self.gpu.device.create_command_encoder(&Default::default());
            self.record(&mut encoder, &hidden, draw)?;
            self.gpu.queue.submit([encoder.finish()]);
            submits += 1;
            let report = self.wait_stats()?;
            if let Some(shortfall) = report.cannot_complete {
                return Err(Error::unsupported(shortfall.why));
            }
            if report.incomplete {
                continue;
            }
            let mut stats = report.stats;
            if targets.color.is_some() {
                let mut encoder = self.gpu.device.create_command_encoder(&Default::default());
                self.present_into(&mut encoder, targets.color, stats.k, false);
                self.gpu.queue.submit([encoder.finish()]);
                submits += 1;
            }
            stats.submits = submits;
            stats.blocking_readbacks = submits;
            return Ok(stats);
        }
        Err(Error::runtime(format!(
            "{}: no complete frame in {} frames",
            self.method,
            super::MAX_EXACT_FRAMES
        )))
    }

    /// Waits for every submitted frame's statistics and returns the last one (exact mode and
    /// tests; the wait is a blocking readback).
    pub fn wait_stats(&mut self) -> Result<FrameReport> {
        let gpu = self.gpu.clone();
        gpu.guarded("waiting for a frame's statistics", || self.wait_for_stats())
    }

    fn wait_for_stats(&mut self) -> Result<FrameReport> {
        // Another thread polling the same device may be running the mapping callbacks when the
        // wait returns: give them a bounded time to land.
        let deadline = std::time::Instant::now() + STATS_TIMEOUT;
        let mut idle_since = None;
        let mut last = None;
        loop {
            // A lost device completes nothing: its mappings never land.
            self.gpu.check_device()?;
            let idle = self.gpu.wait_idle()?;
            let done = self.ring.poll(&self.gpu);
            if let Some(r) = self.decode(done).pop() {
                last = Some(r);
            }
            if !self.ring.pending() {
                break;
            }
            // The queue did all its work and a mapping is still pending: its copy was never
            // submitted, or the device is lost (strata not told, on an application's device).
            let now = std::time::Instant::now();
            let idle_for = match idle {
                true => now - *idle_since.get_or_insert(now),
                false => std::time::Duration::ZERO,
            };
            if idle_for > STATS_IDLE_TIMEOUT {
                return Err(Error::runtime(
                    "the frame's statistics never arrived though the GPU queue is idle: the frame was not submitted, or the device was lost (an application tells strata with Gpu::device_lost)",
                ));
            }
            if now > deadline {
                return Err(Error::runtime(format!(
                    "the frame's statistics did not arrive within {} s",
                    STATS_TIMEOUT.as_secs()
                )));
            }
            std::thread::sleep(std::time::Duration::from_millis(1));
        }
        last.ok_or_else(|| Error::runtime("the frame recorded no statistics"))
    }
}

/// The submission order `options` ask for, made for `scene`'s triangles and attached to its
/// draws (or detached when there is none).
fn attach_order(
    gpu: &Gpu,
    options: &RenderOptions,
    scene: &mut SceneGpu,
) -> Result<Option<TriangleOrder>> {
    let order = options
        .frame
        .order
        .map(|o| TriangleOrder::new(gpu, o, options.frame.order_seed, &scene.centroids))
        .transpose()?;
    scene.draw_indices = order.as_ref().and_then(|o| o.indices().cloned());
    if let Some(animation) = &mut scene.animation {
        animation.bind(gpu, &scene.vertices, order.as_ref().map(|o| o.centroids()));
    }
    Ok(order)
}

#[cfg(test)]
mod tests;
