//! `mboit`: moment-based order-independent transparency (Münstermann, Krumpen, Klein, Peters 2018,
//! Proc. ACM CGIT 1(1)), with four (default), six or eight power moments in 32-bit floats.
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
//! `--moments 6|8`: six or eight power moments, the ones past the fourth a·(z⁵, z⁶[, z⁷, z⁸]) in
//! a third target (Rg32Float, Rgba32Float), so 8 or 16 more bytes per sample; eight moments need
//! 36 bytes of render targets per sample, over WebGPU's default 32, and are refused with one
//! error line on a device that does not allow them. The reconstruction generalizes the four-moment
//! one: the Hankel system B·c = (1, z, …, zⁿ) solved through L·D·Lᵀ, the n other points of
//! support as the roots of Σ cᵢ·xⁱ (each bracketed between the roots of its derivative and found
//! by Newton's steps that bisection keeps in the bracket, at most 48: bounded, and no cubic or
//! quartic formula to lose precision in f32), the
//! interpolating polynomial through (z, η) and (xᵢ, \[xᵢ < z\]), and its expectation. The bias
//! vectors are the paper's code's for 32-bit moments; the bias amounts for 6 and 8 moments
//! ([`MOMENT_BIAS_6`], [`MOMENT_BIAS_8`]) were measured here, as the smallest that keeps the f32
//! result within 2/255 of the f64 closed form on the tests' scenes.
//!
//! `--moments trig2|trig3|trig4`: n = 2, 3 or 4 trigonometric moments (the paper's section on
//! them, after Peters et al.'s trigonometric moment shadow maps): the warped depth z becomes the
//! angle φ = (z + 1)·(π − θ/2) on the unit circle, leaving a wrapping zone of θ = π/10 between the
//! farthest depth and the nearest; a fragment adds a·e^{ikφ} (k = 1..n) as (re, im) pairs, in the
//! targets 4, 6 or 8 power moments use. The reconstruction at a fragment's angle: the moments
//! biased by β toward the uniform distribution (0 past the zeroth), the Hermitian Toeplitz system
//! B·c = (1, u, …, uⁿ), u = e^{iφ}, solved through L·D·Lᴴ; the other points of support are the
//! roots of Σ conj(c_k)·x^k, which lie on the circle (Aberth's iteration, 24 rounds from points
//! spread over it: bounded); each point gets 1 if its angle is before φ, 0 after, plus a ramp
//! across the wrapping zone (linear in the angle — the published code ramps a pseudo-angle, which
//! is not derived here), the fragment's own point η; their weights come out of the moments
//! through the polynomial that interpolates those values (Newton's divided differences), as for
//! six and eight power moments. The bias values (4·10⁻⁷, 8·10⁻⁷, 1.5·10⁻⁶ for 2, 3, 4) are those
//! a public port of the paper's code lists for 32-bit moments, not checked against the paper,
//! whose tables were not at hand; θ = π/10 and η = 0.25 are the published code's defaults.
//!
//! `wavelet` (its own method, `--coefficients 4|8`) runs these passes over another basis, after a
//! first geometry pass that blends each sample's nearest and farthest warped depth into an
//! Rgba32Float target (MIN into r, MAX into a; 16 bytes per sample): b0 and 4 or 8 Haar
//! coefficients of the absorbance step a·\[x > s\], x the warped depth on the pixel's own range
//! (the union of its samples') mapped to [0, 1) (`haar_*` in mboit_math.wgsl, twin `cpu::haar_*`),
//! in the targets 4 or 8 power moments use; a fragment's transmittance is exp(−A) for the
//! projection A evaluated at its depth — the average of the absorbance over its bin — less its own
//! step. No bias: nothing is solved for. Three geometry passes.
//!
//! Not exact, by design: the coverage is exact, the order is estimated. The 16-bit quantized
//! variants are not built. Translucency gets Fresnel opacity but no
//! absorption between surfaces.

use bytemuck::Zeroable;

use crate::gpu::twin::{gpu_struct, wgsl_module};

use crate::error::{Error, Result};
use crate::frame::passes::{blend_add, color_geometry_pass, color_target, geometry_pipeline};
use crate::frame::{FrameContext, Recorded, SceneGpu};
use crate::gpu::binding::{self, Slot};
use crate::gpu::shader::{self, Stage};
use crate::gpu::{Gpu, ResourceCache};
use crate::methods::weighted::Moments;
use crate::methods::weighted::WeightedOptions;
use crate::methods::Method;

const B0_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::R32Float;
const MOMENTS_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba32Float;
const ACCUMULATION_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba16Float;
/// wavelet's depth range per sample: the nearest in r (MIN blending), the farthest in a (MAX).
const BOUNDS_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba32Float;
/// Bytes per sample of wavelet's depth range.
pub const WAVELET_BOUNDS_BYTES: u64 = 16;
/// Bytes per sample: b0, the four moments and the accumulation.
pub const MBOIT_SAMPLE_BYTES: u64 = 4 + 16 + 8;
/// Bytes per pixel of the fragment count.
pub const MBOIT_COUNT_BYTES: u64 = 4;
/// The paper's moment bias for four power moments in 32-bit floats.
pub const MOMENT_BIAS: f32 = 5e-7;
/// The paper's overestimation.
pub const OVERESTIMATION: f32 = 0.25;

gpu_struct! {
    /// mboit's uniforms (`strata::weighted::mboit_params`), bound as `mp` by mboit_math.wgsl.
    /// The moment count is not among them: it is each stage's own constant (MBOIT_MOMENTS in
    /// the shade stage).
    pub struct MboitParams {
        /// The moment bias β of the paper.
        pub bias: f32,
        /// The overestimation η of the paper.
        pub overestimation: f32,
        pad_a: u32,
        pad_b: u32,
    }
}

/// `strata::weighted::mboit_params`: [`MboitParams`] for mboit_math.wgsl.
pub(crate) const PARAMS_WGSL: &str = wgsl_module!("strata::weighted::mboit_params", MboitParams);

/// The moment bias for 4, 6 and 8 power moments in 32-bit floats: the paper's for four; for six
/// and eight measured here (the paper's tables for them were not at hand) as the smallest that
/// keeps the f32 reconstruction within 2/255 of the f64 one on the tests' scenes — less bias
/// follows the exact picture more closely (in f64 on nvpro at 40², RMSE 0.0160 at 5·10⁻⁷ against
/// 0.0168 at 5·10⁻⁶ for six), and at 5·10⁻⁷ eight moments lost 12 of 1600 pixels to f32 rounding.
pub fn moment_bias(moments: Moments) -> f32 {
    match moments {
        Moments::Power(4) => MOMENT_BIAS,
        Moments::Power(6) => MOMENT_BIAS_6,
        Moments::Power(_) => MOMENT_BIAS_8,
        Moments::Trigonometric(n) => TRIG_MOMENT_BIAS[n as usize - 2],
        // Haar coefficients are evaluated, not solved for: nothing to keep well-conditioned.
        Moments::Haar(_) => 0.0,
    }
}

/// The bias toward the uniform distribution on the circle for 2, 3 and 4 trigonometric moments
/// in 32-bit floats (see the module docs for where they come from).
pub const TRIG_MOMENT_BIAS: [f32; 3] = [4e-7, 8e-7, 1.5e-6];

/// The bias with 6 moments.
pub const MOMENT_BIAS_6: f32 = 5e-7;
/// The bias with 8 moments.
pub const MOMENT_BIAS_8: f32 = 2e-6;

/// The third target's format and bytes per sample for 6 and 8 real moments.
fn high_format(reals: u32) -> (wgpu::TextureFormat, u64) {
    if reals == 6 {
        (wgpu::TextureFormat::Rg32Float, 8)
    } else {
        (wgpu::TextureFormat::Rgba32Float, 16)
    }
}

/// The moments stage of any moments but four power moments (a third target past 4 real values)
/// and their shade stage, made on first use.
struct HighStage {
    moments: Moments,
    pipeline: wgpu::RenderPipeline,
    shade: wgpu::RenderPipeline,
}

/// `mboit`: a pass accumulating moments, a pass weighting each fragment by the transmittance they reconstruct, a composite.
pub struct Mboit {
    moments_layout: wgpu::BindGroupLayout,
    shade_layout: wgpu::BindGroupLayout,
    moments: wgpu::RenderPipeline,
    shade: wgpu::RenderPipeline,
    composite: super::Composite,
    high: Option<HighStage>,
    cache: ResourceCache,
    samples: u32,
    /// `wavelet`: the moments are `--coefficients` Haar coefficients, not `--moments`, over each
    /// pixel's depth range from a first pass.
    wavelet: Option<WaveletStage>,
}

/// wavelet's depth-range pass and the coefficients pass's layout that reads its target.
struct WaveletStage {
    bounds: wgpu::RenderPipeline,
    coefficients_layout: wgpu::BindGroupLayout,
}

/// An additively blended target.
fn target(format: wgpu::TextureFormat) -> Option<wgpu::ColorTargetState> {
    use wgpu::BlendFactor::One;
    color_target(format, Some(blend_add(One, One)))
}

/// The moments pass of `moments` (into b0, the first four reals and, past four, the rest) and
/// its shade pass, over the frame's, the moments' and the shade's bind group `layouts`.
fn passes(
    gpu: &Gpu,
    scene: &SceneGpu,
    [moments_layout, shade_layout]: [&wgpu::BindGroupLayout; 2],
    moments: Moments,
) -> Result<[wgpu::RenderPipeline; 2]> {
    let samples = scene.samples;
    let reals = moments.reals();
    let mut targets = vec![target(B0_FORMAT), target(MOMENTS_FORMAT)];
    if reals > 4 {
        targets.push(target(high_format(reals).0));
    }
    let pass = |stage: Stage, entry, layout, targets: &[_]| {
        let layouts = [&scene.frame_layout, layout];
        geometry_pipeline(
            gpu,
            scene,
            (&stage, entry),
            &layouts,
            targets,
            None,
            samples,
        )
    };
    Ok([
        pass(
            moments_stage(samples, moments),
            "fs_moments",
            moments_layout,
            &targets,
        )?,
        pass(
            shade_stage(samples, moments),
            "fs_shade",
            shade_layout,
            &[target(ACCUMULATION_FORMAT)],
        )?,
    ])
}

/// The definitions of `moments`' stages, reading multisampled targets with `--msaa`:
/// MBOIT_MOMENTS (the real values), MBOIT_TRIG and MBOIT_HAAR (the count of trigonometric
/// moments and of Haar coefficients, 0 for the other kinds).
fn moment_defs(samples: u32, moments: Moments) -> shader::Defs {
    let (trig, haar) = match moments {
        Moments::Trigonometric(n) => (n, 0),
        Moments::Haar(n) => (0, n),
        Moments::Power(_) => (0, 0),
    };
    shader::target_samples(samples)
        .value("MBOIT_MOMENTS", moments.reals())
        .value("MBOIT_TRIG", trig)
        .value("MBOIT_HAAR", haar)
}

/// The accumulation stage of `moments` (`fs_moments`; and wavelet's depth-range pass
/// `fs_bounds`, which any `moments` has), reading multisampled depth ranges with `--msaa`.
pub fn moments_stage(samples: u32, moments: Moments) -> Stage {
    Stage::new("strata.mboit.moments", include_str!("mboit_moments.wgsl"))
        .with(super::LIBRARY)
        .defs(&moment_defs(samples, moments))
}

/// The shade stage for `moments`, reading multisampled moments with `--msaa`.
pub fn shade_stage(samples: u32, moments: Moments) -> Stage {
    Stage::new("strata.mboit.shade", include_str!("mboit_shade.wgsl"))
        .with(super::LIBRARY)
        .defs(&moment_defs(samples, moments))
}

/// The composite stage, reading multisampled targets with `--msaa`.
pub fn composite_stage(samples: u32) -> Stage {
    Stage::new("strata.mboit.composite", super::COMPOSITE_WGSL)
        .with(super::LIBRARY)
        .defs(&shader::target_samples(samples).flag("MOMENTS"))
}

impl Mboit {
    /// The pipelines for `scene` (on a device with FLOAT32_BLENDABLE: its descriptor's
    /// `needs`, which `methods::create` checks).
    pub fn new(gpu: &Gpu, scene: &SceneGpu) -> Result<Mboit> {
        let device = &gpu.device;
        let samples = scene.samples;
        let texture = Slot::target(samples);
        let moments_layout = binding::layout(
            device,
            "strata.mboit.moments.layout",
            &[Slot::Uniform, Slot::StorageRw],
        );
        let shade_layout = binding::layout(
            device,
            "strata.mboit.shade.layout",
            &[Slot::Uniform, texture, texture, texture, texture],
        );
        let [moments, shade] = passes(
            gpu,
            scene,
            [&moments_layout, &shade_layout],
            Moments::Power(4),
        )?;
        let composite = super::Composite::new(gpu, scene, composite_stage(samples));
        Ok(Mboit {
            moments_layout,
            shade_layout,
            moments,
            shade,
            composite,
            high: None,
            cache: ResourceCache::default(),
            samples,
            wavelet: None,
        })
    }

    /// `wavelet`'s pipelines: mboit's passes over Haar coefficients.
    pub fn wavelet(gpu: &Gpu, scene: &SceneGpu) -> Result<Mboit> {
        let samples = scene.samples;
        let texture = Slot::target(samples);
        let coefficients_layout = binding::layout(
            &gpu.device,
            "strata.wavelet.coefficients.layout",
            &[Slot::Uniform, Slot::StorageRw, texture],
        );
        let stage = moments_stage(samples, Moments::Power(4));
        let range = |operation| wgpu::BlendComponent {
            src_factor: wgpu::BlendFactor::One,
            dst_factor: wgpu::BlendFactor::One,
            operation,
        };
        let bounds = geometry_pipeline(
            gpu,
            scene,
            (&stage, "fs_bounds"),
            &[&scene.frame_layout],
            &[Some(wgpu::ColorTargetState {
                format: BOUNDS_FORMAT,
                blend: Some(wgpu::BlendState {
                    color: range(wgpu::BlendOperation::Min),
                    alpha: range(wgpu::BlendOperation::Max),
                }),
                write_mask: wgpu::ColorWrites::ALL,
            })],
            None,
            samples,
        )?;
        Ok(Mboit {
            wavelet: Some(WaveletStage {
                bounds,
                coefficients_layout,
            }),
            ..Mboit::new(gpu, scene)?
        })
    }

    /// The stages of `moments` (any but four power moments), made when first asked for.
    fn high_stage(&mut self, gpu: &Gpu, scene: &SceneGpu, moments: Moments) -> Result<()> {
        if self.high.as_ref().is_some_and(|h| h.moments == moments) {
            return Ok(());
        }
        let reals = moments.reals();
        let bytes = 4 + 16 + if reals > 4 { high_format(reals).1 } else { 0 };
        let allowed = gpu.limits.max_color_attachment_bytes_per_sample;
        if bytes > allowed as u64 {
            let (option, instead) = match moments {
                Moments::Haar(n) => (format!("wavelet --coefficients {n}"), "--coefficients 4"),
                _ => (
                    format!("mboit --moments {moments}"),
                    "--moments 6, trig3 or 4",
                ),
            };
            return Err(Error::unsupported(format!(
                "{option} blends {bytes} bytes per sample, and this device's render targets take {allowed} (max_color_attachment_bytes_per_sample); use {instead}"
            )));
        }
        let moments_layout = match (&self.wavelet, moments) {
            (Some(w), Moments::Haar(_)) => &w.coefficients_layout,
            _ => &self.moments_layout,
        };
        let [pipeline, shade] = passes(gpu, scene, [moments_layout, &self.shade_layout], moments)?;
        self.high = Some(HighStage {
            moments,
            pipeline,
            shade,
        });
        Ok(())
    }
}

impl Method for Mboit {
    fn record(&mut self, ctx: &mut FrameContext<'_>) -> Result<Recorded> {
        let gpu = ctx.gpu;
        let weighted = &ctx.options.frame.family::<WeightedOptions>();
        let moments = if self.wavelet.is_some() {
            Moments::Haar(weighted.coefficients)
        } else {
            weighted.moments
        };
        let reals = moments.reals();
        let high_bytes = if reals > 4 { high_format(reals).1 } else { 0 };
        let bounds_bytes = if self.wavelet.is_some() {
            WAVELET_BOUNDS_BYTES
        } else {
            0
        };
        let sample_bytes = MBOIT_SAMPLE_BYTES + high_bytes + bounds_bytes;
        let bytes = ctx.pixels() * (sample_bytes * self.samples as u64 + MBOIT_COUNT_BYTES);
        ctx.check_budget(bytes)?;
        let high = moments != Moments::Power(4);
        if high {
            self.high_stage(gpu, ctx.scene, moments)?;
        }
        let (w, h) = ctx.size();
        let usage = wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::TEXTURE_BINDING;
        let samples = self.samples;
        let mut view = |label, format| {
            self.cache
                .texture_samples(gpu, label, (w, h), format, usage, samples)
                .create_view(&Default::default())
        };
        let b0 = view("strata.mboit.b0", B0_FORMAT);
        let moments_view = view("strata.mboit.moments", MOMENTS_FORMAT);
        let high_view =
            (reals > 4).then(|| view("strata.mboit.moments_high", high_format(reals).0));
        let accumulation = view("strata.mboit.accumulation", ACCUMULATION_FORMAT);
        let bounds_view = self
            .wavelet
            .is_some()
            .then(|| view("strata.wavelet.bounds", BOUNDS_FORMAT));
        let counts = super::pixel_counts(ctx, &mut self.cache, "strata.mboit.counts")?;
        let params = MboitParams {
            bias: moment_bias(moments),
            overestimation: OVERESTIMATION,
            ..Zeroable::zeroed()
        };
        let params = self
            .cache
            .uniform(gpu, "strata.mboit.params", bytemuck::bytes_of(&params));
        let texture = wgpu::BindingResource::TextureView;
        let moments_group = match (&self.wavelet, &bounds_view) {
            (Some(w), Some(bounds)) => binding::group(
                &gpu.device,
                "strata.wavelet.coefficients.group",
                &w.coefficients_layout,
                &[
                    params.as_entire_binding(),
                    counts.as_entire_binding(),
                    texture(bounds),
                ],
            ),
            _ => binding::group(
                &gpu.device,
                "strata.mboit.moments.group",
                &self.moments_layout,
                &[params.as_entire_binding(), counts.as_entire_binding()],
            ),
        };
        let (moments_pipeline, shade_pipeline) = match (&self.high, high) {
            (Some(high), true) => (&high.pipeline, &high.shade),
            _ => (&self.moments, &self.shade),
        };
        let shade_group = binding::group(
            &gpu.device,
            "strata.mboit.shade.group",
            &self.shade_layout,
            &[
                params.as_entire_binding(),
                texture(&b0),
                texture(&moments_view),
                texture(high_view.as_ref().unwrap_or(&moments_view)),
                texture(bounds_view.as_ref().unwrap_or(&b0)),
            ],
        );
        let zero = wgpu::Color::TRANSPARENT;
        let frame_group = ctx.frame_group;
        let mut passes = 2;
        if let (Some(w), Some(bounds)) = (&self.wavelet, &bounds_view) {
            // Warped depths lie in [−1, 1]: 2 and −2 are past every fragment's.
            let empty = wgpu::Color {
                r: 2.0,
                g: 0.0,
                b: 0.0,
                a: -2.0,
            };
            color_geometry_pass(ctx, "bounds", &w.bounds, &[frame_group], &[(bounds, empty)]);
            passes = 3;
        }
        let mut targets = vec![(&b0, zero), (&moments_view, zero)];
        if let Some(high_view) = &high_view {
            targets.push((high_view, zero));
        }
        color_geometry_pass(
            ctx,
            "moments",
            moments_pipeline,
            &[frame_group, &moments_group],
            &targets,
        );
        color_geometry_pass(
            ctx,
            "shade",
            shade_pipeline,
            &[frame_group, &shade_group],
            &[(&accumulation, zero)],
        );
        self.composite.record(ctx, &counts, [&b0, &accumulation]);
        Ok(Recorded::passes(passes, bytes))
    }

    fn resources(&self) -> Vec<&ResourceCache> {
        vec![&self.cache]
    }
}
