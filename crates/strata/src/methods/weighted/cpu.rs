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
            options.frame.weighted.weight,
            f.alpha,
            f.distance,
            f.depth,
            options.frame.weighted.depth_scale,
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
/// (E\[z\], E\[z²\], E\[z³\], E\[z⁴\]), biased by `bias` toward `BIAS_MOMENTS`, with weight
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

/// The moments the bias pulls toward for 4, 6 and 8 power moments in 32-bit floats (the values
/// of the paper's code).
pub fn bias_moments(count: usize) -> &'static [f64] {
    match count {
        4 => &BIAS_MOMENTS,
        6 => &[0.0, 0.48, 0.0, 0.451, 0.0, 0.45],
        _ => &[
            0.0,
            0.75,
            0.0,
            0.676_666_666_666_666_6,
            0.0,
            0.63,
            0.0,
            0.600_303_030_303_030_3,
        ],
    }
}

/// The real roots, in ascending order, of the polynomial Σ cᵢ·xⁱ of degree 1 to 4 (`c` low to
/// high, the last coefficient nonzero), each bracketed between consecutive roots of its
/// derivative (or the Cauchy bound) and found by Newton's steps that bisection keeps inside the
/// bracket. The polynomial a Hankel system gives has only
/// real, simple roots; where rounding leaves fewer sign changes than its degree, the derivative's
/// roots where it comes nearest zero stand in.
pub fn polynomial_roots(c: &[f64]) -> Vec<f64> {
    let degree = c.len() - 1;
    if degree == 1 {
        return vec![-c[0] / c[1]];
    }
    let eval = |x: f64| c.iter().rev().fold(0.0, |acc, a| acc * x + a);
    let derivative: Vec<f64> = (1..=degree).map(|i| i as f64 * c[i]).collect();
    let critical = polynomial_roots(&derivative);
    let bound = 1.0
        + c[..degree]
            .iter()
            .map(|a| (a / c[degree]).abs())
            .fold(0.0, f64::max);
    let mut edges = vec![-bound];
    edges.extend(critical.iter().map(|x| x.clamp(-bound, bound)));
    edges.push(bound);
    let mut roots = Vec::with_capacity(degree);
    for pair in edges.windows(2) {
        let (mut lo, mut hi) = (pair[0], pair[1]);
        let (f_lo, f_hi) = (eval(lo), eval(hi));
        if f_lo * f_hi > 0.0 {
            continue;
        }
        let rising = f_hi > f_lo;
        let slope = |x: f64| derivative.iter().rev().fold(0.0, |acc: f64, a| acc * x + a);
        let mut x = 0.5 * (lo + hi);
        for _ in 0..ROOT_STEPS {
            let fx = eval(x);
            if fx == 0.0 {
                break;
            }
            if (fx < 0.0) == rising {
                lo = x;
            } else {
                hi = x;
            }
            let newton = x - fx / slope(x);
            let next = if newton > lo && newton < hi {
                newton
            } else {
                0.5 * (lo + hi)
            };
            let done = (next - x).abs() <= 1e-12 * x.abs().max(1.0);
            x = next;
            if done {
                break;
            }
        }
        roots.push(x);
    }
    let mut stand_ins = critical;
    stand_ins.sort_by(|a, b| eval(*a).abs().total_cmp(&eval(*b).abs()));
    roots.extend(
        stand_ins
            .into_iter()
            .take(degree.saturating_sub(roots.len())),
    );
    roots.truncate(degree);
    roots.sort_by(f64::total_cmp);
    roots
}

/// Steps per root at most: Newton's, kept inside the bracket by bisection (`mboit_roots` in
/// WGSL takes as many, converging to f32).
pub const ROOT_STEPS: u32 = 48;

/// [`absorbance_fraction`] for 6 or 8 power moments (E\[z\], …, E\[z^2n\]): the Hankel system
/// B·c = (1, z, …, zⁿ) solved through L·D·Lᵀ, the n other points of support as the roots of
/// Σ cᵢ·xⁱ, the interpolating polynomial of degree n through (z, η) and (xᵢ, \[xᵢ < z\]) in Newton
/// form, and its expectation under the moments.
pub fn absorbance_fraction_n(moments: &[f64], z: f64, bias: f64, overestimation: f64) -> f64 {
    let n = moments.len() / 2;
    let target = bias_moments(moments.len());
    let m = |k: usize| -> f64 {
        if k == 0 {
            1.0
        } else {
            moments[k - 1] + (target[k - 1] - moments[k - 1]) * bias
        }
    };
    let size = n + 1;
    let (mut l, mut d) = ([[0.0f64; 5]; 5], [0.0f64; 5]);
    for i in 0..size {
        for j in 0..=i {
            let s = m(i + j) - (0..j).map(|k| l[i][k] * l[j][k] * d[k]).sum::<f64>();
            if i == j {
                d[i] = s;
            } else {
                l[i][j] = s / d[j];
            }
        }
    }
    let mut c = [0.0f64; 5];
    for i in 0..size {
        c[i] = z.powi(i as i32) - (0..i).map(|k| l[i][k] * c[k]).sum::<f64>();
    }
    for i in 0..size {
        c[i] /= d[i];
    }
    for i in (0..size).rev() {
        c[i] -= (i + 1..size).map(|k| l[k][i] * c[k]).sum::<f64>();
    }
    let roots = polynomial_roots(&c[..size]);
    let (mut x, mut f) = ([0.0f64; 5], [0.0f64; 5]);
    x[0] = z;
    f[0] = overestimation;
    for (i, r) in roots.iter().enumerate() {
        x[i + 1] = *r;
        f[i + 1] = if *r < z { 1.0 } else { 0.0 };
    }
    // Divided differences in place: f[i] becomes f[x0, …, xi].
    for level in 1..size {
        for i in (level..size).rev() {
            f[i] = (f[i] - f[i - 1]) / (x[i] - x[i - level]);
        }
    }
    // Newton form to monomials: p ← p·(X − x_k) + f_k from the highest k down.
    let mut p = [0.0f64; 5];
    p[0] = f[n];
    for k in (0..n).rev() {
        for j in (1..size).rev() {
            p[j] = p[j - 1] - x[k] * p[j];
        }
        p[0] = f[k] - x[k] * p[0];
    }
    (0..size).map(|k| p[k] * m(k)).sum()
}

/// b0 and the absorbance-weighted power moments Σ a·zᵏ (k = 1..count) of `fragments`.
fn mboit_moments(fragments: &[&RefFragment], camera: &Camera, count: usize) -> (f64, Vec<f64>) {
    let mut b0 = 0.0;
    let mut b = vec![0.0f64; count];
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
/// Four moments by the closed form, six and eight by [`absorbance_fraction_n`].
fn mboit_transmittance((b0, b): &(f64, Vec<f64>), z: f64, bias: f64, overestimation: f64) -> f64 {
    if *b0 <= 0.0 {
        return 1.0;
    }
    let moments: Vec<f64> = b.iter().map(|x| x / b0).collect();
    let fraction = match moments[..] {
        [m1, m2, m3, m4] => absorbance_fraction([m1, m2, m3, m4], z, bias, overestimation),
        _ => absorbance_fraction_n(&moments, z, bias, overestimation),
    };
    (-b0 * fraction).exp().clamp(0.0, 1.0)
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

/// `mboit`'s settings: the moment bias β, the overestimation η, and the power moments (4, 6, 8).
#[derive(Clone, Copy, Debug)]
pub struct MboitSettings {
    /// The moment bias β.
    pub bias: f64,
    /// The overestimation η.
    pub overestimation: f64,
    /// Power moments: 4, 6 or 8.
    pub moments: usize,
}

/// One pixel of `mboit` over `background`, from its fragments in any order.
pub fn mboit(
    fragments: &[RefFragment],
    background: [f64; 3],
    camera: &Camera,
    settings: MboitSettings,
) -> [f64; 3] {
    let all: Vec<&RefFragment> = fragments.iter().collect();
    let moments = mboit_moments(&all, camera, settings.moments);
    mboit_resolve(
        &all,
        moments.0,
        |f| {
            mboit_transmittance(
                &moments,
                mboit_depth(camera, f.distance),
                settings.bias,
                settings.overestimation,
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
    settings: MboitSettings,
    samples: u32,
) -> [f64; 3] {
    let covering = |s: u32| -> Vec<&RefFragment> {
        fragments
            .iter()
            .filter(|f| f.coverage & (1 << s) != 0)
            .collect()
    };
    let moments: Vec<(f64, Vec<f64>)> = (0..samples)
        .map(|s| mboit_moments(&covering(s), camera, settings.moments))
        .collect();
    let t = |f: &RefFragment| {
        let z = mboit_depth(camera, f.distance);
        let covered: Vec<f64> = (0..samples)
            .filter(|s| f.coverage & (1 << s) != 0)
            .map(|s| {
                mboit_transmittance(
                    &moments[s as usize],
                    z,
                    settings.bias,
                    settings.overestimation,
                )
            })
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
