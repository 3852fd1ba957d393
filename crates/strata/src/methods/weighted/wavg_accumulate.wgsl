#define_import_path strata::weighted::wavg_accumulate
#import strata::scene::{SceneVarying, behind_opaque, pixel_index, pixel_of, shade}

// wavg accumulate pass (Bavoil & Myers 2008's weighted average): every fragment adds its
// premultiplied color and its opacity to the accumulation target and 1 to the count target
// (blend ONE, ONE), and multiplies the revealage target by 1 − α (blend ZERO,
// ONE_MINUS_SRC), the exact coverage that `--opacity product` takes and the opacity statistics
// compare the average's with. With --msaa each covered sample blends the fragment, so every
// sample has its own sums, count and product.

@group(1) @binding(0) var<storage, read_write> counts: array<atomic<u32>>;

struct WavgOut {
    @location(0) accumulation: vec4<f32>,
    @location(1) revealage: vec4<f32>,
    @location(2) count: vec4<f32>,
}

fn fs_wavg_step(v: SceneVarying, front_facing: bool, mask: u32) -> WavgOut {
    if behind_opaque(v.position) {
        discard;
    }
    atomicAdd(&counts[pixel_index(pixel_of(v.position))], 1u);
    let c = shade(v.world, v.normal, v.material);
    var out: WavgOut;
    out.accumulation = vec4<f32>(c.rgb * c.a, c.a);
    out.revealage = vec4<f32>(c.a);
    out.count = vec4<f32>(1.0);
    return out;
}
