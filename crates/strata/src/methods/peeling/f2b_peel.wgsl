#define_import_path strata::peeling::f2b_peel
#import strata::scene::{SceneVarying, behind_opaque, pixel_index, pixel_of, shade}
#import strata::composite::{Composite}

// f2b peel pass: keeps fragments strictly after the last captured one in (depth, primitive)
// order; the depth test (LESS, primitive order among equals) picks the nearest of them.

@group(1) @binding(0) var<storage, read> state: array<Composite>;
// Every fragment of the pixel, counted by the first peel pass.
@group(1) @binding(1) var<storage, read_write> counts: array<atomic<u32>>;

struct PeelOut {
    @location(0) color: vec4<f32>,
    @location(1) tag: u32,
    @location(2) depth: f32,
}

@fragment
fn fs_peel_first(v: SceneVarying, @builtin(front_facing) front_facing: bool) -> PeelOut {
    if behind_opaque(v.position) {
        discard;
    }
    atomicAdd(&counts[pixel_index(pixel_of(v.position))], 1u);
    return peel(v, front_facing);
}

@fragment
fn fs_peel(v: SceneVarying, @builtin(front_facing) front_facing: bool) -> PeelOut {
    if behind_opaque(v.position) {
        discard;
    }
    return peel(v, front_facing);
}

fn peel(v: SceneVarying, front_facing: bool) -> PeelOut {
    let s = state[pixel_index(pixel_of(v.position))];
    let tag = (v.prim << 1u) | select(0u, 1u, front_facing);
    let z = v.position.z;
    if s.count > 0u && !(z > s.last_depth || (z == s.last_depth && tag > s.last_tag)) {
        discard;
    }
    var out: PeelOut;
    out.color = shade(v.world, v.normal, v.material);
    out.tag = tag;
    out.depth = z;
    return out;
}
