// Puts the blended color over the background and writes (rgb, count) to the output.

@group(1) @binding(0) var<storage, read_write> counts: array<u32>;
@group(1) @binding(1) var blended: texture_2d<f32>;
@group(1) @binding(2) var<storage, read_write> output: array<vec4<f32>>;

@compute @workgroup_size(8, 8)
fn cs_finish(@builtin(global_invocation_id) id: vec3<u32>) {
    if id.x >= frame.size.x || id.y >= frame.size.y {
        return;
    }
    let pixel = id.xy;
    let c = textureLoad(blended, vec2<i32>(pixel), 0);
    let i = pixel_index(pixel);
    output[i] = vec4<f32>(c.rgb + (1.0 - c.a) * background_at(pixel), f32(counts[i]));
}
