#import strata::scene::{SceneVarying, behind_opaque, shade, uniform_scene_tag}
#import strata::fragment::{Fragment}
#import strata::color::{DownlevelState, downlevel_state}
#import strata::composite::{Composite, composite_finish, composite_front, composite_new, view_distance}

// f2b on a downlevel device (composed with UNIFORM_SCENE): no storage buffers and no compute,
// so every step is a render pass over textures.
// - peel i: the scene, LESS depth test; a fragment survives only strictly after the previous
//   layer's (depth, tag) at its pixel, read from that layer's targets (the first peel keeps
//   everything in front of the opaque depth). Writes layer i's color, tag and depth. A pixel
//   whose previous layer was empty is finished: everything there is discarded.
// - accumulate i: a full-screen triangle composites layer i behind the pixel's running state,
//   read from one pair of state targets and written to the other. Pixels without a fragment in
//   layer i are discarded, so each pair holds every other layer's state; the count in `.a`
//   tells which pair is the later (`resolved_state`).
// - after the last layer, one more peel counts in an occlusion query whether anything lies
//   deeper: if so the frame is incomplete.
// State targets: (color.rgb, count) and (transmittance.rgb, unused), their f32 bits in Rgba32Uint:
// 32 bytes per pixel, a downlevel device's most per sample. Layer depths travel as their bits
// in R32Uint likewise: 32-bit float targets do not render everywhere (`DownlevelState`).

const EMPTY: u32 = 0xffffffffu;

struct PeelOut {
    @location(0) color: vec4<f32>,
    @location(1) tag: u32,
    @location(2) depth: u32,
}

// The previous layer (peels after the first).
@group(1) @binding(0) var last_tag: texture_2d<u32>;
@group(1) @binding(1) var last_depth: texture_2d<u32>;

// A depth as its texture holds it, and back.
fn depth_bits(depth: f32) -> u32 {
    return bitcast<u32>(depth);
}

fn depth_at(t: texture_2d<u32>, p: vec2<i32>) -> f32 {
    return bitcast<f32>(textureLoad(t, p, 0).r);
}

fn peel(v: SceneVarying, front_facing: bool) -> PeelOut {
    var out: PeelOut;
    out.color = shade(v.world, v.normal, v.material);
    out.tag = uniform_scene_tag(v.prim, v.material, front_facing);
    out.depth = depth_bits(v.position.z);
    return out;
}

@fragment
fn fs_peel_first(v: SceneVarying, @builtin(front_facing) front_facing: bool) -> PeelOut {
    if behind_opaque(v.position) {
        discard;
    }
    return peel(v, front_facing);
}

@fragment
fn fs_peel(v: SceneVarying, @builtin(front_facing) front_facing: bool) -> PeelOut {
    if behind_opaque(v.position) {
        discard;
    }
    let p = vec2<i32>(v.position.xy);
    let t = textureLoad(last_tag, p, 0).r;
    let d = depth_at(last_depth, p);
    let z = v.position.z;
    let out = peel(v, front_facing);
    if t == EMPTY || !(z > d || (z == d && out.tag > t)) {
        discard;
    }
    return out;
}

// Exact mode's count pass: every fragment in front of the opaque depth adds 1 to its pixel
// (an R16Float target blended ONE, ONE: exact up to 2048), which the batch renderer reads back
// to peel as many layers as the deepest pixel has.
@fragment
fn fs_count(v: SceneVarying) -> @location(0) vec4<f32> {
    if behind_opaque(v.position) {
        discard;
    }
    return vec4<f32>(1.0);
}

// Group 1 of the accumulate pass (its vertex stage: `vs_fullscreen`).
@group(1) @binding(2) var state_color: texture_2d<u32>;
@group(1) @binding(3) var state_transmittance: texture_2d<u32>;
@group(1) @binding(4) var layer_color: texture_2d<f32>;
@group(1) @binding(5) var layer_tag: texture_2d<u32>;
@group(1) @binding(6) var layer_depth: texture_2d<u32>;

@fragment
fn fs_accumulate(@builtin(position) position: vec4<f32>) -> DownlevelState {
    let p = vec2<i32>(position.xy);
    let tag = textureLoad(layer_tag, p, 0).r;
    if tag == EMPTY {
        discard;
    }
    let held = bitcast<vec4<f32>>(textureLoad(state_color, p, 0));
    var s = composite_new();
    s.color = held.rgb;
    s.count = u32(held.a);
    s.transmittance = bitcast<vec4<f32>>(textureLoad(state_transmittance, p, 0)).rgb;
    if s.count > 0u {
        s.last_tag = textureLoad(last_tag, p, 0).r;
        s.last_depth = depth_at(last_depth, p);
        s.last_distance = view_distance(s.last_depth);
    }
    let c = textureLoad(layer_color, p, 0);
    let f = Fragment(depth_at(layer_depth, p), tag, pack2x16float(c.rg), pack2x16float(c.ba));
    composite_front(&s, f);
    return downlevel_state(composite_finish(s));
}
