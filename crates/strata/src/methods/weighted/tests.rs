//! wboit against its own closed form on the CPU (`cpu::wboit` over the reference's fragments).
//! Tolerance: 2/255 on ≥ 99.9% of pixels, as for the exact methods. The targets are the paper's
//! f16 (11 significant bits): each of n additive blends rounds the sums by at most 2⁻¹¹ relative,
//! so on the ≤ 6 layers used here the weighted average moves by under 6·2⁻¹¹ ≈ 0.3%, below 1/255.

use super::cpu;
use crate::frame::{Effect, RenderOptions};
use crate::methods::weighted::Weight;
use crate::methods::weighted::WeightedOptions;
use crate::methods::weighted::{Moments, Opacity};
use crate::render::LinearImage;
use crate::scene::{loaders, Scene};
use crate::testing::{assert_close, assert_exact, per_pixel, render_gpu, scene_name};

// The scenes the closed forms are checked on (translucent, with `at_alpha`).
const LAYERS: &str = "builtin:layers?n=6&coverage=0.75&order=random&seed=3";
const NVPRO_96: &str = "builtin:nvpro?objects=96&subdiv=10&seed=8";
const NVPRO_400: &str = "builtin:nvpro?objects=400&subdiv=10&seed=3";
const DRAGON: &str = "builtin:dragon";
const SPHERES_8: &str = "builtin:spheres?layers=8";

/// Default options at `size`² over a black background (low opacities show in every channel).
fn over_black(size: u32) -> RenderOptions {
    let mut options = RenderOptions::sized(size, size);
    options.frame.background = crate::scene::Background::Color([0.0, 0.0, 0.0]);
    options
}

/// `options` with wboit's `weight` and `depth_scale`.
fn weighted(mut options: RenderOptions, weight: Weight, depth_scale: f64) -> RenderOptions {
    options.frame.families.set(WeightedOptions {
        weight,
        depth_scale,
        ..Default::default()
    });
    options
}

/// `options` with --msaa 4.
fn multisampled(mut options: RenderOptions) -> RenderOptions {
    options.build.msaa = 4;
    options
}

/// The scene of `spec` with every material's opacity `alpha`.
fn at_alpha(spec: &str, alpha: f32) -> Scene {
    let mut scene = loaders::load_scene(spec).unwrap();
    scene.override_alpha(alpha);
    scene
}

fn closed_form(scene: &Scene, options: &RenderOptions) -> LinearImage {
    per_pixel(scene, options, |_, l, bg| cpu::wboit(l, bg, options))
}

#[test]
fn wboit_equals_its_closed_form_for_every_weight() {
    // Low opacity over black: the coverage 1 − Π(1 − α) shows in every channel.
    let scene = at_alpha(LAYERS, 0.25);
    for weight in [Weight::Eq7, Weight::Eq8, Weight::Eq9, Weight::Eq10] {
        // Scales that put the layers' distances in each weight's steep part.
        for depth_scale in [1.0, 10.0, 60.0] {
            let opts = weighted(over_black(40), weight, depth_scale);
            let expected = closed_form(&scene, &opts);
            let (actual, stats) = render_gpu(&scene, &opts, "wboit");
            let name = format!("wboit-{}-scale{depth_scale}", weight.name());
            assert_exact(&name, &actual, &expected, Effect::Transparency);
            assert_eq!(stats.fragments_dropped, Some(0));
            assert_eq!(stats.max_depth_complexity, Some(6));
        }
    }
}

/// With --msaa 4 each sample blends the fragments covering it: the picture is the average of
/// the samples' closed forms.
#[test]
fn multisampled_wboit_averages_the_samples_closed_forms() {
    let scene = loaders::load_scene("builtin:spheres?layers=4").unwrap();
    let opts = multisampled(RenderOptions::sized(40, 40));
    let expected = per_pixel(&scene, &opts, |_, l, bg| {
        cpu::per_sample(l, 4, |own| cpu::wboit(own, bg, &opts))
    });
    let (actual, _) = render_gpu(&scene, &opts, "wboit");
    assert_exact("wboit-msaa4", &actual, &expected, Effect::Transparency);
    // Anti-aliased: the edges differ from the single-sampled picture.
    let single = {
        let mut options = opts;
        options.build.msaa = 1;
        options
    };
    let (aliased, _) = render_gpu(&scene, &single, "wboit");
    let moved = (0..aliased.pixels.len())
        .filter(|&i| (aliased.pixels[i][0] - actual.pixels[i][0]).abs() > 0.02)
        .count();
    assert!(moved > 20, "{moved} pixels changed");
}

/// The weights change the picture (a weight ignored would pass the test above on one weight
/// only if the closed form ignored it too): eq. 7 and eq. 9 differ on overlapping layers.
#[test]
fn wboit_weights_differ_and_the_depth_scale_matters() {
    let scene = loaders::load_scene(NVPRO_96).unwrap();
    let opts = |weight, depth_scale| weighted(RenderOptions::sized(32, 32), weight, depth_scale);
    let (a, _) = render_gpu(&scene, &opts(Weight::Eq7, 1.0), "wboit");
    let (b, _) = render_gpu(&scene, &opts(Weight::Eq9, 1.0), "wboit");
    let (c, _) = render_gpu(&scene, &opts(Weight::Eq7, 100.0), "wboit");
    assert!(a != b && a != c);
    // And the closed form agrees on the nvpro scene too.
    assert_close(
        "wboit-nvpro",
        &c,
        &closed_form(&scene, &opts(Weight::Eq7, 100.0)),
        Effect::Transparency,
        2,
        0.001,
    );
}

#[test]
fn wboit_params_layout_matches_wgsl() {
    crate::gpu::twin::assert_twin::<super::WboitParams>();
}

/// The settings `mboit` runs with at `moments`.
fn settings(moments: Moments) -> cpu::MboitSettings {
    cpu::MboitSettings {
        bias: super::mboit::moment_bias(moments) as f64,
        overestimation: super::mboit::OVERESTIMATION as f64,
        moments,
    }
}

fn mboit_closed_form(scene: &Scene, options: &RenderOptions) -> LinearImage {
    let camera = scene.camera_or_framing();
    per_pixel(scene, options, |_, l, bg| {
        cpu::mboit(
            l,
            bg,
            &camera,
            settings(options.frame.family::<WeightedOptions>().moments),
        )
    })
}

/// With --msaa 4 every sample has its own moments, each fragment is weighted by the mean of its
/// covered samples' transmittances, and the samples are resolved and averaged: the closed form
/// `cpu::mboit_multisampled`. Fully covered pixels stay the single-sampled result.
#[test]
fn multisampled_mboit_equals_its_closed_form() {
    let scene = at_alpha("builtin:spheres?layers=4", 0.4);
    let opts = multisampled(over_black(40));
    let camera = scene.camera_or_framing();
    let expected = per_pixel(&scene, &opts, |_, l, bg| {
        cpu::mboit_multisampled(l, bg, &camera, settings(Moments::Power(4)), 4)
    });
    let (actual, stats) = render_gpu(&scene, &opts, "mboit");
    assert_exact("mboit-msaa4", &actual, &expected, Effect::Transparency);
    assert_eq!(stats.bytes_allocated, 40 * 40 * (28 * 4 + 4));
    // On flat layers (37 pixels: edges between sample positions) the same as single-sampled
    // where every fragment covers every sample, and anti-aliased at the edges.
    let layers = at_alpha(LAYERS, 0.4);
    let four = {
        let mut options = opts;
        options.frame.width = 37;
        options.frame.height = 37;
        options
    };
    let single = {
        let mut options = four.clone();
        options.build.msaa = 1;
        options
    };
    let (aliased, _) = render_gpu(&layers, &single, "mboit");
    let (smooth, _) = render_gpu(&layers, &four, "mboit");
    let lists = crate::reference::fragments(&layers, &four).unwrap();
    let (mut moved, mut interior) = (0, 0);
    for (i, l) in lists.iter().enumerate() {
        let differs = (0..3).any(|c| (aliased.pixels[i][c] - smooth.pixels[i][c]).abs() > 1e-4);
        if !l.is_empty() && l.iter().all(|f| f.coverage == 0b1111) {
            interior += 1;
            assert!(
                !differs,
                "fully covered pixel {i}: {:?} vs {:?}",
                aliased.pixels[i], smooth.pixels[i]
            );
        } else if differs {
            moved += 1;
        }
    }
    assert!(
        interior > 200 && moved > 20,
        "{interior} interior, {moved} edge pixels changed"
    );
}

/// mboit against its f64 closed form: the same moments, the same reconstruction per fragment.
#[test]
fn mboit_equals_its_closed_form() {
    for spec in [LAYERS, NVPRO_96, NVPRO_400, DRAGON] {
        let scene = at_alpha(spec, 0.4);
        let opts = over_black(40);
        let expected = mboit_closed_form(&scene, &opts);
        let (actual, stats) = render_gpu(&scene, &opts, "mboit");
        assert_close(
            &format!("mboit-{}", scene_name(spec)),
            &actual,
            &expected,
            Effect::Transparency,
            2,
            0.001,
        );
        assert_eq!(stats.geometry_passes, 2);
        assert_eq!(stats.exact, Some(false));
        assert_eq!(stats.fragments_dropped, Some(0));
    }
}

/// mboit at 40² against its closed form, with its memory (`high_bytes` per pixel in the third
/// target); returns its RMSE against `exact`.
fn mboit_against_closed_form(
    scene: &Scene,
    opts: &RenderOptions,
    name: &str,
    high_bytes: u64,
    exact: &LinearImage,
) -> f64 {
    let expected = mboit_closed_form(scene, opts);
    let (actual, stats) = render_gpu(scene, opts, "mboit");
    assert_exact(name, &actual, &expected, Effect::Transparency);
    assert_eq!(
        stats.bytes_allocated,
        40 * 40 * (28 + high_bytes + 4),
        "{name}"
    );
    crate::metrics::compare(
        &exact.to_rgba8(Effect::Transparency),
        &actual.to_rgba8(Effect::Transparency),
    )
    .unwrap()
    .rmse
}

/// Six and eight power moments against their f64 closed forms (the same moments, the
/// reconstruction through the roots of the Hankel system's solution), with their memory; and
/// more moments follow the exact picture more closely on the deep nvpro scene.
#[test]
fn mboit_with_six_and_eight_moments_equals_its_closed_form() {
    let scene = at_alpha(NVPRO_400, 0.4);
    let base = over_black(40);
    let exact = crate::testing::render_reference(&scene, &base);
    let mut errors = Vec::new();
    for (moments, high_bytes) in [(4, 0), (6, 8), (8, 16)] {
        let opts = {
            let mut options = base.clone();
            options.frame.family_mut::<WeightedOptions>().moments = Moments::Power(moments);
            options
        };
        let name = format!("mboit{moments}-nvpro");
        errors.push(mboit_against_closed_form(
            &scene, &opts, &name, high_bytes, &exact,
        ));
    }
    // Measured: 0.0168, 0.0160, 0.0156.
    eprintln!("mboit RMSE against the reference at 4, 6, 8 moments: {errors:?}");
    assert!(errors[1] < errors[0] && errors[2] < errors[1], "{errors:?}");
    // The f32 reconstruction stays the f64 one on the other scenes too.
    for spec in [LAYERS, DRAGON, SPHERES_8] {
        let scene = at_alpha(spec, 0.4);
        for moments in [6, 8] {
            let opts = {
                let mut options = base.clone();
                options.frame.family_mut::<WeightedOptions>().moments = Moments::Power(moments);
                options
            };
            let expected = mboit_closed_form(&scene, &opts);
            let (actual, _) = render_gpu(&scene, &opts, "mboit");
            let name = format!("mboit{moments}-{}", spec.trim_start_matches("builtin:"));
            assert_exact(&name, &actual, &expected, Effect::Transparency);
        }
    }
}

/// The generic reconstruction of six and eight moments, given four, is the closed form.
#[test]
fn the_generic_reconstruction_of_four_moments_is_the_closed_form() {
    let support: [(f64, f64); 5] = [(-0.6, 0.5), (-0.2, 1.0), (0.1, 0.3), (0.5, 2.0), (0.8, 0.7)];
    let m = four_moments(&support);
    for i in 0..=20 {
        let z = -1.0 + 0.1 * i as f64;
        let closed = cpu::absorbance_fraction(m, z, 5e-7, 0.25);
        let generic = cpu::absorbance_fraction_n(&m, z, 5e-7, 0.25);
        assert!(
            (closed - generic).abs() < 1e-9,
            "z {z}: {closed} vs {generic}"
        );
    }
}

#[test]
fn polynomial_roots_are_found_in_order() {
    // (x + 0.9)(x − 0.1)(x − 0.3)(x − 0.75)
    let roots = [-0.9, 0.1, 0.3, 0.75];
    let mut c = vec![1.0];
    for r in roots {
        let mut next = vec![0.0; c.len() + 1];
        for (i, a) in c.iter().enumerate() {
            next[i + 1] += a;
            next[i] -= r * a;
        }
        c = next;
    }
    let found = cpu::polynomial_roots(&c);
    for (f, r) in found.iter().zip(roots) {
        assert!((f - r).abs() < 1e-9, "{found:?}");
    }
    assert_eq!(cpu::polynomial_roots(&c[1..]).len(), 3);
}

/// The reconstruction's limits: a lone fragment is in front of nothing but η of itself; a depth in
/// front of every fragment sees almost nothing of them, the far end nearly all (the weight the
/// canonical representation puts at the depth itself counts only η).
#[test]
fn mboit_reconstruction_limits() {
    let single = fraction_of(&[(0.1, 1.0)], 0.1, 0.25);
    assert!((single - 0.25).abs() < 1e-3, "{single}");
    let zs = [(-0.5, 1.0), (-0.1, 1.0), (0.3, 1.0), (0.6, 1.0)];
    assert!(fraction_of(&zs, -0.9, 0.25) < 0.01);
    assert!(fraction_of(&zs, 1.0, 0.25) > 0.95);
    let mut last = 0.0;
    for i in 0..=20 {
        let f = fraction_of(&zs, -1.0 + 0.1 * i as f64, 0.25);
        assert!(f >= last - 1e-9, "not monotone at {i}: {f} < {last}");
        last = f;
    }
}

/// The first four power moments of `support` (depth, absorbance), normalized by its total.
fn four_moments(support: &[(f64, f64)]) -> [f64; 4] {
    let total: f64 = support.iter().map(|s| s.1).sum();
    std::array::from_fn(|k| {
        support
            .iter()
            .map(|(x, a)| a * x.powi(k as i32 + 1))
            .sum::<f64>()
            / total
    })
}

/// The fraction of `support` (depth, absorbance) in front of `z` that the four moments give.
fn fraction_of(support: &[(f64, f64)], z: f64, overestimation: f64) -> f64 {
    let m = four_moments(support);
    cpu::absorbance_fraction(m, z, 5e-7, overestimation)
}

/// The same with `count` (6 or 8) moments and their bias.
fn fraction_of_n(support: &[(f64, f64)], z: f64, overestimation: f64, count: usize) -> f64 {
    let total: f64 = support.iter().map(|s| s.1).sum();
    let m: Vec<f64> = (0..count)
        .map(|k| {
            support
                .iter()
                .map(|(x, a)| a * x.powi(k as i32 + 1))
                .sum::<f64>()
                / total
        })
        .collect();
    cpu::absorbance_fraction_n(
        &m,
        z,
        settings(Moments::Power(count as u32)).bias,
        overestimation,
    )
}

proptest::proptest! {
    #![proptest_config(proptest::prelude::ProptestConfig::with_cases(300))]

    /// The moment bound brackets the truth: with η = 0 the fraction is at most the absorbance
    /// strictly in front of z, with η = 1 at least the absorbance at or in front of it.
    #[test]
    fn mboit_bounds_bracket_the_true_fraction(
        support in proptest::collection::vec((-0.95f64..0.95, 0.05f64..3.0), 3..7),
        z in -1.0f64..1.0,
    ) {
        let total: f64 = support.iter().map(|s| s.1).sum();
        let before: f64 = support.iter().filter(|s| s.0 < z).map(|s| s.1).sum::<f64>() / total;
        let upto: f64 = support.iter().filter(|s| s.0 <= z).map(|s| s.1).sum::<f64>() / total;
        let lower = fraction_of(&support, z, 0.0);
        let upper = fraction_of(&support, z, 1.0);
        proptest::prop_assert!(lower <= before + 1e-3, "lower {lower} > {before}");
        proptest::prop_assert!(upper >= upto - 1e-3, "upper {upper} < {upto}");
        for count in [6, 8] {
            let lower = fraction_of_n(&support, z, 0.0, count);
            let upper = fraction_of_n(&support, z, 1.0, count);
            proptest::prop_assert!(lower <= before + 1e-3, "{count}: lower {lower} > {before}");
            proptest::prop_assert!(upper >= upto - 1e-3, "{count}: upper {upper} < {upto}");
        }
    }
}

#[test]
fn mboit_params_layout_matches_wgsl() {
    crate::gpu::twin::assert_twin::<super::mboit::MboitParams>();
}

/// stochastic's closed form: each pixel's reference fragments (with their sample coverage)
/// through `cpu::stochastic`, the same stipples in f64.
fn stochastic_closed_form(scene: &Scene, options: &RenderOptions) -> LinearImage {
    let samples = (
        options.build.msaa,
        options.frame.family::<WeightedOptions>().passes,
    );
    per_pixel(scene, options, |i, l, bg| {
        cpu::stochastic(l, i, samples, bg)
    })
}

fn stochastic_options(size: u32, passes: u32) -> RenderOptions {
    let mut options = over_black(size);
    options.frame.family_mut::<WeightedOptions>().passes = passes;
    options.build.msaa = 4;
    options
}

/// The GPU's stipples, depths and sums against the closed form: opacities whose α·S is whole
/// (every stipple has ⌊α·S⌋ samples) and fractional (the hash decides), one pass and three.
#[test]
fn stochastic_equals_its_closed_form() {
    for alpha in [0.25, 0.4] {
        let scene = at_alpha(LAYERS, alpha);
        for passes in [1, 3] {
            let opts = stochastic_options(40, passes);
            let expected = stochastic_closed_form(&scene, &opts);
            let (actual, stats) = render_gpu(&scene, &opts, "stochastic");
            assert_exact(
                &format!("stochastic-alpha{alpha}-passes{passes}"),
                &actual,
                &expected,
                Effect::Transparency,
            );
            assert_eq!(stats.fragments_dropped, Some(0));
            assert_eq!(stats.geometry_passes, 2 * passes + 1);
        }
    }
}

/// Curved, deep scenes with many sub-pixel triangles (nvpro, the dragon), whose surfaces lie
/// close in window depth: equal because both order each sample's fragments by the depth at the
/// pixel center.
#[test]
fn stochastic_equals_its_closed_form_on_nvpro_and_the_dragon() {
    let dragon = at_alpha(DRAGON, 0.4);
    for (name, scene, size) in [
        (
            "nvpro",
            loaders::load_scene("builtin:nvpro?objects=160&subdiv=10&seed=3").unwrap(),
            48,
        ),
        ("dragon", dragon, 64),
    ] {
        let opts = stochastic_options(size, 2);
        let (actual, _) = render_gpu(&scene, &opts, "stochastic");
        assert_exact(
            &format!("stochastic-{name}"),
            &actual,
            &stochastic_closed_form(&scene, &opts),
            Effect::Transparency,
        );
    }
}

/// More passes, more samples: the noise against the reference falls (the stipples are fixed,
/// so this is the same comparison on every run).
#[test]
fn stochastic_noise_falls_with_passes() {
    let scene = at_alpha(LAYERS, 0.4);
    let truth = crate::testing::render_reference(&scene, &stochastic_options(48, 1))
        .to_rgba8(Effect::Transparency);
    let rmse = |passes| {
        let (image, _) = render_gpu(&scene, &stochastic_options(48, passes), "stochastic");
        crate::metrics::compare(&truth, &image.to_rgba8(Effect::Transparency))
            .unwrap()
            .rmse
    };
    let (one, four, sixteen) = (rmse(1), rmse(4), rmse(16));
    assert!(sixteen < four && four < one, "RMSE {one} {four} {sixteen}");
}

/// A single-sampled frame has no samples to stipple: one clear error, no panic.
#[test]
fn stochastic_refuses_a_single_sampled_frame() {
    let scene = loaders::load_scene("builtin:layers?n=2").unwrap();
    let mut opts = stochastic_options(16, 1);
    opts.build.msaa = 1;
    let mut r = crate::Renderer::new(crate::testing::gpu(), &scene, &opts).unwrap();
    let e = r.render("stochastic").expect_err("single-sampled");
    assert!(e.to_string().contains("--msaa 4 or 8"), "{e}");
}

#[test]
fn stochastic_params_layout_matches_wgsl() {
    crate::gpu::twin::assert_twin::<super::stochastic::StochasticParams>();
}

/// The stipples' counts average α·S and their samples are distinct.
#[test]
fn stipples_have_the_expected_sample_count() {
    for alpha in [0.1f32, 0.25, 0.4, 0.9] {
        for samples in [4, 8] {
            let masks: Vec<u32> = (0..4000)
                .map(|prim| cpu::stipple(17, prim, alpha, 0, samples))
                .collect();
            let mean = masks.iter().map(|m| m.count_ones() as f64).sum::<f64>() / 4000.0;
            let expected = alpha as f64 * samples as f64;
            assert!(
                (mean - expected).abs() < 0.05,
                "α {alpha} S {samples}: {mean}"
            );
            assert!(masks.iter().all(|m| m >> samples == 0));
            let whole = expected.floor() as u32;
            assert!(masks
                .iter()
                .all(|m| m.count_ones() == whole || m.count_ones() == whole + 1));
        }
    }
}

/// Two, three and four trigonometric moments against their f64 closed forms (the same moments,
/// the same canonical representation on the circle), with their memory; and their error
/// against the reference on nvpro, printed for the record.
#[test]
fn mboit_with_trigonometric_moments_equals_its_closed_form() {
    let base = over_black(40);
    let mut errors = Vec::new();
    for spec in [NVPRO_400, LAYERS, DRAGON, SPHERES_8] {
        let scene = at_alpha(spec, 0.4);
        let exact = crate::testing::render_reference(&scene, &base);
        for (n, high_bytes) in [(2, 0), (3, 8), (4, 16)] {
            let mut opts = base.clone();
            opts.frame.family_mut::<WeightedOptions>().moments = Moments::Trigonometric(n);
            let name = format!("mboit-trig{n}-{}", spec.trim_start_matches("builtin:"));
            let rmse = mboit_against_closed_form(&scene, &opts, &name, high_bytes, &exact);
            errors.push((name, rmse));
        }
    }
    eprintln!("mboit trigonometric RMSE against the reference: {errors:?}");
}

/// Two fragments far apart on the circle: in front of both nothing absorbs, between them about
/// the first one's share, behind both all of it.
#[test]
fn trigonometric_reconstruction_orders_two_fragments() {
    let a = -(0.5f64).ln();
    let (z_near, z_far) = (-0.5, 0.5);
    for n in 2..=4usize {
        let mut b = vec![[1.0, 0.0]; n + 1];
        for (k, m) in b.iter_mut().enumerate().skip(1) {
            let at = |z: f64| {
                let phi = k as f64 * cpu::trig_angle(z);
                [a * phi.cos(), a * phi.sin()]
            };
            let (p, q) = (at(z_near), at(z_far));
            let bias = 1.0 - super::mboit::TRIG_MOMENT_BIAS[n - 2] as f64;
            *m = [
                bias * (p[0] + q[0]) / (2.0 * a),
                bias * (p[1] + q[1]) / (2.0 * a),
            ];
        }
        let fraction = |z: f64| cpu::trig_absorbance_fraction(&b, cpu::trig_angle(z), 0.25);
        assert!(fraction(-0.9) < 0.05, "n {n}: {}", fraction(-0.9));
        assert!(
            (fraction(0.0) - 0.5).abs() < 0.05,
            "n {n}: {}",
            fraction(0.0)
        );
        assert!(fraction(0.9) > 0.95, "n {n}: {}", fraction(0.9));
    }
}

#[test]
fn moments_parse_as_the_command_line_writes_them() {
    assert_eq!("6".parse::<Moments>().unwrap(), Moments::Power(6));
    assert_eq!(
        "trig3".parse::<Moments>().unwrap(),
        Moments::Trigonometric(3)
    );
    assert_eq!(Moments::Trigonometric(4).to_string(), "trig4");
    for bad in ["5", "trig1", "trig5", "trig", "four", ""] {
        let e = bad.parse::<Moments>().unwrap_err().to_string();
        assert!(e.contains("--moments") && e.contains("trig2"), "{bad}: {e}");
    }
}

/// The Haar projection of a step, evaluated anywhere, is the step's average over that point's
/// bin (width 2^−levels): what `wavelet` reconstructs.
#[test]
fn haar_coefficients_of_a_step_give_its_bin_average() {
    for n in crate::methods::weighted::options::WAVELET_COEFFICIENTS {
        let bins = f64::from(n);
        for s in [0.0, 0.03, 0.125, 0.3, 0.5, 0.61, 0.874, 0.99] {
            for x in [0.0, 0.05, 0.124, 0.2, 0.45, 0.5, 0.7, 0.9, 0.999] {
                let projected: f64 = (0..n)
                    .map(|i| cpu::haar_step_coefficient(s, i) * cpu::haar_basis(x, i))
                    .sum();
                let bin = (x * bins).floor();
                let (start, end) = (bin / bins, (bin + 1.0) / bins);
                let average = ((end - s.max(start)) / (end - start)).clamp(0.0, 1.0);
                assert!(
                    (projected - average).abs() < 1e-12,
                    "n {n}, step at {s}, at {x}: {projected} against {average}"
                );
            }
        }
    }
}

fn wavelet_options(coefficients: u32) -> RenderOptions {
    let mut options = over_black(40);
    options.frame.family_mut::<WeightedOptions>().coefficients = coefficients;
    options
}

/// wavelet against its f64 closed form (the same depth ranges, coefficients and reconstruction
/// per fragment) on layers, nvpro and the dragon, at 4 and 8 coefficients, with its memory; and 8
/// coefficients follow the exact picture at least as closely as 4 on nvpro.
#[test]
fn wavelet_equals_its_closed_form() {
    for spec in [LAYERS, NVPRO_400, DRAGON] {
        let scene = at_alpha(spec, 0.4);
        let camera = scene.camera_or_framing();
        let exact = crate::testing::render_reference(&scene, &over_black(40));
        let mut errors = Vec::new();
        for (coefficients, high_bytes) in [(4, 0), (8, 16)] {
            let opts = wavelet_options(coefficients);
            let expected = per_pixel(&scene, &opts, |_, l, bg| {
                cpu::mboit(l, bg, &camera, settings(Moments::Haar(coefficients)))
            });
            let (actual, stats) = render_gpu(&scene, &opts, "wavelet");
            let name = format!("wavelet{coefficients}-{}", scene_name(spec));
            assert_exact(&name, &actual, &expected, Effect::Transparency);
            assert_eq!(
                stats.bytes_allocated,
                40 * 40 * (28 + high_bytes + super::mboit::WAVELET_BOUNDS_BYTES + 4),
                "{name}"
            );
            assert_eq!(stats.geometry_passes, 3);
            assert_eq!(stats.exact, Some(false));
            errors.push(
                crate::metrics::compare(
                    &exact.to_rgba8(Effect::Transparency),
                    &actual.to_rgba8(Effect::Transparency),
                )
                .unwrap()
                .rmse,
            );
        }
        eprintln!("{spec}: wavelet RMSE against the reference at 4, 8 coefficients: {errors:?}");
        if spec.contains("nvpro") {
            assert!(errors[1] <= errors[0], "{errors:?}");
        }
    }
}

/// `--coefficients` other than 4 or 8 is refused in one line.
#[test]
fn wavelet_takes_4_or_8_coefficients() {
    for bad in [0, 2, 6, 16] {
        let e = wavelet_options(bad).validate().unwrap_err().to_string();
        assert!(e.contains("--coefficients") && !e.contains('\n'), "{e}");
    }
}

/// With --msaa 4 each sample has its own coefficients over the pixel's depth range (the union of
/// its samples'), each fragment is weighted by the mean of its covered samples' transmittances:
/// `cpu::mboit_multisampled` with Haar coefficients.
#[test]
fn multisampled_wavelet_equals_its_closed_form() {
    let scene = at_alpha("builtin:spheres?layers=4", 0.4);
    let mut opts = wavelet_options(8);
    opts.build.msaa = 4;
    let camera = scene.camera_or_framing();
    let expected = per_pixel(&scene, &opts, |_, l, bg| {
        cpu::mboit_multisampled(l, bg, &camera, settings(Moments::Haar(8)), 4)
    });
    let (actual, stats) = render_gpu(&scene, &opts, "wavelet");
    assert_exact("wavelet-msaa4", &actual, &expected, Effect::Transparency);
    assert_eq!(
        stats.bytes_allocated,
        40 * 40 * ((28 + 16 + super::mboit::WAVELET_BOUNDS_BYTES) * 4 + 4)
    );
}

/// `options` with wavg's `opacity`.
fn wavg_options(mut options: RenderOptions, opacity: Opacity) -> RenderOptions {
    options.frame.family_mut::<WeightedOptions>().opacity = opacity;
    options
}

/// wavg matches its closed form with either opacity, on layers of differing opacities (where
/// the two differ: the test fails if `--opacity` were ignored) and on nvpro.
#[test]
fn wavg_equals_its_closed_form_for_each_opacity() {
    for spec in [LAYERS, NVPRO_96] {
        let scene = loaders::load_scene(spec).unwrap();
        let mut pictures = Vec::new();
        for opacity in [Opacity::Average, Opacity::Product] {
            let opts = wavg_options(over_black(40), opacity);
            let expected = per_pixel(&scene, &opts, |_, l, bg| cpu::wavg(l, bg, opacity));
            let (actual, stats) = render_gpu(&scene, &opts, "wavg");
            let name = format!("wavg-{}-{}", opacity.name(), scene_name(spec));
            assert_exact(&name, &actual, &expected, Effect::Transparency);
            assert_eq!(stats.fragments_dropped, Some(0));
            pictures.push(actual);
        }
        assert!(
            pictures[0] != pictures[1],
            "{spec}: --opacity changed nothing"
        );
    }
}

/// With --msaa 4 each sample has its own sums, count and product: the picture is the average of
/// the samples' closed forms.
#[test]
fn multisampled_wavg_averages_the_samples_closed_forms() {
    let scene = loaders::load_scene("builtin:spheres?layers=4").unwrap();
    for opacity in [Opacity::Average, Opacity::Product] {
        let opts = wavg_options(multisampled(RenderOptions::sized(40, 40)), opacity);
        let expected = per_pixel(&scene, &opts, |_, l, bg| {
            cpu::per_sample(l, 4, |own| cpu::wavg(own, bg, opacity))
        });
        let (actual, _) = render_gpu(&scene, &opts, "wavg");
        let name = format!("wavg-{}-msaa4", opacity.name());
        assert_exact(&name, &actual, &expected, Effect::Transparency);
    }
}

/// The frame's own statistics: the largest gap between the average's and the product's
/// transmittance and the pixels past 1/255 are those of the fragments (to the f16 targets'
/// rounding), whichever opacity the frame composited with; fragments of one opacity have none.
#[test]
fn wavg_reports_how_far_its_opacity_lay_from_the_exact_one() {
    use super::wavg::WavgStats;
    let scene = loaders::load_scene("builtin:demo").unwrap();
    let opts = over_black(40);
    let lists = crate::methods::kbuffer::tests::fragments_where_rasterizers_agree(&scene, &opts);
    let gaps: Vec<f64> = lists
        .iter()
        .map(|l| {
            let (average, product) = cpu::wavg_transmittances(l);
            (average - product).abs()
        })
        .collect();
    let largest = gaps.iter().copied().fold(0.0, f64::max);
    let past = |threshold: f64| gaps.iter().filter(|&&g| g > threshold).count() as u64;
    assert!(
        largest > 0.05 && past(1.0 / 255.0) > 20,
        "{largest} {}",
        past(1.0 / 255.0)
    );
    for opacity in [Opacity::Average, Opacity::Product] {
        let (_, stats) = render_gpu(&scene, &wavg_options(opts.clone(), opacity), "wavg");
        let own = *stats.family::<WavgStats>().expect("wavg's statistics");
        assert!(
            (own.opacity_gap_max as f64 - largest).abs() < 0.01,
            "{own:?} against {largest}"
        );
        let pixels = own.opacity_gap_pixels;
        assert!(
            (past(1.0 / 255.0 + 0.005)..=past(1.0 / 255.0 - 0.003)).contains(&pixels),
            "{pixels} pixels against {} past 1/255",
            past(1.0 / 255.0)
        );
    }
    // One opacity (0.5: exact in f16, as are its sums and powers): the average is the product.
    let (_, stats) = render_gpu(&at_alpha(NVPRO_96, 0.5), &opts, "wavg");
    let own = *stats.family::<WavgStats>().expect("wavg's statistics");
    assert!(
        own.opacity_gap_pixels == 0 && own.opacity_gap_max < 1e-3,
        "{own:?}"
    );
}

#[test]
fn wavg_params_layout_matches_wgsl() {
    crate::gpu::twin::assert_twin::<super::wavg::WavgParams>();
}

/// Every method that declares a closed form (`Descriptor::closed_form`) matches it at its
/// defaults and fewest samples, taken from the table: a new approximate method is held to its
/// closed form with no line added here.
#[test]
fn every_declared_closed_form_is_its_methods_picture() {
    use crate::methods::PixelSite;
    let scene = loaders::load_scene(LAYERS).unwrap();
    let camera = scene.camera_or_framing();
    let declared: Vec<_> = crate::methods::TABLE
        .iter()
        .filter_map(|d| Some((d, d.closed_form?)))
        .collect();
    assert!(declared.len() >= 5, "{}", declared.len());
    for (d, closed_form) in declared {
        let mut opts = over_black(40);
        opts.build.msaa = d.min_samples;
        let expected = per_pixel(&scene, &opts, |index, l, background| {
            let site = PixelSite {
                index,
                background,
                camera: &camera,
                options: &opts,
            };
            closed_form(l, &site)
        });
        let (actual, _) = render_gpu(&scene, &opts, d.name);
        let name = format!("closed-form-{}", d.name);
        assert_exact(&name, &actual, &expected, Effect::Transparency);
    }
}

/// The weighted family's methods are approximate and each declares its closed form.
#[test]
fn each_weighted_method_declares_its_closed_form() {
    for d in crate::methods::TABLE {
        if d.family == crate::methods::Family::Weighted {
            assert!(!d.exact && d.closed_form.is_some(), "{}", d.name);
        }
    }
}
