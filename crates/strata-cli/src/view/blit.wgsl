// Shows an image at one texel per window pixel, its top-left corner at `origin`; the scissor
// clips it to the 3D area. Texels are loaded, never filtered, so an sRGB window shows exactly
// the image's bytes.

struct Blit {
    origin: vec2<i32>,
    // 1 when the window's format is not sRGB: encode here what the hardware would.
    encode_srgb: u32,
}

@group(0) @binding(0) var<uniform> blit: Blit;
@group(0) @binding(1) var image: texture_2d<f32>;

fn srgb_encode(c: f32) -> f32 {
    if c <= 0.0031308 {
        return 12.92 * c;
    }
    return 1.055 * pow(c, 1.0 / 2.4) - 0.055;
}

@fragment
fn fs_blit(@builtin(position) pos: vec4<f32>) -> @location(0) vec4<f32> {
    let texel = vec2<i32>(floor(pos.xy)) - blit.origin;
    let size = vec2<i32>(textureDimensions(image));
    let inside = all(texel >= vec2<i32>(0)) && all(texel < size);
    var c = textureLoad(image, clamp(texel, vec2<i32>(0), size - 1), 0);
    if !inside {
        c = vec4<f32>(0.0, 0.0, 0.0, 1.0);
    }
    if blit.encode_srgb == 1u {
        c = vec4<f32>(srgb_encode(c.r), srgb_encode(c.g), srgb_encode(c.b), c.a);
    }
    return c;
}
