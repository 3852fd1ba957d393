#define_import_path strata::weighted::wavg_composite
#import strata::scene::{frame, pixel_index, report_pixel, samples_per_pixel}
#import strata::color::{Resolved, resolved_over}
#import strata::weighted::wavg_params::{WavgParams}
#import strata::weighted::wavg_constants::{GAP_MAX, GAP_PIXELS, OPACITY_PRODUCT}
#ifdef MULTISAMPLED
alias TargetTexture = texture_multisampled_2d<f32>;
#else
alias TargetTexture = texture_2d<f32>;
#endif

// wavg's composite: per sample the average color Σαc / Σα of its n fragments over an opacity
// taken from their average opacity ᾱ = Σα / n, 1 − (1 − ᾱ)ⁿ (the paper's), or from the exact
// product 1 − Π(1 − α) (`--opacity product`); the samples averaged. Every pixel also measures
// how far the average's transmittance lies from the product's (the pixel's mean over its
// samples of each, their difference): the largest difference of the frame as f32 bits (an
// atomic max orders non-negative f32 bits as numbers) and the pixels where it passes 1/255.

@group(1) @binding(0) var<uniform> params: WavgParams;
@group(1) @binding(1) var<storage, read_write> counts: array<u32>;
@group(1) @binding(2) var accumulation: TargetTexture;
@group(1) @binding(3) var revealage: TargetTexture;
@group(1) @binding(4) var count_target: TargetTexture;
@group(1) @binding(5) var<storage, read_write> output: array<Resolved>;
@group(1) @binding(6) var<storage, read_write> opacity_gap: array<atomic<u32>, 2>;

// Sample `si`'s average color and its transmittance by each opacity.
struct SampleResult {
    color: vec3<f32>,
    average_t: f32,
    product_t: f32,
}

fn sample_result(pixel: vec2<i32>, si: u32) -> SampleResult {
    let sum = textureLoad(accumulation, pixel, i32(si));
    let n = textureLoad(count_target, pixel, i32(si)).r;
    var r: SampleResult;
    r.product_t = textureLoad(revealage, pixel, i32(si)).r;
    r.average_t = 1.0;
    r.color = vec3<f32>(0.0);
    if n >= 1.0 {
        let mean_alpha = clamp(sum.a / n, 0.0, 1.0);
        r.average_t = pow(1.0 - mean_alpha, n);
        r.color = sum.rgb / max(sum.a, 1e-4);
    }
    return r;
}

fn pixel_resolved(pixel: vec2<i32>, count: u32) -> Resolved {
    let samples = samples_per_pixel();
    var color = vec4<f32>(0.0);
    var average_t = 0.0;
    var product_t = 0.0;
    for (var si = 0u; si < samples; si++) {
        if count == 0u {
            break;
        }
        let r = sample_result(pixel, si);
        var t = r.average_t;
        if params.opacity == OPACITY_PRODUCT {
            t = r.product_t;
        }
        color += vec4<f32>(r.color * (1.0 - t), 1.0 - t);
        average_t += r.average_t;
        product_t += r.product_t;
    }
    if count > 0u {
        let gap = abs(average_t - product_t) / f32(samples);
        atomicMax(&opacity_gap[GAP_MAX], bitcast<u32>(gap));
        if gap > 1.0 / 255.0 {
            atomicAdd(&opacity_gap[GAP_PIXELS], 1u);
        }
    }
    return resolved_over(color / f32(samples), count);
}

@compute @workgroup_size(8, 8)
fn cs_composite(@builtin(global_invocation_id) id: vec3<u32>) {
    if id.x >= frame.size.x || id.y >= frame.size.y {
        return;
    }
    let i = pixel_index(id.xy);
    let count = counts[i];
    output[i] = pixel_resolved(vec2<i32>(id.xy), count);
    report_pixel(count, count);
}
