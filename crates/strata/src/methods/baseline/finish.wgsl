#define_import_path strata::baseline::finish
#import strata::scene::{frame, pixel_index, report_pixel, samples_per_pixel}
#import strata::color::{Resolved, resolved_over}
#ifdef MULTISAMPLED
alias TargetTexture = texture_multisampled_2d<f32>;
#else
alias TargetTexture = texture_2d<f32>;
#endif

// The blended color is already premultiplied with alpha = 1 − transmittance: it becomes the
// pixel's result as it is, with the fragment count. With --msaa (the target then multisampled)
// the samples' colors, averaged.

@group(1) @binding(0) var<storage, read_write> counts: array<u32>;
@group(1) @binding(1) var blended: TargetTexture;
@group(1) @binding(2) var<storage, read_write> output: array<Resolved>;

// cs_finish's pixel step: its made compute stage calls it for each pixel of the frame.
fn cs_finish_pixel(pixel: vec2<u32>) {
    let i = pixel_index(pixel);
    let count = counts[i];
    let samples = samples_per_pixel();
    var color = vec4<f32>(0.0);
    // Single-sampled the index is the mip level, 0; multisampled it is the sample.
    for (var si = 0u; si < samples; si++) {
        color += textureLoad(blended, vec2<i32>(pixel), i32(si));
    }
    output[i] = resolved_over(color / f32(samples), count);
    report_pixel(count, count);
}
