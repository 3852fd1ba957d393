//! `stochastic`: stochastic transparency (Enderton, Sintorn, Shirley & Luebke 2011, TVCG 17(8))
//! with stratified coverage masks (Laine & Karras 2011, "Stratified sampling for stochastic
//! transparency"), over the S = 4 or 8 samples of a multisampled frame (`--msaa`).
//!
//! Passes, per `--passes P` pass p (seed p): depth (geometry pass: each fragment writes its depth
//! at the pixel center — on every sample, as strata's multisampled methods order fragments — to
//! the samples of its stipple, about α·S of them chosen by a hash of pixel, primitive and
//! pass, into a multisampled Depth32Float with the test LESS: each sample keeps the nearest
//! surface that stippled it) and accumulate (geometry pass: each fragment adds (α·c, α) into a
//! multisampled Rgba16Float at every sample where it is not behind that depth, LESS_EQUAL, no
//! depth write). Then once: total (geometry pass: Π(1 − α) per sample by multiplicative blending
//! into an R16Float, and the per-pixel fragment count) and the composite (compute: the color
//! Σ α·c·v / Σ α·v over the samples and passes, times the coverage 1 − Π(1 − α) averaged over
//! the samples). 2P + 1 geometry passes. Memory: (4 + 8 + 2)·S + 4 bytes per pixel and 256 per
//! pass of parameters.
//!
//! Not exact, by design: v, the fraction of a pixel's samples from which a fragment is seen, is
//! an unbiased estimate of its transmittance (the expected picture is the exact one up to the
//! alpha correction), and the picture is noisy: more samples or passes lower the noise. The
//! stipples are fixed by pixel, primitive and pass, so a frame is reproducible and an animation
//! does not shimmer between still frames. Its own closed form (`cpu::stochastic`, the same hash
//! and stipples in f64) is tested; its error against the reference is measured (`strata bench
//! approx-quality`). Translucency gets Fresnel opacity but no absorption between surfaces.

use bytemuck::Zeroable;

use crate::gpu::twin::{gpu_struct, wgsl_module};

use crate::error::{Error, Result};
use crate::frame::passes::{
    blend_add, color_geometry_pass, color_target, depth_geometry_pass, geometry_pipeline,
};
use crate::frame::{FrameContext, Recorded, SceneGpu};
use crate::gpu::binding::{self, Slot};
use crate::gpu::shader::Stage;
use crate::gpu::{Gpu, ResourceCache};
use crate::methods::weighted::WeightedOptions;
use crate::methods::Method;

use super::LIBRARY;

const DEPTH_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Depth32Float;
const ACCUMULATION_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba16Float;
const TOTAL_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::R16Float;
/// Bytes per pixel and sample: the stochastic depth, the accumulation and the total.
pub const STOCHASTIC_SAMPLE_BYTES: u64 = 4 + 8 + 2;
/// Bytes per pixel of the fragment count.
pub const STOCHASTIC_COUNT_BYTES: u64 = 4;
pub use crate::methods::weighted::options::MAX_STOCHASTIC_PASSES;

gpu_struct! {
    /// A pass's uniforms (`strata::weighted::stochastic_params`).
    pub struct StochasticParams {
        /// This pass's seed: the pass index.
        pub seed: u32,
        /// Samples per pixel.
        pub samples: u32,
        pad_a: u32,
        pad_b: u32,
    }
}

/// The WGSL declaration of [`StochasticParams`].
pub(crate) const PARAMS_WGSL: &str =
    wgsl_module!("strata::weighted::stochastic_params", StochasticParams);

/// `stochastic`: per pass a stipple-depth pass and an accumulate pass, then a total pass and a
/// composite.
pub struct Stochastic {
    pass_layout: wgpu::BindGroupLayout,
    depth: wgpu::RenderPipeline,
    accumulate: wgpu::RenderPipeline,
    total: wgpu::RenderPipeline,
    composite: super::Composite,
    cache: ResourceCache,
    samples: u32,
}

/// The fewest samples a pixel's stipples take (`--msaa 4`).
pub const MIN_SAMPLES: u32 = 4;

/// Refuses a frame that is not multisampled: the stipples are a pixel's samples.
pub fn check_samples(samples: u32) -> Result<()> {
    if samples < MIN_SAMPLES {
        return Err(Error::input(
            "stochastic needs --msaa 4 or 8: its stipples are the samples of a pixel",
        ));
    }
    Ok(())
}

impl Stochastic {
    /// The passes' pipelines for `scene` (multisampled).
    pub fn new(gpu: &Gpu, scene: &SceneGpu) -> Result<Stochastic> {
        let samples = scene.samples;
        check_samples(samples)?;
        let device = &gpu.device;
        let pass_layout = binding::layout(
            device,
            "strata.stochastic.pass.layout",
            &[Slot::Uniform, Slot::StorageRw],
        );
        let stage = Stage::new("strata.stochastic", include_str!("stochastic.wgsl")).with(LIBRARY);
        let layouts = [&scene.frame_layout, &pass_layout];
        let pipeline = |entry: &str, targets: &[Option<wgpu::ColorTargetState>], depth| {
            geometry_pipeline(
                gpu,
                scene,
                (&stage, entry),
                &layouts,
                targets,
                depth,
                samples,
            )
        };
        let depth_test = |compare, write| wgpu::DepthStencilState {
            format: DEPTH_FORMAT,
            depth_write_enabled: Some(write),
            depth_compare: Some(compare),
            stencil: Default::default(),
            bias: Default::default(),
        };
        let blended = |format, src, dst| color_target(format, Some(blend_add(src, dst)));
        use wgpu::BlendFactor::{One, OneMinusSrc, Zero};
        let depth = pipeline(
            "fs_stochastic_depth",
            &[],
            Some(depth_test(wgpu::CompareFunction::Less, true)),
        )?;
        let accumulate = pipeline(
            "fs_stochastic_accumulate",
            &[blended(ACCUMULATION_FORMAT, One, One)],
            Some(depth_test(wgpu::CompareFunction::LessEqual, false)),
        )?;
        let total = pipeline(
            "fs_stochastic_total",
            &[blended(TOTAL_FORMAT, Zero, OneMinusSrc)],
            None,
        )?;
        let composite_stage = Stage::new(
            "strata.stochastic.composite",
            include_str!("stochastic_composite.wgsl"),
        )
        .with(LIBRARY);
        let composite = super::Composite::new(gpu, scene, composite_stage);
        Ok(Stochastic {
            pass_layout,
            depth,
            accumulate,
            total,
            composite,
            cache: ResourceCache::default(),
            samples,
        })
    }
}

impl Method for Stochastic {
    fn record(&mut self, ctx: &mut FrameContext<'_>) -> Result<Recorded> {
        let gpu = ctx.gpu;
        let passes = ctx.options.frame.family::<WeightedOptions>().passes;
        let stride = gpu.limits.min_uniform_buffer_offset_alignment as u64;
        let bytes = ctx.pixels()
            * (STOCHASTIC_SAMPLE_BYTES * self.samples as u64 + STOCHASTIC_COUNT_BYTES)
            + stride * passes as u64;
        ctx.check_budget(bytes)?;
        let (w, h) = ctx.size();
        let samples = self.samples;
        let mut view = |label, format, usage| {
            self.cache
                .texture_samples(gpu, label, (w, h), format, usage, samples)
                .create_view(&Default::default())
        };
        let target = wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::TEXTURE_BINDING;
        let depth = view(
            "strata.stochastic.depth",
            DEPTH_FORMAT,
            wgpu::TextureUsages::RENDER_ATTACHMENT,
        );
        let accumulation = view(
            "strata.stochastic.accumulation",
            ACCUMULATION_FORMAT,
            target,
        );
        let total = view("strata.stochastic.total", TOTAL_FORMAT, target);
        let counts = super::pixel_counts(ctx, &mut self.cache, "strata.stochastic.counts")?;
        // One parameter block per pass, each at an offset uniform bindings may start at.
        let mut blocks = vec![0u8; (stride * passes as u64) as usize];
        for pass in 0..passes {
            let params = StochasticParams {
                seed: pass,
                samples,
                ..Zeroable::zeroed()
            };
            let at = (stride * pass as u64) as usize;
            blocks[at..at + 16].copy_from_slice(bytemuck::bytes_of(&params));
        }
        let params = self.cache.uniform(gpu, "strata.stochastic.params", &blocks);
        let pass_groups: Vec<wgpu::BindGroup> = (0..passes)
            .map(|pass| {
                binding::group(
                    &gpu.device,
                    "strata.stochastic.pass.group",
                    &self.pass_layout,
                    &[
                        wgpu::BindingResource::Buffer(wgpu::BufferBinding {
                            buffer: &params,
                            offset: stride * pass as u64,
                            size: wgpu::BufferSize::new(16),
                        }),
                        counts.as_entire_binding(),
                    ],
                )
            })
            .collect();
        let frame_group = ctx.frame_group;
        for (pass, group) in pass_groups.iter().enumerate() {
            let groups = [frame_group, group];
            depth_geometry_pass(
                ctx,
                "depth",
                (&self.depth, &groups),
                &[],
                (&depth, wgpu::LoadOp::Clear(1.0)),
            );
            // The passes' sums add up: the composite's ratio does not change with their count.
            let load = if pass == 0 {
                wgpu::LoadOp::Clear(wgpu::Color::TRANSPARENT)
            } else {
                wgpu::LoadOp::Load
            };
            depth_geometry_pass(
                ctx,
                "accumulate",
                (&self.accumulate, &groups),
                &[(&accumulation, load)],
                (&depth, wgpu::LoadOp::Load),
            );
        }
        color_geometry_pass(
            ctx,
            "total",
            &self.total,
            &[frame_group, &pass_groups[0]],
            &[(&total, wgpu::Color::WHITE)],
        );
        self.composite.record(ctx, &counts, [&accumulation, &total]);
        Ok(Recorded::passes(2 * passes + 1, bytes))
    }

    fn resources(&self) -> Vec<&ResourceCache> {
        vec![&self.cache]
    }
}
