//! The CPU closed forms of the approximate methods, in f64: weighted blended OIT (McGuire & Bavoil
//! 2013, eq. 6 with the weights of eqs. 7–10), what `wboit` computes up to its f16 targets, and
//! moment-based OIT with four power moments (Münstermann et al. 2018), what `mboit` computes up to
//! its f32 moments and f16 accumulation.

use crate::frame::{RenderOptions, Weight};
use crate::resolve::RefFragment;
use crate::scene::{Camera, Projection};

/// w(z, α) of the paper's equations 7–10; `distance` in view-space units (before the scale),
/// `depth` the window depth.
pub fn weight(weight: Weight, alpha: f64, distance: f64, depth: f64, depth_scale: f64) -> f64 {
    let z = distance.abs() * depth_scale;
    let w = match weight {
        Weight::Eq7 => (10.0 / (1e-5 + (z / 5.0).powi(2) + (z / 200.0).powi(6))).clamp(1e-2, 3e3),
        Weight::Eq8 => (10.0 / (1e-5 + (z / 10.0).powi(3) + (z / 200.0).powi(6))).clamp(1e-2, 3e3),
        Weight::Eq9 => (0.03 / (1e-5 + (z / 200.0).powi(4))).clamp(1e-2, 3e3),
        Weight::Eq10 => (3e3 * (1.0 - depth).powi(3)).max(1e-2),
    };
    alpha * w
}

/// One pixel over `background`: Σ wαc / Σ wα · (1 − Π(1 − α)) + background · Π(1 − α). The
/// fragments may come in any order.
pub fn wboit(fragments: &[RefFragment], background: [f64; 3], options: &RenderOptions) -> [f64; 3] {
    let (mut sum, mut weights, mut revealage) = ([0.0f64; 3], 0.0f64, 1.0f64);
    for f in fragments {
        let w = weight(
            options.weight,
            f.alpha,
            f.distance,
            f.depth,
            options.depth_scale,
        );
        for (s, c) in sum.iter_mut().zip(f.color) {
            *s += c * f.alpha * w;
        }
        weights += f.alpha * w;
        revealage *= 1.0 - f.alpha;
    }
    let weights = weights.clamp(1e-4, 5e4);
    [0, 1, 2].map(|i| sum[i] / weights * (1.0 - revealage) + background[i] * revealage)
}

/// The moment bias vector of four power moments.
const BIAS_MOMENTS: [f64; 4] = [0.0, 0.375, 0.0, 0.375];
const MAX_ALPHA: f64 = 0.9999;

/// A view distance warped to [−1, 1] as `mboit_depth` does: logarithmic between the camera's
/// near and far planes (linear for orthographic cameras).
pub fn mboit_depth(camera: &Camera, distance: f64) -> f64 {
    let (n, f) = (camera.near as f64, camera.far as f64);
    match camera.projection {
        Projection::Orthographic { .. } => 2.0 * (distance - n) / (f - n) - 1.0,
        Projection::Perspective { .. } => 2.0 * (distance / n).ln() / (f / n).ln() - 1.0,
    }
}

/// The fraction of the absorbance in front of warped depth `z` from normalized moments
/// (E[z], E[z²], E[z³], E[z⁴]), biased by `bias` toward [`BIAS_MOMENTS`], with weight
/// `overestimation` at `z`: the quadratic through `z` and the two other points of support of the
/// canonical representation, integrated against the moments.
pub fn absorbance_fraction(moments: [f64; 4], z: f64, bias: f64, overestimation: f64) -> f64 {
    let m: [f64; 4] = std::array::from_fn(|i| moments[i] + (BIAS_MOMENTS[i] - moments[i]) * bias);
    // L·D·Lᵀ of the Hankel matrix, then the solution of B·c = (1, z, z²).
    let d2 = m[1] - m[0] * m[0];
    let l32 = (m[2] - m[0] * m[1]) / d2;
    let d3 = m[3] - m[1] * m[1] - l32 * l32 * d2;
    let y2 = (z - m[0]) / d2;
    let y3 = (z * z - m[1] - l32 * (z - m[0])) / d3;
    let c3 = y3;
    let c2 = y2 - l32 * c3;
    let c1 = 1.0 - m[0] * c2 - m[1] * c3;
    let (p, q) = (c2 / c3, c1 / c3);
    let r = (p * p * 0.25 - q).max(0.0).sqrt();
    let (z1, z2) = (-0.5 * p - r, -0.5 * p + r);
    let step = |x: f64| if x < z { 1.0 } else { 0.0 };
    let (f0, f1, f2) = (overestimation, step(z1), step(z2));
    let f01 = (f1 - f0) / (z1 - z);
    let f12 = (f2 - f1) / (z2 - z1);
    let f012 = (f12 - f01) / (z2 - z);
    let a2 = f012;
    let a1 = f01 - f012 * (z + z1);
    let a0 = f0 - f01 * z + f012 * z * z1;
    a0 + a1 * m[0] + a2 * m[1]
}

/// b0 and the absorbance-weighted power moments Σ a·zᵏ (k = 1..4) of `fragments`.
fn mboit_moments(fragments: &[&RefFragment], camera: &Camera) -> (f64, [f64; 4]) {
    let mut b0 = 0.0;
    let mut b = [0.0f64; 4];
    for f in fragments {
        let a = -(1.0 - f.alpha.min(MAX_ALPHA)).ln();
        let z = mboit_depth(camera, f.distance);
        b0 += a;
        for (k, bk) in b.iter_mut().enumerate() {
            *bk += a * z.powi(k as i32 + 1);
        }
    }
    (b0, b)
}

/// The transmittance the moments `(b0, b)` give in front of warped depth `z`.
fn mboit_transmittance((b0, b): (f64, [f64; 4]), z: f64, bias: f64, overestimation: f64) -> f64 {
    if b0 <= 0.0 {
        return 1.0;
    }
    let moments = b.map(|x| x / b0);
    (-b0 * absorbance_fraction(moments, z, bias, overestimation))
        .exp()
        .clamp(0.0, 1.0)
}

/// One sample's color over `background`: the fragments covering it, each weighted by α and its
/// transmittance `t(f)`, averaged over the coverage the sample's moments give.
fn mboit_resolve(
    fragments: &[&RefFragment],
    b0: f64,
    t: impl Fn(&RefFragment) -> f64,
    background: [f64; 3],
) -> [f64; 3] {
    if b0 <= 0.0 {
        return background;
    }
    let (mut sum, mut weights) = ([0.0f64; 3], 0.0f64);
    for f in fragments {
        let (alpha, t) = (f.alpha.min(MAX_ALPHA), t(f));
        for (s, c) in sum.iter_mut().zip(f.color) {
            *s += c * alpha * t;
        }
        weights += alpha * t;
    }
    let coverage = 1.0 - (-b0).exp();
    [0, 1, 2].map(|i| {
        let color = if weights > 0.0 { sum[i] / weights } else { 0.0 };
        color * coverage + background[i] * (1.0 - coverage)
    })
}

/// One pixel of `mboit` over `background`, from its fragments in any order.
pub fn mboit(
    fragments: &[RefFragment],
    background: [f64; 3],
    camera: &Camera,
    bias: f64,
    overestimation: f64,
) -> [f64; 3] {
    let all: Vec<&RefFragment> = fragments.iter().collect();
    let moments = mboit_moments(&all, camera);
    mboit_resolve(
        &all,
        moments.0,
        |f| {
            mboit_transmittance(
                moments,
                mboit_depth(camera, f.distance),
                bias,
                overestimation,
            )
        },
        background,
    )
}

/// One pixel of `mboit --msaa S` (fragments with their coverage masks): each sample's moments
/// from the fragments covering it; a fragment weighted by the mean of its covered samples'
/// transmittances at its depth; each sample resolved on its own, the samples averaged.
pub fn mboit_multisampled(
    fragments: &[RefFragment],
    background: [f64; 3],
    camera: &Camera,
    (bias, overestimation): (f64, f64),
    samples: u32,
) -> [f64; 3] {
    let covering = |s: u32| -> Vec<&RefFragment> {
        fragments
            .iter()
            .filter(|f| f.coverage & (1 << s) != 0)
            .collect()
    };
    let moments: Vec<(f64, [f64; 4])> = (0..samples)
        .map(|s| mboit_moments(&covering(s), camera))
        .collect();
    let t = |f: &RefFragment| {
        let z = mboit_depth(camera, f.distance);
        let covered: Vec<f64> = (0..samples)
            .filter(|s| f.coverage & (1 << s) != 0)
            .map(|s| mboit_transmittance(moments[s as usize], z, bias, overestimation))
            .collect();
        covered.iter().sum::<f64>() / covered.len().max(1) as f64
    };
    let mut sum = [0.0; 3];
    for s in 0..samples {
        let c = mboit_resolve(&covering(s), moments[s as usize].0, t, background);
        sum = std::array::from_fn(|i| sum[i] + c[i] / samples as f64);
    }
    sum
}
