#define_import_path strata::convex::merge
#import strata::scene::{frame, pixel_index, report_pixel, report_samples, samples_per_pixel}
#import strata::color::{Resolved, resolved_mean, resolved_sum_add, resolved_sum_new}
#import strata::fragment::{Fragment, fragment_before}
#import strata::composite::{Composite, composite_finish, composite_front, composite_new}
const LAYERS: u32 = #{CONVEX_LAYERS}u;
const MERGE_WORKGROUP: u32 = #{MERGE_WORKGROUP}u;

// convex merge: after each capture pass, every pixel sorts the fragments its pass left (at most
// LAYERS) and composites them behind what earlier passes merged. A pass's nearest fragment in
// front of the last merged one in (depth, primitive) order is an order violation: counted, and
// composited where it arrived (the order could not be kept). init and finish bracket the frame.
// The merge visits only the pixels the pass listed (sample entries with --msaa, capture.wgsl). LAYERS and MERGE_WORKGROUP come from
// the method's definitions (CONVEX_LAYERS, MERGE_WORKGROUP).

@group(1) @binding(0) var<storage, read_write> state: array<Composite>;
@group(1) @binding(1) var<storage, read_write> claims: array<u32>;
@group(1) @binding(2) var<storage, read> slots: array<Fragment>;
// Per pixel: fragments generated over the frame's passes.
@group(1) @binding(3) var<storage, read_write> generated: array<u32>;
// 64-bit counts (low word first): [0, 1] order violations (pixel-passes), [2, 3] pixel-passes
// with fragments past LAYERS.
@group(1) @binding(4) var<storage, read_write> counters: array<atomic<u32>>;
const VIOLATIONS: u32 = 0u;
const OVERFLOWS: u32 = 2u;
@group(1) @binding(5) var<storage, read_write> output: array<Resolved>;
@group(1) @binding(6) var<storage, read> touched: array<u32>;
@group(1) @binding(7) var<storage, read> touched_count: u32;

// cs_init's pixel step: its made compute stage calls it for each pixel of the frame.
fn cs_init_pixel(pixel: vec2<u32>) {
    let p = pixel_index(pixel);
    let samples = samples_per_pixel();
    for (var s = 0u; s < samples; s++) {
        let i = p * samples + s;
        state[i] = composite_new();
        generated[i] = 0u;
        claims[i] = 0u;
    }
    if frame.coverage_bits != 0u {
        let pixels = frame.size.x * frame.size.y;
        claims[pixels * samples + p] = 0u;
        claims[pixels * samples + pixels + p] = 0u;
    }
}

@compute @workgroup_size(MERGE_WORKGROUP)
fn cs_merge(@builtin(global_invocation_id) id: vec3<u32>) {
    // The dispatch stops growing at 65535 workgroups; past that each invocation takes every
    // stride-th listed pixel (at most a few at the largest frames).
    let stride = 65535u * MERGE_WORKGROUP;
    let count = min(touched_count, arrayLength(&touched));
    for (var t = id.x; t < count; t += stride) {
        merge_pixel(touched[t]);
    }
}

// Adds one to the 64-bit count at words (at, at + 1): a frame of many passes over a large,
// multisampled screen can pass 2^32 pixel-passes.
fn count_one(at: u32) {
    if atomicAdd(&counters[at], 1u) == 0xffffffffu {
        atomicAdd(&counters[at + 1u], 1u);
    }
}

fn merge_pixel(i: u32) {
    let claimed = claims[i];
    if claimed == 0u {
        return;
    }
    claims[i] = 0u;
    generated[i] += claimed;
    if claimed > LAYERS {
        count_one(OVERFLOWS);
    }
    let n = min(claimed, LAYERS);
    var f: array<Fragment, LAYERS>;
    for (var a = 0u; a < n; a++) {
        let x = slots[i * LAYERS + a];
        var b = a;
        while b > 0u {
            if !fragment_before(x, f[b - 1u]) {
                break;
            }
            f[b] = f[b - 1u];
            b--;
        }
        f[b] = x;
    }
    var s = state[i];
    let last = Fragment(s.last_depth, s.last_tag, 0u, 0u);
    if s.count > 0u && fragment_before(f[0], last) {
        count_one(VIOLATIONS);
    }
    for (var a = 0u; a < n; a++) {
        composite_front(&s, f[a]);
    }
    state[i] = s;
}

// cs_finish's pixel step: its made compute stage calls it for each pixel of the frame.
fn cs_finish_pixel(pixel: vec2<u32>) {
    let p = pixel_index(pixel);
    if frame.coverage_bits == 0u {
        let s = state[p];
        output[p] = composite_finish(s);
        report_pixel(generated[p], s.count);
        return;
    }
    // --msaa: the samples' average; the pixel's fragments and drops the capture counted.
    let samples = samples_per_pixel();
    let pixels = frame.size.x * frame.size.y;
    var sum = resolved_sum_new();
    var deepest = 0u;
    for (var s = 0u; s < samples; s++) {
        let i = p * samples + s;
        resolved_sum_add(&sum, composite_finish(state[i]));
        deepest = max(deepest, generated[i]);
    }
    let fragments = claims[pixels * samples + p];
    let kept = fragments - min(claims[pixels * samples + pixels + p], fragments);
    output[p] = resolved_mean(sum, samples, kept);
    report_samples(fragments, kept, deepest);
}
