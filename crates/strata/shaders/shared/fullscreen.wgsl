// One triangle covering the target: the vertex stage of every full-screen pass that needs
// nothing from the scene (`Gpu::fullscreen_vertex_module`).

@vertex
fn vs_fullscreen(@builtin(vertex_index) i: u32) -> @builtin(position) vec4<f32> {
    let uv = vec2<f32>(f32((i << 1u) & 2u), f32(i & 2u));
    return vec4<f32>(uv * 2.0 - 1.0, 0.0, 1.0);
}
