//! `mboit`: moment-based order-independent transparency (Münstermann, Krumpen, Klein, Peters 2018,
//! Proc. ACM CGIT 1(1)), with four power moments in 32-bit floats.
//!
//! Passes: moments (geometry pass: each fragment's absorbance a = −ln(1 − α) into an R32Float b0
//! and a·(z, z², z³, z⁴) into an Rgba32Float, both by additive blending, z the depth warped
//! logarithmically to [−1, 1]; an atomic per-pixel fragment count); shade (geometry pass: each
//! fragment's color times α times the transmittance reconstructed in front of it from the
//! moments, additively into an Rgba16Float); composite (compute: the weighted average color over
//! the exact coverage 1 − exp(−b0)). The reconstruction is the paper's bound for four power
//! moments (a quadratic through the fragment's depth and the two other points of support of the
//! canonical representation) with its settings for 32-bit moments: moment bias β = 5·10⁻⁷ toward
//! the moments (0, 0.375, 0, 0.375), overestimation η = 0.25. Memory: 4 + 16 + 8 + 4 = 32 bytes
//! per pixel. Needs FLOAT32_BLENDABLE (additive blending of 32-bit float targets).
//!
//! With `--msaa 4|8` the three targets are multisampled, and shading stays once per pixel and
//! primitive: the moments pass blends each fragment into the samples it covers, so every sample
//! has its own moments; the shade pass weights the fragment by the mean, over the samples it
//! covers, of each sample's transmittance at its depth (one color per fragment, as engines
//! shade), blended into those samples; the composite resolves each sample and averages them.
//! Memory: (4 + 16 + 8)·S + 4 bytes per pixel for S samples.
//!
//! Not exact, by design: the coverage is exact, the order is estimated. Six, eight or
//! trigonometric moments and the 16-bit quantized variants are not built. Translucency gets Fresnel
//! opacity but no absorption between surfaces.

use bytemuck::{Pod, Zeroable};

use crate::error::{Error, Result};
use crate::frame::{FrameContext, Recorded, SceneGpu};
use crate::gpu::binding::{self, Slot};
use crate::gpu::passes::{
    capture_pipeline_with, color_geometry_pass, compute_pipeline, dispatch_pixels,
};
use crate::gpu::{shader, Gpu, ResourceCache};
use crate::methods::Method;

const B0_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::R32Float;
const MOMENTS_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba32Float;
const ACCUMULATION_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba16Float;
/// Bytes per sample: b0, the four moments and the accumulation.
pub const MBOIT_SAMPLE_BYTES: u64 = 4 + 16 + 8;
/// Bytes per pixel of the fragment count.
pub const MBOIT_COUNT_BYTES: u64 = 4;
/// The paper's moment bias for four power moments in 32-bit floats.
pub const MOMENT_BIAS: f32 = 5e-7;
/// The paper's overestimation.
pub const OVERESTIMATION: f32 = 0.25;

const MATH_WGSL: &str = include_str!("mboit_math.wgsl");

/// Keep in sync with `MboitParams` in mboit_math.wgsl.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub struct MboitParams {
    pub bias: f32,
    pub overestimation: f32,
    pub _pad: [u32; 2],
}

pub struct Mboit {
    moments_layout: wgpu::BindGroupLayout,
    shade_layout: wgpu::BindGroupLayout,
    composite_layout: wgpu::BindGroupLayout,
    moments: wgpu::RenderPipeline,
    shade: wgpu::RenderPipeline,
    composite: wgpu::ComputePipeline,
    cache: ResourceCache,
    samples: u32,
}

fn additive() -> Option<wgpu::BlendState> {
    let add = wgpu::BlendComponent {
        src_factor: wgpu::BlendFactor::One,
        dst_factor: wgpu::BlendFactor::One,
        operation: wgpu::BlendOperation::Add,
    };
    Some(wgpu::BlendState {
        color: add,
        alpha: add,
    })
}

fn target(format: wgpu::TextureFormat) -> Option<wgpu::ColorTargetState> {
    Some(wgpu::ColorTargetState {
        format,
        blend: additive(),
        write_mask: wgpu::ColorWrites::ALL,
    })
}

pub fn moments_source() -> String {
    [MATH_WGSL, include_str!("mboit_moments.wgsl")].join("\n")
}

/// The shade stage, reading multisampled moments with `--msaa`.
pub fn shade_source(samples: u32) -> String {
    shader::multisampled(
        &[MATH_WGSL, include_str!("mboit_shade.wgsl")].join("\n"),
        samples,
    )
}

/// The composite stage, reading multisampled targets with `--msaa`.
pub fn composite_source(samples: u32) -> String {
    shader::multisampled(include_str!("mboit_composite.wgsl"), samples)
}

impl Mboit {
    pub fn new(gpu: &Gpu, scene: &SceneGpu) -> Result<Mboit> {
        if !gpu.has(wgpu::Features::FLOAT32_BLENDABLE) {
            return Err(Error::unsupported(
                "mboit blends 32-bit float moments, and this adapter lacks FLOAT32_BLENDABLE",
            ));
        }
        let device = &gpu.device;
        let samples = scene.samples;
        let texture = if samples > 1 {
            Slot::TextureFloatMultisampled
        } else {
            Slot::TextureFloat
        };
        let moments_layout = binding::layout(
            device,
            "strata.mboit.moments.layout",
            &[Slot::Uniform, Slot::StorageRw],
        );
        let shade_layout = binding::layout(
            device,
            "strata.mboit.shade.layout",
            &[Slot::Uniform, texture, texture],
        );
        let composite_layout = binding::layout(
            device,
            "strata.mboit.composite.layout",
            &[Slot::StorageRw, texture, texture, Slot::StorageRw],
        );
        let module = shader::module(device, "strata.mboit.moments", &moments_source());
        let moments = capture_pipeline_with(
            gpu,
            "strata.mboit.moments",
            (&module, &module),
            "fs_moments",
            &[&scene.frame_layout, &moments_layout],
            &[target(B0_FORMAT), target(MOMENTS_FORMAT)],
            None,
            samples,
        );
        let module = shader::module(device, "strata.mboit.shade", &shade_source(samples));
        let shade = capture_pipeline_with(
            gpu,
            "strata.mboit.shade",
            (&module, &module),
            "fs_shade",
            &[&scene.frame_layout, &shade_layout],
            &[target(ACCUMULATION_FORMAT)],
            None,
            samples,
        );
        let module = shader::module(device, "strata.mboit.composite", &composite_source(samples));
        let composite = compute_pipeline(
            gpu,
            "strata.mboit.composite",
            &module,
            "cs_composite",
            &[&scene.frame_layout, &composite_layout],
        );
        Ok(Mboit {
            moments_layout,
            shade_layout,
            composite_layout,
            moments,
            shade,
            composite,
            cache: ResourceCache::default(),
            samples,
        })
    }
}

impl Method for Mboit {
    fn record(&mut self, ctx: &mut FrameContext<'_>) -> Result<Recorded> {
        let gpu = ctx.gpu;
        let bytes = ctx.pixels() * (MBOIT_SAMPLE_BYTES * self.samples as u64 + MBOIT_COUNT_BYTES);
        ctx.check_budget(bytes)?;
        let (w, h) = ctx.size();
        let usage = wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::TEXTURE_BINDING;
        let samples = self.samples;
        let mut view = |label, format| {
            self.cache
                .texture_samples(gpu, label, (w, h), format, usage, samples)
                .create_view(&Default::default())
        };
        let b0 = view("strata.mboit.b0", B0_FORMAT);
        let moments = view("strata.mboit.moments", MOMENTS_FORMAT);
        let accumulation = view("strata.mboit.accumulation", ACCUMULATION_FORMAT);
        let counts = self.cache.storage(
            gpu,
            "strata.mboit.counts",
            ctx.pixels() * 4,
            wgpu::BufferUsages::empty(),
        )?;
        let params = MboitParams {
            bias: MOMENT_BIAS,
            overestimation: OVERESTIMATION,
            _pad: [0; 2],
        };
        let params = self
            .cache
            .uniform(gpu, "strata.mboit.params", bytemuck::bytes_of(&params));
        let texture = wgpu::BindingResource::TextureView;
        let moments_group = binding::group(
            &gpu.device,
            "strata.mboit.moments.group",
            &self.moments_layout,
            &[params.as_entire_binding(), counts.as_entire_binding()],
        );
        let shade_group = binding::group(
            &gpu.device,
            "strata.mboit.shade.group",
            &self.shade_layout,
            &[params.as_entire_binding(), texture(&b0), texture(&moments)],
        );
        let composite_group = binding::group(
            &gpu.device,
            "strata.mboit.composite.group",
            &self.composite_layout,
            &[
                counts.as_entire_binding(),
                texture(&b0),
                texture(&accumulation),
                ctx.output.as_entire_binding(),
            ],
        );
        ctx.encoder.clear_buffer(&counts, 0, None);
        let zero = wgpu::Color::TRANSPARENT;
        let frame_group = ctx.frame_group;
        color_geometry_pass(
            ctx,
            "moments",
            &self.moments,
            &[frame_group, &moments_group],
            &[(&b0, zero), (&moments, zero)],
        );
        color_geometry_pass(
            ctx,
            "shade",
            &self.shade,
            &[frame_group, &shade_group],
            &[(&accumulation, zero)],
        );
        dispatch_pixels(
            ctx,
            "composite",
            &self.composite,
            &[frame_group, &composite_group],
        );
        Ok(Recorded {
            geometry_passes: 2,
            bytes_allocated: bytes,
            ..Default::default()
        })
    }

    fn resources(&self) -> Vec<&ResourceCache> {
        vec![&self.cache]
    }
}
