//! What a method records a frame with, below both `methods` and `render`: the options of a
//! picture, the scene on the GPU, the frame context a method records into, the per-pixel result
//! every resolve writes, the frame totals and the statistics a frame reports.
//!
//! A frame is a recording into a [`wgpu::CommandEncoder`] the caller owns:
//! 1. the frame uniforms (camera, effect) are written with `queue.write_buffer`;
//! 2. the method records its passes — capture (one or more geometry passes) and resolve — and
//!    writes each pixel's [`Resolved`] value (premultiplied color, RGB transmittance, fragment
//!    count) and the frame totals;
//! 3. the present pass puts the resolved colors over the caller's color target
//!    (color + transmittance·target);
//! 4. the totals, the method's counters and the pass timestamps are copied to a staging slot
//!    that is mapped when the GPU has finished the submission: [`FrameStats`] arrive a frame or
//!    more later, tagged with their frame number. Nothing in steady state waits on the GPU.
//!
//! [`crate::FrameRecorder`] (in `render`, above the methods) drives this for an application;
//! [`crate::Renderer`] is the batch renderer on top of it that the CLI and the tests use.

pub mod application;
pub mod colormap;
pub mod family;
pub mod msaa;
pub mod options;
pub mod passes;
pub mod present;
pub mod scene_gpu;
pub mod stats;
pub mod uniforms;
pub mod values;

use std::collections::BTreeMap;

use bytemuck::{Pod, Zeroable};
#[cfg(feature = "serde")]
use serde::Serialize;

use crate::error::{Error, Result};
use crate::gpu::timing::Timer;
use crate::gpu::Gpu;
pub use crate::scene::{Pipeline, MAX_SIDE};

pub use crate::gpu::readback::ReadbackList;
pub use family::{FamilyOption, FamilyOptions, FamilyStat, FamilyStats};
pub use options::{Band, BuildOptions, Effect, FrameOptions, Lighting, RenderOptions, BAND_ALIGN};
pub use scene_gpu::SceneGpu;
pub use values::{
    ComputeRasterStats, GbufferView, LightingStats, NormalEncoding, Raster, TemporalCulling,
    Tonemap,
};

/// How a pixel's depth-ordered fragments become a color.
/// What every frame reports (`--stats FILE.json`). Unknown values are `None` (`null`).
#[derive(Clone, Debug, Default)]
#[cfg_attr(feature = "serde", derive(Serialize))]
pub struct FrameStats {
    /// The frame these statistics belong to (frames count from 0 per recorder).
    pub frame: u64,
    /// The method's id (`strata methods` lists them).
    pub method: String,
    /// With `--method auto`: why this method was chosen ([`crate::methods::choice`]).
    #[cfg_attr(feature = "serde", serde(skip_serializing_if = "Option::is_none"))]
    pub method_choice: Option<String>,
    /// Frame width in pixels.
    pub width: u32,
    /// Frame height in pixels.
    pub height: u32,
    /// Fragments kept per pixel (k-buffers, kpeel, fixed arrays); `None` for methods without a k.
    pub k: Option<u32>,
    /// The effect rendered: "transparency", "translucency" or "complexity".
    pub effect: String,
    /// Passes over the scene's geometry this frame recorded (peeling: one per layer).
    pub geometry_passes: u32,
    /// Whether this frame's picture equals the reference of the whole scene: the method is
    /// exact by design (the catalogue's flag), or exact whenever it drops nothing
    /// (abuffer-fixed, mlab, bucket), and the frame composited every fragment — nothing
    /// dropped (beyond a k or a number of layers either), no lock failure, no order violation
    /// (convex), nothing culled by temporal culling, no overflow. Approximate methods (wboit,
    /// mboit, unsorted, ...) say false: their error is measured against the reference, never
    /// hidden. `None` only for a downlevel device's frame that could not tell (no occlusion
    /// result yet).
    pub exact: Option<bool>,
    /// For the k-buffers that promise each pixel's k nearest (`strata reference --k N`, N the
    /// frame's k): whether the frame kept that promise — no lock failure, no overflow, nothing
    /// culled by temporal culling — whatever lay beyond k. `None` for methods without that
    /// promise, or without a k.
    pub exact_k_nearest: Option<bool>,
    /// GPU milliseconds per pass name (same-named passes added); `None` without timestamp queries.
    pub gpu_ms: Option<BTreeMap<String, f64>>,
    /// The sum of `gpu_ms`.
    pub gpu_ms_total: Option<f64>,
    /// Fragments the capture saw (after the opaque depth test), summed over the frame's pixels.
    /// This and the next three counts are known for every frame of a full device; `None` only
    /// where nothing could count them: a downlevel device's real-time frames (no storage to
    /// count in, [`crate::DownlevelFrame`]) or a statistics readback that failed.
    pub fragments_generated: Option<u64>,
    /// Fragments the method kept in its storage (composited).
    pub fragments_stored: Option<u64>,
    /// Fragments the method could not keep (beyond k, a full pool, culled).
    pub fragments_dropped: Option<u64>,
    /// The largest fragment count of any pixel.
    pub max_depth_complexity: Option<u32>,
    /// Bytes of GPU memory the method allocated for this frame.
    pub bytes_allocated: u64,
    /// The method's storage, or the compute rasterizer's work items, ran out: the fragment
    /// counts are then lower bounds (the frame is incomplete and exact mode renders it again).
    pub overflow: Option<bool>,
    /// Capture invocations that gave up on a per-pixel lock after `--max-tries` (the frame is then not exact).
    pub lock_failures: Option<u64>,
    /// How the capture's atomics are ordered on this adapter (k-buffer methods): "acquire-release
    /// (SPIR-V passthrough)", or "relaxed" with or without coherent storage.
    pub memory_ordering: Option<String>,
    /// Horizontal bands the picture was rendered in, when its per-pixel buffers outgrew the
    /// device's storage bindings (counters are summed over bands, GPU times too).
    #[cfg_attr(feature = "serde", serde(skip_serializing_if = "Option::is_none"))]
    pub bands: Option<u32>,
    /// With the GPU histogram on ([`crate::FrameRecorder::set_histogram`]): pixels per fragment
    /// count, bin i = exactly i fragments, up to the last non-empty bin.
    #[cfg_attr(feature = "serde", serde(skip_serializing_if = "Option::is_none"))]
    pub depth_histogram: Option<Vec<u64>>,
    /// Pixels with 1023 or more fragments: the histogram's last bin, which counts them together.
    #[cfg_attr(feature = "serde", serde(skip_serializing_if = "Option::is_none"))]
    pub depth_histogram_clipped: Option<u64>,
    /// With `--k auto`: how this frame's k (`k`) was chosen and what it captured.
    #[cfg_attr(feature = "serde", serde(skip_serializing_if = "Option::is_none"))]
    pub k_auto: Option<AutoKStats>,
    /// With `--pipeline`: the lit opaque frame (pipeline, lights drawn and culled, G-buffer
    /// bytes).
    pub lighting: Option<LightingStats>,
    /// The rasterizer of the storage geometry passes: "hw" or "compute".
    pub raster: String,
    /// With `--raster compute`, or a method with its own compute rasterizer (`tiled`): its
    /// work items, capacity and overflow.
    pub compute_raster: Option<ComputeRasterStats>,
    /// With `--temporal on`: fragments culled before any lock by last frame's interface
    /// (included in `fragments_generated` and `fragments_dropped`).
    #[cfg_attr(feature = "serde", serde(skip_serializing_if = "Option::is_none"))]
    pub culled_temporal: Option<u64>,
    /// With `--order`: the submission order.
    #[cfg_attr(feature = "serde", serde(skip_serializing_if = "Option::is_none"))]
    pub order: Option<String>,
    /// With `--order`: the sampled normalized Kendall tau distance between the submission
    /// order and front-to-back depth order (0: front to back, 1: back to front).
    #[cfg_attr(feature = "serde", serde(skip_serializing_if = "Option::is_none"))]
    pub kendall_tau: Option<f64>,
    /// What the method's family reports beyond the fields above (`tiled`: its rounds, lists and
    /// work, `crate::methods::tiled::TiledStats`; `convex`: its order,
    /// `crate::methods::convex::ConvexStats`): read by type with [`FrameStats::family`]; in
    /// the JSON, under the family's key.
    #[cfg_attr(feature = "serde", serde(flatten))]
    pub family: Option<FamilyStats>,
    /// Times strata blocked the CPU on the GPU for this picture (0 in real-time frames).
    pub blocking_readbacks: u32,
    /// Command buffers strata submitted itself for this picture (0 in real-time frames: the
    /// application submits).
    pub submits: u32,
    /// The adapter's name.
    pub adapter: Option<String>,
    /// The backend (Vulkan, Metal, DX12, GL).
    pub backend: Option<String>,
}

impl FrameStats {
    /// The family's statistics of type `T`, when the frame's method reports them
    /// (`stats.family::<TiledStats>()`).
    pub fn family<T: FamilyStat>(&self) -> Option<&T> {
        self.family.as_ref().and_then(FamilyStats::get)
    }
}

/// How `--k auto` chose a frame's k.
#[derive(Clone, Debug, Default)]
#[cfg_attr(feature = "serde", derive(Serialize))]
pub struct AutoKStats {
    /// The robustness ratio R asked for.
    pub robustness_target: f64,
    /// The memory budget (`--budget-mb`), if any.
    pub budget_mb: Option<f64>,
    /// The largest k the budget holds by the method's memory formula.
    pub k_budget: u32,
    /// The frame whose depth-complexity histogram chose k (`None`: a first frame's guess).
    pub histogram_frame: Option<u64>,
    /// The fraction of that histogram's fragments k captures (`None` for a guess).
    pub predicted_robustness: Option<f64>,
    /// The fraction of this frame's fragments it kept: stored / generated.
    pub achieved_robustness: Option<f64>,
}

/// Why no later frame of this size can be complete: the message, and where one storage
/// binding is what is short, what the frame needed and what a binding holds (in one unit), from
/// which the batch renderer predicts the bands that could fit.
#[derive(Clone, Debug)]
pub struct Shortfall {
    /// One line saying what cannot fit.
    pub why: String,
    /// (bytes the frame needed, bytes one storage binding holds), when a binding is what is short.
    pub binding: Option<(u64, u64)>,
}

/// What a method reports about its frame once its counters are back.
#[derive(Clone, Debug, Default)]
pub struct MethodStats {
    /// The method's storage ran out this frame (see [`FrameStats::overflow`]).
    pub overflow: Option<bool>,
    /// Lock acquisitions that gave up (see [`FrameStats::lock_failures`]).
    pub lock_failures: Option<u64>,
    /// The frame is missing fragments that a larger pool or more layers would have kept; the
    /// method has already grown for the next frame. Exact mode renders again.
    pub incomplete: bool,
    /// Why no later frame can be complete either (memory limits): exact mode's error.
    pub cannot_complete: Option<Shortfall>,
    /// With `--temporal on`: fragments culled by last frame's interface (never counted by the
    /// resolve: the frame's totals add them as generated and dropped).
    pub culled_temporal: Option<u64>,
    /// A method with its own compute rasterizer (`tiled`): its work items.
    pub compute_raster: Option<ComputeRasterStats>,
    /// What the method's family reports beyond these ([`FrameStats::family`]).
    pub family: Option<FamilyStats>,
}

/// What a method recorded: known on the CPU when the frame is recorded.
#[derive(Clone, Debug, Default)]
pub struct Recorded {
    /// Passes over the scene's geometry the method recorded.
    pub geometry_passes: u32,
    /// The k the frame ran with, for methods that have one.
    pub k: Option<u32>,
    /// Bytes of GPU memory the method allocated.
    pub bytes_allocated: u64,
    /// The size this frame ran with where it is fed back (pool nodes, array stride, layers).
    pub capacity: u64,
    /// The compute rasterizer's setup records this frame held, where its method keeps them
    /// (tiled), fed back with its item capacity.
    pub setup_capacity: u64,
    /// How the capture's atomics are ordered (k-buffer methods).
    pub memory_ordering: Option<&'static str>,
    /// The frame ran with temporal culling.
    pub temporal: bool,
    /// What the family knows of the frame when it records it (`convex`: its order; the
    /// violations come back with the statistics), which its [`MethodStats::family`] completes.
    pub family: Option<FamilyStats>,
}

impl Recorded {
    /// A frame of `geometry_passes` passes over the scene that allocated `bytes_allocated`.
    pub fn passes(geometry_passes: u32, bytes_allocated: u64) -> Recorded {
        Recorded {
            geometry_passes,
            bytes_allocated,
            ..Default::default()
        }
    }
}

/// Frame totals every resolve adds each pixel to (`report_pixel` in composite.wgsl); 64-bit
/// sums are two words, low first, carried on overflow of the low word.
/// Keep in sync with the TOTAL_ constants in shaders/shared/scene.wgsl.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Totals {
    /// Fragments every resolve saw.
    pub generated: u64,
    /// Fragments the method kept.
    pub stored: u64,
    /// Fragments the method dropped.
    pub dropped: u64,
    /// The largest per-pixel fragment count.
    pub max_depth: u32,
    /// Resolves (of pixels or samples) whose loops the adapter ended early: lavapipe stops an
    /// invocation's loops after 65535 iterations in all. Their pixels are wrong, so the frame is
    /// refused.
    pub cut_short: u32,
}

/// Words of the totals buffer.
pub const TOTAL_WORDS: u64 = 8;

impl Totals {
    /// The totals from the words of the totals buffer, as the shaders wrote them.
    pub fn from_words(w: &[u32]) -> Totals {
        let wide = |i: usize| w[i] as u64 | (w[i + 1] as u64) << 32;
        Totals {
            generated: wide(0),
            stored: wide(2),
            dropped: wide(4),
            max_depth: w[6],
            cut_short: w[7],
        }
    }
}

/// A 64-bit counter kept as two u32 words (low, high) by `wide_add` in WGSL.
pub fn wide(words: &[u32], at: usize) -> u64 {
    words[at] as u64 | (words[at + 1] as u64) << 32
}

/// The per-pixel result of every resolve. Keep in sync with `Resolved` in color.wgsl.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable, PartialEq)]
pub struct Resolved {
    /// Premultiplied linear RGB: the light the fragments put in front of what lies behind.
    pub color: [f32; 3],
    /// Fragments composited into this pixel.
    pub count: u32,
    /// What shows of what lies behind, per channel: the picture is
    /// `color + transmittance · background` (1 − alpha where everything blends over).
    pub transmittance: [f32; 3],
    /// Unused (WGSL's 16-byte alignment).
    pub _spare: u32,
}

/// Bytes of one [`Resolved`].
pub const RESOLVED_BYTES: u64 = std::mem::size_of::<Resolved>() as u64;

/// Issues draw calls into a geometry pass whose pipeline and bind groups the method has set and
/// whose vertex-buffer slot 0 holds the scene's triangle list: triangle `t` is vertices
/// 3t..3t+3, so a callback draws any ranges (culled subsets, chunks) of it. A heavy frame's
/// geometry pass calls it once per band of rows, each under a scissor strata sets
/// (docs/watchdog.md, S2): it draws the same each time and sets no scissor of its own.
pub type DrawCallback<'a> = dyn Fn(&mut wgpu::RenderPass<'_>) + 'a;

/// Where a frame goes: the application's color target (the frame's size, RENDER_ATTACHMENT,
/// a blendable single-sampled format; the resolve is blended OVER it; `None` leaves the result
/// in [`crate::FrameRecorder::resolved`] only) and the depth of its opaque surfaces (any depth
/// format, the frame's size, single-sampled, with TEXTURE_BINDING usage; fragments at or behind
/// it are rejected, with `--msaa` at their pixel center; `None`: nothing opaque). `record` refuses targets that do not fit in one
/// line before it records anything.
#[derive(Clone, Copy, Default)]
pub struct FrameTargets<'a> {
    /// The application's color target and its format; the frame is composited OVER it.
    pub color: Option<(&'a wgpu::TextureView, wgpu::TextureFormat)>,
    /// The depth of the application's opaque surfaces.
    pub opaque_depth: Option<&'a wgpu::TextureView>,
}

/// What a method gets to record one frame.
pub struct FrameContext<'a> {
    /// The method's id, which labels its passes `strata.<method>.<pass>`.
    pub method: &'static str,
    /// The device.
    pub gpu: &'a Gpu,
    /// The scene's buffers on the device.
    pub scene: &'a SceneGpu,
    /// The recorder's options.
    pub options: &'a RenderOptions,
    /// The frame's k: the options' `k`, or with `--k auto` the one the recorder chose for this
    /// frame (the caller's options keep theirs).
    pub k: Option<u32>,
    /// The caller's encoder: every pass of the frame goes here; nothing is submitted.
    pub encoder: &'a mut wgpu::CommandEncoder,
    /// GPU timing of the frame's passes.
    pub timer: &'a mut Timer,
    /// Group 0 bound to the scene in primitive order.
    pub frame_group: &'a wgpu::BindGroup,
    /// The depth of opaque surfaces (1.0 where there are none).
    pub opaque_depth: &'a wgpu::TextureView,
    /// Per pixel [`Resolved`], the method's result.
    pub output: &'a wgpu::Buffer,
    /// Issues the geometry's draw calls; `None` draws every triangle of the scene.
    pub draw: Option<&'a DrawCallback<'a>>,
    /// The method's counters to read back with the frame's statistics.
    pub readback: &'a mut ReadbackList,
    /// With `--raster compute`: the compute rasterizer the storage geometry passes go through.
    pub raster: Option<&'a mut dyn ComputeCapture>,
}

/// What draws a storage-only capture pass in compute instead of the GPU's rasterizer (strata's
/// compute rasterizer, `crate::raster::ComputeRaster`): the frame holds it, and
/// [`passes::storage_geometry_pass`] hands it the method's compute capture stage and groups.
pub trait ComputeCapture {
    /// Records the storage capture of every triangle of the scene into `name`'s passes: `pipeline` is the method's compute capture stage, `groups` its bind groups after group 0.
    fn capture(
        &mut self,
        ctx: &mut FrameContext<'_>,
        name: &'static str,
        pipeline: &wgpu::ComputePipeline,
        groups: &[&wgpu::BindGroup],
    );
}

impl FrameContext<'_> {
    /// Records the geometry's draws into a pass whose pipeline and bind groups are set.
    pub fn draw_geometry(&self, pass: &mut wgpu::RenderPass<'_>) {
        self.scene.draw(pass, self.draw);
    }

    /// Pixels of the frame.
    pub fn pixels(&self) -> u64 {
        self.options.pixels()
    }

    /// The label of one of the method's passes.
    pub fn label(&self, pass: &str) -> String {
        format!("strata.{}.{pass}", self.method)
    }

    /// The frame's (width, height) in pixels.
    pub fn size(&self) -> (u32, u32) {
        (self.options.frame.width, self.options.frame.height)
    }

    /// The null target in `slot` for this frame's size and the scene's samples, (re)made when
    /// they changed (see [`crate::gpu::passes::NullTarget::ensure`]).
    pub fn null_target<'s>(
        &self,
        slot: &'s mut Option<crate::gpu::passes::NullTarget>,
        label: &str,
    ) -> &'s crate::gpu::passes::NullTarget {
        let samples = self.scene.samples;
        crate::gpu::passes::NullTarget::ensure(slot, self.gpu, label, self.size(), samples)
    }

    /// The memory ledger's rule: a method allocating `bytes` for this frame stays within
    /// `--budget-mb`, checked before it allocates.
    pub fn check_budget(&self, bytes: u64) -> Result<()> {
        match self.options.budget_bytes() {
            Some(budget) if bytes > budget => Err(Error::input(format!(
                "{}: needs {:.2} MiB at {}x{}{}, more than --budget-mb {}",
                self.method,
                bytes as f64 / 1048576.0,
                self.options.frame.width,
                self.options.frame.height,
                self.options
                    .frame
                    .k
                    .map(|k| format!(" and k={k}"))
                    .unwrap_or_default(),
                self.options.frame.budget_mb.unwrap_or(0.0)
            ))),
            _ => Ok(()),
        }
    }

    /// Workgroups of 8×8 covering the image.
    pub fn pixel_workgroups(&self) -> (u32, u32) {
        (
            self.options.frame.width.div_ceil(8),
            self.options.frame.height.div_ceil(8),
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testing::assert_layout;

    #[test]
    fn resolved_layout_matches_wgsl() {
        assert_layout!(Resolved, 32, count: 12, transmittance: 16);
        assert_eq!(RESOLVED_BYTES, 32);
    }

    #[test]
    fn wide_counters_join_low_and_high_words() {
        let w = [u32::MAX, 1, 5, 0, 7, 2, 9, 0];
        let t = Totals::from_words(&w);
        assert_eq!(t.generated, (1u64 << 33) - 1);
        assert_eq!(t.stored, 5);
        assert_eq!(t.dropped, 7 + (2u64 << 32));
        assert_eq!(t.max_depth, 9);
    }
}
