#define_import_path strata::weighted::mboit_math
#import strata::scene::{frame}
#import strata::composite::{view_distance}
#import strata::weighted::mboit_params::{MboitParams}

// Moment-based OIT (Münstermann et al. 2018): the moments a fragment adds and the transmittance
// reconstructed from four, six or eight power moments. Keep the reconstructions in sync with
// `cpu::absorbance_fraction` (four, closed form) and `cpu::absorbance_fraction_n` (six and
// eight).

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

// Steps per root at most (cpu::ROOT_STEPS): Newton's, bisection keeping them in the bracket.
const MBOIT_ROOT_STEPS: u32 = 48u;

// The k-th moment (k ≥ 1) the bias pulls toward, for 6 or 8 power moments (cpu::bias_moments).
fn mboit_bias_moment(count: u32, k: u32) -> f32 {
    if (k & 1u) == 1u {
        return 0.0;
    }
    var six = array<f32, 3>(0.48, 0.451, 0.45);
    var eight = array<f32, 4>(0.75, 0.67666666666666664, 0.63, 0.60030303030303034);
    if count == 6u {
        return six[k / 2u - 1u];
    }
    return eight[k / 2u - 1u];
}

fn mboit_polynomial(c: array<f32, 5>, degree: u32, x: f32) -> f32 {
    var v = c[degree];
    for (var i = degree; i > 0u; i--) {
        v = v * x + c[i - 1u];
    }
    return v;
}

// The real roots, ascending, of Σ cᵢ·xⁱ of degree n (2 ≤ n ≤ 4): each root of a derivative
// brackets the next derivative's (cpu::polynomial_roots), from the linear one up, and Newton's
// steps, bisected back into the bracket when they leave it, find the root in it; where rounding
// leaves fewer sign changes than the degree, the critical points nearest zero stand in.
fn mboit_roots(c: array<f32, 5>, n: u32) -> array<f32, 4> {
    // chain[j]: the j-th derivative, of degree n − j.
    var chain: array<array<f32, 5>, 5>;
    chain[0] = c;
    for (var j = 1u; j < n; j++) {
        for (var i = 0u; i <= n - j; i++) {
            chain[j][i] = f32(i + 1u) * chain[j - 1u][i + 1u];
        }
    }
    var roots: array<f32, 4>;
    roots[0] = -chain[n - 1u][0] / chain[n - 1u][1];
    var count = 1u;
    for (var degree = 2u; degree <= n; degree++) {
        let p = chain[n - degree];
        var bound = 0.0;
        for (var i = 0u; i < degree; i++) {
            bound = max(bound, abs(p[i] / p[degree]));
        }
        bound += 1.0;
        var edges: array<f32, 6>;
        edges[0] = -bound;
        for (var i = 0u; i < count; i++) {
            edges[i + 1u] = clamp(roots[i], -bound, bound);
        }
        edges[count + 1u] = bound;
        var found: array<f32, 4>;
        var nf = 0u;
        for (var e = 0u; e <= count; e++) {
            var lo = edges[e];
            var hi = edges[e + 1u];
            let f_lo = mboit_polynomial(p, degree, lo);
            let f_hi = mboit_polynomial(p, degree, hi);
            if f_lo * f_hi > 0.0 || nf >= degree {
                continue;
            }
            let rising = f_hi > f_lo;
            let slope = chain[n - degree + 1u];
            var x = 0.5 * (lo + hi);
            for (var it = 0u; it < MBOIT_ROOT_STEPS; it++) {
                let fx = mboit_polynomial(p, degree, x);
                if fx == 0.0 {
                    break;
                }
                if (fx < 0.0) == rising {
                    lo = x;
                } else {
                    hi = x;
                }
                let newton = x - fx / mboit_polynomial(slope, degree - 1u, x);
                // A step out of the bracket (or not a number) bisects instead.
                let next = select(0.5 * (lo + hi), newton, newton > lo && newton < hi);
                let done = abs(next - x) <= 1e-7 * max(abs(x), 1.0);
                x = next;
                if done {
                    break;
                }
            }
            found[nf] = x;
            nf++;
        }
        var used = 0u;
        for (var guard = 0u; guard < 4u; guard++) {
            if nf >= degree {
                break;
            }
            var best = 0u;
            var best_value = -1.0;
            for (var i = 0u; i < count; i++) {
                let v = abs(mboit_polynomial(p, degree, roots[i]));
                if (used & (1u << i)) == 0u && (best_value < 0.0 || v < best_value) {
                    best = i;
                    best_value = v;
                }
            }
            used |= 1u << best;
            found[nf] = roots[best];
            nf++;
        }
        // Ascending (insertion sort of at most four).
        for (var i = 1u; i < degree; i++) {
            let x = found[i];
            var k = i;
            while k > 0u {
                if !(found[k - 1u] > x) {
                    break;
                }
                found[k] = found[k - 1u];
                k--;
            }
            found[k] = x;
        }
        roots = found;
        count = degree;
    }
    return roots;
}

// mboit_absorbance_fraction for 6 or 8 normalized power moments (`count`; cpu::absorbance_fraction_n):
// the Hankel system through L·D·Lᵀ, the other points of support as the roots of its solution,
// the interpolating polynomial through (z, η) and (xᵢ, [xᵢ < z]) in Newton form, and its
// expectation.
fn mboit_absorbance_fraction_n(moments: array<f32, 8>, count: u32, z: f32) -> f32 {
    let n = count / 2u;
    let size = n + 1u;
    var m: array<f32, 9>;
    m[0] = 1.0;
    for (var k = 1u; k <= count; k++) {
        m[k] = mix(moments[k - 1u], mboit_bias_moment(count, k), mp.bias);
    }
    var l: array<array<f32, 5>, 5>;
    var d: array<f32, 5>;
    for (var i = 0u; i < size; i++) {
        for (var j = 0u; j <= i; j++) {
            var s = m[i + j];
            for (var k = 0u; k < j; k++) {
                s -= l[i][k] * l[j][k] * d[k];
            }
            if i == j {
                d[i] = s;
            } else {
                l[i][j] = s / d[j];
            }
        }
    }
    var c: array<f32, 5>;
    var power = 1.0;
    for (var i = 0u; i < size; i++) {
        var v = power;
        for (var k = 0u; k < i; k++) {
            v -= l[i][k] * c[k];
        }
        c[i] = v;
        power *= z;
    }
    for (var i = 0u; i < size; i++) {
        c[i] /= d[i];
    }
    for (var i = size; i > 0u; i--) {
        for (var k = i; k < size; k++) {
            c[i - 1u] -= l[k][i - 1u] * c[k];
        }
    }
    let roots = mboit_roots(c, n);
    var x: array<f32, 5>;
    var f: array<f32, 5>;
    x[0] = z;
    f[0] = mp.overestimation;
    for (var i = 0u; i < n; i++) {
        x[i + 1u] = roots[i];
        f[i + 1u] = select(0.0, 1.0, roots[i] < z);
    }
    for (var level = 1u; level < size; level++) {
        for (var i = size - 1u; i >= level; i--) {
            f[i] = (f[i] - f[i - 1u]) / (x[i] - x[i - level]);
        }
    }
    var p: array<f32, 5>;
    p[0] = f[n];
    for (var k = n; k > 0u; k--) {
        let xk = x[k - 1u];
        for (var j = size - 1u; j > 0u; j--) {
            p[j] = p[j - 1u] - xk * p[j];
        }
        p[0] = f[k - 1u] - xk * p[0];
    }
    var fraction = 0.0;
    for (var k = 0u; k < size; k++) {
        fraction += p[k] * m[k];
    }
    return fraction;
}

// Transmittance in front of warped depth z from b0 and 6 or 8 moments.
fn mboit_transmittance_n(b0: f32, b: array<f32, 8>, count: u32, z: f32) -> f32 {
    if b0 <= 0.0 {
        return 1.0;
    }
    var normalized: array<f32, 8>;
    for (var k = 0u; k < count; k++) {
        normalized[k] = b[k] / b0;
    }
    return clamp(exp(-b0 * mboit_absorbance_fraction_n(normalized, count, z)), 0.0, 1.0);
}

// Trigonometric moments (`--moments trig2|trig3|trig4`, n = 2, 3, 4 complex moments): a warped
// depth z becomes the point u = e^{iφ} of the unit circle, φ = (z + 1)·(π − θ/2), so depths fill
// the circle but for the wrapping zone, an arc of θ = π/10 between the farthest depth and the
// nearest. A fragment adds a·u^j (j = 1..n, as (re, im) pairs) to the moments. Keep these with
// `cpu::trig_absorbance_fraction`.
const TRIG_WRAPPING_ZONE: f32 = 0.31415927;
const TRIG_PI: f32 = 3.14159265;

fn trig_angle(z: f32) -> f32 {
    return (z + 1.0) * (TRIG_PI - 0.5 * TRIG_WRAPPING_ZONE);
}

fn c_mul(a: vec2<f32>, b: vec2<f32>) -> vec2<f32> {
    return vec2<f32>(a.x * b.x - a.y * b.y, a.x * b.y + a.y * b.x);
}

fn c_conj(a: vec2<f32>) -> vec2<f32> {
    return vec2<f32>(a.x, -a.y);
}

fn c_div(a: vec2<f32>, b: vec2<f32>) -> vec2<f32> {
    return c_mul(a, c_conj(b)) / dot(b, b);
}

// A point's angle on the circle in [0, 2π).
fn c_angle(a: vec2<f32>) -> f32 {
    let t = atan2(a.y, a.x);
    return select(t, t + 2.0 * TRIG_PI, t < 0.0);
}

// Entry (j, k) of the Hermitian Toeplitz matrix of the moments `b` (b[0] = 1).
fn toeplitz(b: array<vec2<f32>, 5>, j: u32, k: u32) -> vec2<f32> {
    if j >= k {
        return b[j - k];
    }
    return c_conj(b[k - j]);
}

// The fraction of the absorbance in front of the circle point at angle `phi`, from the biased
// normalized moments `b` (b[0] = 1) of `n` ≤ 4: the canonical representation of the moments
// through u = e^{iφ} — the kernel vector c = B⁻¹·(1, u, …, uⁿ) by L·D·Lᴴ, the other points of
// support as the roots of Σ conj(c_k)·x^k (on the circle; Aberth's iteration, bounded), their
// weights summed through the polynomial that interpolates the value of each point (η at u; 1 for
// a root before u, 0 after, ramped across the wrapping zone) and the moments.
fn trig_absorbance_fraction(b: array<vec2<f32>, 5>, n: u32, phi: f32) -> f32 {
    var l: array<array<vec2<f32>, 5>, 5>;
    var d: array<f32, 5>;
    for (var k = 0u; k <= n; k++) {
        for (var j = 0u; j < k; j++) {
            var s = toeplitz(b, k, j);
            for (var m = 0u; m < j; m++) {
                s -= d[m] * c_mul(l[k][m], c_conj(l[j][m]));
            }
            l[k][j] = s / d[j];
        }
        var dk = 1.0;
        for (var m = 0u; m < k; m++) {
            dk -= d[m] * dot(l[k][m], l[k][m]);
        }
        d[k] = dk;
    }
    let u = vec2<f32>(cos(phi), sin(phi));
    var c: array<vec2<f32>, 5>;
    var power = vec2<f32>(1.0, 0.0);
    for (var k = 0u; k <= n; k++) {
        var y = power;
        for (var m = 0u; m < k; m++) {
            y -= c_mul(l[k][m], c[m]);
        }
        c[k] = y;
        power = c_mul(power, u);
    }
    for (var k = 0u; k <= n; k++) {
        c[k] /= d[k];
    }
    for (var i = 0u; i <= n; i++) {
        let k = n - i;
        for (var m = k + 1u; m <= n; m++) {
            c[k] -= c_mul(c_conj(l[m][k]), c[m]);
        }
    }
    // The monic kernel polynomial: coefficients conj(c_k) / conj(c_n).
    var kernel: array<vec2<f32>, 5>;
    for (var k = 0u; k <= n; k++) {
        kernel[k] = c_div(c_conj(c[k]), c_conj(c[n]));
    }
    let roots = trig_kernel_roots(kernel, n);
    // Newton's divided differences through (u, η) and (r_i, f_i), then the monomial form.
    var x: array<vec2<f32>, 5>;
    var dd: array<vec2<f32>, 5>;
    x[0] = u;
    dd[0] = vec2<f32>(mp.overestimation, 0.0);
    for (var i = 1u; i <= n; i++) {
        x[i] = roots[i - 1u];
        let a = c_angle(x[i]);
        let front = select(0.0, 1.0, a < phi);
        let ramp = clamp((a - (2.0 * TRIG_PI - TRIG_WRAPPING_ZONE)) / TRIG_WRAPPING_ZONE, 0.0, 1.0);
        dd[i] = vec2<f32>(front + ramp, 0.0);
    }
    for (var level = 1u; level <= n; level++) {
        for (var i = n; i >= level; i--) {
            dd[i] = c_div(dd[i] - dd[i - 1u], x[i] - x[i - level]);
        }
    }
    var p: array<vec2<f32>, 5>;
    p[0] = dd[n];
    for (var i = 1u; i <= n; i++) {
        // p ← p·(x − x_{n−i}) + dd_{n−i}, degree i.
        let at = n - i;
        for (var k = i; k >= 1u; k--) {
            p[k] = p[k - 1u] - c_mul(p[k], x[at]);
        }
        p[0] = dd[at] - c_mul(p[0], x[at]);
    }
    var s = 0.0;
    for (var k = 0u; k <= n; k++) {
        s += c_mul(p[k], b[k]).x;
    }
    return select(clamp(s, 0.0, 1.0), 0.0, s != s);
}

// The roots of the monic polynomial Σ a_k·x^k of degree n (a[n] = 1) by Aberth's iteration from
// points spread over the unit circle, where these roots lie: a fixed number of rounds.
fn trig_kernel_roots(a: array<vec2<f32>, 5>, n: u32) -> array<vec2<f32>, 4> {
    var r: array<vec2<f32>, 4>;
    for (var i = 0u; i < n; i++) {
        let t = 2.0 * TRIG_PI * (f32(i) + 0.25) / f32(n);
        r[i] = vec2<f32>(cos(t), sin(t));
    }
    for (var round = 0u; round < TRIG_ROOT_ROUNDS; round++) {
        for (var i = 0u; i < n; i++) {
            var value = a[n];
            var slope = vec2<f32>(0.0);
            for (var j = 0u; j < n; j++) {
                let k = n - 1u - j;
                slope = c_mul(slope, r[i]) + value;
                value = c_mul(value, r[i]) + a[k];
            }
            let ratio = c_div(value, slope);
            var repulsion = vec2<f32>(0.0);
            for (var j = 0u; j < n; j++) {
                if j != i {
                    repulsion += c_div(vec2<f32>(1.0, 0.0), r[i] - r[j]);
                }
            }
            let step = c_div(ratio, vec2<f32>(1.0, 0.0) - c_mul(ratio, repulsion));
            if all(step == step) {
                r[i] -= step;
            }
        }
    }
    return r;
}

const TRIG_ROOT_ROUNDS: u32 = 24u;

// The transmittance in front of warped depth z from b0 and n trigonometric moments (the sums
// a·e^{ikφ} as (re, im) pairs), biased by β toward the uniform distribution on the circle
// (whose moments past the zeroth are 0).
fn mboit_transmittance_trig(b0: f32, b: array<f32, 8>, n: u32, z: f32) -> f32 {
    if b0 <= 0.0 {
        return 1.0;
    }
    var m: array<vec2<f32>, 5>;
    m[0] = vec2<f32>(1.0, 0.0);
    for (var k = 1u; k <= n; k++) {
        m[k] = (1.0 - mp.bias) * vec2<f32>(b[2u * k - 2u], b[2u * k - 1u]) / b0;
    }
    return clamp(exp(-b0 * trig_absorbance_fraction(m, n, trig_angle(z))), 0.0, 1.0);
}

// Wavelet OIT (`wavelet`, after Aizenshtein, Smal & McGuire 2022): each pixel's absorbance as a
// function of depth, A(x) = Σ aᵢ·[x > xᵢ] over its fragments, projected on the Haar basis of
// [0, 1): coefficient 0 the scaling function, coefficient 2^j + k the wavelet ψ_jk(x) =
// 2^{j/2}·ψ(2^j·x − k) (ψ = 1 on [0, ½), −1 on [½, 1)). A step's coefficients have a closed form,
// so a fragment adds them by additive blending, and the projection evaluated at a depth is the
// average of A over that depth's bin of width 2^{−levels}. The basis spans each pixel's own
// depth range, (nearest, farthest) warped depth of its fragments from a first pass, so the bins
// divide where its fragments are. Keep in step with `cpu::haar_*`.

// A warped depth z on [0, 1) within the pixel's range `bounds` (the farthest into the last bin;
// a pixel of one depth at 0).
fn haar_position(z: f32, bounds: vec2<f32>) -> f32 {
    let span = bounds.y - bounds.x;
    if span <= 0.0 {
        return 0.0;
    }
    return clamp((z - bounds.x) / span, 0.0, 0.99999994);
}

// Coefficient i of the unit step at s, [x > s].
fn haar_step_coefficient(s: f32, i: u32) -> f32 {
    if i == 0u {
        return 1.0 - s;
    }
    let level = firstLeadingBit(i);
    let scale = f32(1u << level);
    let t = scale * s - f32(i - (1u << level));
    if t <= 0.0 || t >= 1.0 {
        return 0.0;
    }
    return select(t - 1.0, -t, t < 0.5) * inverseSqrt(scale);
}

// Basis function i at x.
fn haar_basis(x: f32, i: u32) -> f32 {
    if i == 0u {
        return 1.0;
    }
    let level = firstLeadingBit(i);
    let scale = f32(1u << level);
    let t = scale * x - f32(i - (1u << level));
    if t < 0.0 || t >= 1.0 {
        return 0.0;
    }
    return select(-1.0, 1.0, t < 0.5) * sqrt(scale);
}

// The transmittance in front of a fragment of absorbance `own` at warped depth z, from b0 and n
// Haar coefficients: exp(−A(z)) less the fragment's own step (whose projection at its own depth
// is not 0, as the step itself is there, but the part of its bin behind it), A clamped to [0, b0]
// (a projection may overshoot where steps crowd a bin's edge).
fn haar_transmittance(b0: f32, c: array<f32, 8>, n: u32, z: f32, own: f32, bounds: vec2<f32>) -> f32 {
    if b0 <= 0.0 {
        return 1.0;
    }
    let x = haar_position(z, bounds);
    var absorbance = 0.0;
    for (var i = 0u; i < n; i++) {
        absorbance += (c[i] - own * haar_step_coefficient(x, i)) * haar_basis(x, i);
    }
    return exp(-clamp(absorbance, 0.0, b0));
}
