#define_import_path strata::weighted::wboit_accumulate
#import strata::scene::{SceneVarying, behind_opaque, pixel_index, pixel_of, shade}
#import strata::composite::{view_distance}

// wboit accumulate pass (McGuire & Bavoil 2013): every fragment adds its weighted premultiplied
// color and weighted alpha to the accumulation target (blend ONE, ONE) and multiplies the
// revealage target by 1 − α (blend ZERO, ONE_MINUS_SRC). Keep `WboitParams` in sync with
// `WboitParams` in weighted/mod.rs.

struct WboitParams {
    weight: u32,
    depth_scale: f32,
    pad_a: u32,
    pad_b: u32,
}

@group(1) @binding(0) var<uniform> wp: WboitParams;
@group(1) @binding(1) var<storage, read_write> counts: array<atomic<u32>>;

struct WboitOut {
    @location(0) accumulation: vec4<f32>,
    @location(1) revealage: vec4<f32>,
}

const WEIGHT_EQ7: u32 = 0u;
const WEIGHT_EQ8: u32 = 1u;
const WEIGHT_EQ9: u32 = 2u;

// The paper's weight functions; `distance` in view-space units (scaled), `depth` in window space.
fn wboit_weight(alpha: f32, distance: f32, depth: f32) -> f32 {
    let z = abs(distance) * wp.depth_scale;
    var w: f32;
    if wp.weight == WEIGHT_EQ7 {
        w = clamp(10.0 / (1e-5 + pow(z / 5.0, 2.0) + pow(z / 200.0, 6.0)), 1e-2, 3e3);
    } else if wp.weight == WEIGHT_EQ8 {
        w = clamp(10.0 / (1e-5 + pow(z / 10.0, 3.0) + pow(z / 200.0, 6.0)), 1e-2, 3e3);
    } else if wp.weight == WEIGHT_EQ9 {
        w = clamp(0.03 / (1e-5 + pow(z / 200.0, 4.0)), 1e-2, 3e3);
    } else {
        w = max(1e-2, 3e3 * pow(1.0 - depth, 3.0));
    }
    return alpha * w;
}

@fragment
fn fs_wboit(v: SceneVarying) -> WboitOut {
    if behind_opaque(v.position) {
        discard;
    }
    atomicAdd(&counts[pixel_index(pixel_of(v.position))], 1u);
    let c = shade(v.world, v.normal, v.material);
    let w = wboit_weight(c.a, view_distance(v.position.z), v.position.z);
    var out: WboitOut;
    out.accumulation = vec4<f32>(c.rgb * c.a * w, c.a * w);
    out.revealage = vec4<f32>(c.a);
    return out;
}
