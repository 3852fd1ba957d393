#define_import_path strata::baseline::blend
#import strata::scene::{SceneVarying, behind_opaque, pixel_index, pixel_of, shade}

// unsorted / sorted: one geometry pass of premultiplied "over" blending in draw order.
// The count of every pixel's fragments goes to a storage buffer for the complexity effect.

@group(1) @binding(0) var<storage, read_write> counts: array<atomic<u32>>;

struct BlendOut {
    @location(0) color: vec4<f32>,
}

fn fs_blend_step(v: SceneVarying, front_facing: bool, mask: u32) -> BlendOut {
    if behind_opaque(v.position) {
        discard;
    }
    atomicAdd(&counts[pixel_index(pixel_of(v.position))], 1u);
    let c = shade(v.world, v.normal, v.material);
    return BlendOut(vec4<f32>(c.rgb * c.a, c.a));
}
