#define_import_path strata::weighted::mboit_moments
#import strata::scene::{SceneVarying, behind_opaque, pixel_index, pixel_of, samples_per_pixel, shade}
#import strata::weighted::mboit_math::{c_mul, haar_position, haar_step_coefficient, mboit_absorbance, mboit_depth, trig_angle}

// mboit pass 1: every fragment adds its absorbance a = −ln(1 − α) to b0 and a·(z, z², z³, z⁴) to
// the moments (additive blending into 32-bit float targets), and counts itself; with 6 or 8
// moments a·(z⁵, z⁶[, z⁷, z⁸]) go to a third target. Trigonometric moments store
// a·u^k, u = e^{iφ(z)}, as (re, im) pairs: u and u² in the second target, u³[, u⁴] in the third.
// The definitions pick the stage's moments as in mboit_shade.wgsl: MBOIT_MOMENTS real values
// (4, 6 or 8), trigonometric ones where MBOIT_TRIG > 0, wavelet's Haar coefficients where
// MBOIT_HAAR > 0, power moments else; fs_bounds reads none of them.

@group(1) @binding(1) var<storage, read_write> counts: array<atomic<u32>>;
// wavelet: each sample's nearest (r) and farthest (a) warped depth, from fs_bounds (types
// spelled out: a module an application's capture imports takes no alias).
#ifdef MULTISAMPLED
@group(1) @binding(2) var bounds_target: texture_multisampled_2d<f32>;
#else
@group(1) @binding(2) var bounds_target: texture_2d<f32>;
#endif

// wavelet's first pass: the warped depth as the least (r, blended with MIN) and the greatest
// (a, blended with MAX) of the samples the fragment covers.
struct BoundsOut {
    @location(0) bounds: vec4<f32>,
}

fn fs_bounds_step(v: SceneVarying, front_facing: bool, mask: u32) -> BoundsOut {
    if behind_opaque(v.position) {
        discard;
    }
    let z = mboit_depth(v.position.z);
    return BoundsOut(vec4<f32>(z, 0.0, 0.0, z));
}

// The pixel's depth range: the union of its samples' (a fragment's coefficients are the same in
// every sample it covers, so every sample maps depth alike).
fn pixel_bounds(pixel: vec2<i32>) -> vec2<f32> {
    var bounds = vec2<f32>(2.0, -2.0);
    for (var si = 0; si < i32(samples_per_pixel()); si++) {
        let b = textureLoad(bounds_target, pixel, i32(si));
        bounds = vec2<f32>(min(bounds.x, b.r), max(bounds.y, b.a));
    }
    return bounds;
}

// A fragment's absorbance (x) and a·zᵏ for k = 1..8 (the rest), counting it at its pixel.
struct FragmentMoments {
    a: f32,
    low: vec4<f32>,
    high: vec4<f32>,
}

fn fragment_moments(v: SceneVarying) -> FragmentMoments {
    atomicAdd(&counts[pixel_index(pixel_of(v.position))], 1u);
    let a = mboit_absorbance(shade(v.world, v.normal, v.material).a);
    let z = mboit_depth(v.position.z);
    let z2 = z * z;
    let z4 = z2 * z2;
    let low = vec4<f32>(z, z2, z2 * z, z4);
    return FragmentMoments(a, a * low, a * z4 * low);
}

// A fragment's absorbance and a·u^k (k = 1..4) as (re, im) pairs, counting it at its pixel.
fn fragment_trig_moments(v: SceneVarying) -> FragmentMoments {
    atomicAdd(&counts[pixel_index(pixel_of(v.position))], 1u);
    let a = mboit_absorbance(shade(v.world, v.normal, v.material).a);
    let phi = trig_angle(mboit_depth(v.position.z));
    let u = vec2<f32>(cos(phi), sin(phi));
    let u2 = c_mul(u, u);
    return FragmentMoments(a, a * vec4<f32>(u, u2), a * vec4<f32>(c_mul(u2, u), c_mul(u2, u2)));
}

// A fragment's absorbance and a times the Haar coefficients of the step at its depth (wavelet:
// the first four written with 4 coefficients, all eight with 8), counting it at its pixel.
fn fragment_haar_coefficients(v: SceneVarying) -> FragmentMoments {
    atomicAdd(&counts[pixel_index(pixel_of(v.position))], 1u);
    let a = mboit_absorbance(shade(v.world, v.normal, v.material).a);
    let s = haar_position(mboit_depth(v.position.z), pixel_bounds(vec2<i32>(pixel_of(v.position))));
    var c: array<f32, 8>;
    for (var i = 0u; i < 8u; i++) {
        c[i] = a * haar_step_coefficient(s, i);
    }
    return FragmentMoments(a, vec4<f32>(c[0], c[1], c[2], c[3]), vec4<f32>(c[4], c[5], c[6], c[7]));
}

// The stage's targets: b0, the first four moments, and with 6 or 8 real values a third.
struct MomentsOut {
    @location(0) total_absorbance: vec4<f32>,
    @location(1) moments: vec4<f32>,
#if MBOIT_MOMENTS == 6
    @location(2) high: vec2<f32>,
#else if MBOIT_MOMENTS == 8
    @location(2) high: vec4<f32>,
#endif
}

fn fs_moments_step(v: SceneVarying, front_facing: bool, mask: u32) -> MomentsOut {
    if behind_opaque(v.position) {
        discard;
    }
#if MBOIT_TRIG > 0
    let m = fragment_trig_moments(v);
#else if MBOIT_HAAR > 0
    let m = fragment_haar_coefficients(v);
#else
    let m = fragment_moments(v);
#endif
#if MBOIT_MOMENTS == 6
    return MomentsOut(vec4<f32>(m.a), m.low, m.high.xy);
#else if MBOIT_MOMENTS == 8
    return MomentsOut(vec4<f32>(m.a), m.low, m.high);
#else
    return MomentsOut(vec4<f32>(m.a), m.low);
#endif
}
