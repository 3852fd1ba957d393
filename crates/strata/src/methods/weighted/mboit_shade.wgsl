// mboit pass 2: every fragment adds its color weighted by α and by the transmittance the moments
// give in front of it, (T·α·c, T·α), into the accumulation target (additive blending). With
// --msaa (the targets then multisampled) T is the mean over the samples the fragment covers of
// each sample's own transmittance: shading stays once per pixel and primitive.

@group(1) @binding(1) var b0_target: texture_2d<f32>;
@group(1) @binding(2) var moments_target: texture_2d<f32>;

@fragment
fn fs_shade(v: SceneVarying, @builtin(sample_mask) mask: u32) -> @location(0) vec4<f32> {
    if behind_opaque(v.position) {
        discard;
    }
    let pixel = vec2<i32>(pixel_of(v.position));
    let z = mboit_depth(v.position.z);
    let samples = max(frame.coverage_bits, 1u);
    // Single-sampled the index is the mip level, 0, and the one sample counts whatever the mask.
    let covered = select(mask, 1u, samples == 1u);
    var t = 0.0;
    var n = 0u;
    for (var si = 0u; si < samples; si++) {
        if (covered & (1u << si)) != 0u {
            let b0 = textureLoad(b0_target, pixel, si).r;
            t += mboit_transmittance(b0, textureLoad(moments_target, pixel, si), z);
            n += 1u;
        }
    }
    t /= f32(max(n, 1u));
    let c = shade(v.world, v.normal, v.material);
    let alpha = min(c.a, MBOIT_MAX_ALPHA);
    return vec4<f32>(c.rgb * alpha * t, alpha * t);
}
