#define_import_path strata::peeling::bucket_histogram
#import strata::scene::{SceneVarying, behind_opaque, pixel_index, pixel_of}
#import strata::peeling::bucket_common::{HISTOGRAM_WORDS, SUBINTERVALS, bucket_of}

// Bucket depth peeling with --buckets adaptive, the histogram pass (between bounds and sort):
// each fragment sets the bit of its part of the pixel's range, 1024 equal parts. The paper ORs
// bits into render targets with logic-op blending; WebGPU has no logic ops, so one storage
// atomicOr per fragment sets it.

@group(1) @binding(1) var bounds: texture_2d<f32>;
@group(1) @binding(2) var<storage, read_write> histogram_bits: array<atomic<u32>>;

// fs_histogram's capture step: its made fragment stage and the compute rasterizer call it.
fn fs_histogram_capture(v: SceneVarying, front_facing: bool, mask: u32) {
    if behind_opaque(v.position) {
        return;
    }
    let pixel = pixel_of(v.position);
    let range = textureLoad(bounds, pixel, 0);
    let part = bucket_of(v.position.z, -range.x, range.y, SUBINTERVALS);
    let word = pixel_index(pixel) * HISTOGRAM_WORDS + part / 32u;
    atomicOr(&histogram_bits[word], 1u << (part % 32u));
}
