//! The weighted methods' entries in the method table.

use crate::methods::table::{Descriptor, Family, PixelSite, Setup, Support};
use crate::resolve::RefFragment;

use super::cpu;
use super::options::{WeightedOptions, COEFFICIENTS, MOMENTS, OPACITY, PASSES, WEIGHT};

/// The weighted methods' blend modes.
const SUMS_OF_OVER: Support = Support::No(
    "its order-independent sums model transmittance as a product of (1 - opacity), which only the over operator has",
);
use crate::methods::{Method, MethodId};

type Made = crate::error::Result<Box<dyn Method>>;

// Each entry's builder makes its own method.
fn wboit(_: MethodId, made: &Setup<'_>) -> Made {
    Ok(Box::new(super::Wboit::new(made.gpu, made.scene)?))
}

fn mboit(_: MethodId, made: &Setup<'_>) -> Made {
    Ok(Box::new(super::mboit::Mboit::new(made.gpu, made.scene)?))
}

fn wavelet(_: MethodId, made: &Setup<'_>) -> Made {
    Ok(Box::new(super::mboit::Mboit::wavelet(
        made.gpu, made.scene,
    )?))
}

fn wavg(_: MethodId, made: &Setup<'_>) -> Made {
    Ok(Box::new(super::wavg::Wavg::new(made.gpu, made.scene)?))
}

fn stochastic(_: MethodId, made: &Setup<'_>) -> Made {
    let method = super::stochastic::Stochastic::new(made.gpu, made.scene)?;
    Ok(Box::new(method))
}

// Each entry's closed form (`cpu`): per sample where the composite averages samples.
type Pixel = [f64; 3];

fn wboit_pixel(f: &[RefFragment], at: &PixelSite<'_>) -> Pixel {
    let samples = at.options.build.msaa;
    cpu::per_sample(f, samples, |own| cpu::wboit(own, at.background, at.options))
}

fn mboit_settings(moments: super::Moments) -> cpu::MboitSettings {
    cpu::MboitSettings {
        bias: super::mboit::moment_bias(moments) as f64,
        overestimation: super::mboit::OVERESTIMATION as f64,
        moments,
    }
}

fn moments_pixel(f: &[RefFragment], at: &PixelSite<'_>, moments: super::Moments) -> Pixel {
    let (settings, samples) = (mboit_settings(moments), at.options.build.msaa);
    if samples > 1 {
        cpu::mboit_multisampled(f, at.background, at.camera, settings, samples)
    } else {
        cpu::mboit(f, at.background, at.camera, settings)
    }
}

fn mboit_pixel(f: &[RefFragment], at: &PixelSite<'_>) -> Pixel {
    let moments = at.options.frame.family::<WeightedOptions>().moments;
    moments_pixel(f, at, moments)
}

fn wavelet_pixel(f: &[RefFragment], at: &PixelSite<'_>) -> Pixel {
    let coefficients = at.options.frame.family::<WeightedOptions>().coefficients;
    moments_pixel(f, at, super::Moments::Haar(coefficients))
}

fn stochastic_pixel(f: &[RefFragment], at: &PixelSite<'_>) -> Pixel {
    let passes = at.options.frame.family::<WeightedOptions>().passes;
    let samples = (at.options.build.msaa, passes);
    cpu::stochastic(f, at.index, samples, at.background)
}

fn wavg_pixel(f: &[RefFragment], at: &PixelSite<'_>) -> Pixel {
    let opacity = at.options.frame.family::<WeightedOptions>().opacity;
    let samples = at.options.build.msaa;
    cpu::per_sample(f, samples, |own| cpu::wavg(own, at.background, opacity))
}

/// `wboit`.
pub const WBOIT: Descriptor = Descriptor {
    memory: "(10·S + 4)·W·H; S samples per pixel (--msaa, else 1)",
    summary: "weighted blended OIT (McGuire & Bavoil 2013): weighted average color over exact coverage, weights of eqs. 7-10 (--weight, --depth-scale); what engines ship",
    reads: &[WEIGHT],
    blend_modes: SUMS_OF_OVER,
    downlevel: true,
    app_shaders: Support::Yes,
    closed_form: Some(wboit_pixel),
    ..Descriptor::new(MethodId::Wboit, "wboit", Family::Weighted, wboit)
};

/// `mboit`.
pub const MBOIT: Descriptor = Descriptor {
    needs: wgpu::Features::FLOAT32_BLENDABLE,
    geometry_passes: "2",
    memory: "(28·S + 4)·W·H, +8·S with --moments 6 or trig3, +16·S with 8 or trig4; S samples per pixel (--msaa, else 1)",
    summary: "moment-based OIT (Münstermann et al. 2018): 4, 6 or 8 power moments of absorbance over log depth, or 2, 3 or 4 trigonometric moments of its angle on a circle with a wrapping zone of π/10 (--moments 4|6|8|trig2|trig3|trig4; 32-bit, overestimation 0.25), transmittance reconstructed per fragment; exact coverage",
    reads: &[MOMENTS],
    blend_modes: SUMS_OF_OVER,
    app_shaders: Support::Yes,
    closed_form: Some(mboit_pixel),
    ..Descriptor::new(MethodId::Mboit, "mboit", Family::Weighted, mboit)
};

/// `wavelet`.
pub const WAVELET: Descriptor = Descriptor {
    needs: wgpu::Features::FLOAT32_BLENDABLE,
    geometry_passes: "3",
    memory: "(44·S + 4)·W·H with --coefficients 4, +16·S with 8 (the default); S samples per pixel (--msaa, else 1)",
    summary: "wavelet OIT (after Aizenshtein, Smal & McGuire 2022): each pixel's absorbance over its own depth range (a min/max pass first) as 4 or 8 Haar coefficients (--coefficients; closed form per fragment, additive 32-bit targets), transmittance reconstructed per fragment as its depth bin's average less its own step; exact coverage",
    reads: &[COEFFICIENTS],
    blend_modes: SUMS_OF_OVER,
    app_shaders: Support::Yes,
    closed_form: Some(wavelet_pixel),
    ..Descriptor::new(MethodId::Wavelet, "wavelet", Family::Weighted, wavelet)
};

/// `stochastic`.
pub const STOCHASTIC: Descriptor = Descriptor {
    geometry_passes: "2·P + 1 (P: --passes)",
    memory: "(14·S + 4)·W·H + 256·P; S samples per pixel (--msaa 4|8, required)",
    summary: "stochastic transparency (Enderton et al. 2011) with stratified masks: each fragment stipples about α·S of a pixel's samples with its depth, is accumulated where no stipple lies in front, and the alpha-corrected average is composited; noisy, unbiased, reproducible (--passes for more samples)",
    reads: &[PASSES],
    min_samples: super::stochastic::MIN_SAMPLES,
    blend_modes: SUMS_OF_OVER,
    app_shaders: Support::Yes,
    closed_form: Some(stochastic_pixel),
    ..Descriptor::new(MethodId::Stochastic, "stochastic", Family::Weighted, stochastic)
};

/// `wavg`.
pub const WAVG: Descriptor = Descriptor {
    memory: "(12·S + 4)·W·H + 8; S samples per pixel (--msaa, else 1)",
    summary: "weighted average OIT (Bavoil & Myers 2008): the opacity-weighted average color over the opacity of n fragments of their average opacity ᾱ, 1 − (1 − ᾱ)ⁿ, or the exact 1 − Π(1 − α) (--opacity average|product); every frame reports how far the two lay apart (\"wavg\" statistics)",
    reads: &[OPACITY],
    blend_modes: SUMS_OF_OVER,
    app_shaders: Support::Yes,
    closed_form: Some(wavg_pixel),
    ..Descriptor::new(MethodId::Wavg, "wavg", Family::Weighted, wavg)
};
