//! The options of a picture, split by how long they live:
//! - [`BuildOptions`]: what a [`crate::FrameRecorder`] is made with (the rasterizer, the sample
//!   count, the lit pipeline, the cache); another value means another recorder, because
//!   pipelines, targets or preprocesses depend on it;
//! - [`FrameOptions`]: what may change between two frames of one recorder (size, band, effect, k,
//!   order, temporal culling, and each family's parameters: one struct per family, declared in
//!   its folder and carried as [`FamilyOptions`]).
//!
//! [`RenderOptions`] holds both; its [`RenderOptions::validate`] is the one check of a
//! combination, run once where options enter (recorder, renderer, reference).

use std::path::PathBuf;

use crate::error::{Error, Result};
use crate::frame::family::{FamilyOption, FamilyOptions};
use crate::frame::msaa;
use crate::frame::values::{GbufferView, NormalEncoding, Raster, TemporalCulling, Tonemap};
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
    /// Each method family's own parameters (`frame.family::<KBufferOptions>()`): the
    /// k-buffer family's, peeling's, the weighted family's, declared in their folders.
    pub families: FamilyOptions,
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
            families: FamilyOptions::default(),
            order: None,
            order_seed: 0,
            temporal: None,
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

    /// A family's options (their default when never set).
    pub fn family<T: FamilyOption>(&self) -> T {
        self.families.get()
    }

    /// A family's options to change.
    pub fn family_mut<T: FamilyOption>(&mut self) -> &mut T {
        self.families.get_mut()
    }

    /// These options with a family's set to `value`.
    pub fn with_family<T: FamilyOption>(mut self, value: T) -> FrameOptions {
        self.families.set(value);
        self
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
        if let Some(r) = self.k_auto {
            if !(r > 0.0 && r <= 1.0) {
                return Err(Error::input(format!(
                    "--robustness {r} is outside (0, 1] (the fraction of fragments to capture)"
                )));
            }
        }
        self.families.validate()
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
