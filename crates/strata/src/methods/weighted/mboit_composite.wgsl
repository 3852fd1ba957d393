// mboit composite: the transmittance-weighted average color over the exact coverage
// 1 − exp(−b0) = 1 − Π(1 − α), premultiplied, with the fragment count.

@group(1) @binding(0) var<storage, read_write> counts: array<u32>;
@group(1) @binding(1) var b0_target: texture_2d<f32>;
@group(1) @binding(2) var accumulation: texture_2d<f32>;
@group(1) @binding(3) var<storage, read_write> output: array<Resolved>;

@compute @workgroup_size(8, 8)
fn cs_composite(@builtin(global_invocation_id) id: vec3<u32>) {
    if id.x >= frame.size.x || id.y >= frame.size.y {
        return;
    }
    let pixel = vec2<i32>(id.xy);
    let i = pixel_index(id.xy);
    let count = counts[i];
    let coverage = 1.0 - exp(-textureLoad(b0_target, pixel, 0).r);
    let sum = textureLoad(accumulation, pixel, 0);
    var color = vec4<f32>(0.0);
    if sum.a > 0.0 {
        color = vec4<f32>(sum.rgb / sum.a * coverage, coverage);
    }
    output[i] = Resolved(color, count, 0u, 0u, 0u);
    report_pixel(count, count);
}
