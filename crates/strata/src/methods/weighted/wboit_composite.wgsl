// wboit composite: the weighted average color of the pixel's fragments over the coverage
// 1 − Π(1 − α) they have together, premultiplied, with the fragment count. With --msaa (the
// targets then multisampled) each sample's, averaged.

@group(1) @binding(0) var<storage, read_write> counts: array<u32>;
@group(1) @binding(1) var accumulation: TargetTexture;
@group(1) @binding(2) var revealage: TargetTexture;
@group(1) @binding(3) var<storage, read_write> output: array<Resolved>;

@compute @workgroup_size(8, 8)
fn cs_composite(@builtin(global_invocation_id) id: vec3<u32>) {
    if id.x >= frame.size.x || id.y >= frame.size.y {
        return;
    }
    let pixel = vec2<i32>(id.xy);
    let i = pixel_index(id.xy);
    let count = counts[i];
    let samples = max(frame.coverage_bits, 1u);
    var color = vec4<f32>(0.0);
    // Single-sampled the index is the mip level, 0; multisampled it is the sample.
    for (var si = 0u; si < samples && count > 0u; si++) {
        let sum = textureLoad(accumulation, pixel, si);
        let coverage = 1.0 - textureLoad(revealage, pixel, si).r;
        // The paper clamps the weight sum away from 0 and from f16 overflow.
        let average = sum.rgb / clamp(sum.a, 1e-4, 5e4);
        color += vec4<f32>(average * coverage, coverage);
    }
    output[i] = Resolved(color / f32(samples), count, 0u, 0u, 0u);
    report_pixel(count, count);
}
