#define_import_path strata::weighted::mboit_shade
#import strata::scene::{SceneVarying, behind_opaque, pixel_of, samples_per_pixel, shade}
#import strata::weighted::mboit_math::{MBOIT_MAX_ALPHA, haar_transmittance, mboit_absorbance, mboit_depth, mboit_transmittance, mboit_transmittance_n, mboit_transmittance_trig}
const MBOIT_MOMENTS: u32 = #{MBOIT_MOMENTS}u;
// Trigonometric moments: their count n (MBOIT_MOMENTS is then 2n, the real values); 0 for power
// moments.
const MBOIT_TRIG: u32 = #{MBOIT_TRIG}u;
// wavelet: its Haar coefficients (MBOIT_MOMENTS too); 0 for moments.
const MBOIT_HAAR: u32 = #{MBOIT_HAAR}u;

// mboit pass 2: every fragment adds its color weighted by α and by the transmittance the moments
// give in front of it, (T·α·c, T·α), into the accumulation target (additive blending). With
// --msaa (the targets then multisampled) T is the mean over the samples the fragment covers of
// each sample's own transmittance: shading stays once per pixel and primitive. With 6 or 8
// moments those past the fourth come from a third target. MBOIT_MOMENTS is the definition of the
// method: each count compiles its own stage, so the generic solver's loops have constant bounds.

// The targets' types are spelled out: a module an application's capture imports takes no
// alias. With four moments moments_high is the moments target again (not read); mboit's
// bounds_target is b0 again (not read), wavelet's the depth range of each sample (fs_bounds).
#ifdef MULTISAMPLED
@group(1) @binding(1) var b0_target: texture_multisampled_2d<f32>;
@group(1) @binding(2) var moments_target: texture_multisampled_2d<f32>;
@group(1) @binding(3) var moments_high: texture_multisampled_2d<f32>;
@group(1) @binding(4) var bounds_target: texture_multisampled_2d<f32>;
#else
@group(1) @binding(1) var b0_target: texture_2d<f32>;
@group(1) @binding(2) var moments_target: texture_2d<f32>;
@group(1) @binding(3) var moments_high: texture_2d<f32>;
@group(1) @binding(4) var bounds_target: texture_2d<f32>;
#endif

// The pixel's depth range, the union of its samples' (as the coefficients pass took it).
fn pixel_bounds(pixel: vec2<i32>) -> vec2<f32> {
    var bounds = vec2<f32>(2.0, -2.0);
    for (var si = 0u; si < samples_per_pixel(); si++) {
        let b = textureLoad(bounds_target, pixel, i32(si));
        bounds = vec2<f32>(min(bounds.x, b.r), max(bounds.y, b.a));
    }
    return bounds;
}

// The transmittance at warped depth z of sample si (the mip level, 0, single-sampled).
// `own` is the fragment's own absorbance, which wavelet takes out of its bin's average.
fn sample_transmittance(pixel: vec2<i32>, si: u32, z: f32, high: bool, own: f32) -> f32 {
    let b0 = textureLoad(b0_target, pixel, i32(si)).r;
    let low = textureLoad(moments_target, pixel, i32(si));
    if !high && MBOIT_TRIG == 0u && MBOIT_HAAR == 0u {
        return mboit_transmittance(b0, low, z);
    }
    var up = vec4<f32>(0.0);
    if high {
        up = textureLoad(moments_high, pixel, i32(si));
    }
    let b = array<f32, 8>(low.x, low.y, low.z, low.w, up.x, up.y, up.z, up.w);
    if MBOIT_TRIG > 0u {
        return mboit_transmittance_trig(b0, b, MBOIT_TRIG, z);
    }
    if MBOIT_HAAR > 0u {
        return haar_transmittance(b0, b, MBOIT_HAAR, z, own, pixel_bounds(pixel));
    }
    return mboit_transmittance_n(b0, b, MBOIT_MOMENTS, z);
}

// The fragment's weighted color: its transmittance averaged over the samples it covers (the one
// sample counts whatever the mask single-sampled).
fn shade_fragment(v: SceneVarying, mask: u32, high: bool) -> vec4<f32> {
    let pixel = vec2<i32>(pixel_of(v.position));
    let z = mboit_depth(v.position.z);
    let samples = samples_per_pixel();
    let covered = select(mask, 1u, samples == 1u);
    let c = shade(v.world, v.normal, v.material);
    let alpha = min(c.a, MBOIT_MAX_ALPHA);
    let own = mboit_absorbance(alpha);
    var t = 0.0;
    var n = 0u;
    for (var si = 0u; si < samples; si++) {
        if (covered & (1u << si)) != 0u {
            t += sample_transmittance(pixel, si, z, high, own);
            n += 1u;
        }
    }
    t /= f32(max(n, 1u));
    return vec4<f32>(c.rgb * alpha * t, alpha * t);
}

struct ShadeOut {
    @location(0) color: vec4<f32>,
}

fn fs_shade_step(v: SceneVarying, front_facing: bool, mask: u32) -> ShadeOut {
    if behind_opaque(v.position) {
        discard;
    }
    return ShadeOut(shade_fragment(v, mask, MBOIT_MOMENTS > 4u));
}
