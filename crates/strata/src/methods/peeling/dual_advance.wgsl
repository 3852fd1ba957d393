#define_import_path strata::peeling::dual_advance
#import strata::scene::{frame, pixel_index, report_pixel, report_samples, sample_entry, samples_per_pixel}
#import strata::color::{Resolved, resolved_mean, resolved_sum_add, resolved_sum_new}
#import strata::fragment::{Fragment}
#import strata::composite::{Composite, composite_back, composite_back_new, composite_front, composite_join, composite_new}
#ifdef WIDE_KEYS
#import strata::peeling::dual_key64::{no_max, no_min}
#else
#import strata::peeling::dual_key32::{no_max, no_min}
#endif
#ifdef WIDE_KEYS
alias Key = u64;
#else
alias Key = u32;
#endif

// dual peeling between passes: composites the peeled front layer front-to-back and the back
// layer back-to-front, then makes the next bounds current and counts pixels with layers left.
// With --msaa each of a pixel's S sample entries (`p * S + s`) peels on its own, finish
// averages them and reports the counts after the sample entries of hits (dual_peel.wgsl).

struct Counters {
    pending: atomic<u32>,
    dropped: atomic<u32>,
}

@group(1) @binding(0) var<storage, read_write> bounds: array<Key>;
@group(1) @binding(1) var<storage, read_write> next_bounds: array<Key>;
@group(1) @binding(2) var<storage, read_write> layers: array<Fragment>;
@group(1) @binding(3) var<storage, read_write> hits: array<u32>;
@group(1) @binding(4) var<storage, read_write> front: array<Composite>;
@group(1) @binding(5) var<storage, read_write> back: array<Composite>;
@group(1) @binding(6) var<storage, read_write> counters: Counters;
@group(1) @binding(7) var<storage, read_write> output: array<Resolved>;

// cs_init's pixel step: its made compute stage calls it for each pixel of the frame.
fn cs_init_pixel(pixel: vec2<u32>) {
    let p = pixel_index(pixel);
    for (var s = 0u; s < samples_per_pixel(); s++) {
        let i = sample_entry(p, s);
        front[i] = composite_new();
        back[i] = composite_back_new();
        next_bounds[2u * i] = no_min();
        next_bounds[2u * i + 1u] = no_max();
        hits[3u * i] = 0u;
        hits[3u * i + 1u] = 0u;
        hits[3u * i + 2u] = 0u;
    }
    if frame.coverage_bits != 0u {
        let pixels = frame.size.x * frame.size.y;
        let after = 3u * pixels * samples_per_pixel();
        hits[after + p] = 0u;
        hits[after + pixels + p] = 0u;
    }
}

fn advance_entry(i: u32) {
    let front_hits = hits[3u * i];
    if front_hits > 0u {
        var s = front[i];
        composite_front(&s, layers[2u * i]);
        front[i] = s;
    }
    let back_hits = hits[3u * i + 1u];
    if back_hits > 0u {
        var s = back[i];
        composite_back(&s, layers[2u * i + 1u]);
        back[i] = s;
    }
    let dropped = max(front_hits, 1u) - 1u + max(back_hits, 1u) - 1u;
    if dropped > 0u {
        atomicAdd(&counters.dropped, dropped);
    }
    hits[3u * i] = 0u;
    hits[3u * i + 1u] = 0u;
    let lo = next_bounds[2u * i];
    let hi = next_bounds[2u * i + 1u];
    bounds[2u * i] = lo;
    bounds[2u * i + 1u] = hi;
    next_bounds[2u * i] = no_min();
    next_bounds[2u * i + 1u] = no_max();
    if lo <= hi {
        atomicAdd(&counters.pending, 1u);
    }
}

// cs_advance's pixel step: its made compute stage calls it for each pixel of the frame.
fn cs_advance_pixel(pixel: vec2<u32>) {
    let p = pixel_index(pixel);
    for (var s = 0u; s < samples_per_pixel(); s++) {
        advance_entry(sample_entry(p, s));
    }
}

// cs_finish's pixel step: its made compute stage calls it for each pixel of the frame.
fn cs_finish_pixel(pixel: vec2<u32>) {
    let p = pixel_index(pixel);
    if frame.coverage_bits == 0u {
        let r = composite_join(front[p], back[p]);
        output[p] = r;
        report_pixel(hits[3u * p + 2u], r.count);
        return;
    }
    let samples = samples_per_pixel();
    var sum = resolved_sum_new();
    var deepest = 0u;
    for (var s = 0u; s < samples; s++) {
        let i = p * samples + s;
        resolved_sum_add(&sum, composite_join(front[i], back[i]));
        deepest = max(deepest, hits[3u * i + 2u]);
    }
    let pixels = frame.size.x * frame.size.y;
    let after = 3u * pixels * samples;
    let composited = hits[after + pixels + p];
    output[p] = resolved_mean(sum, samples, composited);
    report_samples(hits[after + p], composited, deepest);
}
