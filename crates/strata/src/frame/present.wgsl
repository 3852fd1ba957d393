#define_import_path strata::frame::present
#import strata::color::{Resolved, srgb_to_linear}
#import strata::frame::present_params::{PresentParams}

// The present pass: one full-screen triangle that puts each pixel's resolved color over the
// application's color target, in linear space (an sRGB target encodes after blending): the
// target becomes color + transmittance·target. Where every transmittance is grey (no multiply
// material) one draw does it with premultiplied "over" (alpha = 1 − transmittance); else a
// first draw multiplies the target by the RGB transmittance and a second adds the color. The
// complexity effect draws an opaque heatmap instead.

@group(0) @binding(0) var<uniform> params: PresentParams;
@group(0) @binding(1) var<storage, read> resolved: array<Resolved>;
// The crate's heatmap colormap, 256 entries of packed sRGB8 (r | g << 8 | b << 16).
@group(0) @binding(2) var<storage, read> colormap: array<u32>;

fn mean_transmittance(r: Resolved) -> f32 {
    return (r.transmittance.r + r.transmittance.g + r.transmittance.b) / 3.0;
}

fn present_pixel(position: vec4<f32>) -> Resolved {
    let pixel = vec2<u32>(position.xy);
    if pixel.x >= params.size.x || pixel.y >= params.size.y {
        // Nothing in front: the target as it is.
        return Resolved(vec3<f32>(0.0), 0u, vec3<f32>(1.0), 0u);
    }
    return resolved[pixel.y * params.size.x + pixel.x];
}

// The first of two draws: the target times the transmittance (blend: zero, source).
@fragment
fn fs_present_filter(@builtin(position) position: vec4<f32>) -> @location(0) vec4<f32> {
    let r = present_pixel(position);
    return vec4<f32>(r.transmittance, mean_transmittance(r));
}

// The second: plus the color (blend: one, one).
@fragment
fn fs_present_add(@builtin(position) position: vec4<f32>) -> @location(0) vec4<f32> {
    let r = present_pixel(position);
    return vec4<f32>(r.color, 1.0 - mean_transmittance(r));
}

@fragment
fn fs_present(@builtin(position) position: vec4<f32>) -> @location(0) vec4<f32> {
    let pixel = vec2<u32>(position.xy);
    if pixel.x >= params.size.x || pixel.y >= params.size.y {
        discard;
    }
    let r = resolved[pixel.y * params.size.x + pixel.x];
    if params.complexity == 0u {
        return vec4<f32>(r.color, 1.0 - mean_transmittance(r));
    }
    if r.count == 0u {
        return vec4<f32>(0.0, 0.0, 0.0, 1.0);
    }
    // 1..full onto the upper 80% of the colormap, as metrics::colormap::ramp does.
    let t = 0.2 + 0.8 * f32(min(r.count, params.complexity_full)) / f32(max(params.complexity_full, 1u));
    let c = colormap[u32(round(t * 255.0))];
    let rgb = vec3<f32>(f32(c & 255u), f32((c >> 8u) & 255u), f32((c >> 16u) & 255u)) / 255.0;
    return vec4<f32>(srgb_to_linear(rgb.r), srgb_to_linear(rgb.g), srgb_to_linear(rgb.b), 1.0);
}
