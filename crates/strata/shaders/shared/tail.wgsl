#define_import_path strata::tail
#import strata::fragment::{Fragment, stored_color}
#import strata::composite::{Composite}
#import strata::weight::{oit_weight}

// A pixel's tail (--tail blend|weighted): the fragments beyond its k nearest, composited as one
// term behind them — their color averaged by α (or by α·w(z) of weighted blended OIT, so nearer
// ones count more) over the opacity 1 − exp(−Σ −ln(1 − α)) they have together. The sums are
// 64-bit fixed point, so a tail cannot depend on the order its fragments joined it: the
// k-buffers add to it from racing captures and resolves, tiled from its one-pass kernel and
// its rounds. Parameters come from the method's uniforms (`TailParams`, Rust's `TailSettings`).

// How a method's tail is blended: `mode` is `Tail::index` (0 drop, 1 blend, 2 weighted);
// `weight` the weight function (`Weight::index`) in its low byte and TAIL_ORTHOGRAPHIC for an
// orthographic view; `depth_p`, `depth_q` take a window depth to the scaled view distance the
// weight reads (`tail_depth` in Rust).
struct TailParams {
    mode: u32,
    weight: u32,
    depth_p: f32,
    depth_q: f32,
}

// Fixed-point scale of the tail sums (64-bit: a pixel would need about 2^42 tail fragments to
// wrap them).
const TAIL_SCALE: f32 = 65536.0;
// TailParams::mode of --tail weighted.
const TAIL_WEIGHTED: u32 = 2u;
// The weighted tail's color and weight sums carry this many times TAIL_SCALE: its weights span
// 10⁻²·α to 3·10³, so the small ones keep their precision (the sums go in as 64-bit values; a
// pixel would need about 2^21 tail fragments of the largest weight to wrap them).
const TAIL_WEIGHTED_SCALE: f32 = 256.0;
const TAIL_ORTHOGRAPHIC: u32 = 0x100u;

// The five sums of `tail_share`, each (low word, high word).
struct Tail {
    sums: array<vec2<u32>, 5>,
}

fn tail_empty() -> Tail {
    return Tail(array<vec2<u32>, 5>());
}

// The sum (low, high) plus `add`, carrying out of the low word.
fn tail_sum(sum: vec2<u32>, add: vec2<u32>) -> vec2<u32> {
    let low = sum.x + add.x;
    return vec2<u32>(low, sum.y + add.y + select(0u, 1u, low < add.x));
}

// The sum less `taken` (modulo 2^64: exact wherever the result is a true sum of shares).
fn tail_less(sum: vec2<u32>, taken: vec2<u32>) -> vec2<u32> {
    let low = ~taken.x + 1u;
    return tail_sum(sum, vec2<u32>(low, ~taken.y + select(0u, 1u, low == 0u)));
}

// A 64-bit fixed-point tail sum (low word, high word) as a number.
fn tail_value(sum: vec2<u32>) -> f32 {
    return (f32(sum.x) + f32(sum.y) * 4294967296.0) / TAIL_SCALE;
}

// v ≥ 0 (under 2^56) as a 64-bit value (low word, high word).
fn wide_of(v: f32) -> vec2<u32> {
    let high = u32(v / 4294967296.0);
    return vec2<u32>(u32(v - f32(high) * 4294967296.0), high);
}

// The view distance of window depth `depth`, times --depth-scale: p / (q − depth) in a
// perspective view, p + q·depth in an orthographic one.
fn tail_distance(params: TailParams, depth: f32) -> f32 {
    if (params.weight & TAIL_ORTHOGRAPHIC) != 0u {
        return params.depth_p + params.depth_q * depth;
    }
    return params.depth_p / (params.depth_q - depth);
}

// How much a tail fragment of opacity `a` counts in the tail's color: α, or with --tail weighted
// α·w(z) of weighted blended OIT, nearer fragments counting more.
fn tail_weight_of(params: TailParams, f: Fragment, a: f32) -> f32 {
    if params.mode == TAIL_WEIGHTED {
        return oit_weight(params.weight & 0xffu, 1.0, a, tail_distance(params, f.depth), f.depth);
    }
    return a;
}

// One fragment's share of its pixel's tail sums: (α or the weight)·r, ·g, ·b, the α or weight,
// and −ln(1 − α), each a 64-bit fixed-point value of the stored color. It is the same share
// whichever way the fragment reaches the tail, and the sums are integers.
fn tail_share_of(params: TailParams, f: Fragment) -> array<vec2<u32>, 5> {
    let c = stored_color(f);
    let a = clamp(c.a, 0.0, 0.999);
    var share: array<vec2<u32>, 5>;
    if params.mode == TAIL_WEIGHTED {
        let weight = tail_weight_of(params, f, a) * (TAIL_SCALE * TAIL_WEIGHTED_SCALE);
        share[0] = wide_of(weight * clamp(c.r, 0.0, 64.0));
        share[1] = wide_of(weight * clamp(c.g, 0.0, 64.0));
        share[2] = wide_of(weight * clamp(c.b, 0.0, 64.0));
        share[3] = wide_of(weight);
    } else {
        share[0] = vec2<u32>(u32(a * clamp(c.r, 0.0, 64.0) * TAIL_SCALE), 0u);
        share[1] = vec2<u32>(u32(a * clamp(c.g, 0.0, 64.0) * TAIL_SCALE), 0u);
        share[2] = vec2<u32>(u32(a * clamp(c.b, 0.0, 64.0) * TAIL_SCALE), 0u);
        share[3] = vec2<u32>(u32(a * TAIL_SCALE), 0u);
    }
    share[4] = vec2<u32>(u32(-log(1.0 - a) * TAIL_SCALE), 0u);
    return share;
}

// `f` joins the tail `t`.
fn tail_join(t: ptr<function, Tail>, params: TailParams, f: Fragment) {
    let share = tail_share_of(params, f);
    for (var i = 0u; i < 5u; i++) {
        (*t).sums[i] = tail_sum((*t).sums[i], share[i]);
    }
}

// `f`, which had joined the tail `t`, leaves it (composited instead).
fn tail_leave(t: ptr<function, Tail>, params: TailParams, f: Fragment) {
    let share = tail_share_of(params, f);
    for (var i = 0u; i < 5u; i++) {
        (*t).sums[i] = tail_less((*t).sums[i], share[i]);
    }
}

// Composites the tail behind what `s` holds: the weighted average color of the tail fragments
// over the opacity 1 − exp(−Σ −ln(1 − α)) they have together.
fn composite_tail_of(s: ptr<function, Composite>, t: Tail, params: TailParams) {
    var sum = vec4<f32>(tail_value(t.sums[0]), tail_value(t.sums[1]), tail_value(t.sums[2]), tail_value(t.sums[3]));
    if params.mode == TAIL_WEIGHTED {
        sum /= TAIL_WEIGHTED_SCALE;
    }
    if sum.w <= 0.0 {
        return;
    }
    let opacity = 1.0 - exp(-tail_value(t.sums[4]));
    (*s).color += (*s).transmittance * opacity * sum.rgb / sum.w;
    (*s).transmittance *= 1.0 - opacity;
}
