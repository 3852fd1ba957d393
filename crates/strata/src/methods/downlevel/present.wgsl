// Present of f2b's downlevel frame over the application's color target, in linear space: the
// target becomes color + transmittance·target, in two draws of a full-screen triangle. Group 0:
// both pairs of state targets (see f2b_downlevel.wgsl).

struct StateOut {
    @location(0) color: vec4<f32>,
    @location(1) transmittance: vec4<f32>,
}

// The state targets hold f32 bits (`strata::color::DownlevelState`).
@group(0) @binding(0) var color_a: texture_2d<u32>;
@group(0) @binding(1) var transmittance_a: texture_2d<u32>;
@group(0) @binding(2) var color_b: texture_2d<u32>;
@group(0) @binding(3) var transmittance_b: texture_2d<u32>;

fn state_at(t: texture_2d<u32>, p: vec2<i32>) -> vec4<f32> {
    return bitcast<vec4<f32>>(textureLoad(t, p, 0));
}

// The pixel's final state: the pair holding more layers.
fn resolved_state(p: vec2<i32>) -> StateOut {
    let a = state_at(color_a, p);
    let b = state_at(color_b, p);
    if b.a > a.a {
        return StateOut(b, state_at(transmittance_b, p));
    }
    return StateOut(a, state_at(transmittance_a, p));
}

// Present, first draw: the application's target times the transmittance (blend: zero, source).
@fragment
fn fs_present_filter(@builtin(position) position: vec4<f32>) -> @location(0) vec4<f32> {
    let s = resolved_state(vec2<i32>(position.xy));
    let t = s.transmittance.rgb;
    return vec4<f32>(t, (t.r + t.g + t.b) / 3.0);
}

// Present, second draw: plus the color (blend: one, one).
@fragment
fn fs_present_add(@builtin(position) position: vec4<f32>) -> @location(0) vec4<f32> {
    let s = resolved_state(vec2<i32>(position.xy));
    let t = s.transmittance.rgb;
    return vec4<f32>(s.color.rgb, 1.0 - (t.r + t.g + t.b) / 3.0);
}
