#define_import_path strata::peeling::bucket_reduce
#import strata::scene::{samples_per_pixel}
#import strata::peeling::bucket_common::{NO_DEPTH}

// Bucket depth peeling with --msaa, between the bounds and the routing passes: each pixel's
// bounds over all its samples (the MAX of the samples' (−nearest, farthest)), so a fragment is
// routed to one bucket at every sample it covers.

@group(1) @binding(1) var bounds_samples: texture_multisampled_2d<f32>;

@vertex
fn vs_reduce(@builtin(vertex_index) i: u32) -> @builtin(position) vec4<f32> {
    let uv = vec2<f32>(f32((i << 1u) & 2u), f32(i & 2u));
    return vec4<f32>(uv * 2.0 - 1.0, 0.0, 1.0);
}

@fragment
fn fs_reduce(@builtin(position) position: vec4<f32>) -> @location(0) vec4<f32> {
    let pixel = vec2<u32>(position.xy);
    var range = vec2<f32>(NO_DEPTH);
    for (var s = 0u; s < samples_per_pixel(); s++) {
        range = max(range, textureLoad(bounds_samples, pixel, i32(s)).xy);
    }
    return vec4<f32>(range, NO_DEPTH, NO_DEPTH);
}
