#define_import_path strata::weighted::stochastic
#import strata::scene::{SceneVarying, behind_opaque, pixel_index, pixel_of, shade}
#import strata::weighted::stochastic_params::{StochasticParams}

// Stochastic transparency (Enderton, Sintorn, Shirley & Luebke 2011) with stratified masks
// (Laine & Karras 2011), over the S samples of a multisampled frame. Per --passes pass:
// - depth: each fragment writes its depth (at the pixel center), with the depth test LESS, to
//   the samples of its stipple (`stipple`: about α·S of them), so each sample keeps the nearest
//   surface that stippled it;
// - accumulate: each fragment adds (α·c, α) to every sample where it is not behind that depth
//   (the depth test LESS_EQUAL, no write): summed over the samples, α·c·v and α·v, v being the
//   fraction of samples that see it, which estimates its transmittance times S.
// Then once: total (Π(1 − α) per sample by multiplicative blending, and the fragment count),
// and the composite (stochastic_composite.wgsl). Keep `StochasticParams` in sync with
// weighted/stochastic.rs, and `hash_u32` and `stipple` with their CPU twins in weighted/cpu.rs.

@group(1) @binding(0) var<uniform> sp: StochasticParams;
@group(1) @binding(1) var<storage, read_write> counts: array<atomic<u32>>;

// A 32-bit integer hash: one step of a PCG generator and its output permutation (Jarzynski &
// Olano 2020, "Hash Functions for GPU Rendering").
fn hash_u32(x: u32) -> u32 {
    let state = x * 747796405u + 2891336453u;
    let word = ((state >> ((state >> 28u) + 4u)) ^ state) * 277803737u;
    return (word >> 22u) ^ word;
}

// The samples a fragment of opacity `alpha` stipples in this pass: n = ⌊α·S⌋, plus one with
// probability frac(α·S) (so n averages α·S), drawn without replacement. Fixed by the pixel, the
// primitive and the pass, so every frame draws the same.
fn stipple(pixel: u32, prim: u32, alpha: f32) -> u32 {
    let samples = sp.samples;
    var h = hash_u32(pixel ^ hash_u32(prim ^ hash_u32(sp.seed)));
    let scaled = clamp(alpha, 0.0, 1.0) * f32(samples);
    var n = u32(scaled);
    if f32(h >> 8u) * (1.0 / 16777216.0) < scaled - f32(n) {
        n += 1u;
    }
    n = min(n, samples);
    var free = (1u << samples) - 1u;
    var mask = 0u;
    for (var i = 0u; i < n; i++) {
        h = hash_u32(h);
        // The (h mod remaining)-th sample not yet drawn.
        var skip = h % (samples - i);
        for (var b = 0u; b < samples; b++) {
            let bit = 1u << b;
            if (free & bit) != 0u {
                if skip == 0u {
                    mask |= bit;
                    free &= ~bit;
                    break;
                }
                skip -= 1u;
            }
        }
    }
    return mask;
}

struct StippleOut {
    @builtin(sample_mask) mask: u32,
    @builtin(frag_depth) depth: f32,
}

// Both depth passes write and test the depth at the pixel center on every sample, as strata's
// other multisampled methods order a pixel's fragments (and the reference does): each sample
// then sees the fragments in the order the pixel's center does.
fn fs_stochastic_depth_step(v: SceneVarying, front_facing: bool, mask: u32) -> StippleOut {
    if behind_opaque(v.position) {
        discard;
    }
    let c = shade(v.world, v.normal, v.material);
    return StippleOut(stipple(pixel_index(pixel_of(v.position)), v.prim, c.a), v.position.z);
}

struct AccumulateOut {
    @location(0) sums: vec4<f32>,
    @builtin(frag_depth) depth: f32,
}

fn fs_stochastic_accumulate_step(v: SceneVarying, front_facing: bool, mask: u32) -> AccumulateOut {
    if behind_opaque(v.position) {
        discard;
    }
    let c = shade(v.world, v.normal, v.material);
    return AccumulateOut(vec4<f32>(c.rgb * c.a, c.a), v.position.z);
}

struct TotalOut {
    @location(0) opacity: vec4<f32>,
}

fn fs_stochastic_total_step(v: SceneVarying, front_facing: bool, mask: u32) -> TotalOut {
    if behind_opaque(v.position) {
        discard;
    }
    atomicAdd(&counts[pixel_index(pixel_of(v.position))], 1u);
    return TotalOut(vec4<f32>(shade(v.world, v.normal, v.material).a));
}
