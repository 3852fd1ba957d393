//! Approximate OIT as engines ship it: `wboit`, weighted blended order-independent transparency
//! (McGuire & Bavoil 2013, JCGT 2(2)), here, `mboit`, moment-based OIT ([`mboit`]), and
//! `stochastic`, stochastic transparency ([`stochastic`]), and `wavg`, the weighted average
//! ([`wavg`]).
//!
//! Passes: accumulate (1 geometry pass into two targets: Rgba16Float Σ w·α·c and Σ w·α with
//! additive blending, R16Float revealage Π(1 − α) by multiplicative blending, and an atomic
//! per-pixel fragment count); composite (compute: the weighted average color times the coverage
//! 1 − Π(1 − α), into the output). The weight w(z, α) is one of the paper's equations 7–10
//! (`--weight`), of the view-space distance times `--depth-scale` (the constants assume 0.1–500
//! units) or, for equation 10, of the window depth. Memory: 8 + 2 + 4 = 14 bytes per pixel (the
//! targets' 10 per sample with `--msaa`).
//!
//! Not exact, by design: the coverage is exact, the color a weighted average that approaches
//! the ordered composite only when the weights fall steeply with depth. Its error against the
//! reference is measured (`strata bench approx-quality`), and its own closed form is tested
//! (`cpu::wboit`). Translucency gets Fresnel opacity but no absorption between surfaces, which
//! needs ordered neighbours; the complexity effect counts every fragment.
//!
//! With `--msaa` the two targets are multisampled: the blend writes each fragment, shaded once,
//! into the samples it covers, and the composite averages the per-sample results — what engines
//! do, and per sample the same closed form.

pub mod cpu;
pub mod descriptor;
pub mod mboit;
pub mod options;
pub mod stochastic;
pub mod wavg;

pub use options::{Moments, Opacity, Weight, WeightedOptions};

use bytemuck::Zeroable;

use crate::gpu::twin::{gpu_struct, wgsl_module};

use crate::error::Result;
use crate::frame::passes::{
    blend_add, color_geometry_pass, color_target, compute_pipeline, dispatch_pixels,
    geometry_pipeline,
};
use crate::frame::{FrameContext, Recorded, SceneGpu};
use crate::gpu::binding::{self, Slot};
use crate::gpu::shader::{self, Library, Stage};
use crate::gpu::{Gpu, ResourceCache};

/// The composite of wboit and (with `MOMENTS`) mboit.
pub(crate) const COMPOSITE_WGSL: &str = include_str!("composite.wgsl");

/// The weighted family's WGSL modules (`strata::weighted::…`).
pub const LIBRARY: Library = &[
    WBOIT_PARAMS_WGSL,
    include_str!("wboit_accumulate.wgsl"),
    COMPOSITE_WGSL,
    mboit::PARAMS_WGSL,
    include_str!("mboit_math.wgsl"),
    include_str!("mboit_moments.wgsl"),
    include_str!("mboit_shade.wgsl"),
    stochastic::PARAMS_WGSL,
    include_str!("stochastic.wgsl"),
    include_str!("stochastic_composite.wgsl"),
    wavg::PARAMS_WGSL,
    wavg::CONSTANTS_WGSL,
    include_str!("wavg_accumulate.wgsl"),
    include_str!("wavg_composite.wgsl"),
];
use crate::methods::Method;

pub(crate) const ACCUMULATION_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba16Float;
pub(crate) const REVEALAGE_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::R16Float;
/// Bytes per pixel and sample of the two targets.
pub const WBOIT_SAMPLE_BYTES: u64 = 8 + 2;
/// Bytes per pixel of the fragment count.
pub const WBOIT_COUNT_BYTES: u64 = 4;

gpu_struct! {
    /// wboit's accumulate uniforms (`strata::weighted::wboit_params`), bound as `wp` by
    /// wboit_accumulate.wgsl.
    pub struct WboitParams {
        /// [`crate::Weight::index`]: which of the paper's weight functions.
        pub weight: u32,
        /// Scales view depth in the weight functions (`--depth-scale`).
        pub depth_scale: f32,
        pad_a: u32,
        pad_b: u32,
    }
}

impl WboitParams {
    /// The accumulate pass's uniforms for `weighted`.
    pub(crate) fn new(weighted: &crate::methods::weighted::WeightedOptions) -> WboitParams {
        WboitParams {
            weight: weighted.weight.index(),
            depth_scale: weighted.depth_scale as f32,
            ..Zeroable::zeroed()
        }
    }
}

/// `strata::weighted::wboit_params`: [`WboitParams`] for wboit_accumulate.wgsl.
pub(crate) const WBOIT_PARAMS_WGSL: &str =
    wgsl_module!("strata::weighted::wboit_params", WboitParams);

/// `wboit`: one geometry pass accumulating weighted colors and revealage, then a composite.
pub struct Wboit {
    accumulate_layout: wgpu::BindGroupLayout,
    accumulate: wgpu::RenderPipeline,
    composite: Composite,
    cache: ResourceCache,
    samples: u32,
}

impl Wboit {
    /// The accumulate and composite pipelines for `scene`.
    pub fn new(gpu: &Gpu, scene: &SceneGpu) -> Result<Wboit> {
        let device = &gpu.device;
        let accumulate_layout = binding::layout(
            device,
            "strata.wboit.accumulate.layout",
            &[Slot::Uniform, Slot::StorageRw],
        );
        let samples = scene.samples;
        let stage = Stage::new(
            "strata.wboit.accumulate",
            include_str!("wboit_accumulate.wgsl"),
        )
        .with(LIBRARY);
        let accumulate = geometry_pipeline(
            gpu,
            scene,
            (&stage, "fs_wboit"),
            &[&scene.frame_layout, &accumulate_layout],
            &[sums(ACCUMULATION_FORMAT), revealage(REVEALAGE_FORMAT)],
            None,
            samples,
        )?;
        Ok(Wboit {
            accumulate_layout,
            accumulate,
            composite: Composite::new(gpu, scene, composite_stage(samples)),
            cache: ResourceCache::default(),
            samples,
        })
    }
}

/// The composite stage, reading multisampled targets with `--msaa`.
pub fn composite_stage(samples: u32) -> Stage {
    Stage::new("strata.wboit.composite", COMPOSITE_WGSL)
        .with(LIBRARY)
        .defs(&shader::target_samples(samples))
}

/// A target that sums what each fragment writes (blend ONE, ONE).
fn sums(format: wgpu::TextureFormat) -> Option<wgpu::ColorTargetState> {
    use wgpu::BlendFactor::One;
    color_target(format, Some(blend_add(One, One)))
}

/// A target that each fragment multiplies by 1 − its value (blend ZERO, ONE_MINUS_SRC): cleared
/// to 1, it holds Π(1 − α).
fn revealage(format: wgpu::TextureFormat) -> Option<wgpu::ColorTargetState> {
    use wgpu::BlendFactor::{OneMinusSrc, Zero};
    color_target(format, Some(blend_add(Zero, OneMinusSrc)))
}

/// Views of this frame's targets (label, format), `samples` per pixel, kept in `cache`:
/// attachments the composite then reads.
fn sample_views<const N: usize>(
    ctx: &FrameContext<'_>,
    cache: &mut ResourceCache,
    samples: u32,
    targets: [(&'static str, wgpu::TextureFormat); N],
) -> [wgpu::TextureView; N] {
    let usage = wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::TEXTURE_BINDING;
    targets.map(|(label, format)| {
        cache
            .texture_samples(ctx.gpu, label, ctx.size(), format, usage, samples)
            .create_view(&Default::default())
    })
}

/// The per-pixel fragment counts of this frame, zeroed: the geometry pass adds to them, the
/// composite reads them.
fn pixel_counts(
    ctx: &mut FrameContext<'_>,
    cache: &mut ResourceCache,
    label: &'static str,
) -> Result<wgpu::Buffer> {
    let counts = cache.storage(ctx.gpu, label, ctx.pixels() * 4)?;
    ctx.encoder.clear_buffer(&counts, 0, None);
    Ok(counts)
}

/// A weighted composite over every pixel (compute): the fragment counts and two accumulation
/// targets (multisampled with `--msaa`) into the frame's output.
struct Composite {
    layout: wgpu::BindGroupLayout,
    pipeline: wgpu::ComputePipeline,
}

impl Composite {
    /// The composite of `stage`'s `cs_composite` for `scene`'s samples, named after the stage.
    fn new(gpu: &Gpu, scene: &SceneGpu, stage: Stage) -> Composite {
        let target = Slot::target(scene.samples);
        let layout = binding::layout(
            &gpu.device,
            &format!("{}.layout", stage.label),
            &[Slot::StorageRw, target, target, Slot::StorageRw],
        );
        let module = stage.module(&gpu.device);
        let pipeline = compute_pipeline(
            gpu,
            &stage.label,
            (&module, "cs_composite"),
            &[&scene.frame_layout, &layout],
        );
        Composite { layout, pipeline }
    }

    /// Records the composite of `counts` and `targets`.
    fn record(
        &self,
        ctx: &mut FrameContext<'_>,
        counts: &wgpu::Buffer,
        targets: [&wgpu::TextureView; 2],
    ) {
        let group = binding::group(
            &ctx.gpu.device,
            "strata.weighted.composite.group",
            &self.layout,
            &[
                counts.as_entire_binding(),
                wgpu::BindingResource::TextureView(targets[0]),
                wgpu::BindingResource::TextureView(targets[1]),
                ctx.output.as_entire_binding(),
            ],
        );
        let frame_group = ctx.frame_group;
        dispatch_pixels(ctx, "composite", &self.pipeline, &[frame_group, &group]);
    }
}

impl Method for Wboit {
    fn record(&mut self, ctx: &mut FrameContext<'_>) -> Result<Recorded> {
        let gpu = ctx.gpu;
        let bytes = ctx.pixels() * (WBOIT_SAMPLE_BYTES * self.samples as u64 + WBOIT_COUNT_BYTES);
        ctx.check_budget(bytes)?;
        let [accumulation, revealage] = sample_views(
            ctx,
            &mut self.cache,
            self.samples,
            [
                ("strata.wboit.accumulation", ACCUMULATION_FORMAT),
                ("strata.wboit.revealage", REVEALAGE_FORMAT),
            ],
        );
        let counts = pixel_counts(ctx, &mut self.cache, "strata.wboit.counts")?;
        let params = WboitParams::new(&ctx.options.frame.family::<WeightedOptions>());
        let params = self
            .cache
            .uniform(gpu, "strata.wboit.params", bytemuck::bytes_of(&params));
        let accumulate_group = binding::group(
            &gpu.device,
            "strata.wboit.accumulate.group",
            &self.accumulate_layout,
            &[params.as_entire_binding(), counts.as_entire_binding()],
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
            ],
        );
        self.composite
            .record(ctx, &counts, [&accumulation, &revealage]);
        Ok(Recorded::passes(1, bytes))
    }

    fn resources(&self) -> Vec<&ResourceCache> {
        vec![&self.cache]
    }
}

/// The family's stages as its methods build them (every moment set, single- and
/// multisampled), for the test that validates every stage.
#[cfg(test)]
pub(crate) fn stages() -> Vec<Stage> {
    use crate::methods::weighted::Moments;
    let mut stages = vec![
        Stage::new("wboit.accumulate", include_str!("wboit_accumulate.wgsl")).with(LIBRARY),
        wavg::accumulate_stage(),
    ];
    for samples in [1, 4] {
        stages.push(composite_stage(samples));
        stages.push(mboit::composite_stage(samples));
        stages.push(wavg::composite_stage(samples));
        let power = [4, 6, 8].map(Moments::Power);
        let trigonometric = [2, 3, 4].map(Moments::Trigonometric);
        let haar = [4, 8].map(Moments::Haar);
        for moments in power.into_iter().chain(trigonometric).chain(haar) {
            stages.push(mboit::moments_stage(samples, moments));
            stages.push(mboit::shade_stage(samples, moments));
        }
    }
    stages
}

#[cfg(test)]
mod tests;
