// mboit pass 2: every fragment adds its color weighted by α and by the transmittance the moments
// give in front of it, (T·α·c, T·α), into the accumulation target (additive blending).

@group(1) @binding(1) var b0_target: texture_2d<f32>;
@group(1) @binding(2) var moments_target: texture_2d<f32>;

@fragment
fn fs_shade(v: SceneVarying) -> @location(0) vec4<f32> {
    if behind_opaque(v.position) {
        discard;
    }
    let pixel = vec2<i32>(pixel_of(v.position));
    let b0 = textureLoad(b0_target, pixel, 0).r;
    let b = textureLoad(moments_target, pixel, 0);
    let c = shade(v.world, v.normal, v.material);
    let alpha = min(c.a, MBOIT_MAX_ALPHA);
    let t = mboit_transmittance(b0, b, mboit_depth(v.position.z));
    return vec4<f32>(c.rgb * alpha * t, alpha * t);
}
