#define_import_path strata::color

// Colors: the sRGB transfer functions (the one WGSL copy; the Rust one is in scene/mod.rs) and
// the per-pixel result every resolve writes and the present pass reads. No bindings.
// Keep `Resolved` in sync with `Resolved` in crates/strata/src/frame/mod.rs.

struct Resolved {
    // Premultiplied linear color: the light the fragments put in front of the background.
    color: vec3<f32>,
    count: u32,
    // What shows of the background, per channel (1 − alpha where every fragment blends over;
    // multiply materials tint it).
    transmittance: vec3<f32>,
    spare: u32,
}

// The result of a hardware-blended method: premultiplied color and alpha = 1 − transmittance.
fn resolved_over(premultiplied: vec4<f32>, count: u32) -> Resolved {
    return Resolved(premultiplied.rgb, count, vec3<f32>(1.0 - premultiplied.a), 0u);
}

// A result as a downlevel frame's state targets hold it (crates/strata/src/methods/downlevel):
// (color, count) and (transmittance, unused), the f32 values' bits in Rgba32Uint targets
// (32-bit float targets are not renderable on WebGL2 without an extension, nor on wgpu's GL
// backend; 32-bit integer ones are everywhere, and keep every bit).
struct DownlevelState {
    @location(0) color: vec4<u32>,
    @location(1) transmittance: vec4<u32>,
}

fn downlevel_state(r: Resolved) -> DownlevelState {
    return DownlevelState(
        bitcast<vec4<u32>>(vec4<f32>(r.color, f32(r.count))),
        bitcast<vec4<u32>>(vec4<f32>(r.transmittance, 0.0)),
    );
}

// A multisampled pixel's per-sample results, summed for their mean.
struct ResolvedSum {
    color: vec3<f32>,
    transmittance: vec3<f32>,
}

fn resolved_sum_new() -> ResolvedSum {
    return ResolvedSum(vec3<f32>(0.0), vec3<f32>(0.0));
}

fn resolved_sum_add(sum: ptr<function, ResolvedSum>, r: Resolved) {
    (*sum).color += r.color;
    (*sum).transmittance += r.transmittance;
}

// The pixel's result: the mean of `samples` sample results, with its fragment count.
fn resolved_mean(sum: ResolvedSum, samples: u32, count: u32) -> Resolved {
    let n = f32(samples);
    return Resolved(sum.color / n, count, sum.transmittance / n, 0u);
}

fn linear_to_srgb(c: f32) -> f32 {
    let x = clamp(c, 0.0, 1.0);
    return select(1.055 * pow(x, 1.0 / 2.4) - 0.055, x * 12.92, x <= 0.0031308);
}

fn srgb_to_linear(c: f32) -> f32 {
    return select(pow((c + 0.055) / 1.055, 2.4), c / 12.92, c <= 0.04045);
}
