#define_import_path strata::peeling::bucket_bounds
#import strata::scene::{SceneVarying, behind_opaque, pixel_index, pixel_of}
#import strata::peeling::bucket_common::{NO_DEPTH}

// Bucket depth peeling, pass 1 (bounds): every fragment writes (−z, z) into an Rg32Float
// target with MAX blending, leaving each pixel's nearest depth (negated) and its farthest; it
// also counts the pixel's fragments for the resolve's account.

@group(1) @binding(1) var<storage, read_write> counts: array<atomic<u32>>;

struct BoundsOut {
    @location(0) bounds: vec4<f32>,
}

fn fs_bounds_step(v: SceneVarying, front_facing: bool, mask: u32) -> BoundsOut {
    if behind_opaque(v.position) {
        discard;
    }
    atomicAdd(&counts[pixel_index(pixel_of(v.position))], 1u);
    let z = v.position.z;
    return BoundsOut(vec4<f32>(-z, z, NO_DEPTH, NO_DEPTH));
}
