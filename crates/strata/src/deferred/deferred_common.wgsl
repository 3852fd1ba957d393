#define_import_path strata::deferred::deferred_common
#import strata::deferred::params::{DeferredParams}
#import strata::scene::{frame}

// What every deferred stage shares: the group-1 bindings (each pass's layout names the subset it
// reads, so no pass binds a target it renders to), the normal encodings, and reading a G-buffer
// pixel back into a surface. The encodings' CPU twins are in encoding.rs.

@group(1) @binding(0) var<uniform> params: DeferredParams;
// RGBA8 sRGB: albedo RGB, material id in A (8 bits, so 256 materials).
@group(1) @binding(1) var gbuffer_albedo: texture_2d<f32>;
// RGB10A2: the encoded view-space normal in RG, the specular exponent / 1023 in B.
@group(1) @binding(2) var gbuffer_normal: texture_2d<f32>;
@group(1) @binding(3) var gbuffer_depth: texture_2d<f32>;
// Rgba16Float light buffers the light volumes add into.
@group(1) @binding(4) var light_diffuse: texture_2d<f32>;
@group(1) @binding(5) var light_specular: texture_2d<f32>;
// Ambient occlusion after the blur (R), and before it.
@group(1) @binding(6) var ambient_occlusion: texture_2d<f32>;
@group(1) @binding(7) var ambient_occlusion_raw: texture_2d<f32>;
// Indices into `lights` of the lights that survived frustum culling: sphere volumes, then
// cones, then full-screen lights; a draw's instance index selects one.
@group(1) @binding(8) var<storage, read> visible_lights: array<u32>;
// The unit light-volume meshes as triangle lists (xyz, w unused).
@group(1) @binding(9) var<storage, read> volume_vertices: array<vec4<f32>>;
// Debug only: the view-space normal before encoding (Rgba32Float).
@group(1) @binding(10) var exact_normal: texture_2d<u32>;
// The lit frame (premultiplied, alpha = coverage) the tone map reads.
@group(1) @binding(11) var hdr_color: texture_2d<f32>;

const ENCODING_SPHEREMAP: u32 = 0u;
const MAX_EXPONENT: f32 = 1023.0;

fn encode_normal(n: vec3<f32>) -> vec2<f32> {
    if params.normal_encoding == ENCODING_SPHEREMAP {
        return n.xy / sqrt(max(8.0 * n.z + 8.0, 1e-12)) + 0.5;
    }
    let p = n.xy / (abs(n.x) + abs(n.y) + abs(n.z));
    var folded = p;
    if n.z < 0.0 {
        folded = (1.0 - abs(p.yx)) * select(vec2<f32>(-1.0), vec2<f32>(1.0), p >= vec2<f32>(0.0));
    }
    return folded * 0.5 + 0.5;
}

fn decode_normal(e: vec2<f32>) -> vec3<f32> {
    if params.normal_encoding == ENCODING_SPHEREMAP {
        let fenc = e * 4.0 - 2.0;
        let f = dot(fenc, fenc);
        let g = sqrt(max(1.0 - f / 4.0, 0.0));
        return normalize(vec3<f32>(fenc * g, 1.0 - f / 2.0));
    }
    let f = e * 2.0 - 1.0;
    let z = 1.0 - abs(f.x) - abs(f.y);
    var xy = f;
    if z < 0.0 {
        xy = (1.0 - abs(f.yx)) * select(vec2<f32>(-1.0), vec2<f32>(1.0), f >= vec2<f32>(0.0));
    }
    return normalize(vec3<f32>(xy, z));
}

// World position of the surface at a pixel's center, from its window depth.
fn world_at(pixel: vec2<i32>, depth: f32) -> vec3<f32> {
    let uv = (vec2<f32>(pixel) + 0.5) / vec2<f32>(frame.size);
    let ndc = vec4<f32>(uv.x * 2.0 - 1.0, 1.0 - uv.y * 2.0, depth, 1.0);
    let w = params.inv_view_proj * ndc;
    return w.xyz / w.w;
}

// A view-space direction in world space (the view matrix is a rotation and a translation).
fn view_to_world(n: vec3<f32>) -> vec3<f32> {
    return (vec4<f32>(n, 0.0) * frame.view).xyz;
}

struct Surface {
    world: vec3<f32>,
    // World-space unit normal, facing the viewer.
    normal: vec3<f32>,
    albedo: vec3<f32>,
    material: u32,
    shininess: f32,
}

fn read_surface(pixel: vec2<i32>, depth: f32) -> Surface {
    let a = textureLoad(gbuffer_albedo, pixel, 0);
    let n = textureLoad(gbuffer_normal, pixel, 0);
    var s: Surface;
    s.world = world_at(pixel, depth);
    s.normal = view_to_world(decode_normal(n.xy));
    s.albedo = a.rgb;
    s.material = u32(round(a.a * 255.0));
    s.shininess = max(round(n.z * MAX_EXPONENT), 1.0);
    return s;
}
