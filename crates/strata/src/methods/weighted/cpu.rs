//! The CPU closed form of weighted blended OIT (McGuire & Bavoil 2013, eq. 6 with the weights of
//! eqs. 7–10), in f64: what `wboit` computes, up to its f16 targets.

use crate::frame::{RenderOptions, Weight};
use crate::resolve::RefFragment;

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
