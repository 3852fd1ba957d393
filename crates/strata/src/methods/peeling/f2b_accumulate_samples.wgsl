#define_import_path strata::peeling::f2b_accumulate_samples
#import strata::scene::{covering_tag, frame, pixel_index, report_samples}
#import strata::color::{Resolved, resolved_mean, resolved_sum_add, resolved_sum_new}
#import strata::fragment::{fragment_new}
#import strata::composite::{Composite, composite_finish, composite_front, composite_new}

// f2b's compute passes with --msaa: a running composite per sample; accumulate composites each
// sample's layer behind it; finish averages the samples and reports the account pass's counts.

const NO_TAG: f32 = -1.0;

@group(1) @binding(0) var<storage, read_write> state: array<Composite>;
@group(1) @binding(1) var layer_color: texture_multisampled_2d<f32>;
@group(1) @binding(2) var layer_tag: texture_multisampled_2d<f32>;
@group(1) @binding(3) var layer_depth: texture_multisampled_2d<f32>;
@group(1) @binding(4) var<storage, read_write> counts: array<u32>;
@group(1) @binding(5) var<storage, read_write> output: array<Resolved>;

@compute @workgroup_size(8, 8)
fn cs_init(@builtin(global_invocation_id) id: vec3<u32>) {
    if id.x >= frame.size.x || id.y >= frame.size.y {
        return;
    }
    let p = pixel_index(id.xy);
    for (var s = 0u; s < frame.coverage_bits; s++) {
        state[p * frame.coverage_bits + s] = composite_new();
    }
}

@compute @workgroup_size(8, 8)
fn cs_accumulate(@builtin(global_invocation_id) id: vec3<u32>) {
    if id.x >= frame.size.x || id.y >= frame.size.y {
        return;
    }
    let xy = vec2<i32>(id.xy);
    let p = pixel_index(id.xy);
    for (var s = 0u; s < frame.coverage_bits; s++) {
        let t = textureLoad(layer_tag, xy, i32(s)).r;
        if t == NO_TAG {
            continue;
        }
        let tag = u32(t);
        let c = textureLoad(layer_color, xy, i32(s));
        let front_facing = (tag & 1u) == 1u;
        var f = fragment_new(textureLoad(layer_depth, xy, i32(s)).r, tag >> 1u, front_facing, c);
        // The multisampled tag (sample s's bit), which the resolve reads the primitive of.
        f.tag = covering_tag(tag >> 1u, front_facing, 1u << s);
        let i = p * frame.coverage_bits + s;
        var st = state[i];
        composite_front(&st, f);
        state[i] = st;
    }
}

@compute @workgroup_size(8, 8)
fn cs_finish(@builtin(global_invocation_id) id: vec3<u32>) {
    if id.x >= frame.size.x || id.y >= frame.size.y {
        return;
    }
    let samples = frame.coverage_bits;
    let pixels = frame.size.x * frame.size.y;
    let p = pixel_index(id.xy);
    var sum = resolved_sum_new();
    var deepest = 0u;
    for (var s = 0u; s < samples; s++) {
        resolved_sum_add(&sum, composite_finish(state[p * samples + s]));
        deepest = max(deepest, counts[2u * pixels + p * samples + s]);
    }
    let composited = counts[pixels + p];
    output[p] = resolved_mean(sum, samples, composited);
    report_samples(counts[p], composited, deepest);
}
