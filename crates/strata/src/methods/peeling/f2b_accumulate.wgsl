#define_import_path strata::peeling::f2b_accumulate
#import strata::scene::{frame, pixel_index, report_pixel}
#import strata::color::{Resolved}
#import strata::fragment::{fragment_new}
#import strata::composite::{Composite, composite_finish, composite_front, composite_new}

// f2b accumulate pass: composites the layer just peeled behind the pixel's running result.
// finish: the result, and the pixel's account (its fragment count from the first peel pass).

const EMPTY: u32 = 0xffffffffu;

@group(1) @binding(0) var<storage, read_write> state: array<Composite>;
@group(1) @binding(1) var layer_color: texture_2d<f32>;
@group(1) @binding(2) var layer_tag: texture_2d<u32>;
@group(1) @binding(3) var layer_depth: texture_2d<f32>;
@group(1) @binding(4) var<storage, read_write> counts: array<u32>;
@group(1) @binding(5) var<storage, read_write> output: array<Resolved>;

@compute @workgroup_size(8, 8)
fn cs_init(@builtin(global_invocation_id) id: vec3<u32>) {
    if id.x >= frame.size.x || id.y >= frame.size.y {
        return;
    }
    state[pixel_index(id.xy)] = composite_new();
}

@compute @workgroup_size(8, 8)
fn cs_accumulate(@builtin(global_invocation_id) id: vec3<u32>) {
    if id.x >= frame.size.x || id.y >= frame.size.y {
        return;
    }
    let p = vec2<i32>(id.xy);
    let tag = textureLoad(layer_tag, p, 0).r;
    if tag == EMPTY {
        return;
    }
    let c = textureLoad(layer_color, p, 0);
    let f = fragment_new(textureLoad(layer_depth, p, 0).r, tag >> 1u, (tag & 1u) == 1u, c);
    let i = pixel_index(id.xy);
    var s = state[i];
    composite_front(&s, f);
    state[i] = s;
}

@compute @workgroup_size(8, 8)
fn cs_finish(@builtin(global_invocation_id) id: vec3<u32>) {
    if id.x >= frame.size.x || id.y >= frame.size.y {
        return;
    }
    let i = pixel_index(id.xy);
    let s = state[i];
    output[i] = composite_finish(s);
    report_pixel(counts[i], s.count);
}
