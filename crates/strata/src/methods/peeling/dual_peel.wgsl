#define_import_path strata::peeling::dual_peel
#import strata::scene::{SceneVarying, behind_opaque, frame, pixel_index, pixel_of, sample_entry, samples_per_pixel, scene_fragment_covering}
#import strata::fragment::{Fragment}
#ifdef WIDE_KEYS
#import strata::peeling::dual_key64::{fragment_key}
#else
#import strata::peeling::dual_key32::{fragment_key}
#endif

// dual peeling capture passes over keys of 64 bits (WIDE_KEYS: dual_key64.wgsl) or 32
// (dual_key32.wgsl); a composable module cannot name its key type with an alias.
// bounds: nearest and farthest key per pixel. peel: the fragment at the current nearest key
// goes to the front slot, the one at the farthest to the back slot, everything between bounds
// the next pass. hits: per pixel the front and back slots' claims and (third word) every
// fragment of the pixel, counted by the bounds pass.
// With --msaa every sample peels on its own: each array holds S sample entries per pixel
// (`sample_entry`), a fragment (shaded once) takes part at each sample it covers, and after the
// sample entries hits holds per pixel its fragments (bounds pass) and those some sample
// composited (account pass).

#ifdef WIDE_KEYS
@group(1) @binding(0) var<storage, read> bounds: array<u64>;
@group(1) @binding(1) var<storage, read_write> next_bounds: array<atomic<u64>>;
#else
@group(1) @binding(0) var<storage, read> bounds: array<u32>;
@group(1) @binding(1) var<storage, read_write> next_bounds: array<atomic<u32>>;
#endif
@group(1) @binding(2) var<storage, read_write> layers: array<Fragment>;
@group(1) @binding(3) var<storage, read_write> hits: array<atomic<u32>>;

#ifdef WIDE_KEYS
fn widen_next(i: u32, key: u64) {
#else
fn widen_next(i: u32, key: u32) {
#endif
    atomicMin(&next_bounds[2u * i], key);
    atomicMax(&next_bounds[2u * i + 1u], key);
}

#ifdef WIDE_KEYS
fn key_of(v: SceneVarying, front_facing: bool) -> u64 {
#else
fn key_of(v: SceneVarying, front_facing: bool) -> u32 {
#endif
    return fragment_key(v.position.z, (v.prim << 1u) | select(0u, 1u, front_facing));
}

// The samples of a pixel a fragment covering `mask` takes part at: bit s for
// `sample_entry(p, s)`; single-sampled bit 0, the pixel itself.
fn dual_samples(mask: u32) -> u32 {
    if frame.coverage_bits == 0u {
        return 1u;
    }
    return mask & ((1u << frame.coverage_bits) - 1u);
}

// --msaa: the word of hits after the sample entries holding pixel p's `which`-th count (0: its
// fragments, 1: those some sample composited).
fn pixel_count_word(p: u32, which: u32) -> u32 {
    let pixels = frame.size.x * frame.size.y;
    return 3u * pixels * samples_per_pixel() + which * pixels + p;
}

// fs_bounds's capture step: its made fragment stage and the compute rasterizer call it.
fn fs_bounds_capture(v: SceneVarying, front_facing: bool, mask: u32) {
    if behind_opaque(v.position) {
        return;
    }
    let p = pixel_index(pixel_of(v.position));
    let key = key_of(v, front_facing);
    if frame.coverage_bits != 0u {
        atomicAdd(&hits[pixel_count_word(p, 0u)], 1u);
    }
    let samples = dual_samples(mask);
    for (var s = 0u; s < samples_per_pixel(); s++) {
        if ((samples >> s) & 1u) != 0u {
            let i = sample_entry(p, s);
            atomicAdd(&hits[3u * i + 2u], 1u);
            widen_next(i, key);
        }
    }
}

// One fragment at sample entry i: into a slot at its bounds, or widening the next bounds.
#ifdef WIDE_KEYS
fn peel_at(i: u32, key: u64, f: Fragment) {
#else
fn peel_at(i: u32, key: u32, f: Fragment) {
#endif
    let lo = bounds[2u * i];
    let hi = bounds[2u * i + 1u];
    if key < lo || key > hi {
        return;
    }
    var slot = 2u * i;
    var claim = 3u * i;
    if key == hi && key != lo {
        slot += 1u;
        claim += 1u;
    } else if key != lo {
        widen_next(i, key);
        return;
    }
    // Fragments sharing a key (equal depth, 32-bit keys only) share a slot: the first keeps it,
    // the rest are counted.
    if atomicAdd(&hits[claim], 1u) == 0u {
        layers[slot] = f;
    }
}

// fs_peel's capture step: its made fragment stage and the compute rasterizer call it.
fn fs_peel_capture(v: SceneVarying, front_facing: bool, mask: u32) {
    if behind_opaque(v.position) {
        return;
    }
    let p = pixel_index(pixel_of(v.position));
    let key = key_of(v, front_facing);
    // The tag in the multisampled form, which the resolve reads the primitive of.
    let f = scene_fragment_covering(v, front_facing, mask);
    let samples = dual_samples(mask);
    for (var s = 0u; s < samples_per_pixel(); s++) {
        if ((samples >> s) & 1u) != 0u {
            peel_at(sample_entry(p, s), key, f);
        }
    }
}

// --msaa's account after the last pass: a fragment was composited at a sample unless its key
// lies within the sample's remaining bounds (what the last pass left between its slots).
// fs_account's capture step: its made fragment stage and the compute rasterizer call it.
fn fs_account_capture(v: SceneVarying, front_facing: bool, mask: u32) {
    if behind_opaque(v.position) {
        return;
    }
    let p = pixel_index(pixel_of(v.position));
    let key = key_of(v, front_facing);
    let samples = dual_samples(mask);
    var composited = false;
    for (var s = 0u; s < samples_per_pixel(); s++) {
        if ((samples >> s) & 1u) != 0u {
            let i = sample_entry(p, s);
            composited = composited || key < bounds[2u * i] || key > bounds[2u * i + 1u];
        }
    }
    if composited {
        atomicAdd(&hits[pixel_count_word(p, 1u)], 1u);
    }
}
