//! The CPU closed forms of the approximate methods, in f64: weighted blended OIT (McGuire & Bavoil
//! 2013, eq. 6 with the weights of eqs. 7–10), what `wboit` computes up to its f16 targets;
//! moment-based OIT with four power moments (Münstermann et al. 2018), what `mboit` computes up to
//! its f32 moments and f16 accumulation; stochastic transparency (Enderton et al. 2011) with the
//! same stipples as `stochastic`, up to its f16 accumulation; and the weighted average (Bavoil &
//! Myers 2008), what `wavg` computes up to its f16 targets.

use crate::frame::RenderOptions;
use crate::methods::weighted::Weight;
use crate::methods::weighted::WeightedOptions;
use crate::methods::weighted::{Moments, Opacity};
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
            options.frame.family::<WeightedOptions>().weight,
            f.alpha,
            f.distance,
            f.depth,
            options.frame.family::<WeightedOptions>().depth_scale,
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

/// The average over a pixel's `samples` of `pixel` of the fragments covering each (all of
/// them when single-sampled): how a composite of per-sample results averages them.
pub fn per_sample(
    fragments: &[RefFragment],
    samples: u32,
    pixel: impl Fn(&[RefFragment]) -> [f64; 3],
) -> [f64; 3] {
    if samples <= 1 {
        return pixel(fragments);
    }
    let mut sum = [0.0; 3];
    for sample in 0..samples {
        let own: Vec<_> = fragments
            .iter()
            .filter(|f| f.coverage & (1 << sample) != 0)
            .copied()
            .collect();
        let c = pixel(&own);
        sum = std::array::from_fn(|i| sum[i] + c[i] / samples as f64);
    }
    sum
}

/// A pixel's sums for `wavg`: Σ α·c, Σ α, the count n and Π(1 − α).
fn wavg_sums(fragments: &[RefFragment]) -> ([f64; 3], f64, f64, f64) {
    let (mut sum, mut alpha, mut product) = ([0.0f64; 3], 0.0f64, 1.0f64);
    for f in fragments {
        for (s, c) in sum.iter_mut().zip(f.color) {
            *s += c * f.alpha;
        }
        alpha += f.alpha;
        product *= 1.0 - f.alpha;
    }
    (sum, alpha, fragments.len() as f64, product)
}

/// A pixel's transmittance by each of `wavg`'s opacities: (1 − ᾱ)ⁿ with ᾱ = Σα / n, and
/// Π(1 − α); both 1 without fragments.
pub fn wavg_transmittances(fragments: &[RefFragment]) -> (f64, f64) {
    let (_, alpha, n, product) = wavg_sums(fragments);
    match n > 0.0 {
        true => ((1.0 - (alpha / n).clamp(0.0, 1.0)).powf(n), product),
        false => (1.0, 1.0),
    }
}

/// One pixel over `background` as `wavg` composites it (Bavoil & Myers 2008): the average color
/// Σαc / Σα over the opacity 1 − T, T by `opacity` (see [`wavg_transmittances`]). The fragments
/// may come in any order.
pub fn wavg(fragments: &[RefFragment], background: [f64; 3], opacity: Opacity) -> [f64; 3] {
    let (sum, alpha, _, _) = wavg_sums(fragments);
    let (average, product) = wavg_transmittances(fragments);
    let t = match opacity {
        Opacity::Average => average,
        Opacity::Product => product,
    };
    [0, 1, 2].map(|i| sum[i] / alpha.max(1e-4) * (1.0 - t) + background[i] * t)
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

/// A fragment's absorbance −ln(1 − α), α capped as the GPU caps it.
fn absorbance(f: &RefFragment) -> f64 {
    -(1.0 - f.alpha.min(MAX_ALPHA)).ln()
}

/// A warped depth z on the Haar basis's [0, 1) within a pixel's range `(nearest, farthest)` (the
/// farthest into the last bin, a pixel of one depth at 0); the twin of `haar_position` in
/// mboit_math.wgsl.
pub fn haar_position(z: f64, (nearest, farthest): (f64, f64)) -> f64 {
    let span = farthest - nearest;
    if span <= 0.0 {
        return 0.0;
    }
    ((z - nearest) / span).clamp(0.0, 1.0 - f64::EPSILON)
}

/// The nearest and farthest warped depth of a pixel's fragments (wavelet's first pass).
fn depth_bounds(fragments: &[RefFragment], camera: &Camera) -> (f64, f64) {
    fragments.iter().fold((2.0, -2.0), |(lo, hi), f| {
        let z = mboit_depth(camera, f.distance);
        (lo.min(z), hi.max(z))
    })
}

/// Haar coefficient `i` of the unit step \[x > s\] on [0, 1): i = 0 the scaling function's, 1 − s;
/// i = 2^j + k the wavelet ψ_jk's, 2^{−j/2}·(−t or t − 1) for t = 2^j·s − k in [0, ½) or [½, 1),
/// 0 outside.
pub fn haar_step_coefficient(s: f64, i: u32) -> f64 {
    if i == 0 {
        return 1.0 - s;
    }
    let level = i.ilog2();
    let scale = f64::from(1u32 << level);
    let t = scale * s - f64::from(i - (1 << level));
    if t <= 0.0 || t >= 1.0 {
        return 0.0;
    }
    (if t < 0.5 { -t } else { t - 1.0 }) / scale.sqrt()
}

/// Haar basis function `i` at x: 1 for the scaling function, ±2^{j/2} on the halves of ψ_jk's
/// bin.
pub fn haar_basis(x: f64, i: u32) -> f64 {
    if i == 0 {
        return 1.0;
    }
    let level = i.ilog2();
    let scale = f64::from(1u32 << level);
    let t = scale * x - f64::from(i - (1 << level));
    if !(0.0..1.0).contains(&t) {
        return 0.0;
    }
    (if t < 0.5 { 1.0 } else { -1.0 }) * scale.sqrt()
}

/// b0 and the absorbance-weighted moments of `fragments`: power moments Σ a·zᵏ (k = 1..n), or
/// trigonometric ones Σ a·e^{ikφ(z)} as (re, im) pairs.
fn mboit_moments(
    fragments: &[&RefFragment],
    camera: &Camera,
    kind: Moments,
    bounds: (f64, f64),
) -> (f64, Vec<f64>) {
    let mut b0 = 0.0;
    let mut b = vec![0.0f64; kind.reals() as usize];
    for f in fragments {
        let a = absorbance(f);
        let z = mboit_depth(camera, f.distance);
        b0 += a;
        match kind {
            Moments::Power(_) => {
                for (k, bk) in b.iter_mut().enumerate() {
                    *bk += a * z.powi(k as i32 + 1);
                }
            }
            Moments::Trigonometric(_) => {
                let phi = trig_angle(z);
                for (k, pair) in b.chunks_exact_mut(2).enumerate() {
                    let angle = (k + 1) as f64 * phi;
                    pair[0] += a * angle.cos();
                    pair[1] += a * angle.sin();
                }
            }
            Moments::Haar(_) => {
                let s = haar_position(z, bounds);
                for (i, c) in b.iter_mut().enumerate() {
                    *c += a * haar_step_coefficient(s, i as u32);
                }
            }
        }
    }
    (b0, b)
}

/// The transmittance the moments `(b0, b)` of `kind` give in front of warped depth `z` for a
/// fragment of absorbance `own`. Four power moments by the closed form, six and eight by
/// [`absorbance_fraction_n`], trigonometric ones by [`trig_absorbance_fraction`] (biased toward
/// the uniform distribution on the circle), Haar coefficients by evaluating the projection less
/// the fragment's own step.
fn mboit_transmittance(
    (b0, b): &(f64, Vec<f64>),
    kind: Moments,
    (z, own, bounds): (f64, f64, (f64, f64)),
    (bias, overestimation): (f64, f64),
) -> f64 {
    if *b0 <= 0.0 {
        return 1.0;
    }
    if let Moments::Haar(_) = kind {
        let x = haar_position(z, bounds);
        let absorbance: f64 = (0..b.len() as u32)
            .map(|i| (b[i as usize] - own * haar_step_coefficient(x, i)) * haar_basis(x, i))
            .sum();
        return (-absorbance.clamp(0.0, *b0)).exp();
    }
    let moments: Vec<f64> = b.iter().map(|x| x / b0).collect();
    let fraction = match (kind, &moments[..]) {
        (Moments::Trigonometric(_), _) => {
            let biased: Vec<[f64; 2]> = std::iter::once([1.0, 0.0])
                .chain(
                    moments
                        .chunks_exact(2)
                        .map(|m| [(1.0 - bias) * m[0], (1.0 - bias) * m[1]]),
                )
                .collect();
            trig_absorbance_fraction(&biased, trig_angle(z), overestimation)
        }
        (_, &[m1, m2, m3, m4]) => absorbance_fraction([m1, m2, m3, m4], z, bias, overestimation),
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

/// `mboit`'s settings: the moment bias β, the overestimation η, and the moments.
#[derive(Clone, Copy, Debug)]
pub struct MboitSettings {
    /// The moment bias β.
    pub bias: f64,
    /// The overestimation η.
    pub overestimation: f64,
    /// Power moments 4, 6 or 8, or trigonometric moments 2, 3 or 4.
    pub moments: Moments,
}

/// One pixel of `mboit` over `background`, from its fragments in any order.
pub fn mboit(
    fragments: &[RefFragment],
    background: [f64; 3],
    camera: &Camera,
    settings: MboitSettings,
) -> [f64; 3] {
    let all: Vec<&RefFragment> = fragments.iter().collect();
    let bounds = depth_bounds(fragments, camera);
    let moments = mboit_moments(&all, camera, settings.moments, bounds);
    mboit_resolve(
        &all,
        moments.0,
        |f| {
            mboit_transmittance(
                &moments,
                settings.moments,
                (mboit_depth(camera, f.distance), absorbance(f), bounds),
                (settings.bias, settings.overestimation),
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
    // wavelet's depth range is the pixel's, over all its samples.
    let bounds = depth_bounds(fragments, camera);
    let moments: Vec<(f64, Vec<f64>)> = (0..samples)
        .map(|s| mboit_moments(&covering(s), camera, settings.moments, bounds))
        .collect();
    let t = |f: &RefFragment| {
        let z = mboit_depth(camera, f.distance);
        let covered: Vec<f64> = (0..samples)
            .filter(|s| f.coverage & (1 << s) != 0)
            .map(|s| {
                mboit_transmittance(
                    &moments[s as usize],
                    settings.moments,
                    (z, absorbance(f), bounds),
                    (settings.bias, settings.overestimation),
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

/// `hash_u32` of stochastic.wgsl: one PCG step and its output permutation.
pub fn hash_u32(x: u32) -> u32 {
    let state = x.wrapping_mul(747_796_405).wrapping_add(2_891_336_453);
    let word = ((state >> ((state >> 28) + 4)) ^ state).wrapping_mul(277_803_737);
    (word >> 22) ^ word
}

/// `stipple` of stochastic.wgsl: the samples (of `samples`) a fragment of opacity `alpha` of
/// primitive `prim` at pixel `pixel` stipples in pass `seed`, in the shader's f32 arithmetic.
pub fn stipple(pixel: u32, prim: u32, alpha: f32, seed: u32, samples: u32) -> u32 {
    let mut h = hash_u32(pixel ^ hash_u32(prim ^ hash_u32(seed)));
    let scaled = alpha.clamp(0.0, 1.0) * samples as f32;
    let mut n = scaled as u32;
    if (h >> 8) as f32 * (1.0 / 16_777_216.0) < scaled - n as f32 {
        n += 1;
    }
    let n = n.min(samples);
    let mut free = (1u32 << samples) - 1;
    let mut mask = 0;
    for i in 0..n {
        h = hash_u32(h);
        let skip = (h % (samples - i)) as usize;
        let bit = (0..samples)
            .map(|b| 1u32 << b)
            .filter(|bit| free & bit != 0)
            .nth(skip)
            .expect("n ≤ samples leaves a free sample");
        mask |= bit;
        free &= !bit;
    }
    mask
}

/// One pixel (row-major index `pixel`) of `stochastic` with `samples` per pixel and `passes`
/// passes, over `background`: per pass each sample's nearest stippling depth, the sums of α·c
/// and α over the samples where each fragment is not behind it, then that average times the
/// coverage 1 − Π(1 − α) averaged over the samples. The fragments carry their sample coverage.
pub fn stochastic(
    fragments: &[RefFragment],
    pixel: u32,
    (samples, passes): (u32, u32),
    background: [f64; 3],
) -> [f64; 3] {
    let covers = |f: &RefFragment, s: u32| f.coverage as u32 & (1 << s) != 0;
    let mut sum = [0.0f64; 4];
    for pass in 0..passes {
        let mut nearest = vec![1.0f64; samples as usize];
        for f in fragments {
            let mask = stipple(pixel, f.prim, f.alpha as f32, pass, samples);
            for s in (0..samples).filter(|&s| mask & (1 << s) != 0 && covers(f, s)) {
                nearest[s as usize] = nearest[s as usize].min(f.depth);
            }
        }
        for f in fragments {
            for s in 0..samples {
                if covers(f, s) && f.depth <= nearest[s as usize] {
                    for (total, c) in sum.iter_mut().zip(f.color) {
                        *total += f.alpha * c;
                    }
                    sum[3] += f.alpha;
                }
            }
        }
    }
    let transmittance: f64 = (0..samples)
        .map(|s| {
            fragments
                .iter()
                .filter(|f| covers(f, s))
                .map(|f| 1.0 - f.alpha)
                .product::<f64>()
        })
        .sum::<f64>()
        / samples as f64;
    let coverage = 1.0 - transmittance;
    [0, 1, 2].map(|c| {
        let color = if sum[3] > 0.0 {
            sum[c] / sum[3] * coverage
        } else {
            0.0
        };
        color + transmittance * background[c]
    })
}

/// The wrapping zone of trigonometric moments: the arc of the unit circle, θ = π/10, left
/// between the farthest warped depth and the nearest (`TRIG_WRAPPING_ZONE` in mboit_math.wgsl).
pub const TRIG_WRAPPING_ZONE: f64 = std::f64::consts::PI / 10.0;

/// `trig_angle`: a warped depth's angle on the unit circle, in [0, 2π − θ].
pub fn trig_angle(z: f64) -> f64 {
    (z + 1.0) * (std::f64::consts::PI - 0.5 * TRIG_WRAPPING_ZONE)
}

type Complex = [f64; 2];

fn c_mul(a: Complex, b: Complex) -> Complex {
    [a[0] * b[0] - a[1] * b[1], a[0] * b[1] + a[1] * b[0]]
}

fn c_conj(a: Complex) -> Complex {
    [a[0], -a[1]]
}

fn c_sub(a: Complex, b: Complex) -> Complex {
    [a[0] - b[0], a[1] - b[1]]
}

fn c_scale(a: Complex, s: f64) -> Complex {
    [a[0] * s, a[1] * s]
}

fn c_div(a: Complex, b: Complex) -> Complex {
    c_scale(c_mul(a, c_conj(b)), 1.0 / (b[0] * b[0] + b[1] * b[1]))
}

/// A point's angle in [0, 2π).
fn c_angle(a: Complex) -> f64 {
    let t = a[1].atan2(a[0]);
    if t < 0.0 {
        t + std::f64::consts::TAU
    } else {
        t
    }
}

/// Rounds of Aberth's iteration (`TRIG_ROOT_ROUNDS`).
const TRIG_ROOT_ROUNDS: usize = 24;

/// `trig_kernel_roots`: the roots of the monic polynomial Σ a_k·x^k (a\[n\] = 1) by Aberth's
/// iteration from points spread over the unit circle.
fn trig_kernel_roots(a: &[Complex]) -> Vec<Complex> {
    let n = a.len() - 1;
    let mut r: Vec<Complex> = (0..n)
        .map(|i| {
            let t = std::f64::consts::TAU * (i as f64 + 0.25) / n as f64;
            [t.cos(), t.sin()]
        })
        .collect();
    for _ in 0..TRIG_ROOT_ROUNDS {
        for i in 0..n {
            let (mut value, mut slope) = (a[n], [0.0, 0.0]);
            for k in (0..n).rev() {
                let s = c_mul(slope, r[i]);
                slope = [s[0] + value[0], s[1] + value[1]];
                let v = c_mul(value, r[i]);
                value = [v[0] + a[k][0], v[1] + a[k][1]];
            }
            let ratio = c_div(value, slope);
            let mut repulsion = [0.0, 0.0];
            for j in (0..n).filter(|&j| j != i) {
                let q = c_div([1.0, 0.0], c_sub(r[i], r[j]));
                repulsion = [repulsion[0] + q[0], repulsion[1] + q[1]];
            }
            let step = c_div(ratio, c_sub([1.0, 0.0], c_mul(ratio, repulsion)));
            if step[0].is_finite() && step[1].is_finite() {
                r[i] = c_sub(r[i], step);
            }
        }
    }
    r
}

/// `trig_absorbance_fraction`: the fraction of the absorbance in front of the circle point at
/// angle `phi`, from biased normalized trigonometric moments `b` (b\[0\] = 1, n = b.len() − 1
/// complex moments), with weight `overestimation` at the point itself.
pub fn trig_absorbance_fraction(b: &[Complex], phi: f64, overestimation: f64) -> f64 {
    let n = b.len() - 1;
    let toeplitz = |j: usize, k: usize| if j >= k { b[j - k] } else { c_conj(b[k - j]) };
    let mut l = [[[0.0f64; 2]; 5]; 5];
    let mut d = [0.0f64; 5];
    for k in 0..=n {
        for j in 0..k {
            let mut s = toeplitz(k, j);
            for m in 0..j {
                s = c_sub(s, c_scale(c_mul(l[k][m], c_conj(l[j][m])), d[m]));
            }
            l[k][j] = c_scale(s, 1.0 / d[j]);
        }
        d[k] = 1.0
            - (0..k)
                .map(|m| d[m] * (l[k][m][0].powi(2) + l[k][m][1].powi(2)))
                .sum::<f64>();
    }
    let u = [phi.cos(), phi.sin()];
    let mut c = [[0.0f64; 2]; 5];
    let mut power = [1.0, 0.0];
    for k in 0..=n {
        let mut y = power;
        for m in 0..k {
            y = c_sub(y, c_mul(l[k][m], c[m]));
        }
        c[k] = y;
        power = c_mul(power, u);
    }
    for k in 0..=n {
        c[k] = c_scale(c[k], 1.0 / d[k]);
    }
    for k in (0..=n).rev() {
        for m in k + 1..=n {
            c[k] = c_sub(c[k], c_mul(c_conj(l[m][k]), c[m]));
        }
    }
    let kernel: Vec<Complex> = (0..=n).map(|k| c_div(c_conj(c[k]), c_conj(c[n]))).collect();
    let roots = trig_kernel_roots(&kernel);
    let mut x = [[0.0f64; 2]; 5];
    let mut dd = [[0.0f64; 2]; 5];
    x[0] = u;
    dd[0] = [overestimation, 0.0];
    let zone = std::f64::consts::TAU - TRIG_WRAPPING_ZONE;
    for i in 1..=n {
        x[i] = roots[i - 1];
        let a = c_angle(x[i]);
        let front = if a < phi { 1.0 } else { 0.0 };
        let ramp = ((a - zone) / TRIG_WRAPPING_ZONE).clamp(0.0, 1.0);
        dd[i] = [front + ramp, 0.0];
    }
    for level in 1..=n {
        for i in (level..=n).rev() {
            dd[i] = c_div(c_sub(dd[i], dd[i - 1]), c_sub(x[i], x[i - level]));
        }
    }
    let mut p = [[0.0f64; 2]; 5];
    p[0] = dd[n];
    for i in 1..=n {
        let at = n - i;
        for k in (1..=i).rev() {
            p[k] = c_sub(p[k - 1], c_mul(p[k], x[at]));
        }
        p[0] = c_sub(dd[at], c_mul(p[0], x[at]));
    }
    let s: f64 = (0..=n).map(|k| c_mul(p[k], b[k])[0]).sum();
    if s.is_nan() {
        0.0
    } else {
        s.clamp(0.0, 1.0)
    }
}
