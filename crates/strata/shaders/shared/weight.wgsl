#define_import_path strata::weight

// The weight functions of weighted blended OIT (McGuire & Bavoil 2013, equations 7–10), shared by
// `wboit` and the k-buffers' weighted tail (--tail weighted). `kind` is `Weight::index` (0 eq7,
// 1 eq8, 2 eq9, 3 eq10); `distance` in view-space units before `scale`, `depth` in window space.
// Keep in sync with `methods::weighted::cpu::weight`.

const WEIGHT_EQ7: u32 = 0u;
const WEIGHT_EQ8: u32 = 1u;
const WEIGHT_EQ9: u32 = 2u;

// α·w(z): the paper's weights include the fragment's alpha.
fn oit_weight(kind: u32, scale: f32, alpha: f32, distance: f32, depth: f32) -> f32 {
    let z = abs(distance) * scale;
    var w: f32;
    if kind == WEIGHT_EQ7 {
        w = clamp(10.0 / (1e-5 + pow(z / 5.0, 2.0) + pow(z / 200.0, 6.0)), 1e-2, 3e3);
    } else if kind == WEIGHT_EQ8 {
        w = clamp(10.0 / (1e-5 + pow(z / 10.0, 3.0) + pow(z / 200.0, 6.0)), 1e-2, 3e3);
    } else if kind == WEIGHT_EQ9 {
        w = clamp(0.03 / (1e-5 + pow(z / 200.0, 4.0)), 1e-2, 3e3);
    } else {
        w = max(1e-2, 3e3 * pow(1.0 - depth, 3.0));
    }
    return alpha * w;
}
