#define_import_path strata::peeling::bucket_common
#import strata::scene::{frame, samples_per_pixel}
#import strata::peeling::bucket_params::{BucketParams}

// Bucket depth peeling's routing and parameters, shared by its passes.
// A pixel's depth range [nearest, farthest] (the bounds pass) is split into equal parts over
// depth in fixed point with 31 fraction bits: exact integer arithmetic, so every pass, and the
// CPU twin (`bucket::select`), routes a depth to the same bucket. Bucket b keeps
// its nearest depth in slot 2b and its farthest in slot 2b + 1; slot s is channel s % 4 of
// layer s / 4 of the bucket targets.


@group(1) @binding(0) var<uniform> params: BucketParams;
// --buckets adaptive: per pixel HISTOGRAM_WORDS words, bit i set when part i of the range holds
// a fragment (written by bucket_histogram.wgsl).
@group(1) @binding(5) var<storage, read> histogram: array<u32>;

// What the bounds and bucket targets are cleared to and what a fragment writes to the
// channels of other buckets: below every −z and z of a window depth, so MAX blending ignores it.
const NO_DEPTH: f32 = -2.0;
// Buckets fit the 32-bit claim word: two slots each.
const MAX_BUCKETS: u32 = 16u;
// The adaptive split's histogram: the range in 1024 equal parts, one bit each.
const SUBINTERVALS: u32 = 1024u;
const HISTOGRAM_WORDS: u32 = 32u;

// With --msaa, S sample entries per pixel, entry p·S + s, each with its own bucket targets'
// samples, claims and records; the routing (bounds, histogram) is the pixel's, over all its
// fragments, so a fragment has one bucket at every sample it covers. Single-sampled S = 1
// (scene's `samples_per_pixel` and `sample_entry`).

// --msaa: the word after the sample entries' claim words counting pixel p's kept fragments.
fn kept_word(p: u32) -> u32 {
    return frame.size.x * frame.size.y * samples_per_pixel() + p;
}

// The samples a fragment covering `mask` reaches (bit 0, the pixel, single-sampled).
fn covered_samples(mask: u32) -> u32 {
    if frame.coverage_bits == 0u {
        return 1u;
    }
    return mask & ((1u << frame.coverage_bits) - 1u);
}

// Window depth in [0, 1] as fixed point: z · 2^31 is exact in f32, and the conversion truncates.
// Clamped, because with --msaa a partly covered pixel's center depth may lie outside [0, 1].
fn depth_fixed(z: f32) -> u32 {
    return u32(clamp(z, 0.0, 1.0) * 2147483648.0);
}

// The bucket of depth `z` in a pixel whose fragments span [nearest, farthest].
fn bucket_of(z: f32, nearest: f32, farthest: f32, buckets: u32) -> u32 {
    let lo = depth_fixed(nearest);
    let hi = max(depth_fixed(farthest), lo);
    let width = (hi - lo) / buckets + 1u;
    return min((max(depth_fixed(z), lo) - lo) / width, buckets - 1u);
}

// The bucket of depth `z` at pixel p. Uniform: its equal part of the range. Adaptive: the rank
// of its part among the occupied parts, spread over the buckets, so parts that hold fragments
// get buckets of their own (when there are at most `buckets` of them) and empty depth costs none.
fn route(z: f32, nearest: f32, farthest: f32, p: u32) -> u32 {
    if params.adaptive == 0u {
        return bucket_of(z, nearest, farthest, params.buckets);
    }
    let part = bucket_of(z, nearest, farthest, SUBINTERVALS);
    let word = part / 32u;
    let base = p * HISTOGRAM_WORDS;
    var below = countOneBits(histogram[base + word] & ((1u << (part % 32u)) - 1u));
    var occupied = countOneBits(histogram[base + word]);
    for (var w = 0u; w < HISTOGRAM_WORDS; w++) {
        if w != word {
            let n = countOneBits(histogram[base + w]);
            occupied += n;
            if w < word {
                below += n;
            }
        }
    }
    return min(below * params.buckets / max(occupied, 1u), params.buckets - 1u);
}
