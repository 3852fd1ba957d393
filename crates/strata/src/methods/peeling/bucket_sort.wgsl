#define_import_path strata::peeling::bucket_sort
#import strata::scene::{SceneVarying, pixel_index, pixel_of}
#import strata::peeling::bucket_common::{NO_DEPTH, route}

// Bucket depth peeling, pass 2 (sort): a fragment of bucket b writes −z to slot 2b and z to
// slot 2b + 1 of the bucket targets, NO_DEPTH everywhere else; MAX blending keeps each bucket's
// nearest and farthest depth — dual depth peeling inside every bucket, all buckets in one
// geometry pass. `fs_sort` and its output struct, one member per target layer, are generated
// (`bucket::sort_stage`) after this file.

@group(1) @binding(1) var bounds: texture_2d<f32>;

// The bucket of a fragment that is not behind the opaque depth.
fn fragment_bucket(v: SceneVarying) -> u32 {
    let pixel = pixel_of(v.position);
    let range = textureLoad(bounds, pixel, 0);
    return route(v.position.z, -range.x, range.y, pixel_index(pixel));
}

// Target layer `layer`'s four channels for a fragment at depth z in bucket b.
fn bucket_channels(layer: u32, b: u32, z: f32) -> vec4<f32> {
    var out = vec4<f32>(NO_DEPTH);
    if b / 2u == layer {
        let c = 2u * (b % 2u);
        out[c] = -z;
        out[c + 1u] = z;
    }
    return out;
}
