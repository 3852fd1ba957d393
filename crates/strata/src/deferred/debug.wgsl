#define_import_path strata::deferred::debug
#import strata::scene::{frame}
#import strata::color::{srgb_to_linear}
#import strata::composite::{view_distance}
#import strata::deferred::views::{VIEW_ALBEDO, VIEW_DEPTH, VIEW_LIGHTS, VIEW_MATERIAL, VIEW_NORMAL, VIEW_NORMAL_ERROR, VIEW_SPECULAR}
#import strata::deferred::deferred_common::{MAX_EXPONENT, ambient_occlusion, decode_normal, exact_normal, gbuffer_albedo, gbuffer_depth, gbuffer_normal, light_diffuse, light_specular, params}

// G-buffer debug views (seed 004's Figs. 4–6 and 9), written over the lit frame as display
// values (sRGB-decoded so the PNG shows them as they are): albedo; the view-space normal as
// n·0.5 + 0.5; the specular exponent / 128; the material id as a hashed color; the stored depth
// (view distance / far); the light buffers' diffuse + specular; the normal's encoding error in
// degrees in R (the renderer draws it as a heatmap); the ambient occlusion factor.

fn display(c: vec3<f32>) -> vec4<f32> {
    return vec4<f32>(srgb_to_linear(c.r), srgb_to_linear(c.g), srgb_to_linear(c.b), 1.0);
}

@fragment
fn fs_debug(@builtin(position) position: vec4<f32>) -> @location(0) vec4<f32> {
    let pixel = vec2<i32>(position.xy);
    let depth = textureLoad(gbuffer_depth, pixel, 0).r;
    if depth >= 1.0 {
        return vec4<f32>(0.0, 0.0, 0.0, 1.0);
    }
    let a = textureLoad(gbuffer_albedo, pixel, 0);
    let n = textureLoad(gbuffer_normal, pixel, 0);
    switch params.debug_view {
        case VIEW_ALBEDO: {
            return vec4<f32>(a.rgb, 1.0);
        }
        case VIEW_NORMAL: {
            return display(decode_normal(n.xy) * 0.5 + 0.5);
        }
        case VIEW_SPECULAR: {
            return display(vec3<f32>(min(n.z * MAX_EXPONENT / 128.0, 1.0)));
        }
        case VIEW_MATERIAL: {
            let id = u32(round(a.a * 255.0));
            let h = (id + 1u) * 2654435761u;
            return display(vec3<f32>(f32(h & 255u), f32((h >> 8u) & 255u), f32((h >> 16u) & 255u)) / 255.0);
        }
        case VIEW_DEPTH: {
            return display(vec3<f32>(view_distance(depth) / frame.far));
        }
        case VIEW_LIGHTS: {
            return vec4<f32>(textureLoad(light_diffuse, pixel, 0).rgb + textureLoad(light_specular, pixel, 0).rgb, 1.0);
        }
        case VIEW_NORMAL_ERROR: {
            let exact = bitcast<vec3<f32>>(textureLoad(exact_normal, pixel, 0).xyz);
            // 2·asin(|a − b| / 2) keeps small angles accurate in f32, where acos(a·b) does not.
            let chord = length(normalize(exact) - decode_normal(n.xy));
            return vec4<f32>(degrees(2.0 * asin(clamp(chord * 0.5, 0.0, 1.0))), 0.0, 0.0, 1.0);
        }
        default: {
            var occlusion = 1.0;
            if params.ssao != 0u {
                occlusion = textureLoad(ambient_occlusion, pixel, 0).r;
            }
            return display(vec3<f32>(occlusion));
        }
    }
}
