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
    ReadbackList, Recorded, RenderOptions, SceneGpu, Totals, TOTAL_WORDS,
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
use stages::StageWords;

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
    /// Each stage's words in the frame's readback.
    words: StageWords,
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

// After the macro, which the stages use.
mod present;
mod report;
mod settings;
mod stages;
mod targets;
mod wait;

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
        let (segments, words) = self.read_back(encoder, readback, histogram);
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
                words,
                auto_k,
                options: self.options.frame.clone(),
            },
        );
        frame
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
