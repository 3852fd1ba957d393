#define_import_path strata::animation::animate_objects
#import strata::dispatch::{GridThread}
#import strata::animation::animate_common::{params, thread_index}
#import strata::animation::params::{GpuMotion}

// One thread per object: its transform at this frame's time, and the transform that carries a
// point of the object from where it is now to where it was in the previous frame (temporal
// culling reprojects with it).

@group(0) @binding(1) var<storage, read> motions: array<GpuMotion>;
@group(0) @binding(2) var<storage, read_write> models: array<mat4x4<f32>>;
@group(0) @binding(3) var<storage, read_write> to_previous: array<mat4x4<f32>>;

// The angle less the nearest multiple of 2π, by the same f32 operations as `reduced_angle` on
// the CPU (scene/animation.rs): GPU sin and cos lose accuracy on large arguments.
fn reduced_angle(a: f32) -> f32 {
    // The f32 values of the CPU's INV_TAU and TAU_LO.
    let n = round(a * 0.15915493667125702);
    return (a - n * 6.28125) - n * 0.0019353071693331003;
}

// Same expression, in the same order, as `Orbit::position` on the CPU.
fn orbit_position(m: GpuMotion, t: f32) -> vec3<f32> {
    let a = reduced_angle(m.angular_speed * t + m.phase);
    return m.centre + m.radius * (cos(a) * m.u + sin(a) * m.v);
}

fn translation(offset: vec3<f32>, scale: f32) -> mat4x4<f32> {
    return mat4x4<f32>(
        vec4<f32>(scale, 0.0, 0.0, 0.0),
        vec4<f32>(0.0, scale, 0.0, 0.0),
        vec4<f32>(0.0, 0.0, scale, 0.0),
        vec4<f32>(offset, 1.0),
    );
}

@compute @workgroup_size(64)
fn object_transforms(at: GridThread) {
    let o = thread_index(at);
    if o >= params.objects {
        return;
    }
    let m = motions[o];
    if m.moving == 0u {
        models[o] = translation(vec3<f32>(0.0), 1.0);
        to_previous[o] = translation(vec3<f32>(0.0), 1.0);
        return;
    }
    let now = orbit_position(m, params.time);
    let before = orbit_position(m, params.previous_time);
    models[o] = translation(now, m.scale);
    // Same scale at both times: the motion between them is a translation.
    to_previous[o] = translation(before - now, 1.0);
}
