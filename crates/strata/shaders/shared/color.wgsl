#define_import_path strata::color

// Colors: the sRGB transfer functions (the one WGSL copy; the Rust one is in scene/mod.rs) and
// the per-pixel result every resolve writes and the present pass reads. No bindings.
// Keep `Resolved` in sync with `Resolved` in crates/strata/src/frame/mod.rs.

struct Resolved {
    // Premultiplied linear color, alpha = 1 − transmittance.
    color: vec4<f32>,
    count: u32,
    pad_a: u32,
    pad_b: u32,
    pad_c: u32,
}

fn linear_to_srgb(c: f32) -> f32 {
    let x = clamp(c, 0.0, 1.0);
    return select(1.055 * pow(x, 1.0 / 2.4) - 0.055, x * 12.92, x <= 0.0031308);
}

fn srgb_to_linear(c: f32) -> f32 {
    return select(pow((c + 0.055) / 1.055, 2.4), c / 12.92, c <= 0.04045);
}
