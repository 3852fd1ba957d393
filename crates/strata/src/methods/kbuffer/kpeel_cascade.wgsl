#define_import_path strata::kbuffer::kpeel_cascade
#import strata::scene::{SceneVarying, behind_opaque, scene_fragment}
#import strata::fragment::{Fragment}
#import strata::kbuffer::storage::{clearly_behind, count_seen, kp, kpixel, pixel_item, pixel_word, pixels}
#import strata::kbuffer::words::{FILLED}
#import strata::kbuffer::kpeel_state::{peel_pending}
#import strata::kbuffer::slot_access::{store_slot}

// k-depth peeling's lock-free capture, for the compute rasterizer (seed 002's multi-layer peeling
// over MDTS cascades). A keys pass sends each fragment behind the pixel's bound through an
// atomicMax cascade of 64-bit keys — depth bits above the tag, inverted so that 0 marks an empty
// slot and a larger key is a nearer fragment — which keeps the pixel's k nearest sorted with no
// lock; keys are unique per pixel, so nothing is lost or swapped at equal depths. With culling
// on, a binary search of loads skips the slots already nearer than the key. A colors pass
// writes each fragment whose key was kept into the slot holding it and raises FILLED past it; the
// kpeel resolve then composites the slots as it does the locked capture's. The colors pass finds
// a fragment's slot by its tag and takes the depth from the key: it is another pipeline, which
// may round the interpolated depth differently, and a kept key whose fragment missed its slot
// would leave FILLED over a slot this pass never wrote. Only where the rasterizer gives the
// fragment its keys-pass depth again (INVARIANT_DEPTH) does its own key find the slot first,
// by binary search, before the walk by tag.
// Needs SHADER_INT64_ATOMIC_ALL_OPS.

@group(2) @binding(0) var<storage, read_write> peel_keys: array<atomic<u64>>;

fn peel_key(f: Fragment) -> u64 {
    return ~((u64(bitcast<u32>(f.depth)) << 32u) | u64(f.tag));
}

// Pixel p's i-th key.
fn peel_key_word(p: u32, i: u32) -> u32 {
    return pixel_item(p, i, kp.k);
}

// The first of pixel p's k slots whose key is not nearer than `key` (k when all are): as
// kb-keys' search (keys.wgsl), loads in place of the atomics that would leave the nearer slots
// as they are, the pixel's most contended words; the last slot first, which culls most keys of a
// full pixel with one load.
fn first_slot_not_nearer(p: u32, key: u64) -> u32 {
    if atomicLoad(&peel_keys[peel_key_word(p, kp.k - 1u)]) > key {
        return kp.k;
    }
    var low = 0u;
    var high = kp.k - 1u;
    while low < high {
        let middle = (low + high) / 2u;
        if atomicLoad(&peel_keys[peel_key_word(p, middle)]) > key {
            low = middle + 1u;
        } else {
            high = middle;
        }
    }
    return low;
}

// fs_kpeel_keys's capture step: its made fragment stage and the compute rasterizer call it.
fn fs_kpeel_keys_capture(v: SceneVarying, front_facing: bool, mask: u32) {
    if behind_opaque(v.position) {
        return;
    }
    let p = kpixel(v.position);
    let f = scene_fragment(v, front_facing);
    if !peel_pending(p, f) {
        return;
    }
    count_seen(p);
    var key = peel_key(f);
    var first = 0u;
    if kp.culling != 0u {
        first = first_slot_not_nearer(p, key);
    }
    for (var i = first; i < kp.k; i++) {
        let old = atomicMax(&peel_keys[peel_key_word(p, i)], key);
        if old == u64(0u) {
            break;
        }
        key = min(key, old);
    }
}

// Decided by the kept key alone: no opaque test here (another pipeline may round it otherwise,
// and a kept key whose fragment this pass discarded would leave its slot unwritten under FILLED).
// fs_kpeel_colors's capture step: its made fragment stage and the compute rasterizer call it.
fn fs_kpeel_colors_capture(v: SceneVarying, front_facing: bool, mask: u32) {
    let p = kpixel(v.position);
    var f = scene_fragment(v, front_facing);
    // The tag's word of a key, as peel_key writes it.
    let tag_word = ~f.tag;
#ifdef INVARIANT_DEPTH
    // The rasterizer gave the fragment its keys-pass depth again: one clearly behind a full
    // pixel's k-th key was not kept this pass (`clearly_behind`); a kept one finds its own key
    // by the keys pass's binary search (the keys are final), log k loads instead of a walk.
    let key = peel_key(f);
    let slot = first_slot_not_nearer(p, key);
    if slot < kp.k && atomicLoad(&peel_keys[peel_key_word(p, slot)]) == key {
        keep_colors(p, slot, f);
        return;
    }
    let last = atomicLoad(&peel_keys[peel_key_word(p, kp.k - 1u)]);
    if last != u64(0u) && clearly_behind(f.depth, ~u32(last >> 32u)) {
        return;
    }
    // And one clearly in front of the nearest kept key was composited by an earlier pass: a
    // pending fragment that near would have taken the first slot.
    let nearest = atomicLoad(&peel_keys[peel_key_word(p, 0u)]);
    if nearest != u64(0u) && clearly_behind(bitcast<f32>(~u32(nearest >> 32u)), bitcast<u32>(f.depth)) {
        return;
    }
#endif
    for (var i = 0u; i < kp.k; i++) {
        let stored = atomicLoad(&peel_keys[peel_key_word(p, i)]);
        // Kept keys fill the slots from the first: an empty one ends them.
        if stored == u64(0u) {
            break;
        }
        if u32(stored) == tag_word {
            f.depth = bitcast<f32>(~u32(stored >> 32u));
            keep_colors(p, i, f);
            break;
        }
    }
}

// The colors of the fragment whose key slot i keeps, into slot i; FILLED covers it.
fn keep_colors(p: u32, i: u32, f: Fragment) {
    store_slot(p, i, f);
    atomicMax(&pixels[pixel_word(p, FILLED)], i + 1u);
}
