#define_import_path strata::deferred::lighting
#import strata::scene::{frame, light_terms, lights, view_direction}
#import strata::deferred::deferred_common::{gbuffer_depth, params, read_surface, visible_lights, volume_vertices}

// Lighting pass: each visible light draws its volume — a sphere for point lights (and spots with
// wide cones), a cone for spots, a full-screen triangle for directional lights and for volumes
// reaching past the far plane. Volumes draw their back faces with depth test GREATER_EQUAL
// against the G-buffer depth: any surface inside a convex volume lies in front of the volume's
// far side, so this covers every lit pixel whether or not the camera is inside. The fragment
// stage adds the light's diffuse and specular (light_terms, the forward formula) into the light
// buffers; outside a light's range its window makes the terms exactly zero.

struct LightVarying {
    @builtin(position) position: vec4<f32>,
    @location(0) @interpolate(flat) light: u32,
}

@vertex
fn vs_sphere_volume(@builtin(vertex_index) vi: u32, @builtin(instance_index) ii: u32) -> LightVarying {
    let index = visible_lights[ii];
    let light = lights[index];
    let p = volume_vertices[vi].xyz * light.range + light.position;
    return LightVarying(frame.view_proj * vec4<f32>(p, 1.0), index);
}

@vertex
fn vs_cone_volume(@builtin(vertex_index) vi: u32, @builtin(instance_index) ii: u32) -> LightVarying {
    let index = visible_lights[ii];
    let light = lights[index];
    let axis = normalize(light.direction);
    var helper = vec3<f32>(0.0, 1.0, 0.0);
    if abs(axis.y) > 0.9 {
        helper = vec3<f32>(1.0, 0.0, 0.0);
    }
    let u = normalize(cross(helper, axis));
    let w = cross(axis, u);
    let local = volume_vertices[params.cone_first + vi].xyz;
    let sin_outer = sqrt(max(1.0 - light.cos_outer * light.cos_outer, 0.0));
    let spread = light.range * sin_outer / max(light.cos_outer, 1e-6);
    let p = light.position + (u * local.x + w * local.y) * spread + axis * (local.z * light.range);
    return LightVarying(frame.view_proj * vec4<f32>(p, 1.0), index);
}

@vertex
fn vs_fullscreen_light(@builtin(vertex_index) vi: u32, @builtin(instance_index) ii: u32) -> LightVarying {
    let uv = vec2<f32>(f32((vi << 1u) & 2u), f32(vi & 2u));
    return LightVarying(vec4<f32>(uv * 2.0 - 1.0, 0.0, 1.0), visible_lights[ii]);
}

struct LightOut {
    @location(0) diffuse: vec4<f32>,
    @location(1) specular: vec4<f32>,
}

@fragment
fn fs_light(v: LightVarying) -> LightOut {
    return light(v);
}

// The same with the volumes' depth test in the shader, for devices that cannot test against a
// depth attachment the pass also reads (wgpu's GL backend has no read-only depth attachment):
// GREATER_EQUAL against the G-buffer depth, on the value the hardware test compares.
@fragment
fn fs_light_tested(v: LightVarying) -> LightOut {
    if v.position.z < textureLoad(gbuffer_depth, vec2<i32>(v.position.xy), 0).r {
        discard;
    }
    return light(v);
}

fn light(v: LightVarying) -> LightOut {
    let pixel = vec2<i32>(v.position.xy);
    let depth = textureLoad(gbuffer_depth, pixel, 0).r;
    if depth >= 1.0 {
        discard;
    }
    let s = read_surface(pixel, depth);
    let t = light_terms(lights[v.light], s.world, s.normal, view_direction(s.world), s.shininess);
    return LightOut(vec4<f32>(t.diffuse, 0.0), vec4<f32>(t.specular, 0.0));
}
