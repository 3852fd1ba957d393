//! `wavg`: weighted average OIT (Bavoil & Myers 2008, the weighted average of their dual depth
//! peeling report) — each pixel's color the average of its fragments' colors weighted by their
//! opacity, over the opacity that n fragments of their average opacity would have.
//!
//! Passes: accumulate (1 geometry pass, additive and multiplicative blending into three
//! targets: Rgba16Float Σ α·c and Σ α, R16Float revealage Π(1 − α), R16Float the count n; and
//! an atomic per-pixel fragment count for the totals); composite (compute: per sample
//! C = Σαc / Σα · (1 − T) with T = (1 − ᾱ)ⁿ, ᾱ = Σα / n, or T = Π(1 − α) with
//! `--opacity product`, the samples averaged). Memory: 8 + 2 + 2 bytes per pixel and sample,
//! + 4 per pixel for the count, + 8 for the statistics.
//!
//! Not exact, by design: the average color is exact when every fragment of a pixel has one
//! color, the opacity when all have one opacity; with one fragment a pixel is exact. Every frame
//! reports how far the paper's average opacity lay from the exact product ([`WavgStats`], under
//! `"wavg"`), measured per pixel on the GPU, without a reference. The count target holds whole
//! numbers exactly up to 2048 fragments per sample (f16). Its closed form is `cpu::wavg`.

use bytemuck::Zeroable;

use crate::error::Result;
use crate::frame::passes::{
    color_geometry_pass, compute_pipeline, dispatch_pixels, geometry_pipeline,
};
use crate::frame::{
    FamilyStat, FamilyStats, FrameContext, MethodStats, Recorded, SceneGpu, Totals,
};
use crate::gpu::binding::{self, Slot};
use crate::gpu::shader::{self, Stage};
use crate::gpu::twin::{gpu_struct, wgsl_constants, wgsl_module};
use crate::gpu::{Gpu, ResourceCache};
use crate::methods::Method;

use super::options::{Opacity, WeightedOptions};
use super::{
    pixel_counts, revealage, sample_views, sums, ACCUMULATION_FORMAT, LIBRARY, REVEALAGE_FORMAT,
};

/// The count target's format: whole numbers exact up to 2048.
pub(crate) const COUNT_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::R16Float;
/// Bytes per pixel and sample of the three targets.
pub const WAVG_SAMPLE_BYTES: u64 = 8 + 2 + 2;
/// Bytes per pixel of the fragment count.
pub const WAVG_COUNT_BYTES: u64 = 4;
/// Bytes of the frame's opacity statistics.
const GAP_BYTES: u64 = 8;

gpu_struct! {
    /// wavg's composite uniforms (`strata::weighted::wavg_params`).
    pub struct WavgParams {
        /// [`Opacity::index`]: the average's opacity (0) or the product's (1).
        pub opacity: u32,
        pad_a: u32,
        pad_b: u32,
        pad_c: u32,
    }
}

/// `strata::weighted::wavg_params`: [`WavgParams`] for wavg_composite.wgsl.
pub(crate) const PARAMS_WGSL: &str = wgsl_module!("strata::weighted::wavg_params", WavgParams);

/// The statistics' words: the largest transmittance difference (f32 bits), the pixels over 1/255.
const GAP_MAX: usize = 0;
const GAP_PIXELS: usize = 1;

/// `strata::weighted::wavg_constants`: the opacity the composite tests for and the statistics'
/// words.
pub(crate) const CONSTANTS_WGSL: &str = wgsl_constants!(
    "strata::weighted::wavg_constants",
    OPACITY_PRODUCT = Opacity::Product,
    GAP_MAX = GAP_MAX,
    GAP_PIXELS = GAP_PIXELS,
);

/// What a `wavg` frame measured of its own approximation: how far the transmittance of the
/// paper's average opacity, (1 − ᾱ)ⁿ, lay from the exact Π(1 − α), per pixel (each the mean over
/// its samples). Whichever `--opacity` the frame composited with, these say what the other
/// would have changed.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize))]
pub struct WavgStats {
    /// The largest difference of any pixel (0: every pixel's fragments agreed, or had one).
    pub opacity_gap_max: f32,
    /// Pixels whose difference passed 1/255 (one step of an 8-bit picture, over a background
    /// of the opposite brightness).
    pub opacity_gap_pixels: u64,
}

impl FamilyStat for WavgStats {
    fn key(&self) -> &'static str {
        "wavg"
    }

    #[cfg(feature = "serde")]
    fn to_json(&self) -> serde_json::Value {
        serde_json::to_value(self).expect("plain numbers")
    }

    fn note(&self) -> Option<String> {
        Some(format!(
            "wavg: the average opacity's transmittance lay up to {:.4} from the exact product's, {} pixels past 1/255 (--opacity product composites with the exact one)",
            self.opacity_gap_max, self.opacity_gap_pixels
        ))
    }

    fn with_band(&self, next: &FamilyStats) -> Option<FamilyStats> {
        let next = next.get::<WavgStats>()?;
        Some(FamilyStats::new(WavgStats {
            opacity_gap_max: self.opacity_gap_max.max(next.opacity_gap_max),
            opacity_gap_pixels: self.opacity_gap_pixels + next.opacity_gap_pixels,
        }))
    }
}

/// `wavg`: one geometry pass into three blended targets, then a composite.
pub struct Wavg {
    accumulate_layout: wgpu::BindGroupLayout,
    accumulate: wgpu::RenderPipeline,
    composite_layout: wgpu::BindGroupLayout,
    composite: wgpu::ComputePipeline,
    cache: ResourceCache,
    samples: u32,
}

/// The accumulate stage.
pub fn accumulate_stage() -> Stage {
    Stage::new(
        "strata.wavg.accumulate",
        include_str!("wavg_accumulate.wgsl"),
    )
    .with(LIBRARY)
}

/// The composite stage, reading multisampled targets with `--msaa`.
pub fn composite_stage(samples: u32) -> Stage {
    Stage::new("strata.wavg.composite", include_str!("wavg_composite.wgsl"))
        .with(LIBRARY)
        .defs(&shader::target_samples(samples))
}

impl Wavg {
    /// The accumulate and composite pipelines for `scene`.
    pub fn new(gpu: &Gpu, scene: &SceneGpu) -> Result<Wavg> {
        let device = &gpu.device;
        let samples = scene.samples;
        let accumulate_layout =
            binding::layout(device, "strata.wavg.accumulate.layout", &[Slot::StorageRw]);
        let accumulate = geometry_pipeline(
            gpu,
            scene,
            (&accumulate_stage(), "fs_wavg"),
            &[&scene.frame_layout, &accumulate_layout],
            &[
                sums(ACCUMULATION_FORMAT),
                revealage(REVEALAGE_FORMAT),
                sums(COUNT_FORMAT),
            ],
            None,
            samples,
        )?;
        let texture = Slot::target(samples);
        let composite_layout = binding::layout(
            device,
            "strata.wavg.composite.layout",
            &[
                Slot::Uniform,
                Slot::StorageRw,
                texture,
                texture,
                texture,
                Slot::StorageRw,
                Slot::StorageRw,
            ],
        );
        let stage = composite_stage(samples);
        let module = stage.module(device);
        let composite = compute_pipeline(
            gpu,
            &stage.label,
            (&module, "cs_composite"),
            &[&scene.frame_layout, &composite_layout],
        );
        Ok(Wavg {
            accumulate_layout,
            accumulate,
            composite_layout,
            composite,
            cache: ResourceCache::default(),
            samples,
        })
    }
}

impl Method for Wavg {
    fn record(&mut self, ctx: &mut FrameContext<'_>) -> Result<Recorded> {
        let gpu = ctx.gpu;
        let bytes =
            ctx.pixels() * (WAVG_SAMPLE_BYTES * self.samples as u64 + WAVG_COUNT_BYTES) + GAP_BYTES;
        ctx.check_budget(bytes)?;
        let [accumulation, revealage, count] = sample_views(
            ctx,
            &mut self.cache,
            self.samples,
            [
                ("strata.wavg.accumulation", ACCUMULATION_FORMAT),
                ("strata.wavg.revealage", REVEALAGE_FORMAT),
                ("strata.wavg.count", COUNT_FORMAT),
            ],
        );
        let counts = pixel_counts(ctx, &mut self.cache, "strata.wavg.counts")?;
        let gap = self
            .cache
            .readable(gpu, "strata.wavg.opacity_gap", GAP_BYTES)?;
        ctx.encoder.clear_buffer(&gap, 0, None);
        let opacity = ctx.options.frame.family::<WeightedOptions>().opacity;
        let params = WavgParams {
            opacity: opacity.index(),
            ..Zeroable::zeroed()
        };
        let params = self
            .cache
            .uniform(gpu, "strata.wavg.params", bytemuck::bytes_of(&params));
        let accumulate_group = binding::group(
            &gpu.device,
            "strata.wavg.accumulate.group",
            &self.accumulate_layout,
            &[counts.as_entire_binding()],
        );
        let frame_group = ctx.frame_group;
        color_geometry_pass(
            ctx,
            "accumulate",
            &self.accumulate,
            &[frame_group, &accumulate_group],
            &[
                (&accumulation, wgpu::Color::TRANSPARENT),
                (&revealage, wgpu::Color::WHITE),
                (&count, wgpu::Color::TRANSPARENT),
            ],
        );
        let composite_group = binding::group(
            &ctx.gpu.device,
            "strata.wavg.composite.group",
            &self.composite_layout,
            &[
                params.as_entire_binding(),
                counts.as_entire_binding(),
                wgpu::BindingResource::TextureView(&accumulation),
                wgpu::BindingResource::TextureView(&revealage),
                wgpu::BindingResource::TextureView(&count),
                ctx.output.as_entire_binding(),
                gap.as_entire_binding(),
            ],
        );
        dispatch_pixels(
            ctx,
            "composite",
            &self.composite,
            &[frame_group, &composite_group],
        );
        ctx.readback.words(&gap, 0, GAP_BYTES / 4);
        Ok(Recorded::passes(1, bytes))
    }

    fn stats(&mut self, _recorded: &Recorded, _totals: &Totals, words: &[u32]) -> MethodStats {
        let (Some(&max), Some(&pixels)) = (words.get(GAP_MAX), words.get(GAP_PIXELS)) else {
            return MethodStats::default();
        };
        let stats = WavgStats {
            opacity_gap_max: f32::from_bits(max),
            opacity_gap_pixels: pixels as u64,
        };
        MethodStats {
            family: Some(FamilyStats::new(stats)),
            ..Default::default()
        }
    }

    fn resources(&self) -> Vec<&ResourceCache> {
        vec![&self.cache]
    }
}
