// The picture's background under the method's present pass: a solid color or the reference's
// checker (16-pixel cells), linear colors written to an sRGB target.

struct Background {
    light: vec4<f32>,
    dark: vec4<f32>,
    checker: u32,
}

@group(0) @binding(0) var<uniform> bg: Background;

@fragment
fn fs_background(@builtin(position) pos: vec4<f32>) -> @location(0) vec4<f32> {
    let cell = vec2<u32>(pos.xy) / 16u;
    if bg.checker == 0u || (cell.x + cell.y) % 2u == 0u {
        return bg.light;
    }
    return bg.dark;
}
