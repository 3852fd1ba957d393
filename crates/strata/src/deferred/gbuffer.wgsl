#define_import_path strata::deferred::gbuffer
#import strata::scene::{SceneVarying, facing_normal, frame, materials, view_direction}
#import strata::deferred::deferred_common::{MAX_EXPONENT, encode_normal}

// G-buffer pass (seed 004's compressed layout): the opaque surfaces, depth-tested, write albedo
// and material id, the encoded view-space normal with the specular exponent, and depth. Normals
// turn towards the viewer first (two-sided lighting, as `shade`).

struct GbufferOut {
    @location(0) albedo: vec4<f32>,
    @location(1) normal: vec4<f32>,
}

fn gbuffer_normal_of(v: SceneVarying) -> vec3<f32> {
    let n = facing_normal(v.normal, view_direction(v.world));
    return normalize((frame.view * vec4<f32>(n, 0.0)).xyz);
}

fn gbuffer_out(v: SceneVarying) -> GbufferOut {
    let m = materials[v.material];
    var out: GbufferOut;
    out.albedo = vec4<f32>(clamp(m.color, vec3<f32>(0.0), vec3<f32>(1.0)), f32(v.material) / 255.0);
    out.normal = vec4<f32>(encode_normal(gbuffer_normal_of(v)), m.shininess / MAX_EXPONENT, 0.0);
    return out;
}

@fragment
fn fs_gbuffer(v: SceneVarying) -> GbufferOut {
    return gbuffer_out(v);
}

struct GbufferExactOut {
    @location(0) albedo: vec4<f32>,
    @location(1) normal: vec4<f32>,
    @location(2) exact: vec4<u32>,
}

// The same, plus the normal before encoding (the normal-error debug view compares the two), its
// bits in an integer target: 32-bit float targets are not renderable on every backend (GL).
@fragment
fn fs_gbuffer_exact(v: SceneVarying) -> GbufferExactOut {
    let g = gbuffer_out(v);
    return GbufferExactOut(g.albedo, g.normal, bitcast<vec4<u32>>(vec4<f32>(gbuffer_normal_of(v), 0.0)));
}
