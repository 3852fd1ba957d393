#define_import_path strata::peeling::f2b_accumulate
#import strata::scene::{covering_tag, frame, pixel_index, report_pixel, report_samples, target_samples}
#import strata::color::{Resolved, resolved_mean, resolved_sum_add, resolved_sum_new}
#import strata::fragment::{Fragment, fragment_new}
#import strata::composite::{Composite, composite_finish, composite_front, composite_new}

// f2b's compute passes: a running composite per pixel (with MULTISAMPLED, per sample);
// accumulate composites the layer just peeled behind it; finish writes the result and the
// pixel's account (single-sampled, the first peel pass counted the fragments; multisampled, the
// account pass did, and finish averages the samples).

#ifdef MULTISAMPLED
alias LayerTexture = texture_multisampled_2d<f32>;
// The tag travels as an exact float (32-bit integer targets cannot be multisampled), the
// depth as itself.
alias TagTexture = texture_multisampled_2d<f32>;
const NO_TAG: f32 = -1.0;
fn depth_of(texel: f32) -> f32 {
    return texel;
}
#else
// Tag and depth travel as 32-bit integers (the depth's bits): 32-bit float targets are not
// renderable on every backend.
alias LayerTexture = texture_2d<f32>;
alias TagTexture = texture_2d<u32>;
const NO_TAG: u32 = 0xffffffffu;
fn depth_of(texel: u32) -> f32 {
    return bitcast<f32>(texel);
}
#endif

@group(1) @binding(0) var<storage, read_write> state: array<Composite>;
@group(1) @binding(1) var layer_color: LayerTexture;
@group(1) @binding(2) var layer_tag: TagTexture;
@group(1) @binding(3) var layer_depth: TagTexture;
@group(1) @binding(4) var<storage, read_write> counts: array<u32>;
@group(1) @binding(5) var<storage, read_write> output: array<Resolved>;

// Sample s of the layer at xy as a fragment, if the layer holds one there.
fn layer_fragment(xy: vec2<i32>, s: u32, f: ptr<function, Fragment>) -> bool {
    let t = textureLoad(layer_tag, xy, i32(s)).r;
    if t == NO_TAG {
        return false;
    }
    let tag = u32(t);
    let front_facing = (tag & 1u) == 1u;
    let c = textureLoad(layer_color, xy, i32(s));
    *f = fragment_new(depth_of(textureLoad(layer_depth, xy, i32(s)).r), tag >> 1u, front_facing, c);
#ifdef MULTISAMPLED
    // The multisampled tag (sample s's bit), which the resolve reads the primitive of.
    (*f).tag = covering_tag(tag >> 1u, front_facing, 1u << s);
#endif
    return true;
}

// cs_init's pixel step: its made compute stage calls it for each pixel of the frame.
fn cs_init_pixel(pixel: vec2<u32>) {
    let p = pixel_index(pixel);
    for (var s = 0u; s < target_samples(); s++) {
        state[p * target_samples() + s] = composite_new();
    }
}

// cs_accumulate's pixel step: its made compute stage calls it for each pixel of the frame.
fn cs_accumulate_pixel(pixel: vec2<u32>) {
    let xy = vec2<i32>(pixel);
    let p = pixel_index(pixel);
    for (var s = 0u; s < target_samples(); s++) {
        var f: Fragment;
        if !layer_fragment(xy, s, &f) {
            continue;
        }
        let i = p * target_samples() + s;
        var composite = state[i];
        composite_front(&composite, f);
        state[i] = composite;
    }
}

// cs_finish's pixel step: its made compute stage calls it for each pixel of the frame.
fn cs_finish_pixel(pixel: vec2<u32>) {
    let p = pixel_index(pixel);
#ifdef MULTISAMPLED
    let pixels = frame.size.x * frame.size.y;
    var sum = resolved_sum_new();
    var deepest = 0u;
    for (var s = 0u; s < target_samples(); s++) {
        resolved_sum_add(&sum, composite_finish(state[p * target_samples() + s]));
        deepest = max(deepest, counts[2u * pixels + p * target_samples() + s]);
    }
    let composited = counts[pixels + p];
    output[p] = resolved_mean(sum, target_samples(), composited);
    report_samples(counts[p], composited, deepest);
#else
    let composite = state[p];
    output[p] = composite_finish(composite);
    report_pixel(counts[p], composite.count);
#endif
}
