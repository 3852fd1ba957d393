#define_import_path strata::baseline::blend
#import strata::scene::{SceneVarying, behind_opaque, pixel_index, pixel_of, shade}

// unsorted / sorted: one geometry pass of premultiplied "over" blending in draw order.
// The count of every pixel's fragments goes to a storage buffer for the complexity effect.

@group(1) @binding(0) var<storage, read_write> counts: array<atomic<u32>>;

@fragment
fn fs_blend(v: SceneVarying) -> @location(0) vec4<f32> {
    if behind_opaque(v.position) {
        discard;
    }
    atomicAdd(&counts[pixel_index(pixel_of(v.position))], 1u);
    let c = shade(v.world, v.normal, v.material);
    return vec4<f32>(c.rgb * c.a, c.a);
}
