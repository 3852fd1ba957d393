#define_import_path strata::peeling::bucket_bounds
#import strata::scene::{SceneVarying, behind_opaque, pixel_index, pixel_of}
#import strata::peeling::bucket_common::{NO_DEPTH}

// Bucket depth peeling, pass 1 (bounds): every fragment writes (−z, z) into an Rg32Float
// target with MAX blending, leaving each pixel's nearest depth (negated) and its farthest; it
// also counts the pixel's fragments for the resolve's account.

@group(1) @binding(1) var<storage, read_write> counts: array<atomic<u32>>;

@fragment
fn fs_bounds(v: SceneVarying) -> @location(0) vec4<f32> {
    if behind_opaque(v.position) {
        discard;
    }
    atomicAdd(&counts[pixel_index(pixel_of(v.position))], 1u);
    let z = v.position.z;
    return vec4<f32>(-z, z, NO_DEPTH, NO_DEPTH);
}
