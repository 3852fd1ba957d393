//! What a method records a frame with, below both `methods` and `render`: the options of a
//! picture, the scene on the GPU, the frame context a method records into, the per-pixel result
//! every resolve writes, the frame totals and the statistics a frame reports.
//!
//! A frame is a recording into a [`wgpu::CommandEncoder`] the caller owns:
//! 1. the frame uniforms (camera, effect) are written with `queue.write_buffer`;
//! 2. the method records its passes — capture (one or more geometry passes) and resolve — and
//!    writes each pixel's [`Resolved`] value (premultiplied color, alpha = 1 − transmittance,
//!    fragment count) and the frame totals;
//! 3. the present pass blends the resolved colors OVER the caller's color target;
//! 4. the totals, the method's counters and the pass timestamps are copied to a staging slot
//!    that is mapped when the GPU has finished the submission: [`FrameStats`] arrive a frame or
//!    more later, tagged with their frame number. Nothing in steady state waits on the GPU.
//!
//! [`crate::FrameRecorder`] (in `render`, above the methods) drives this for an application;
//! [`crate::Renderer`] is the batch renderer on top of it that the CLI and the tests use.

pub mod colormap;
pub mod msaa;
pub mod passes;
pub mod present;
pub mod scene_gpu;
pub mod stats;
pub mod uniforms;
pub mod values;

use std::collections::BTreeMap;
use std::str::FromStr;

use bytemuck::{Pod, Zeroable};
use serde::Serialize;

use crate::error::{Error, Result};
use crate::gpu::timing::Timer;
use crate::gpu::Gpu;
pub use crate::scene::{Pipeline, MAX_SIDE};

pub use crate::gpu::readback::ReadbackList;
pub use scene_gpu::SceneGpu;
pub use values::{
    ComputeRasterStats, ConvexStats, GbufferView, LightingStats, NormalEncoding, Raster,
    TemporalCulling, Tonemap, MAX_TRIES_LIMIT,
};

/// How a pixel's depth-ordered fragments become a color.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default, Serialize)]
#[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
#[serde(rename_all = "lowercase")]
pub enum Effect {
    #[default]
    Transparency,
    Translucency,
    Complexity,
}

impl FromStr for Effect {
    type Err = Error;
    fn from_str(s: &str) -> Result<Self> {
        match s {
            "transparency" => Ok(Effect::Transparency),
            "translucency" => Ok(Effect::Translucency),
            "complexity" => Ok(Effect::Complexity),
            _ => Err(Error::input(format!(
                "unknown effect '{s}' (expected transparency, translucency or complexity)"
            ))),
        }
    }
}

impl Effect {
    pub fn name(self) -> &'static str {
        match self {
            Effect::Transparency => "transparency",
            Effect::Translucency => "translucency",
            Effect::Complexity => "complexity",
        }
    }
}

/// What k-buffer methods do with fragments beyond the k nearest.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default, Serialize)]
#[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
#[serde(rename_all = "lowercase")]
pub enum Tail {
    /// Discard them (counted in `fragments_dropped`).
    #[default]
    Drop,
    /// Blend them, unsorted, into one tail term behind the k nearest (weighted average color,
    /// opacity from the sum of their optical depths), as engines do.
    Blend,
}

/// The weight function of weighted blended OIT: McGuire & Bavoil 2013, equations 7–10.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default, Serialize)]
#[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
#[serde(rename_all = "lowercase")]
pub enum Weight {
    /// α·clamp(10 / (10⁻⁵ + (|z|/5)² + (|z|/200)⁶), 10⁻², 3·10³).
    #[default]
    Eq7,
    /// α·clamp(10 / (10⁻⁵ + (|z|/10)³ + (|z|/200)⁶), 10⁻², 3·10³).
    Eq8,
    /// α·clamp(0.03 / (10⁻⁵ + (|z|/200)⁴), 10⁻², 3·10³).
    Eq9,
    /// α·max(10⁻², 3·10³·(1 − d)³), d the window depth.
    Eq10,
}

impl Weight {
    pub fn index(self) -> u32 {
        self as u32
    }

    pub fn name(self) -> &'static str {
        match self {
            Weight::Eq7 => "eq7",
            Weight::Eq8 => "eq8",
            Weight::Eq9 => "eq9",
            Weight::Eq10 => "eq10",
        }
    }
}

/// How `bucket` splits each pixel's depth range into buckets (`--buckets`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default, Serialize)]
#[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
#[serde(rename_all = "lowercase")]
pub enum BucketSplit {
    /// k/2 equal parts of the depth range (Liu et al. 2009's bucket depth peeling).
    #[default]
    Uniform,
    /// The paper's adaptive variant: a histogram pass marks which of 1024 equal parts hold
    /// fragments, and the buckets are shared among the occupied parts only.
    Adaptive,
}

impl BucketSplit {
    pub fn name(self) -> &'static str {
        match self {
            BucketSplit::Uniform => "uniform",
            BucketSplit::Adaptive => "adaptive",
        }
    }
}

impl FromStr for Tail {
    type Err = Error;
    fn from_str(s: &str) -> Result<Self> {
        match s {
            "drop" => Ok(Tail::Drop),
            "blend" => Ok(Tail::Blend),
            _ => Err(Error::input(format!("--tail '{s}' is not drop or blend"))),
        }
    }
}

/// A horizontal band of a taller picture: this picture's rows are rows `top..top + height` of a
/// picture `full_height` rows high and as wide. The projection is cropped to the band, so bands
/// rendered one after another make the whole picture (how [`crate::Renderer`] renders pictures
/// whose per-pixel buffers outgrow the device's storage bindings).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Band {
    pub full_height: u32,
    pub top: u32,
}

/// Band tops are multiples of this many rows: the checkerboard background's period, so that
/// every band continues its pattern.
pub const BAND_ALIGN: u32 = 32;

/// Everything about a picture that is not the scene.
#[derive(Clone, Debug)]
pub struct RenderOptions {
    pub width: u32,
    pub height: u32,
    pub effect: Effect,
    pub background: crate::scene::Background,
    /// Per-pixel capacity for k-buffer methods, and the reference's `--k`.
    pub k: Option<u32>,
    /// Memory a method may allocate, in MiB.
    pub budget_mb: Option<f64>,
    /// Initial node pool of the linked-list methods (nodes); by default sized from the last
    /// frame's measured need.
    pub abuffer_initial_nodes: Option<u64>,
    /// k-buffers: fragments beyond k.
    pub tail: Tail,
    /// k-buffers: cull fragments behind a full pixel's maximum before taking the lock.
    pub culling: bool,
    /// k-buffers: spin-lock tries per fragment (default 65536, at most
    /// [`MAX_TRIES_LIMIT`]).
    pub max_tries: Option<u32>,
    /// Depth peeling: a fixed number of layers per frame; by default the last frame's depth
    /// complexity.
    pub layers: Option<u32>,
    /// kplus-semiheap: slots of the max-heap H (default 1, the paper's), the rest unordered.
    pub heap_size: Option<u32>,
    /// bucket: how each pixel's depth range splits into buckets.
    pub buckets: BucketSplit,
    /// wboit: the weight function.
    pub weight: Weight,
    /// wboit: view-space distances are multiplied by this before the weight function, whose
    /// constants assume distances of 0.1 to 500 units.
    pub depth_scale: f64,
    /// mboit: power moments, 4 (default), 6 or 8.
    pub moments: u32,
    /// `--k auto --robustness R`: each frame's k is chosen from the last depth-complexity
    /// histogram to capture the fraction R of the fragments within `budget_mb` (see
    /// [`crate::methods::kbuffer::predict`]); `k` is then ignored.
    pub k_auto: Option<f64>,
    /// Value the fragment-pool allocation counters start from each frame (normally 0). Tests
    /// start them near 2³² to show that they saturate instead of wrapping.
    pub allocation_counter_start: u32,
    /// `--pipeline`: opaque objects lit forward or deferred, the method over them (see
    /// [`crate::deferred`]); `None`: every surface, opaque ones too, goes through the method.
    pub pipeline: Option<Pipeline>,
    /// The lit pipelines' tone map.
    pub tonemap: Tonemap,
    /// Deferred: screen-space ambient occlusion.
    pub ssao: bool,
    /// Deferred: how the G-buffer stores normals.
    pub normal_encoding: NormalEncoding,
    /// Deferred: write a G-buffer view instead of the picture.
    pub gbuffer_debug: Option<GbufferView>,
    /// Which rasterizer makes the fragments of the storage geometry passes (`--raster`).
    pub raster: Raster,
    /// The picture is a band of a taller one (`None`: the whole picture).
    pub band: Option<Band>,
    /// `--order`: the triangles' submission order, rebuilt on the GPU every frame, and its
    /// Kendall distance to depth order in the statistics (`None`: the scene's order, unmeasured).
    pub order: Option<crate::order::Order>,
    /// `--seed`: random orders draw their permutations from it and the frame number.
    pub order_seed: u64,
    /// `--temporal on`: reverse-reprojection culling against last frame's (k+1)-th depths
    /// ([`crate::methods::kbuffer::temporal`]).
    pub temporal: Option<TemporalCulling>,
    /// `--cache-dir`: preprocesses (convex's decomposition) are kept here between runs, read
    /// when present and written when made (`None`: in memory only).
    pub cache_dir: Option<std::path::PathBuf>,
    /// `--msaa`: samples per pixel (1, 4 or 8) at the standard sample positions; each captured
    /// fragment carries its coverage mask and resolves composite per sample ([`msaa`]).
    pub msaa: u32,
}

impl Default for RenderOptions {
    fn default() -> Self {
        RenderOptions {
            width: 512,
            height: 512,
            effect: Effect::Transparency,
            background: crate::scene::Background::Checker,
            k: None,
            budget_mb: None,
            abuffer_initial_nodes: None,
            tail: Tail::Drop,
            culling: true,
            max_tries: None,
            layers: None,
            k_auto: None,
            heap_size: None,
            buckets: BucketSplit::Uniform,
            weight: Weight::Eq7,
            moments: 4,
            depth_scale: 1.0,
            allocation_counter_start: 0,
            pipeline: None,
            tonemap: Tonemap::default(),
            ssao: false,
            normal_encoding: NormalEncoding::default(),
            gbuffer_debug: None,
            raster: Raster::Hw,
            band: None,
            order: None,
            order_seed: 0,
            temporal: None,
            cache_dir: None,
            msaa: 1,
        }
    }
}

impl RenderOptions {
    pub fn pixels(&self) -> u64 {
        self.width as u64 * self.height as u64
    }

    pub fn budget_bytes(&self) -> Option<u64> {
        self.budget_mb.map(|m| (m * 1048576.0) as u64)
    }

    pub fn validate(&self) -> Result<()> {
        if let Some(tries) = self.max_tries {
            let limit = MAX_TRIES_LIMIT;
            if tries == 0 {
                return Err(Error::input("--max-tries must be at least 1"));
            }
            if tries > limit {
                return Err(Error::input(format!(
                    "--max-tries {tries} is over {limit}: a fragment spinning that long on a starved lock could outlast the GPU's watchdog"
                )));
            }
        }
        if self.width == 0 || self.height == 0 || self.width > MAX_SIDE || self.height > MAX_SIDE {
            return Err(Error::input(format!(
                "size {}x{} is out of range (1..{MAX_SIDE} per side)",
                self.width, self.height
            )));
        }
        if let Some(band) = self.band {
            if band.top % BAND_ALIGN != 0
                || band.full_height > MAX_SIDE
                || band.top as u64 + self.height as u64 > band.full_height as u64
            {
                return Err(Error::input(format!(
                    "band of {} rows at row {} is not inside a picture of {} rows with its top a multiple of {BAND_ALIGN}",
                    self.height, band.top, band.full_height
                )));
            }
            if self.temporal.is_some() {
                return Err(Error::unsupported(format!(
                    "--temporal on reprojects whole frames, and {}x{} is too large for this device to render at once; use a smaller --size",
                    self.width, band.full_height
                )));
            }
            if self.pipeline.is_some() {
                return Err(Error::unsupported(format!(
                    "--pipeline renders the whole picture at once (its screen-space passes see the whole frame), and {}x{} is too large for this device to do so; use a smaller --size",
                    self.width, band.full_height
                )));
            }
        }
        if let (Some(order), Raster::Compute) = (self.order, self.raster) {
            return Err(Error::unsupported(format!(
                "--order {} changes the order the GPU's rasterizer receives triangles in; --raster compute has none (use --raster hw)",
                order.name()
            )));
        }
        if let Some(b) = self.budget_mb {
            if b.is_nan() || b <= 0.0 {
                return Err(Error::input(format!("--budget-mb {b} must be positive")));
            }
        }
        if !(self.depth_scale.is_finite() && self.depth_scale > 0.0) {
            return Err(Error::input(format!(
                "--depth-scale {} must be a positive number",
                self.depth_scale
            )));
        }
        if ![4, 6, 8].contains(&self.moments) {
            return Err(Error::input(format!(
                "--moments {} is not 4, 6 or 8 (mboit's power moments)",
                self.moments
            )));
        }
        if let Some(r) = self.k_auto {
            if !(r > 0.0 && r <= 1.0) {
                return Err(Error::input(format!(
                    "--robustness {r} is outside (0, 1] (the fraction of fragments to capture)"
                )));
            }
        }
        if self.pipeline != Some(Pipeline::Deferred) {
            if self.ssao {
                return Err(Error::input(
                    "--ssao needs --pipeline deferred (it reads the G-buffer)",
                ));
            }
            if let Some(v) = self.gbuffer_debug {
                let name = serde_json::to_value(v).unwrap_or_default();
                return Err(Error::input(format!(
                    "--gbuffer-debug {} needs --pipeline deferred",
                    name.as_str().unwrap_or("view")
                )));
            }
        }
        msaa::check_options(self)?;
        if let Some(l) = self.layers {
            if l == 0 || l > MAX_LAYERS {
                return Err(Error::input(format!(
                    "--layers {l} is outside 1..{MAX_LAYERS}"
                )));
            }
        }
        Ok(())
    }
}

/// Peeling never records more layers than this in one frame.
pub const MAX_LAYERS: u32 = 1024;

/// What every frame reports (`--stats FILE.json`). Unknown values are `None` (`null`).
#[derive(Clone, Debug, Default, Serialize)]
pub struct FrameStats {
    /// The frame these statistics belong to (frames count from 0 per recorder).
    pub frame: u64,
    pub method: String,
    pub width: u32,
    pub height: u32,
    pub k: Option<u32>,
    pub effect: String,
    pub geometry_passes: Option<u32>,
    /// Whether the method is exact by design (the catalogue's flag; a k-buffer's exactness is
    /// that of its k nearest). Approximate methods (wboit, mboit, unsorted, ...) say false: their
    /// error is measured against the reference, never hidden.
    pub exact: Option<bool>,
    pub gpu_ms: Option<BTreeMap<String, f64>>,
    pub gpu_ms_total: Option<f64>,
    pub fragments_generated: Option<u64>,
    pub fragments_stored: Option<u64>,
    pub fragments_dropped: Option<u64>,
    pub max_depth_complexity: Option<u32>,
    pub bytes_allocated: Option<u64>,
    /// The method's storage, or the compute rasterizer's work items, ran out: the fragment
    /// counts are then lower bounds (the frame is incomplete and exact mode renders it again).
    pub overflow: Option<bool>,
    pub lock_failures: Option<u64>,
    /// How the capture's atomics are ordered on this adapter (k-buffer methods): "acquire-release
    /// (SPIR-V passthrough)", or "relaxed" with or without coherent storage.
    pub memory_ordering: Option<String>,
    /// Horizontal bands the picture was rendered in, when its per-pixel buffers outgrew the
    /// device's storage bindings (counters are summed over bands, GPU times too).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub bands: Option<u32>,
    /// With the GPU histogram on ([`crate::FrameRecorder::set_histogram`]): pixels per fragment
    /// count, bin i = exactly i fragments, up to the last non-empty bin.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub depth_histogram: Option<Vec<u64>>,
    /// Pixels with 1023 or more fragments: the histogram's last bin, which counts them together.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub depth_histogram_clipped: Option<u64>,
    /// With `--k auto`: how this frame's k (`k`) was chosen and what it captured.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub k_auto: Option<AutoKStats>,
    /// With `--pipeline`: the lit opaque frame (pipeline, lights drawn and culled, G-buffer
    /// bytes).
    pub lighting: Option<LightingStats>,
    /// The rasterizer of the storage geometry passes: "hw" or "compute".
    pub raster: String,
    /// With `--raster compute`: its work items, capacity and overflow.
    pub compute_raster: Option<ComputeRasterStats>,
    /// With `--temporal on`: fragments culled before any lock by last frame's interface
    /// (included in `fragments_generated` and `fragments_dropped`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub culled_temporal: Option<u64>,
    /// With `--order`: the submission order.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub order: Option<String>,
    /// With `--order`: the sampled normalized Kendall tau distance between the submission
    /// order and front-to-back depth order (0: front to back, 1: back to front).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub kendall_tau: Option<f64>,
    /// `convex`: groups, passes, draws, pairs ordered without a plane, and `order_violations`
    /// (pixel-passes where the order failed).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub convex: Option<ConvexStats>,
    /// Times strata blocked the CPU on the GPU for this picture (0 in real-time frames).
    pub blocking_readbacks: u32,
    /// Command buffers strata submitted itself for this picture (0 in real-time frames: the
    /// application submits).
    pub submits: u32,
    pub adapter: Option<String>,
    pub backend: Option<String>,
}

/// How `--k auto` chose a frame's k.
#[derive(Clone, Debug, Default, Serialize)]
pub struct AutoKStats {
    /// The robustness ratio R asked for.
    pub robustness_target: f64,
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

/// What a method reports about its frame once its counters are back.
#[derive(Clone, Debug, Default)]
pub struct MethodStats {
    pub overflow: Option<bool>,
    pub lock_failures: Option<u64>,
    /// The frame is missing fragments that a larger pool or more layers would have kept; the
    /// method has already grown for the next frame. Exact mode renders again.
    pub incomplete: bool,
    /// Why no later frame can be complete either (memory limits): exact mode's error.
    pub cannot_complete: Option<String>,
    /// With `--temporal on`: fragments culled by last frame's interface (never counted by the
    /// resolve: the frame's totals add them as generated and dropped).
    pub culled_temporal: Option<u64>,
    /// `convex`: the frame's order and its violations.
    pub convex: Option<ConvexStats>,
}

/// What a method recorded: known on the CPU when the frame is recorded.
#[derive(Clone, Debug, Default)]
pub struct Recorded {
    pub geometry_passes: u32,
    pub k: Option<u32>,
    pub bytes_allocated: u64,
    /// The size this frame ran with where it is fed back (pool nodes, array stride, layers).
    pub capacity: u64,
    /// How the capture's atomics are ordered (k-buffer methods).
    pub memory_ordering: Option<&'static str>,
    /// The frame ran with temporal culling.
    pub temporal: bool,
    /// `convex`: its order for this frame (violations come back with the statistics).
    pub convex: Option<ConvexStats>,
}

/// Frame totals every resolve adds each pixel to (`report_pixel` in composite.wgsl); 64-bit
/// sums are two words, low first, carried on overflow of the low word.
/// Keep in sync with the TOTAL_ constants in shaders/shared/scene.wgsl.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Totals {
    pub generated: u64,
    pub stored: u64,
    pub dropped: u64,
    pub max_depth: u32,
}

/// Words of the totals buffer.
pub const TOTAL_WORDS: u64 = 8;

impl Totals {
    pub fn from_words(w: &[u32]) -> Totals {
        let wide = |i: usize| w[i] as u64 | (w[i + 1] as u64) << 32;
        Totals {
            generated: wide(0),
            stored: wide(2),
            dropped: wide(4),
            max_depth: w[6],
        }
    }
}

/// A 64-bit counter kept as two u32 words (low, high) by `wide_add` in WGSL.
pub fn wide(words: &[u32], at: usize) -> u64 {
    words[at] as u64 | (words[at + 1] as u64) << 32
}

/// The per-pixel result of every resolve. Keep in sync with `Resolved` in composite.wgsl.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable, PartialEq)]
pub struct Resolved {
    /// Premultiplied linear RGB and alpha = 1 − transmittance.
    pub color: [f32; 4],
    pub count: u32,
    pub _pad: [u32; 3],
}

pub const RESOLVED_BYTES: u64 = std::mem::size_of::<Resolved>() as u64;

/// Issues draw calls into a geometry pass whose pipeline and bind groups the method has set and
/// whose vertex-buffer slot 0 holds the scene's triangle list: triangle `t` is vertices
/// 3t..3t+3, so a callback draws any ranges (culled subsets, chunks) of it.
pub type DrawCallback<'a> = dyn Fn(&mut wgpu::RenderPass<'_>) + 'a;

/// Where a frame goes: the application's color target (the resolve is blended OVER it; `None`
/// leaves the result in [`crate::FrameRecorder::resolved`] only) and the depth of its opaque
/// surfaces (Depth32Float, the frame's size, with TEXTURE_BINDING usage; fragments at or behind
/// it are rejected; `None`: nothing opaque).
#[derive(Clone, Copy, Default)]
pub struct FrameTargets<'a> {
    pub color: Option<(&'a wgpu::TextureView, wgpu::TextureFormat)>,
    pub opaque_depth: Option<&'a wgpu::TextureView>,
}

/// What a method gets to record one frame.
pub struct FrameContext<'a> {
    /// The method's id, which labels its passes `strata.<method>.<pass>`.
    pub method: &'static str,
    pub gpu: &'a Gpu,
    pub scene: &'a SceneGpu,
    pub options: &'a RenderOptions,
    /// The caller's encoder: every pass of the frame goes here; nothing is submitted.
    pub encoder: &'a mut wgpu::CommandEncoder,
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

    pub fn pixels(&self) -> u64 {
        self.options.pixels()
    }

    /// The label of one of the method's passes.
    pub fn label(&self, pass: &str) -> String {
        format!("strata.{}.{pass}", self.method)
    }

    pub fn size(&self) -> (u32, u32) {
        (self.options.width, self.options.height)
    }

    /// The memory ledger's rule: a method allocating `bytes` for this frame stays within
    /// `--budget-mb`, checked before it allocates.
    pub fn check_budget(&self, bytes: u64) -> Result<()> {
        match self.options.budget_bytes() {
            Some(budget) if bytes > budget => Err(Error::input(format!(
                "{}: needs {:.2} MiB at {}x{}{}, more than --budget-mb {}",
                self.method,
                bytes as f64 / 1048576.0,
                self.options.width,
                self.options.height,
                self.options
                    .k
                    .map(|k| format!(" and k={k}"))
                    .unwrap_or_default(),
                self.options.budget_mb.unwrap_or(0.0)
            ))),
            _ => Ok(()),
        }
    }

    /// Workgroups of 8×8 covering the image.
    pub fn pixel_workgroups(&self) -> (u32, u32) {
        (
            self.options.width.div_ceil(8),
            self.options.height.div_ceil(8),
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::mem::{offset_of, size_of};

    #[test]
    fn resolved_layout_matches_wgsl() {
        assert_eq!(size_of::<Resolved>(), 32);
        assert_eq!(offset_of!(Resolved, count), 16);
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
