#define_import_path strata::weighted::wboit_accumulate
#import strata::scene::{SceneVarying, behind_opaque, pixel_index, pixel_of, shade}
#import strata::composite::{view_distance}
#import strata::weight::{oit_weight}
#import strata::weighted::wboit_params::{WboitParams}

// wboit accumulate pass (McGuire & Bavoil 2013): every fragment adds its weighted premultiplied
// color and weighted alpha to the accumulation target (blend ONE, ONE) and multiplies the
// revealage target by 1 − α (blend ZERO, ONE_MINUS_SRC).

@group(1) @binding(0) var<uniform> wp: WboitParams;
#ifdef UNIFORM_SCENE
// A downlevel device has no storage: a third target counts the fragments (blend ONE, ONE).
struct WboitOut {
    @location(0) accumulation: vec4<f32>,
    @location(1) revealage: vec4<f32>,
    @location(2) count: vec4<f32>,
}
#else
@group(1) @binding(1) var<storage, read_write> counts: array<atomic<u32>>;

struct WboitOut {
    @location(0) accumulation: vec4<f32>,
    @location(1) revealage: vec4<f32>,
}
#endif

fn fs_wboit_step(v: SceneVarying, front_facing: bool, mask: u32) -> WboitOut {
    if behind_opaque(v.position) {
        discard;
    }
#ifndef UNIFORM_SCENE
    atomicAdd(&counts[pixel_index(pixel_of(v.position))], 1u);
#endif
    let c = shade(v.world, v.normal, v.material);
    let w = oit_weight(wp.weight, wp.depth_scale, c.a, view_distance(v.position.z), v.position.z);
    var out: WboitOut;
    out.accumulation = vec4<f32>(c.rgb * c.a * w, c.a * w);
    out.revealage = vec4<f32>(c.a);
#ifdef UNIFORM_SCENE
    out.count = vec4<f32>(1.0);
#endif
    return out;
}
