#define_import_path strata::deferred::ssao
#import strata::scene::{frame}
#import strata::composite::{view_distance}
#import strata::deferred::deferred_common::{ambient_occlusion_raw, gbuffer_depth, params, read_surface}

// Screen-space ambient occlusion from the G-buffer: 16 samples in the hemisphere around each
// surface's normal (a fixed kernel, denser near the point, rotated per pixel in a 4×4 pattern),
// each projected to the screen and occluded when the G-buffer surface there lies in front of it
// by more than a small bias, weighted down when that surface is far outside the radius. The
// 4×4 blur then removes the rotation pattern.

const SSAO_SAMPLES: u32 = 16u;
const GOLDEN_ANGLE: f32 = 2.39996323;

fn kernel_sample(i: u32) -> vec3<f32> {
    // Fibonacci points on the hemisphere, pulled towards the center.
    let t = (f32(i) + 0.5) / f32(SSAO_SAMPLES);
    let z = 1.0 - t * 0.9;
    let r = sqrt(1.0 - z * z);
    let phi = GOLDEN_ANGLE * f32(i);
    let scale = mix(0.2, 1.0, t * t);
    return vec3<f32>(r * cos(phi), r * sin(phi), z) * scale;
}

@fragment
fn fs_ssao(@builtin(position) position: vec4<f32>) -> @location(0) vec4<f32> {
    let pixel = vec2<i32>(position.xy);
    let depth = textureLoad(gbuffer_depth, pixel, 0).r;
    if depth >= 1.0 {
        return vec4<f32>(1.0);
    }
    let s = read_surface(pixel, depth);
    let rotation = f32((pixel.x & 3) * 4 + (pixel.y & 3)) * (6.2831853 / 16.0);
    var helper = vec3<f32>(0.0, 1.0, 0.0);
    if abs(s.normal.y) > 0.9 {
        helper = vec3<f32>(1.0, 0.0, 0.0);
    }
    let t0 = normalize(cross(helper, s.normal));
    let b0 = cross(s.normal, t0);
    let tangent = t0 * cos(rotation) + b0 * sin(rotation);
    let bitangent = cross(s.normal, tangent);
    let here = view_distance(depth);
    let bias = 0.02 * params.ssao_radius;
    var occlusion = 0.0;
    for (var i = 0u; i < SSAO_SAMPLES; i++) {
        let k = kernel_sample(i);
        let p = s.world + (tangent * k.x + bitangent * k.y + s.normal * k.z) * params.ssao_radius;
        let clip = frame.view_proj * vec4<f32>(p, 1.0);
        if clip.w <= 0.0 {
            continue;
        }
        let ndc = clip.xyz / clip.w;
        let q = vec2<i32>(floor((vec2<f32>(ndc.x, -ndc.y) * 0.5 + 0.5) * vec2<f32>(frame.size)));
        if any(q < vec2<i32>(0)) || any(q >= vec2<i32>(frame.size)) || ndc.z >= 1.0 {
            continue;
        }
        let scene = view_distance(textureLoad(gbuffer_depth, q, 0).r);
        let sample_distance = view_distance(clamp(ndc.z, 0.0, 1.0));
        if scene < sample_distance - bias {
            occlusion += smoothstep(0.0, 1.0, params.ssao_radius / max(abs(here - scene), 1e-6));
        }
    }
    return vec4<f32>(1.0 - params.ssao_strength * occlusion / f32(SSAO_SAMPLES));
}

@fragment
fn fs_ssao_blur(@builtin(position) position: vec4<f32>) -> @location(0) vec4<f32> {
    let pixel = vec2<i32>(position.xy);
    var sum = 0.0;
    var n = 0.0;
    for (var dy = -2; dy < 2; dy++) {
        for (var dx = -2; dx < 2; dx++) {
            let q = pixel + vec2<i32>(dx, dy);
            if all(q >= vec2<i32>(0)) && all(q < vec2<i32>(frame.size)) {
                sum += textureLoad(ambient_occlusion_raw, q, 0).r;
                n += 1.0;
            }
        }
    }
    return vec4<f32>(sum / max(n, 1.0));
}
