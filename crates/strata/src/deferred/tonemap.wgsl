#define_import_path strata::deferred::tonemap
#import strata::scene::{background_at}
#import strata::deferred::deferred_common::{hdr_color, params}

// Tone map: the lit frame (premultiplied, alpha = coverage) OVER the picture's background, then
// the tone map the options name; the CPU twin is `encoding::tone_map`.

const TONEMAP_NONE: u32 = 0u;
const TONEMAP_NEUTRAL: u32 = 1u;
const NEUTRAL_KNEE: f32 = 0.8;
const NEUTRAL_DESATURATION: f32 = 0.15;

fn tone_map(c: vec3<f32>) -> vec3<f32> {
    if params.tonemap == TONEMAP_NONE {
        return c;
    }
    if params.tonemap != TONEMAP_NEUTRAL {
        return c / (1.0 + c);
    }
    let peak = max(c.r, max(c.g, c.b));
    if peak < NEUTRAL_KNEE {
        return c;
    }
    let d = 1.0 - NEUTRAL_KNEE;
    let new_peak = 1.0 - d * d / (peak + d - NEUTRAL_KNEE);
    let g = 1.0 - 1.0 / (NEUTRAL_DESATURATION * (peak - new_peak) + 1.0);
    let scaled = c * (new_peak / peak);
    return mix(scaled, vec3<f32>(new_peak), g);
}

// The background alone, blended under the HDR image when a multiply material must filter it.
@fragment
fn fs_background(@builtin(position) position: vec4<f32>) -> @location(0) vec4<f32> {
    return vec4<f32>(background_at(vec2<u32>(position.xy)), 1.0);
}

@fragment
fn fs_tonemap(@builtin(position) position: vec4<f32>) -> @location(0) vec4<f32> {
    let pixel = vec2<u32>(position.xy);
    let lit = textureLoad(hdr_color, vec2<i32>(pixel), 0);
    return vec4<f32>(tone_map(lit.rgb + (1.0 - lit.a) * background_at(pixel)), 1.0);
}
