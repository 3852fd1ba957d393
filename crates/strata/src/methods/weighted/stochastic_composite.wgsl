#define_import_path strata::weighted::stochastic_composite
#import strata::scene::{frame, pixel_index, report_pixel}
#import strata::color::{Resolved, resolved_over}

// stochastic's composite: per pixel, the color Σ α·c·v / Σ α·v summed over its samples and
// passes, times the coverage 1 − Π(1 − α) averaged over its samples (Enderton et al.'s alpha
// correction), premultiplied, with the fragment count.

@group(1) @binding(0) var<storage, read_write> counts: array<u32>;
@group(1) @binding(1) var accumulation: texture_multisampled_2d<f32>;
@group(1) @binding(2) var total: texture_multisampled_2d<f32>;
@group(1) @binding(3) var<storage, read_write> output: array<Resolved>;

// cs_composite's pixel step: its made compute stage calls it for each pixel of the frame.
fn cs_composite_pixel(pixel: vec2<u32>) {
    let texel = vec2<i32>(pixel);
    let i = pixel_index(pixel);
    let count = counts[i];
    let samples = frame.coverage_bits;
    var sum = vec4<f32>(0.0);
    var transmittance = 0.0;
    for (var s = 0u; s < samples; s++) {
        sum += textureLoad(accumulation, texel, i32(s));
        transmittance += textureLoad(total, texel, i32(s)).r;
    }
    let coverage = 1.0 - transmittance / f32(samples);
    var color = vec3<f32>(0.0);
    if sum.a > 0.0 && count > 0u {
        color = sum.rgb / sum.a * coverage;
    }
    output[i] = resolved_over(vec4<f32>(color, coverage), count);
    report_pixel(count, count);
}
