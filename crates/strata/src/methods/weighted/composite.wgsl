#define_import_path strata::weighted::composite
#ifdef UNIFORM_SCENE
#import strata::scene::{samples_per_pixel}
#else
#import strata::scene::{frame, pixel_index, report_pixel, samples_per_pixel}
#endif
#import strata::color::{DownlevelState, Resolved, downlevel_state, resolved_over}
#ifdef MULTISAMPLED
alias TargetTexture = texture_multisampled_2d<f32>;
#else
alias TargetTexture = texture_2d<f32>;
#endif

// The weighted methods' composite: per pixel the weighted average color of its fragments over
// the coverage they have together, premultiplied, with the fragment count; with --msaa (the
// targets then multisampled) each sample's, averaged.
// - wboit: the coverage is 1 − revealage, the blended Π(1 − α).
// - mboit (MOMENTS): transmittance-weighted colors over the exact coverage 1 − exp(−b0) =
//   1 − Π(1 − α).

#ifdef UNIFORM_SCENE
// A downlevel frame's fragment counts: a target the accumulate pass added 1.0 to per fragment.
@group(1) @binding(0) var count_target: texture_2d<f32>;
#else
@group(1) @binding(0) var<storage, read_write> counts: array<u32>;
#endif
#ifdef MOMENTS
@group(1) @binding(1) var b0_target: TargetTexture;
@group(1) @binding(2) var accumulation: TargetTexture;
#else
@group(1) @binding(1) var accumulation: TargetTexture;
@group(1) @binding(2) var revealage: TargetTexture;
#endif
#ifndef UNIFORM_SCENE
@group(1) @binding(3) var<storage, read_write> output: array<Resolved>;
#endif

// Sample `si`'s premultiplied color and coverage (single-sampled `si` is the mip level, 0).
fn sample_color(pixel: vec2<i32>, si: u32) -> vec4<f32> {
#ifdef MOMENTS
    let coverage = 1.0 - exp(-textureLoad(b0_target, pixel, i32(si)).r);
    let sum = textureLoad(accumulation, pixel, i32(si));
    if sum.a > 0.0 {
        return vec4<f32>(sum.rgb / sum.a * coverage, coverage);
    }
    return vec4<f32>(0.0);
#else
    let sum = textureLoad(accumulation, pixel, i32(si));
    let coverage = 1.0 - textureLoad(revealage, pixel, i32(si)).r;
    // The paper clamps the weight sum away from 0 and from f16 overflow.
    let average = sum.rgb / clamp(sum.a, 1e-4, 5e4);
    return vec4<f32>(average * coverage, coverage);
#endif
}

// The pixel's result from its `count` fragments.
fn pixel_resolved(pixel: vec2<i32>, count: u32) -> Resolved {
    let samples = samples_per_pixel();
    var color = vec4<f32>(0.0);
    for (var si = 0u; si < samples; si++) {
        if count == 0u {
            break;
        }
        color += sample_color(pixel, si);
    }
    return resolved_over(color / f32(samples), count);
}

#ifdef UNIFORM_SCENE
// A downlevel frame's composite: a full-screen pass writing the pixel's result into the state
// targets.
@fragment
fn fs_composite(@builtin(position) position: vec4<f32>) -> DownlevelState {
    let pixel = vec2<i32>(position.xy);
    return downlevel_state(pixel_resolved(pixel, u32(round(textureLoad(count_target, pixel, 0).r))));
}
#else
@compute @workgroup_size(8, 8)
fn cs_composite(@builtin(global_invocation_id) id: vec3<u32>) {
    if id.x >= frame.size.x || id.y >= frame.size.y {
        return;
    }
    let i = pixel_index(id.xy);
    let count = counts[i];
    output[i] = pixel_resolved(vec2<i32>(id.xy), count);
    report_pixel(count, count);
}
#endif
