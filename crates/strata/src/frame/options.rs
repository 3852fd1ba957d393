//! The options of a picture, split by how long they live:
//! - [`BuildOptions`]: what a [`crate::FrameRecorder`] is made with (the rasterizer, the sample
//!   count, the lit pipeline, the cache); another value means another recorder, because
//!   pipelines, targets or preprocesses depend on it;
//! - [`FrameOptions`]: what may change between two frames of one recorder (size, band, effect, k and
//!   every family's parameters, order, temporal culling), with one parameter struct per family
//!   ([`KBufferOptions`], [`PeelingOptions`], [`WeightedOptions`]).
//!
//! [`RenderOptions`] holds both; its [`RenderOptions::validate`] is the one check of a
//! combination, run once where options enter (recorder, renderer, reference).

use std::path::PathBuf;
use std::str::FromStr;

use crate::error::{Error, Result};
use crate::frame::msaa;
use crate::frame::values::{GbufferView, NormalEncoding, Raster, TemporalCulling, Tonemap};
use crate::frame::MAX_TRIES_LIMIT;
use crate::keyword::keyword_enum;
use crate::scene::{Background, Pipeline, MAX_SIDE};

keyword_enum! {
    /// What a frame shows (`--effect`).
    #[derive(Default)]
    pub enum Effect ("effect") {
        /// Fragments composited front to back (C += T·α·c).
        #[default]
        Transparency = "transparency",
        /// Transparency plus a Schlick Fresnel term and Beer–Lambert absorption over the thickness between entering and leaving surfaces.
        Translucency = "translucency",
        /// Fragments per pixel, as a heatmap (depth complexity).
        Complexity = "complexity",
    }
}

keyword_enum! {
    /// What k-buffer methods do with fragments beyond the k nearest.
    #[derive(Default)]
    pub enum Tail ("--tail") {
        /// Discard them (counted in `fragments_dropped`).
        #[default]
        Drop = "drop",
        /// Blend them, unsorted, into one tail term behind the k nearest (weighted average color,
        /// opacity from the sum of their optical depths), as engines do.
        Blend = "blend",
        /// Hybrid transparency (Maule et al. 2013): the tail as weighted blended OIT — its color the
        /// average weighted by α·w(z) of McGuire & Bavoil's equations (`--weight`, `--depth-scale`),
        /// its opacity as `blend`'s — behind the k nearest, so nearer tail fragments count more.
        Weighted = "weighted",
    }
}

impl Tail {
    /// Whether fragments beyond k are kept as a tail term (blended or weighted).
    pub fn kept(self) -> bool {
        self != Tail::Drop
    }
}

keyword_enum! {
    /// How the k-buffer family lays out its per-pixel arrays (`--storage-layout`): the words of
    /// each pixel (seen, filled, lock, bound), its slots and its tail sums.
    #[derive(Default)]
    pub enum StorageLayout ("--storage-layout") {
        /// Each pixel's items together (`p · items + i`), as the papers draw their per-pixel
        /// arrays: one pixel's walk over its slots stays within a few cache lines.
        #[default]
        Pixel = "pixel",
        /// Item i of every pixel together (`i · pixels + p`): the neighbouring pixels that a
        /// GPU shades in one warp touch neighbouring words, so a warp's access is a few memory
        /// transactions instead of one per pixel.
        Slot = "slot",
    }
}

impl StorageLayout {
    /// Where item `i` of storage pixel `p`'s `per_pixel` items lies in an array of
    /// `storage_pixels` pixels' items: the CPU twin of `pixel_item` in storage.wgsl.
    pub fn item(self, p: u64, i: u64, per_pixel: u64, storage_pixels: u64) -> u64 {
        match self {
            StorageLayout::Slot => i * storage_pixels + p,
            StorageLayout::Pixel => p * per_pixel + i,
        }
    }
}

keyword_enum! {
    /// The weight function of weighted blended OIT: McGuire & Bavoil 2013, equations 7–10.
    #[derive(Default)]
    pub enum Weight ("--weight") {
        /// α·clamp(10 / (10⁻⁵ + (|z|/5)² + (|z|/200)⁶), 10⁻², 3·10³).
        #[default]
        Eq7 = "eq7",
        /// α·clamp(10 / (10⁻⁵ + (|z|/10)³ + (|z|/200)⁶), 10⁻², 3·10³).
        Eq8 = "eq8",
        /// α·clamp(0.03 / (10⁻⁵ + (|z|/200)⁴), 10⁻², 3·10³).
        Eq9 = "eq9",
        /// α·max(10⁻², 3·10³·(1 − d)³), d the window depth.
        Eq10 = "eq10",
    }
}

keyword_enum! {
    /// How `bucket` splits each pixel's depth range into buckets (`--buckets`).
    #[derive(Default)]
    pub enum BucketSplit ("--buckets") {
        /// k/2 equal parts of the depth range (Liu et al. 2009's bucket depth peeling).
        #[default]
        Uniform = "uniform",
        /// The paper's adaptive variant: a histogram pass marks which of 1024 equal parts hold
        /// fragments, and the buckets are shared among the occupied parts only.
        Adaptive = "adaptive",
    }
}

/// A horizontal band of a taller picture: this picture's rows are rows `top..top + height` of a
/// picture `full_height` rows high and as wide. The projection is cropped to the band, so bands
/// rendered one after another make the whole picture (how [`crate::Renderer`] renders pictures
/// whose per-pixel buffers outgrow the device's storage bindings).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Band {
    /// Rows of the whole picture.
    pub full_height: u32,
    /// The band's first row in the whole picture (a multiple of [`BAND_ALIGN`]).
    pub top: u32,
}

/// Band tops are multiples of this many rows: the checkerboard background's period, so that
/// every band continues its pattern.
pub const BAND_ALIGN: u32 = 32;

/// Everything about a picture that is not the scene.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct RenderOptions {
    /// What the recorder is made with.
    pub build: BuildOptions,
    /// What may change between frames.
    pub frame: FrameOptions,
}

/// What a recorder is made with: fixed for its life.
#[derive(Clone, Debug, PartialEq)]
pub struct BuildOptions {
    /// Which rasterizer makes the fragments of the storage geometry passes (`--raster`).
    pub raster: Raster,
    /// `--msaa`: samples per pixel (1, 4 or 8) at the standard sample positions; each captured
    /// fragment carries its coverage mask and resolves composite per sample ([`msaa`]).
    pub msaa: u32,
    /// `--pipeline` and the lit pipelines' settings.
    pub lighting: Lighting,
    /// `--cache-dir`: preprocesses (convex's decomposition) are kept here between runs, read
    /// when present and written when made (`None`: in memory only).
    pub cache_dir: Option<PathBuf>,
}

impl Default for BuildOptions {
    fn default() -> Self {
        BuildOptions {
            raster: Raster::Hw,
            msaa: 1,
            lighting: Lighting::default(),
            cache_dir: None,
        }
    }
}

/// `--pipeline` and what the lit opaque frame is made with ([`crate::deferred`]).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Lighting {
    /// Opaque objects lit forward or deferred, the method over them; `None`: every surface,
    /// opaque ones too, goes through the method.
    pub pipeline: Option<Pipeline>,
    /// How the lit frame's HDR color maps to the display.
    pub tonemap: Tonemap,
    /// Deferred: screen-space ambient occlusion.
    pub ssao: bool,
    /// Deferred: how the G-buffer stores normals.
    pub normal_encoding: NormalEncoding,
    /// Deferred: write a G-buffer view instead of the picture.
    pub gbuffer_debug: Option<GbufferView>,
}

/// What may change from one frame of a recorder to the next.
#[derive(Clone, Debug, PartialEq)]
pub struct FrameOptions {
    /// Frame width in pixels.
    pub width: u32,
    /// Frame height in pixels.
    pub height: u32,
    /// What the frame shows.
    pub effect: Effect,
    /// What lies behind everything when strata composites the picture itself (exact mode; a recorder composites over the application's target instead).
    pub background: Background,
    /// The picture is a band of a taller one (`None`: the whole picture).
    pub band: Option<Band>,
    /// Per-pixel capacity for k-buffer methods, bucket's slots, and the reference's `--k`.
    pub k: Option<u32>,
    /// `--k auto --robustness R`: each frame's k is chosen from the last depth-complexity
    /// histogram to capture the fraction R of the fragments within `budget_mb` (see
    /// `methods::kbuffer::predict`); `k` is then ignored.
    pub k_auto: Option<f64>,
    /// Memory a method may allocate, in MiB.
    pub budget_mb: Option<f64>,
    /// The k-buffer family's parameters.
    pub kbuffer: KBufferOptions,
    /// Depth peeling's parameters.
    pub peeling: PeelingOptions,
    /// Weighted blended and moment OIT's parameters.
    pub weighted: WeightedOptions,
    /// `--order`: the triangles' submission order, rebuilt on the GPU every frame, and its
    /// Kendall distance to depth order in the statistics (`None`: the scene's order, unmeasured).
    pub order: Option<crate::order::Order>,
    /// `--seed`: random orders draw their permutations from it and the frame number.
    pub order_seed: u64,
    /// `--temporal on`: reverse-reprojection culling against last frame's (k+1)-th depths
    /// (`methods::kbuffer::temporal`).
    pub temporal: Option<TemporalCulling>,
}

impl Default for FrameOptions {
    fn default() -> Self {
        FrameOptions {
            width: 512,
            height: 512,
            effect: Effect::Transparency,
            background: Background::Checker,
            band: None,
            k: None,
            k_auto: None,
            budget_mb: None,
            kbuffer: KBufferOptions::default(),
            peeling: PeelingOptions::default(),
            weighted: WeightedOptions::default(),
            order: None,
            order_seed: 0,
            temporal: None,
        }
    }
}

/// The k-buffer family's parameters (and the linked lists' pools, which share its storage code).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct KBufferOptions {
    /// Fragments beyond k.
    pub tail: Tail,
    /// Cull fragments behind a full pixel's maximum before taking the lock.
    pub culling: bool,
    /// Lock and compare-exchange tries per shader invocation (default 65536, at most
    /// [`MAX_TRIES_LIMIT`]): per fragment under the GPU's rasterizer, shared by the up to 64
    /// fragments an invocation of the compute rasterizer captures (each gets at least one try).
    pub max_tries: Option<u32>,
    /// How the per-pixel arrays are laid out.
    pub layout: StorageLayout,
    /// kplus-semiheap: slots of the max-heap H (default 1, the paper's), the rest unordered.
    pub heap_size: Option<u32>,
    /// Initial node pool of the linked-list methods (nodes); by default sized from the last
    /// frame's measured need.
    pub initial_nodes: Option<u64>,
    /// Value the fragment-pool allocation counters start from each frame (normally 0). Tests
    /// start them near 2³² to show that they saturate instead of wrapping.
    pub allocation_counter_start: u32,
}

impl Default for KBufferOptions {
    fn default() -> Self {
        KBufferOptions {
            tail: Tail::Drop,
            culling: true,
            max_tries: None,
            layout: StorageLayout::Pixel,
            heap_size: None,
            initial_nodes: None,
            allocation_counter_start: 0,
        }
    }
}

/// The depth-peeling family's parameters.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct PeelingOptions {
    /// A fixed number of layers per frame; by default the last frame's depth complexity.
    pub layers: Option<u32>,
    /// bucket: how each pixel's depth range splits into buckets.
    pub buckets: BucketSplit,
}

/// mboit's moments: power moments of the warped depth (4, 6 or 8), or trigonometric moments of
/// its angle on the unit circle (2, 3 or 4 complex moments: 4, 6 or 8 real values).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Moments {
    /// E\[zᵏ\] for k = 1..n.
    Power(u32),
    /// E\[e^{ikφ}\] for k = 1..n.
    Trigonometric(u32),
    /// n Haar coefficients of the absorbance step over the warped depth (`wavelet`'s
    /// `--coefficients`, not an mboit `--moments`).
    Haar(u32),
}

impl Moments {
    /// Every count mboit builds, in the order a menu lists them.
    pub const ALL: [Moments; 6] = [
        Moments::Power(4),
        Moments::Power(6),
        Moments::Power(8),
        Moments::Trigonometric(2),
        Moments::Trigonometric(3),
        Moments::Trigonometric(4),
    ];

    /// The real values it stores per sample besides b0.
    pub fn reals(self) -> u32 {
        match self {
            Moments::Power(n) | Moments::Haar(n) => n,
            Moments::Trigonometric(n) => 2 * n,
        }
    }

    /// Whether it is one of the counts mboit builds.
    pub fn supported(self) -> bool {
        Moments::ALL.contains(&self)
    }
}

impl Default for Moments {
    fn default() -> Self {
        Moments::Power(4)
    }
}

impl std::fmt::Display for Moments {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Moments::Power(n) => write!(f, "{n}"),
            Moments::Trigonometric(n) => write!(f, "trig{n}"),
            Moments::Haar(n) => write!(f, "haar{n}"),
        }
    }
}

impl FromStr for Moments {
    type Err = Error;

    fn from_str(s: &str) -> Result<Moments> {
        let parsed = match s.strip_prefix("trig") {
            Some(n) => n.parse().ok().map(Moments::Trigonometric),
            None => s.parse().ok().map(Moments::Power),
        };
        parsed.filter(|m| m.supported()).ok_or_else(|| {
            Error::input(format!(
                "--moments '{}' is not 4, 6, 8 (power moments) or trig2, trig3, trig4 (trigonometric)",
                crate::error::quoted(s)
            ))
        })
    }
}

/// The most passes `stochastic` takes (`--passes`).
pub const MAX_STOCHASTIC_PASSES: u32 = 64;

/// The coefficient counts `wavelet` builds: the scaling coefficient and the Haar wavelets of 2
/// or 3 levels.
pub const WAVELET_COEFFICIENTS: [u32; 2] = [4, 8];

/// The weighted family's parameters (wboit, mboit).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct WeightedOptions {
    /// wboit: the weight function.
    pub weight: Weight,
    /// wboit: view-space distances are multiplied by this before the weight function, whose
    /// constants assume distances of 0.1 to 500 units.
    pub depth_scale: f64,
    /// mboit: power moments 4 (default), 6 or 8, or trigonometric moments 2, 3 or 4.
    pub moments: Moments,
    /// stochastic: passes of S samples each (1 by default).
    pub passes: u32,
    /// wavelet: Haar coefficients per sample, 4 or 8 (8 by default).
    pub coefficients: u32,
}

impl Default for WeightedOptions {
    fn default() -> Self {
        WeightedOptions {
            weight: Weight::Eq7,
            depth_scale: 1.0,
            moments: Moments::Power(4),
            passes: 1,
            coefficients: 8,
        }
    }
}

impl RenderOptions {
    /// The default options at a size.
    pub fn sized(width: u32, height: u32) -> RenderOptions {
        RenderOptions {
            frame: FrameOptions {
                width,
                height,
                ..Default::default()
            },
            ..Default::default()
        }
    }

    /// Pixels of the frame.
    pub fn pixels(&self) -> u64 {
        self.frame.pixels()
    }

    /// `budget_mb` in bytes.
    pub fn budget_bytes(&self) -> Option<u64> {
        self.frame.budget_bytes()
    }

    /// The whole combination: each part, then what one part allows of the other.
    pub fn validate(&self) -> Result<()> {
        self.frame.validate()?;
        self.build.lighting.validate()?;
        let (build, frame) = (&self.build, &self.frame);
        if let Some(band) = frame.band {
            if band.top % BAND_ALIGN != 0
                || band.full_height > MAX_SIDE
                || band.top as u64 + frame.height as u64 > band.full_height as u64
            {
                return Err(Error::input(format!(
                    "band of {} rows at row {} is not inside a picture of {} rows with its top a multiple of {BAND_ALIGN}",
                    frame.height, band.top, band.full_height
                )));
            }
            if frame.temporal.is_some() {
                return Err(Error::unsupported(format!(
                    "--temporal on reprojects whole frames, and {}x{} is too large for this device to render at once; use a smaller --size",
                    frame.width, band.full_height
                )));
            }
            if build.lighting.pipeline.is_some() {
                return Err(Error::unsupported(format!(
                    "--pipeline renders the whole picture at once (its screen-space passes see the whole frame), and {}x{} is too large for this device to do so; use a smaller --size",
                    frame.width, band.full_height
                )));
            }
        }
        if let (Some(order), Raster::Compute) = (frame.order, build.raster) {
            return Err(Error::unsupported(format!(
                "--order {} changes the order the GPU's rasterizer receives triangles in; --raster compute has none (use --raster hw)",
                order.name()
            )));
        }
        msaa::check_options(self)
    }
}

impl FrameOptions {
    /// Pixels of the frame.
    pub fn pixels(&self) -> u64 {
        self.width as u64 * self.height as u64
    }

    /// `budget_mb` in bytes.
    pub fn budget_bytes(&self) -> Option<u64> {
        self.budget_mb.map(|m| (m * 1048576.0) as u64)
    }

    /// The values that are wrong whatever the recorder.
    pub fn validate(&self) -> Result<()> {
        if let Some(t) = self
            .temporal
            .filter(|t| !(t.epsilon.is_finite() && t.epsilon >= 0.0))
        {
            return Err(Error::input(format!(
                "--temporal-epsilon {} must be a non-negative number",
                t.epsilon
            )));
        }
        if let Some(tries) = self.kbuffer.max_tries {
            let limit = MAX_TRIES_LIMIT;
            if tries == 0 {
                return Err(Error::input("--max-tries must be at least 1"));
            }
            if tries > limit {
                return Err(Error::input(format!(
                    "--max-tries {tries} is over {limit}: an invocation spinning that long on a starved lock could outlast the GPU's watchdog"
                )));
            }
        }
        if self.width == 0 || self.height == 0 || self.width > MAX_SIDE || self.height > MAX_SIDE {
            return Err(Error::input(format!(
                "size {}x{} is out of range (1..{MAX_SIDE} per side)",
                self.width, self.height
            )));
        }
        if let Some(b) = self.budget_mb {
            if b.is_nan() || b <= 0.0 {
                return Err(Error::input(format!("--budget-mb {b} must be positive")));
            }
        }
        let weighted = &self.weighted;
        if !(weighted.depth_scale.is_finite() && weighted.depth_scale > 0.0) {
            return Err(Error::input(format!(
                "--depth-scale {} must be a positive number",
                weighted.depth_scale
            )));
        }
        if !weighted.moments.supported() {
            return Err(Error::input(format!(
                "--moments {} is not 4, 6, 8, trig2, trig3 or trig4 (mboit's moments)",
                weighted.moments
            )));
        }
        if !WAVELET_COEFFICIENTS.contains(&weighted.coefficients) {
            return Err(Error::input(format!(
                "--coefficients {} is not 4 or 8 (wavelet's Haar coefficients)",
                weighted.coefficients
            )));
        }
        if !(1..=MAX_STOCHASTIC_PASSES).contains(&weighted.passes) {
            return Err(Error::input(format!(
                "--passes {} is outside 1..{MAX_STOCHASTIC_PASSES} (stochastic's passes)",
                weighted.passes
            )));
        }
        if let Some(r) = self.k_auto {
            if !(r > 0.0 && r <= 1.0) {
                return Err(Error::input(format!(
                    "--robustness {r} is outside (0, 1] (the fraction of fragments to capture)"
                )));
            }
        }
        if let Some(l) = self.peeling.layers {
            if l == 0 || l > MAX_LAYERS {
                return Err(Error::input(format!(
                    "--layers {l} is outside 1..{MAX_LAYERS}"
                )));
            }
        }
        Ok(())
    }
}

impl Lighting {
    fn validate(&self) -> Result<()> {
        if self.pipeline == Some(Pipeline::Deferred) {
            return Ok(());
        }
        if self.ssao {
            return Err(Error::input(
                "--ssao needs --pipeline deferred (it reads the G-buffer)",
            ));
        }
        if let Some(v) = self.gbuffer_debug {
            return Err(Error::input(format!(
                "--gbuffer-debug {} needs --pipeline deferred",
                v.name()
            )));
        }
        Ok(())
    }
}

/// Peeling never records more layers than this in one frame.
pub const MAX_LAYERS: u32 = 1024;
