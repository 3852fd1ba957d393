#define_import_path strata::kbuffer::mdt
#import strata::scene::{SceneVarying, behind_opaque, scene_fragment, scene_fragment_covering}
#import strata::color::{linear_to_srgb, srgb_to_linear}
#import strata::fragment::{Fragment, fragment_color, fragment_new}
#import strata::kbuffer::storage::{count_pixel_fragment, count_seen, fragment_words, kp, kpixel, pixel_item, sample_pixel, storage_pixels, storage_samples, storage_slots, tail_add}

// Multi-depth-test k-buffers (seed 002's MDTS) with 32-bit keys: each fragment runs an atomicMax
// cascade over its pixel's k keys — the key displaced from a slot carries on to the next — so
// the keys stay sorted with no lock. Keys are stored inverted (0xffffffff − key) so that 0 marks
// an empty slot and atomicMax keeps the nearest.
// kb-mdt32: key = the depth's bits; a second geometry pass finds each fragment's key and writes
//   its color (ties claim equal keys one by one); layout: keys, claims, colors (3 words) per slot.
// kb-mdt-pack: depth mapped to [0.5, 1) so sign and exponent are constant, its top 20 mantissa
//   bits above 12 bits of color in two keys (R6 G6 | B6 A6, sRGB-encoded): two cascades whose
//   slot i belong to the same fragment unless two keys tie in the top 20 bits.

fn slots_in_frame() -> u32 {
    return storage_pixels() * kp.k;
}

// Pixel p's slot i in an array of one word per slot (keys, claims).
fn key_slot(p: u32, i: u32) -> u32 {
    return pixel_item(p, i, kp.k);
}

fn depth_key(depth: f32) -> u32 {
    return 0xffffffffu - bitcast<u32>(depth);
}

fn key_depth(key: u32) -> f32 {
    return bitcast<f32>(0xffffffffu - key);
}

// Cascades `key` through pixel p's keys in the key array that starts at word `array`; returns
// the key displaced past the last slot, 0 when it found a place.
fn cascade(array: u32, p: u32, key_in: u32) -> u32 {
    var key = key_in;
    for (var i = 0u; i < kp.k; i++) {
        let old = atomicMax(&fragment_words[array + key_slot(p, i)], key);
        if old == 0u {
            return 0u;
        }
        key = min(old, key);
    }
    return key;
}

// Filled slots form a prefix: count up to the first empty one.
fn key_count(p: u32) -> u32 {
    var n = 0u;
    while n < kp.k {
        if atomicLoad(&fragment_words[key_slot(p, n)]) == 0u {
            break;
        }
        n += 1u;
    }
    return n;
}

// Culling: the pixel is full and the key is not nearer than its farthest.
fn cascade_culled(p: u32, key: u32) -> bool {
    if kp.culling == 0u {
        return false;
    }
    let last = atomicLoad(&fragment_words[key_slot(p, kp.k - 1u)]);
    return last != 0u && key <= last;
}

// The depth pass: the fragment's key into its pixel's cascade, or with --msaa into each covered
// sample's.
// fs_mdt32_depth's capture step: its made fragment stage and the compute rasterizer call it.
fn fs_mdt32_depth_capture(v: SceneVarying, front_facing: bool, mask: u32) {
    if behind_opaque(v.position) {
        return;
    }
    let pixel = kpixel(v.position);
    count_pixel_fragment(pixel);
    let key = depth_key(v.position.z);
    let samples = storage_samples(mask);
#ifdef MULTISAMPLED
    for (var s = 0u; s < storage_slots(); s++) {
        if ((samples >> s) & 1u) != 0u {
            cascade_at(sample_pixel(pixel, s), key);
        }
    }
#else
    if samples != 0u {
        cascade_at(pixel, key);
    }
#endif
}

// The depth pass for one storage pixel: counts the fragment and cascades its key unless culled.
fn cascade_at(p: u32, key: u32) {
    count_seen(p);
    if !cascade_culled(p, key) {
        cascade(0u, p, key);
    }
}

// The color pass: the fragment claims a slot holding its key in its pixel, or with --msaa in
// each covered sample.
// fs_mdt32_color's capture step: its made fragment stage and the compute rasterizer call it.
fn fs_mdt32_color_capture(v: SceneVarying, front_facing: bool, mask: u32) {
    if behind_opaque(v.position) {
        return;
    }
    let pixel = kpixel(v.position);
    let f = scene_fragment_covering(v, front_facing, mask);
    let samples = storage_samples(mask);
#ifdef MULTISAMPLED
    for (var s = 0u; s < storage_slots(); s++) {
        if ((samples >> s) & 1u) != 0u {
            store_color(sample_pixel(pixel, s), f);
        }
    }
#else
    if samples != 0u {
        store_color(pixel, f);
    }
#endif
}

// Stores `f`'s color and tag in a slot of `p` holding its key that no other fragment claimed;
// else it joins the tail.
fn store_color(p: u32, f: Fragment) {
    let key = depth_key(f.depth);
    let n = slots_in_frame();
    for (var i = 0u; i < kp.k; i++) {
        let slot = key_slot(p, i);
        let stored = atomicLoad(&fragment_words[slot]);
        if stored < key {
            break;
        }
        if stored == key && atomicExchange(&fragment_words[n + slot], 1u) == 0u {
            let c = 2u * n + 3u * slot;
            atomicStore(&fragment_words[c], f.tag);
            atomicStore(&fragment_words[c + 1u], f.rg);
            atomicStore(&fragment_words[c + 2u], f.ba);
            return;
        }
    }
    tail_add(p, f);
}

fn depth20(depth: f32) -> u32 {
    let mapped = min(0.5 + 0.5 * clamp(depth, 0.0, 1.0), bitcast<f32>(0x3f7fffffu));
    return (bitcast<u32>(mapped) & 0x7fffffu) >> 3u;
}

fn depth_of20(top20: u32) -> f32 {
    return (bitcast<f32>(0x3f000000u | (top20 << 3u)) - 0.5) * 2.0;
}

fn six_bits(x: f32) -> u32 {
    return u32(round(clamp(x, 0.0, 1.0) * 63.0));
}

// The two inverted keys of a fragment.
fn pack_keys(depth: f32, color: vec4<f32>) -> vec2<u32> {
    let top = depth20(depth) << 12u;
    let a = top | (six_bits(linear_to_srgb(color.r)) << 6u) | six_bits(linear_to_srgb(color.g));
    let b = top | (six_bits(linear_to_srgb(color.b)) << 6u) | six_bits(color.a);
    return vec2<u32>(0xffffffffu - min(a, 0xfffffffeu), 0xffffffffu - min(b, 0xfffffffeu));
}

fn unpack_keys(inv_a: u32, inv_b: u32) -> Fragment {
    let a = 0xffffffffu - inv_a;
    let b = 0xffffffffu - inv_b;
    let c = vec4<f32>(
        srgb_to_linear(f32((a >> 6u) & 63u) / 63.0),
        srgb_to_linear(f32(a & 63u) / 63.0),
        srgb_to_linear(f32((b >> 6u) & 63u) / 63.0),
        f32(b & 63u) / 63.0,
    );
    return fragment_new(depth_of20(a >> 12u), 0u, false, c);
}

// fs_mdt_pack's capture step: its made fragment stage and the compute rasterizer call it.
fn fs_mdt_pack_capture(v: SceneVarying, front_facing: bool, mask: u32) {
    if behind_opaque(v.position) {
        return;
    }
    let p = kpixel(v.position);
    count_seen(p);
    let f = scene_fragment(v, front_facing);
    let k2 = pack_keys(f.depth, fragment_color(f));
    if cascade_culled(p, k2.x) {
        return;
    }
    cascade(0u, p, k2.x);
    cascade(slots_in_frame(), p, k2.y);
}
