#define_import_path strata::tiled::samples
#import strata::scene::{behind_opaque, frame}
#import strata::composite::{Composite, composite_new}
#import strata::raster::setup::{SetupTriangle, barycentrics_at_point, edge_value, oriented_edges, tile_coverage, tile_coverage_at, wide_negative, wide_zero, window_position}
#import strata::tiled::lists::{COMPOSITE_WORDS, load_composite, pixel_state, state_at, state_float, store_composite, tp}

// --msaa in compute, as the reference samples (`frame::msaa`): a fragment is a (triangle,
// pixel) pair with at least one of the pixel's sample positions inside the triangle (the exact
// top-left rule on the snapped edges) and in front of the far plane; it is shaded, and its depth
// taken, at the pixel center once, and its tag carries the samples it covers
// (`covering_tag`). Every sample composites the fragments covering it in (depth, tag) order —
// its own k nearest with --k, its own tail — and the pixel is the samples' mean.
// The stages are composed with MULTISAMPLED for a multisampled frame; without it, every
// function here reduces to the pixel center's test.

// Sample s's position in subpixels from its pixel's corner (`sample_grid` in Rust).
fn sample_offset(s: u32) -> vec2<i32> {
    let word = select(tp.sample_grid.x, tp.sample_grid.y, s >= 4u);
    let byte = (word >> (8u * (s % 4u))) & 0xffu;
    return vec2<i32>(i32(byte & 15u), i32(byte >> 4u)) * 16;
}

// The pixels of the 8×8 tile `tile` with a sample inside `t`, as `tile_coverage`'s mask (whose
// pixel centers are inside, single-sampled).
fn tile_samples_coverage(t: SetupTriangle, tile: vec2<i32>) -> vec2<u32> {
#ifdef MULTISAMPLED
    var mask = vec2<u32>(0u);
    for (var s = 0u; s < frame.coverage_bits; s++) {
        mask |= tile_coverage_at(t, tile, sample_offset(s));
    }
    return mask;
#else
    return tile_coverage(t, tile);
#endif
}

// The samples of `pixel` inside `t` with their depth in front of the far plane: bit s for
// sample s.
fn pixel_samples(t: SetupTriangle, pixel: vec2<i32>) -> u32 {
    let edges = oriented_edges(t);
    var strict = edges.strict;
    var mask = 0u;
    for (var s = 0u; s < frame.coverage_bits; s++) {
        let point = pixel * 256 + sample_offset(s);
        var inside = true;
        for (var i = 0u; i < 3u; i++) {
            let e = edge_value(edges, i, point);
            if wide_negative(e) || (strict[i] && wide_zero(e)) {
                inside = false;
            }
        }
        if inside && barycentrics_at_point(t, vec2<f32>(point) / 256.0).depth < 1.0 {
            mask |= 1u << s;
        }
    }
    return mask;
}

// The samples a fragment of `t` at `pixel`, its center at `depth`, covers: 0 where it is clipped
// or behind the opaque depth. Single-sampled 1 for a fragment kept (the GPU path clips at the
// far plane and tests the opaque depth with LESS); multisampled, as the reference, the center
// before the far plane and the opaque depth, and the samples `pixel_samples` finds.
fn fragment_samples(t: SetupTriangle, pixel: vec2<i32>, depth: f32) -> u32 {
#ifdef MULTISAMPLED
    if !(depth < 1.0) || behind_opaque(window_position(pixel, depth)) {
        return 0u;
    }
    return pixel_samples(t, pixel);
#else
    return select(1u, 0u, depth > 1.0 || behind_opaque(window_position(pixel, depth)));
#endif
}

// A multisampled pixel's state between rounds: the last fragment a round took in the pixel's
// (depth, tag) order — the next round's bound — the fragments the rounds took, those some
// sample composited, then a composite per sample.
const SAMPLES_BOUND_DEPTH: u32 = 0u;
const SAMPLES_BOUND_TAG: u32 = 1u;
const SAMPLES_TAKEN: u32 = 2u;
const SAMPLES_KEPT: u32 = 3u;
const SAMPLES_COMPOSITES: u32 = 4u;

struct SamplesAccount {
    bound_depth: f32,
    bound_tag: u32,
    taken: u32,
    kept: u32,
}

fn load_account(p: u32) -> SamplesAccount {
    let w = state_at(p);
    return SamplesAccount(state_float(w + SAMPLES_BOUND_DEPTH), pixel_state[w + SAMPLES_BOUND_TAG], pixel_state[w + SAMPLES_TAKEN], pixel_state[w + SAMPLES_KEPT]);
}

fn store_account(p: u32, a: SamplesAccount) {
    let w = state_at(p);
    pixel_state[w + SAMPLES_BOUND_DEPTH] = bitcast<u32>(a.bound_depth);
    pixel_state[w + SAMPLES_BOUND_TAG] = a.bound_tag;
    pixel_state[w + SAMPLES_TAKEN] = a.taken;
    pixel_state[w + SAMPLES_KEPT] = a.kept;
}

fn sample_composite_at(p: u32, s: u32) -> u32 {
    return state_at(p) + SAMPLES_COMPOSITES + s * COMPOSITE_WORDS;
}

// Sample s's composite, new where `fresh` (nothing stored yet).
fn load_sample(p: u32, s: u32, fresh: bool) -> Composite {
    if fresh {
        return composite_new();
    }
    return load_composite(sample_composite_at(p, s));
}

fn store_sample(p: u32, s: u32, c: Composite) {
    store_composite(sample_composite_at(p, s), c);
}

// Fragments sample s of a pixel composited: its composite's count word.
fn sample_count(p: u32, s: u32) -> u32 {
    return pixel_state[sample_composite_at(p, s) + 6u];
}
