// mboit pass 1: every fragment adds its absorbance a = −ln(1 − α) to b0 and a·(z, z², z³, z⁴) to
// the moments (additive blending into 32-bit float targets), and counts itself.

@group(1) @binding(1) var<storage, read_write> counts: array<atomic<u32>>;

struct MomentsOut {
    @location(0) b0: vec4<f32>,
    @location(1) moments: vec4<f32>,
}

@fragment
fn fs_moments(v: SceneVarying) -> MomentsOut {
    if behind_opaque(v.position) {
        discard;
    }
    atomicAdd(&counts[pixel_index(pixel_of(v.position))], 1u);
    let a = mboit_absorbance(shade(v.world, v.normal, v.material).a);
    let z = mboit_depth(v.position.z);
    let z2 = z * z;
    var out: MomentsOut;
    out.b0 = vec4<f32>(a);
    out.moments = a * vec4<f32>(z, z2, z2 * z, z2 * z2);
    return out;
}
