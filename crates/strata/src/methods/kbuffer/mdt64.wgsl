#define_import_path strata::kbuffer::mdt64
#import strata::scene::{SceneVarying, behind_opaque, scene_fragment}
#import strata::color::{linear_to_srgb, srgb_to_linear}
#import strata::fragment::{Fragment, fragment_color, fragment_new}
#import strata::kbuffer::storage::{count_seen, fragment_keys, kp, kpixel, pixel_item, tail_add}

// kb-mdt64: one atomicMax cascade on 64-bit keys — inverted depth bits above 32 bits of color
// (sRGB-encoded RGB and alpha, 8 bits each) — so one geometry pass keeps the k nearest with their
// colors (needs SHADER_INT64_ATOMIC_ALL_OPS). 0 marks an empty slot.

fn srgb8(c: f32) -> u32 {
    return u32(round(linear_to_srgb(c) * 255.0));
}

fn linear_of8(v: u32) -> f32 {
    return srgb_to_linear(f32(v) / 255.0);
}

fn key64(f: Fragment) -> u64 {
    let c = fragment_color(f);
    let color = srgb8(c.r) | (srgb8(c.g) << 8u) | (srgb8(c.b) << 16u) | (u32(round(clamp(c.a, 0.0, 1.0) * 255.0)) << 24u);
    return (u64(0xffffffffu - bitcast<u32>(f.depth)) << 32u) | u64(color);
}

fn fragment_of64(key: u64) -> Fragment {
    let color = u32(key & u64(0xffffffffu));
    let c = vec4<f32>(linear_of8(color & 255u), linear_of8((color >> 8u) & 255u), linear_of8((color >> 16u) & 255u), f32(color >> 24u) / 255.0);
    return fragment_new(bitcast<f32>(0xffffffffu - u32(key >> 32u)), 0u, false, c);
}

// fs_mdt64's capture step: its made fragment stage and the compute rasterizer call it.
fn fs_mdt64_capture(v: SceneVarying, front_facing: bool, mask: u32) {
    if behind_opaque(v.position) {
        return;
    }
    let p = kpixel(v.position);
    count_seen(p);
    var key = key64(scene_fragment(v, front_facing));
    if kp.culling != 0u {
        let last = atomicLoad(&fragment_keys[pixel_item(p, kp.k - 1u, kp.k)]);
        if last != u64(0u) && key <= last {
            tail_add(p, fragment_of64(key));
            return;
        }
    }
    for (var i = 0u; i < kp.k; i++) {
        let old = atomicMax(&fragment_keys[pixel_item(p, i, kp.k)], key);
        if old == u64(0u) {
            return;
        }
        key = min(old, key);
    }
    tail_add(p, fragment_of64(key));
}

fn stored_count(p: u32) -> u32 {
    var n = 0u;
    while n < kp.k {
        if atomicLoad(&fragment_keys[pixel_item(p, n, kp.k)]) == u64(0u) {
            break;
        }
        n += 1u;
    }
    return n;
}

fn stored_fragment(p: u32, i: u32) -> Fragment {
    return fragment_of64(atomicLoad(&fragment_keys[pixel_item(p, i, kp.k)]));
}
