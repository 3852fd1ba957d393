// Moment-based OIT (Münstermann et al. 2018): the moments a fragment adds and the transmittance
// reconstructed from four power moments. Keep `MboitParams` in sync with `MboitParams` in
// weighted/mod.rs, and the reconstruction with `cpu::absorbance_fraction`.

struct MboitParams {
    // The moment bias β and the overestimation η of the paper.
    bias: f32,
    overestimation: f32,
    _pad0: u32,
    _pad1: u32,
}

@group(1) @binding(0) var<uniform> mp: MboitParams;

// The moments of the distribution the bias pulls toward (4 power moments).
const MBOIT_BIAS_MOMENTS = vec4<f32>(0.0, 0.375, 0.0, 0.375);
// α is capped so that a fragment's absorbance −ln(1 − α) stays finite.
const MBOIT_MAX_ALPHA: f32 = 0.9999;

// A window depth warped to [−1, 1]: logarithmic in the view distance between the near and far
// planes (linear for orthographic cameras).
fn mboit_depth(window_depth: f32) -> f32 {
    if frame.orthographic != 0u {
        return 2.0 * window_depth - 1.0;
    }
    let d = view_distance(window_depth);
    return 2.0 * log(d / frame.near) / log(frame.far / frame.near) - 1.0;
}

fn mboit_absorbance(alpha: f32) -> f32 {
    return -log(1.0 - min(alpha, MBOIT_MAX_ALPHA));
}

// The fraction of the pixel's absorbance in front of warped depth z, from its normalized moments
// m = (E[z], E[z²], E[z³], E[z⁴]): the bound of the canonical representation through z (Hamburger
// problem, three points of support), with weight η at z itself.
fn mboit_absorbance_fraction(moments: vec4<f32>, z: f32) -> f32 {
    let m = mix(moments, MBOIT_BIAS_MOMENTS, mp.bias);
    // L·D·Lᵀ of the Hankel matrix [[1, m1, m2], [m1, m2, m3], [m2, m3, m4]].
    let d2 = m.y - m.x * m.x;
    let l32 = (m.z - m.x * m.y) / d2;
    let d3 = m.w - m.y * m.y - l32 * l32 * d2;
    // Solve it for (1, z, z²): forward, scale, backward.
    let y2 = (z - m.x) / d2;
    let y3 = (z * z - m.y - l32 * (z - m.x)) / d3;
    let c3 = y3;
    let c2 = y2 - l32 * c3;
    let c1 = 1.0 - m.x * c2 - m.y * c3;
    // The other two points of support: the roots of c1 + c2·x + c3·x².
    let p = c2 / c3;
    let q = c1 / c3;
    let r = sqrt(max(p * p * 0.25 - q, 0.0));
    let z1 = -0.5 * p - r;
    let z2 = -0.5 * p + r;
    // The quadratic through (z, η), (z1, [z1 < z]), (z2, [z2 < z]) in Newton form, then its
    // expectation under the moments.
    let f0 = mp.overestimation;
    let f1 = select(0.0, 1.0, z1 < z);
    let f2 = select(0.0, 1.0, z2 < z);
    let f01 = (f1 - f0) / (z1 - z);
    let f12 = (f2 - f1) / (z2 - z1);
    let f012 = (f12 - f01) / (z2 - z);
    let a2 = f012;
    let a1 = f01 - f012 * (z + z1);
    let a0 = f0 - f01 * z + f012 * z * z1;
    return a0 + a1 * m.x + a2 * m.y;
}

// Transmittance in front of warped depth z for a pixel of total absorbance b0 and moments b.
fn mboit_transmittance(b0: f32, b: vec4<f32>, z: f32) -> f32 {
    if b0 <= 0.0 {
        return 1.0;
    }
    return clamp(exp(-b0 * mboit_absorbance_fraction(b / b0, z)), 0.0, 1.0);
}
