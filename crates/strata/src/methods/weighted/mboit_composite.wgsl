// mboit composite: the transmittance-weighted average color over the exact coverage
// 1 − exp(−b0) = 1 − Π(1 − α), premultiplied, with the fragment count. With --msaa (the targets
// then multisampled) each sample's, averaged.

@group(1) @binding(0) var<storage, read_write> counts: array<u32>;
@group(1) @binding(1) var b0_target: TargetTexture;
@group(1) @binding(2) var accumulation: TargetTexture;
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
        let coverage = 1.0 - exp(-textureLoad(b0_target, pixel, si).r);
        let sum = textureLoad(accumulation, pixel, si);
        if sum.a > 0.0 {
            color += vec4<f32>(sum.rgb / sum.a * coverage, coverage);
        }
    }
    output[i] = Resolved(color / f32(samples), count, 0u, 0u, 0u);
    report_pixel(count, count);
}
