//! Every GPU method against the CPU reference, on lavapipe in CI.
//!
//! Tolerance for exact methods: max |Δ| ≤ 2/255 per sRGB channel on ≥ 99.9% of pixels. Why not
//! 100%: the reference snaps vertices to 1/256 pixel like lavapipe, but lavapipe derives its
//! edge and depth equations in f32 where the reference uses exact integers and f64, so a pixel
//! center within rounding distance of an edge can be covered by one and not the other; colors
//! also differ by f32 shading and f16 fragment storage, which stays far below 2/255.

use crate::frame::{Effect, RenderOptions};
use crate::methods::kbuffer::KBufferOptions;
use crate::scene::{loaders, Blend, Scene};
use crate::testing::{
    assert_exact, assert_input_error, assert_unsupported, differing_pixels, render_gpu,
    render_reference, renderer, Expected, Failures, EXACT_MAX_DIFF, EXACT_MAX_FRACTION,
};

const EXACT_METHODS: [&str; 6] = ["f2b", "dual", "abuffer-ll", "sbuffer", "kpeel", "tiled"];

pub(crate) fn options(size: u32, effect: Effect) -> RenderOptions {
    let mut options = RenderOptions::sized(size, size);
    options.frame.effect = effect;
    options
}

fn check_exact(name: &str, scene: &Scene, opts: &RenderOptions) {
    check_methods_exact(name, scene, opts, &EXACT_METHODS);
}

/// `methods` against the reference (see [`check_exact`]).
fn check_methods_exact(name: &str, scene: &Scene, opts: &RenderOptions, methods: &[&str]) {
    exact_failures(name, scene, opts, methods).finish(name);
}

/// The failures of `methods` against the reference (see [`check_exact`]); `name` begins their
/// images' names.
fn exact_failures(name: &str, scene: &Scene, opts: &RenderOptions, methods: &[&str]) -> Failures {
    let expected = render_reference(scene, opts);
    // The reference's fragments at the device's own depths and coverage: every pixel matches
    // there (see kbuffer/tests.rs), so on any GPU a difference is the method's. A method that
    // rasterizes in compute (tiled) is held to the compute rasterizer's fragments: on the H100
    // the hardware's depths and shading differ from the reference's where the compute
    // rasterizer's agree with it.
    let truth_for = |raster: crate::raster::Raster| {
        let mut opts = opts.clone();
        opts.build.raster = raster;
        super::kbuffer::tests::exact_truth(scene, &opts, expected.clone())
    };
    let hardware = truth_for(opts.build.raster);
    let mut compute = None;
    let mut failures = Failures::default();
    for &method in methods {
        let (actual, stats) = render_gpu(scene, opts, method);
        if !failures.locks_held(method, &stats) {
            continue;
        }
        failures.frame_says_exact(method, &stats);
        if stats.compute_raster.is_some() && opts.build.msaa > 1 {
            // tiled's samples, found in compute: the compute rasterizer's capture, which the
            // device's fragments are read from, takes no samples; the reference alone, at the
            // exact bar (tiled's own tests hold its fragment counts to the reference's).
            let result = crate::metrics::testing::check_image(
                &format!("{name}-{method}-{}", opts.frame.effect.name()),
                &actual.to_rgba8(opts.frame.effect),
                &expected.to_rgba8(opts.frame.effect),
                crate::testing::EXACT_MAX_DIFF,
                crate::testing::EXACT_MAX_FRACTION,
            );
            failures.check(method, result.map(|_| ()));
            continue;
        }
        let truth = if stats.compute_raster.is_some() {
            compute.get_or_insert_with(|| truth_for(crate::raster::Raster::Compute))
        } else {
            &hardware
        };
        failures.check_exact_picture(
            method,
            &format!("{name}-{method}-{}", opts.frame.effect.name()),
            &actual,
            truth,
            opts.frame.effect,
        );
        assert!(stats.geometry_passes >= 1);
    }
    failures
}

/// The exact methods against the reference on random layers, nested spheres, the demo with
/// translucency, and nvpro (also in complexity): every scene runs, and the test fails at the end
/// naming each failing scene and method. A scene's images are named after it (`builtin:NAME?…`).
#[test]
fn exact_methods_match_reference_on_scenes() {
    let mut failures = Failures::default();
    for (spec, size, effect) in [
        (
            "builtin:layers?n=16&coverage=0.75&order=random&seed=3",
            64,
            Effect::Transparency,
        ),
        ("builtin:spheres?layers=16", 96, Effect::Transparency),
        ("builtin:demo", 96, Effect::Translucency),
        (
            "builtin:nvpro?objects=96&subdiv=12&seed=2",
            96,
            Effect::Transparency,
        ),
        (
            "builtin:nvpro?objects=96&subdiv=12&seed=5",
            80,
            Effect::Complexity,
        ),
    ] {
        let name = crate::testing::scene_name(spec);
        let opts = options(size, effect);
        let scene_failures = exact_failures(name, &scene(spec), &opts, &EXACT_METHODS);
        failures.absorb(&format!("{name} ({})", effect.name()), scene_failures);
    }
    failures.finish("exact methods on scenes");
}

/// Every stage's composed WGSL validates with naga, so a shader error fails without a GPU: each
/// family lists its own stages (`stages()` in its folder; the k-buffers', tiled's and bucket's
/// are validated by their own tests).
#[test]
fn every_stage_validates() {
    use super::{baseline, downlevel, peeling, weighted};
    let families = [
        baseline::stages(),
        weighted::stages(),
        peeling::stages(),
        downlevel::stages().to_vec(),
    ];
    for stage in families.iter().flatten() {
        crate::gpu::shader::validate(stage);
    }
}

fn scene(spec: &str) -> Scene {
    loaders::load_scene(spec).unwrap_or_else(|e| panic!("{spec}: {e}"))
}

/// `n` screen-covering layers in random order (`seed`): every pixel has `n` fragments.
pub(crate) fn covering_layers(n: usize, seed: u64) -> Scene {
    scene(&format!(
        "builtin:layers?n={n}&coverage=1&order=random&seed={seed}"
    ))
}

fn fixture(name: &str) -> String {
    format!("{}/tests/fixtures/{name}", env!("CARGO_MANIFEST_DIR"))
}

#[test]
fn exact_methods_match_reference_on_spheres_with_translucency() {
    // Absorption differs per shell so the entering/leaving rule is what the picture depends on.
    let mut s = scene("builtin:spheres?layers=8");
    for (i, m) in s.materials.iter_mut().enumerate() {
        m.absorption = 0.5 + i as f32;
    }
    let opts = options(96, Effect::Translucency);
    check_exact("spheres", &s, &opts);
    // And the absorption is visible: without it the picture differs.
    let with = render_reference(&s, &opts);
    for m in &mut s.materials {
        m.absorption = 0.0;
    }
    let without = render_reference(&s, &opts);
    let c = crate::metrics::compare(
        &with.to_rgba8(opts.frame.effect),
        &without.to_rgba8(opts.frame.effect),
    )
    .unwrap();
    assert!(c.pct_over_2 > 20.0, "{c:?}");
}

/// WebGPU's default largest storage binding, and lavapipe's.
const ONE_STORAGE_BINDING: u64 = 128 << 20;

/// The scene's vertices exceed one storage binding (2.16M triangles, 149 MiB of vertices): they
/// are drawn from a vertex buffer, and the picture equals the reference.
#[test]
fn a_scene_beyond_one_storage_binding_matches_the_reference() {
    let s = scene("builtin:nvpro?objects=4096&subdiv=24&seed=2");
    let vertex_bytes =
        s.triangle_count() as u64 * 3 * std::mem::size_of::<crate::scene::GpuVertex>() as u64;
    assert!(vertex_bytes > ONE_STORAGE_BINDING, "{vertex_bytes} bytes");
    let opts = options(32, Effect::Transparency);
    let expected = Expected {
        image: super::kbuffer::tests::reference_where_rasterizers_agree(&s, &opts),
        effect: opts.frame.effect,
    };
    for method in ["abuffer-ll", "sbuffer"] {
        let (actual, stats) = render_gpu(&s, &opts, method);
        expected.assert_exact(&format!("beyond-binding-{method}"), &actual);
        assert_eq!(stats.fragments_dropped, Some(0), "{method}");
    }
}

/// A picture rendered in bands of 32 rows (each band a frame of its own, the projection cropped
/// to it) equals the reference, and its statistics add up over the bands.
#[test]
fn pictures_in_bands_match_the_reference() {
    let s = scene("builtin:nvpro?objects=96&subdiv=12&seed=2");
    let opts = options(96, Effect::Transparency);
    let expected = Expected::reference(&s, &opts);
    for method in EXACT_METHODS {
        let (_, whole) = render_gpu(&s, &opts, method);
        let mut r = renderer(&s, &opts);
        r.set_max_band_rows(Some(40)); // rounded down to 32
        let (actual, stats) = r.render(method).unwrap();
        expected.assert_exact(&format!("bands-{method}"), &actual);
        assert_eq!(stats.bands, Some(3), "{method}");
        assert_eq!((stats.width, stats.height), (96, 96), "{method}");
        let (a, b) = (
            whole.fragments_generated.unwrap(),
            stats.fragments_generated.unwrap(),
        );
        // Pixel centres on a triangle's edge may fall either way after the crop's rounding.
        assert!(
            a.abs_diff(b) * 1000 <= a,
            "{method}: {a} whole, {b} in bands"
        );
        assert_eq!(stats.fragments_dropped, Some(0), "{method}");
    }
}

/// On a device whose storage bindings hold 512 KiB, a 128×128 picture's resolved colors fit but
/// an A-buffer's pool and a k-buffer's arrays do not: the picture is rendered in bands, halved
/// until they fit, and equals the reference.
#[test]
fn pictures_beyond_the_bindings_render_in_bands_that_halve_as_needed() {
    let gpu = gpu_with_storage_bindings_of(512 << 10);
    let s = scene("builtin:layers?n=4&coverage=1&order=random&seed=2");
    let mut opts = options(128, Effect::Transparency);
    opts.frame.k = Some(8);
    let expected = Expected::reference(&s, &opts);
    // abuffer-ll's pool outgrows the binding after its first frame; kplus-array's arrays when
    // they are allocated.
    for method in ["abuffer-ll", "kplus-array"] {
        let mut r = crate::Renderer::new(&gpu, &s, &opts).unwrap();
        let (actual, stats) = r.render(method).unwrap();
        expected.assert_exact(&format!("halving-bands-{method}"), &actual);
        assert!(stats.bands.unwrap_or(1) >= 2, "{method}: {:?}", stats.bands);
        assert_eq!(stats.fragments_generated, Some(4 * 128 * 128), "{method}");
        assert_eq!(stats.fragments_dropped, Some(0), "{method}");
    }
}

/// A picture whose fragments cannot fit one binding even spread over bands of 32 rows is
/// refused from what its first frame measured, instead of after halving band after band (a
/// 300K-face model once took 37 s to say so on lavapipe).
#[test]
fn pictures_that_no_band_can_hold_are_refused_from_what_the_first_frame_measured() {
    let gpu = gpu_with_storage_bindings_of(256 << 10);
    let s = scene("builtin:layers?n=32&coverage=1&order=random&seed=2");
    let opts = options(128, Effect::Transparency);
    let mut r = crate::Renderer::new(&gpu, &s, &opts).unwrap();
    let e = r.render("abuffer-ll").unwrap_err();
    assert_unsupported("abuffer-ll", &e, "does not fit even in bands of 32 rows");
    assert!(e.to_string().contains("on average"), "{e}");
}

/// The shared GPU with storage bindings of at most `bytes`.
fn gpu_with_storage_bindings_of(bytes: u64) -> crate::gpu::Gpu {
    let mut gpu = crate::testing::gpu().clone();
    gpu.limits.max_storage_buffer_binding_size = bytes;
    gpu
}

/// Pictures are refused, before anything is allocated, beyond 8192×8192 pixels (a 1 GiB
/// host image); that size itself is accepted.
#[test]
fn pictures_beyond_the_host_image_limit_are_refused_up_front() {
    let s = scene("builtin:layers?n=2");
    let mut opts = options(8192, Effect::Transparency);
    opts.frame.width = 8193;
    let e = crate::Renderer::new(crate::testing::gpu(), &s, &opts)
        .err()
        .expect("refused");
    assert_unsupported("8193 pixels wide", &e, "8192x8192");
}

/// Bands cannot use a depth texture the application drew into at the whole picture's size.
#[test]
fn bands_refuse_an_application_opaque_depth() {
    let mut r = renderer(
        &scene("builtin:layers?n=2"),
        &options(64, Effect::Transparency),
    );
    let _ = r.opaque_depth();
    r.set_max_band_rows(Some(32));
    let e = r
        .render("abuffer-ll")
        .expect_err("bands refuse a lent depth");
    assert!(e.to_string().contains("opaque depth"), "{e}");
}

#[test]
fn exact_methods_match_reference_on_the_dragon() {
    let mut s = scene("builtin:dragon");
    s.override_alpha(0.5);
    check_exact("dragon", &s, &options(128, Effect::Transparency));
}

#[test]
fn exact_methods_match_reference_on_gltf_alpha_blend() {
    let s = scene(&fixture("two_nodes.gltf"));
    assert!(
        s.materials.iter().any(|m| m.opacity < 1.0),
        "fixture has a BLEND material"
    );
    check_exact("gltf-blend", &s, &options(64, Effect::Translucency));
}

/// Unlit screen-covering layers in shuffled order under an orthographic camera have a closed
/// form. Tolerance 1/255: the only error left is f16 fragment storage and 8-bit rounding.
/// Layered quads whose materials blend over, add and multiply in turn (a multiply layer's
/// color filters what lies behind it).
fn blended_layers() -> Scene {
    let mut s = scene("builtin:layers?n=9&coverage=0.75&order=random&seed=5");
    let modes = [Blend::Over, Blend::Add, Blend::Multiply];
    for (i, m) in s.materials.iter_mut().enumerate() {
        m.blend = modes[i % 3];
    }
    s
}

/// The methods that composite add and multiply, with room for every fragment of `scene`:
/// every exact method, and abuffer-fixed as the approximate one (it drops what it cannot
/// store, never blending it wrongly).
fn blending_methods() -> Vec<&'static str> {
    super::catalogue()
        .filter(|d| d.id != super::MethodId::Reference && d.blend_modes.yes())
        .filter(|d| d.exact || d.id == super::MethodId::AbufferFixed)
        .map(|d| d.name)
        .collect()
}

#[test]
fn every_exact_method_blends_add_and_multiply_as_the_reference() {
    let s = blended_layers();
    assert_eq!(s.blend_modes(), [Blend::Add, Blend::Multiply]);
    let mut opts = options(40, Effect::Transparency);
    opts.frame.background = crate::scene::Background::Color([0.3, 0.5, 0.7]);
    opts.frame.k = Some(16);
    let methods = blending_methods();
    assert!(methods.len() >= 18, "{methods:?}");
    check_methods_exact("blend", &s, &opts, &methods);
}

#[test]
fn every_exact_method_blends_add_and_multiply_as_the_reference_multisampled() {
    let s = blended_layers();
    let mut opts = options(40, Effect::Transparency);
    opts.build.msaa = 4;
    // Pixels on a quad's diagonal get a fragment of each of its triangles.
    opts.frame.k = Some(32);
    let methods: Vec<&str> = blending_methods()
        .into_iter()
        .filter(|m| {
            m.parse::<super::MethodId>()
                .unwrap()
                .descriptor()
                .msaa
                .yes()
        })
        .collect();
    check_methods_exact("blend-msaa4", &s, &opts, &methods);
}

#[test]
fn methods_that_only_blend_over_refuse_add_and_multiply_in_one_line() {
    let s = blended_layers();
    let mut opts = options(16, Effect::Transparency);
    let refusing: Vec<_> = super::MethodId::gpu_methods()
        .filter(|m| !m.descriptor().blend_modes.yes())
        .collect();
    assert!(refusing.contains(&super::MethodId::Wboit));
    assert!(refusing.contains(&super::MethodId::Mlab));
    for m in refusing {
        let opts = runnable(m, &opts);
        let e = match crate::Renderer::new(crate::testing::gpu(), &s, &opts)
            .and_then(|mut r| r.render(m.as_str()))
        {
            Ok(_) => panic!("{m} rendered a scene with add and multiply materials"),
            Err(e) => e.to_string(),
        };
        assert!(
            e.contains(&format!("{m} cannot blend 'add' materials")) && !e.contains('\n'),
            "{m}: {e}"
        );
    }
    // A k-buffer's tail blends over: refused with such materials.
    opts.frame.family_mut::<KBufferOptions>().tail = crate::methods::kbuffer::Tail::Blend;
    let e = crate::Renderer::new(crate::testing::gpu(), &s, &opts)
        .and_then(|mut r| r.render("kplus-heap"))
        .expect_err("a blended tail refused")
        .to_string();
    assert!(e.contains("--tail blend"), "{e}");
}

#[test]
fn layers_composite_to_the_closed_form() {
    let n = 12;
    let s = covering_layers(n, 7);
    let background = [0.2f64, 0.3, 0.4];
    let mut opts = options(32, Effect::Transparency);
    opts.frame.background = crate::scene::Background::Color(background.map(|c| c as f32));
    let mut expected = [0.0f64; 3];
    let mut t = 1.0f64;
    for (color, alpha) in crate::scene::builtin::layer_colors(n) {
        for c in 0..3 {
            expected[c] += t * alpha as f64 * color[c] as f64;
        }
        t *= 1.0 - alpha as f64;
    }
    let expected: Vec<u8> = (0..3)
        .map(|c| {
            (crate::scene::linear_to_srgb((expected[c] + t * background[c]) as f32) * 255.0).round()
                as u8
        })
        .collect();
    let mut pictures = vec![("reference", render_reference(&s, &opts))];
    for m in EXACT_METHODS {
        pictures.push((m, render_gpu(&s, &opts, m).0));
    }
    for (method, image) in pictures {
        let rgba = image.to_rgba8(Effect::Transparency);
        for p in rgba.pixels() {
            for c in 0..3 {
                assert!(
                    (p[c] as i32 - expected[c] as i32).abs() <= 1,
                    "{method}: pixel {:?} vs closed form {expected:?}",
                    p
                );
            }
        }
    }
}

#[test]
fn exact_methods_are_deterministic() {
    let s = scene("builtin:nvpro?objects=64&subdiv=10&seed=9");
    let opts = options(64, Effect::Translucency);
    for method in EXACT_METHODS {
        let a = render_gpu(&s, &opts, method).0;
        let b = render_gpu(&s, &opts, method).0;
        assert!(a == b, "{method}: two renders differ");
    }
}

/// Nested spheres whose fragments overflow a pool of 16 nodes: `method`'s frame reports the
/// overflow, takes `passes` geometry passes in all, drops nothing, and its picture is exact.
/// Returns the scene and the options.
fn pool_overflows_and_stays_exact(method: &str, passes: u32) -> (Scene, RenderOptions) {
    let s = scene("builtin:spheres?layers=12");
    let mut opts = options(64, Effect::Transparency);
    opts.frame.family_mut::<KBufferOptions>().initial_nodes = Some(16);
    let (actual, stats) = render_gpu(&s, &opts, method);
    assert_eq!(stats.overflow, Some(true), "{method}");
    assert_eq!(stats.geometry_passes, passes, "{method}");
    assert_eq!(stats.fragments_dropped, Some(0), "{method}");
    Expected::reference(&s, &opts).assert_exact(&format!("overflow-{method}"), &actual);
    (s, opts)
}

#[test]
fn abuffer_pool_overflow_is_detected_and_the_image_stays_exact() {
    let (s, mut opts) = pool_overflows_and_stays_exact("abuffer-ll", 2);
    // A pool that fits reports no overflow.
    opts.frame.family_mut::<KBufferOptions>().initial_nodes = None;
    assert_eq!(render_gpu(&s, &opts, "abuffer-ll").1.overflow, Some(false));
}

#[test]
fn abuffer_budget_too_small_is_a_clear_error() {
    let s = scene("builtin:spheres?layers=12");
    let mut opts = options(64, Effect::Transparency);
    opts.frame.budget_mb = Some(0.02);
    opts.frame.family_mut::<KBufferOptions>().initial_nodes = Some(16);
    let e = renderer(&s, &opts).render("abuffer-ll").unwrap_err();
    assert_input_error("abuffer-ll", &e, "--budget-mb");
}

/// Where no triangles overlap out of order the baselines are exact: screen-aligned layers sort
/// correctly by centroid, and back-to-front submission needs no sort.
#[test]
fn baselines_are_exact_where_order_is_trivial() {
    let opts = options(48, Effect::Transparency);
    let shuffled = scene("builtin:layers?n=10&coverage=0.5&order=random&seed=4");
    let expected = render_reference(&shuffled, &opts);
    let (sorted, _) = render_gpu(&shuffled, &opts, "sorted");
    assert_exact("layers-sorted", &sorted, &expected, opts.frame.effect);
    let back = scene("builtin:layers?n=10&coverage=0.5&order=back&seed=4");
    let (unsorted, _) = render_gpu(&back, &opts, "unsorted");
    assert_exact("layers-unsorted", &unsorted, &expected, opts.frame.effect);
    // And out of order, unsorted blending is visibly wrong: the reason OIT exists.
    let (wrong, _) = render_gpu(&shuffled, &opts, "unsorted");
    let c = crate::metrics::compare(
        &wrong.to_rgba8(opts.frame.effect),
        &expected.to_rgba8(opts.frame.effect),
    )
    .unwrap();
    assert!(
        c.pct_over_2 > 10.0,
        "unsorted on shuffled layers should differ: {c:?}"
    );
}

/// Fragments behind a supplied opaque depth are rejected by every method: layers behind the
/// opaque depth vanish, as if they were not in the scene.
#[test]
fn opaque_depth_rejects_fragments_behind_it() {
    let n = 10;
    let keep = 6;
    let full = covering_layers(n, 2);
    let mut front_only = full.clone();
    front_only.objects.retain(|o| {
        let i: usize = o.name.trim_start_matches("layer ").parse().unwrap();
        i < keep
    });
    let opts = options(32, Effect::Transparency);
    let expected = Expected::reference(&front_only, &opts);
    // Window depth halfway between layer keep−1 and layer keep (orthographic: linear in distance).
    let cam = full.camera.unwrap();
    let z = |i: usize| {
        let d = cam.eye.z - crate::scene::builtin::layer_depth(i, n);
        (d - cam.near) / (cam.far - cam.near)
    };
    let between = 0.5 * (z(keep - 1) + z(keep));
    for method in ["f2b", "dual", "abuffer-ll", "unsorted"] {
        let mut r = renderer(&full, &opts);
        crate::render::clear_depth(
            crate::testing::gpu(),
            &r.opaque_depth().create_view(&Default::default()),
            between,
        );
        let (actual, _) = r.render(method).unwrap();
        if method == "unsorted" {
            // Shuffled submission: only the count is order independent.
            assert_eq!(actual.max_count(), keep as u32);
            continue;
        }
        expected.assert_exact(&format!("opaque-{method}"), &actual);
    }
}

#[test]
fn unknown_method_is_an_input_error() {
    let mut r = renderer(
        &scene("builtin:layers?n=2"),
        &options(16, Effect::Transparency),
    );
    let e = r.render("nope").expect_err("unknown method fails");
    assert_input_error("nope", &e, "unknown method 'nope'");
}

/// `bytes_allocated` follows the formula `strata methods` prints.
#[test]
fn bytes_allocated_follow_the_catalogue_formulas() {
    let s = scene("builtin:spheres?layers=4");
    let opts = options(40, Effect::Transparency);
    let px = 40 * 40;
    let tris = s.triangle_count() as u64;
    for (method, expected) in [
        ("unsorted", 12 * px),
        ("sorted", 12 * px + 12 * tris),
        ("f2b", 72 * px),
        (
            "dual",
            if crate::methods::peeling::has_wide_keys(crate::testing::gpu()) {
                172 * px
            } else {
                156 * px
            },
        ),
    ] {
        assert_eq!(
            render_gpu(&s, &opts, method).1.bytes_allocated,
            expected,
            "{method}"
        );
    }
    let mut opts = opts;
    opts.frame.family_mut::<KBufferOptions>().initial_nodes = Some(5000);
    assert_eq!(
        render_gpu(&s, &opts, "abuffer-ll").1.bytes_allocated,
        20 * 5000 + 16 * px + 156
    );
    assert_eq!(std::mem::size_of::<crate::resolve::RefFragment>(), 64);
}

/// A committed golden picture of shaded output (lit, Fresnel, absorption, checker background),
/// so a change that moved the GPU and the reference the same way is still caught. Regenerate
/// deliberately with `STRATA_BLESS=1 cargo test -p strata golden`.
#[test]
fn golden_demo_translucency() {
    let path = format!(
        "{}/tests/golden/demo-translucency-96.png",
        env!("CARGO_MANIFEST_DIR")
    );
    let opts = options(96, Effect::Translucency);
    let s = scene("builtin:demo");
    let reference = render_reference(&s, &opts).to_rgba8(opts.frame.effect);
    if std::env::var_os("STRATA_BLESS").is_some() {
        reference.save(&path).unwrap();
    }
    let golden = crate::metrics::load_png(std::path::Path::new(&path)).unwrap();
    // The reference is f64 and deterministic: 1/255 allows a last-bit rounding difference of
    // another CPU's libm in pow/exp; the GPU gets the exact-method bar.
    if let Err(m) =
        crate::metrics::testing::check_image("golden-reference", &reference, &golden, 1, 0.0)
    {
        panic!("{m}");
    }
    let (gpu, _) = render_gpu(&s, &opts, "abuffer-ll");
    if let Err(m) = crate::metrics::testing::check_image(
        "golden-abuffer-ll",
        &gpu.to_rgba8(opts.frame.effect),
        &golden,
        EXACT_MAX_DIFF,
        EXACT_MAX_FRACTION,
    ) {
        panic!("{m}");
    }
}

/// An application's draw callback replaces the default draw: drawing only the first half of the
/// layers' triangles gives the picture of a scene holding only those layers.
#[test]
fn draw_callback_issues_the_geometry() {
    let full = scene("builtin:layers?n=8&coverage=1&order=front");
    let mut half = full.clone();
    half.objects.truncate(4);
    let opts = options(24, Effect::Transparency);
    let expected = Expected::reference(&half, &opts);
    let vertices = half.triangle_count() as u32 * 3;
    let drawing = EXACT_METHODS.iter().filter(|m| {
        let id: super::MethodId = m.parse().unwrap();
        id.descriptor().draw_callback.yes()
    });
    for method in drawing {
        let (actual, _) = renderer(&full, &opts)
            .render_with(method, &|pass| pass.draw(0..vertices, 0..1))
            .unwrap();
        expected.assert_exact(&format!("callback-{method}"), &actual);
    }
}

/// Methods keep their buffers between frames: a second frame from the same renderer must equal
/// the first (stale counters, lists or slots would show).
#[test]
fn second_frame_equals_the_first_for_every_method() {
    let s = scene("builtin:nvpro?objects=48&subdiv=10&seed=4");
    let mut opts = options(40, Effect::Transparency);
    opts.frame.k = Some(6);
    let mut shared = renderer(&s, &opts);
    // `kb` races by design: on a GPU that shades a pixel's fragments concurrently its frames may
    // differ, so it is left out.
    for m in super::MethodId::gpu_methods().filter(|&m| m != super::MethodId::Kb) {
        let roomy = room_for_every_fragment(m, &opts);
        let mut own;
        let r = if (roomy.frame.k, roomy.build.msaa) == (opts.frame.k, opts.build.msaa) {
            &mut shared
        } else {
            own = renderer(&s, &roomy);
            &mut own
        };
        let (first, a) = r.render(m.as_str()).unwrap();
        let (second, b) = r.render(m.as_str()).unwrap();
        assert!(first == second, "{m}: second frame differs");
        assert_eq!(a.fragments_generated, b.fragments_generated, "{m}");
    }
}

/// `abuffer-fixed` keeps the first k fragments to arrive, and `mlab` merges in arrival order, and
/// on a GPU the order of arrival changes from frame to frame (the H100 showed it): the frame
/// tests give them room for every fragment, so that a difference can only come from stale or
/// poisoned memory.
pub(crate) fn room_for_every_fragment(m: super::MethodId, opts: &RenderOptions) -> RenderOptions {
    let mut opts = runnable(m, opts);
    if matches!(m, super::MethodId::AbufferFixed | super::MethodId::Mlab) {
        opts.frame.k = Some(64);
    }
    opts
}

/// `opts` with the samples `m` needs at least (stochastic's stipples).
fn runnable(m: super::MethodId, opts: &RenderOptions) -> RenderOptions {
    let mut opts = opts.clone();
    opts.build.msaa = opts.build.msaa.max(m.descriptor().min_samples);
    opts
}

/// Every method but `kb` (which races by design on a GPU) on a small scene at k = 6.
fn frame_test_methods() -> impl Iterator<Item = super::MethodId> {
    super::MethodId::gpu_methods().filter(|m| *m != super::MethodId::Kb)
}

/// Renders each of `methods` twice with one renderer, the second time after filling its
/// storage with garbage: the pictures and counts must be the same.
pub(crate) fn check_poisoned(opts: &RenderOptions, methods: impl Iterator<Item = super::MethodId>) {
    let s = scene("builtin:nvpro?objects=48&subdiv=10&seed=4");
    let mut failures = Failures::default();
    for m in methods {
        let opts = &room_for_every_fragment(m, opts);
        let mut r = renderer(&s, opts);
        let (clean, a) = r.render_method(m, None).unwrap();
        r.recorder().unwrap().poison();
        let (poisoned, b) = r.render_method(m, None).unwrap();
        let name = m.as_str();
        if !(failures.locks_held(name, &a) && failures.locks_held(name, &b)) {
            continue;
        }
        let differing = differing_pixels(&clean, &poisoned);
        failures.check(
            name,
            if differing > 0 {
                Err(format!(
                    "(--msaa {}) poisoned memory changed {differing} pixels; fragments stored {:?} then {:?}, dropped {:?} then {:?}",
                    opts.build.msaa, a.fragments_stored, b.fragments_stored, a.fragments_dropped, b.fragments_dropped
                ))
            } else if (a.fragments_generated, a.fragments_dropped)
                != (b.fragments_generated, b.fragments_dropped)
            {
                Err(format!(
                    "counts changed: generated {:?} then {:?}, dropped {:?} then {:?}",
                    a.fragments_generated, b.fragments_generated, a.fragments_dropped, b.fragments_dropped
                ))
            } else {
                Ok(())
            },
        );
    }
    failures.finish("poisoned storage");
}

/// Per-pixel storage, counters, the resolved frame and the totals filled with garbage before a
/// frame change nothing: a frame reads only what it wrote.
#[test]
fn poisoned_storage_changes_nothing() {
    let mut opts = options(40, Effect::Translucency);
    opts.frame.k = Some(6);
    opts.frame.family_mut::<KBufferOptions>().tail = crate::Tail::Blend;
    // kb-mdt64 and kb-mdt-pack refuse translucency (and kb-mdt-pack a blended tail).
    let methods = frame_test_methods()
        .filter(|m| !matches!(m, super::MethodId::KbMdt64 | super::MethodId::KbMdtPack));
    check_poisoned(&opts, methods);
}

/// The same with `--culling off` and the tail dropped: the H100 changed the ordered captures'
/// pictures over poisoned storage (2026-11-26); these take the published culling bound and the
/// tail sums out of the frame, so a run says whether either is involved.
#[test]
fn poisoned_storage_changes_nothing_without_culling() {
    let mut opts = options(40, Effect::Translucency);
    opts.frame.k = Some(6);
    opts.frame.family_mut::<KBufferOptions>().tail = crate::Tail::Blend;
    opts.frame.family_mut::<KBufferOptions>().culling = false;
    check_poisoned(&opts, super::kbuffer::ordered_methods());
}

#[test]
fn poisoned_storage_changes_nothing_with_the_tail_dropped() {
    let mut opts = options(40, Effect::Translucency);
    opts.frame.k = Some(6);
    check_poisoned(&opts, super::kbuffer::ordered_methods());
}

/// The same with --msaa 4: the per-sample storage, states and counts every family keeps are
/// set before anything reads them.
#[test]
fn poisoned_storage_changes_nothing_multisampled() {
    let mut opts = options(32, Effect::Translucency);
    opts.frame.k = Some(6);
    opts.frame.family_mut::<KBufferOptions>().tail = crate::Tail::Blend;
    opts.build.msaa = 4;
    check_poisoned(
        &opts,
        frame_test_methods().filter(|&m| m.descriptor().msaa.yes()),
    );
}

/// One renderer draws near geometry, then far geometry: the second frame must equal a fresh
/// renderer's frame of the far geometry exactly, fragment counts included (nothing of the first
/// frame may survive in lists, slots, counters or bounds).
#[test]
fn a_second_frame_keeps_nothing_of_the_first() {
    let full = scene("builtin:layers?n=8&coverage=0.8&order=front&seed=3");
    let mut near = full.clone();
    near.objects.truncate(4);
    let split = near.triangle_count() as u32 * 3;
    let total = full.triangle_count() as u32 * 3;
    let draw_near = move |pass: &mut wgpu::RenderPass<'_>| pass.draw(0..split, 0..1);
    let draw_far = move |pass: &mut wgpu::RenderPass<'_>| pass.draw(split..total, 0..1);
    // Methods that draw every triangle themselves refuse a callback (tested below).
    for m in frame_test_methods().filter(|&m| m.descriptor().draw_callback.yes()) {
        let mut opts = options(24, Effect::Transparency);
        // bucket's k is even (two per bucket).
        opts.frame.k = Some(if m == super::MethodId::Bucket { 4 } else { 3 });
        let opts = room_for_every_fragment(m, &opts);
        let mut r = renderer(&full, &opts);
        r.render_method(m, Some(&draw_near)).unwrap();
        let (second, a) = r.render_method(m, Some(&draw_far)).unwrap();
        let mut fresh = renderer(&full, &opts);
        let (expected, b) = fresh.render_method(m, Some(&draw_far)).unwrap();
        assert!(
            second == expected,
            "{m}: the first frame leaked into the second"
        );
        assert_eq!(a.fragments_generated, b.fragments_generated, "{m}");
        assert_eq!(a.fragments_stored, b.fragments_stored, "{m}");
        assert_eq!(a.max_depth_complexity, b.max_depth_complexity, "{m}");
    }
}

/// `sorted` and `convex` draw the scene's triangles through their own index buffers, `tiled`
/// rasterizes them itself: an application's draw callback would be ignored, so it is refused.
#[test]
fn methods_drawing_the_scene_themselves_refuse_a_draw_callback() {
    let s = scene("builtin:layers?n=4");
    let refusing: Vec<_> = super::MethodId::gpu_methods()
        .filter(|m| !m.descriptor().draw_callback.yes())
        .collect();
    assert_eq!(
        refusing,
        [
            super::MethodId::Sorted,
            super::MethodId::Convex,
            super::MethodId::Tiled
        ]
    );
    for method in refusing.iter().map(|m| m.as_str()) {
        let mut r = renderer(&s, &options(16, Effect::Transparency));
        let e = r
            .render_with(method, &|pass| pass.draw(0..6, 0..1))
            .expect_err("refuses a callback");
        assert_unsupported(method, &e, "draw callback");
        // Without one it draws.
        r.render(method).unwrap();
    }
}

/// Pool allocation counters started just below 2³² saturate: every fragment is counted as
/// dropped, the frame reports the overflow, no node is handed out twice and the resolve ends
/// (a wrapped counter would reuse nodes, form cycles and hang the resolve).
#[test]
fn allocation_counters_saturate_instead_of_wrapping() {
    let s = scene("builtin:spheres?layers=6");
    let mut opts = options(32, Effect::Transparency);
    opts.frame.k = Some(4);
    opts.frame
        .family_mut::<KBufferOptions>()
        .allocation_counter_start = u32::MAX - 8;
    let gpu = crate::testing::gpu();
    for m in [
        super::MethodId::AbufferLl,
        super::MethodId::KbAbLl,
        super::MethodId::KbLl,
    ] {
        let mut rec = crate::FrameRecorder::new(gpu, &s, m, &opts).unwrap();
        let mut enc = gpu.device.create_command_encoder(&Default::default());
        rec.record(&mut enc, &Default::default(), None).unwrap();
        gpu.queue.submit([enc.finish()]);
        let report = rec.wait_stats().unwrap();
        let st = report.stats;
        assert!(report.incomplete, "{m}");
        assert_eq!(st.overflow, Some(true), "{m}");
        let generated = st.fragments_generated.unwrap();
        assert!(generated > 0, "{m}");
        assert_eq!(st.fragments_stored, Some(0), "{m}");
        assert_eq!(st.fragments_dropped, Some(generated), "{m}");
        let bytes = crate::gpu::readback::read_buffer(
            gpu,
            rec.resolved(),
            opts.pixels() * crate::frame::RESOLVED_BYTES,
        )
        .unwrap();
        let resolved: Vec<crate::frame::Resolved> = bytemuck::pod_collect_to_vec(&bytes);
        assert!(
            resolved
                .iter()
                .all(|r| r.count == 0 && r.color == [0.0; 3] && r.transmittance == [1.0; 3]),
            "{m}: a fragment was stored from a saturated pool"
        );
    }
}

/// Coincident faces (two layers at exactly the same depth, another held-out shape of input):
/// with 64-bit keys dual peels them one by one in primitive order like f2b and the reference;
/// without, it keeps one and counts the other as dropped.
#[test]
fn dual_peels_coincident_faces_in_primitive_order() {
    let mut s = scene("builtin:layers?n=3&coverage=1&order=front");
    // Layer 1 moved onto layer 0: every pixel has two fragments at exactly equal depth.
    s.objects[1].mesh.positions = s.objects[0].mesh.positions.clone();
    let opts = options(24, Effect::Transparency);
    let expected = render_reference(&s, &opts);
    let (f2b, _) = render_gpu(&s, &opts, "f2b");
    assert_exact("coincident-f2b", &f2b, &expected, opts.frame.effect);
    let (dual, stats) = render_gpu(&s, &opts, "dual");
    if crate::methods::peeling::has_wide_keys(crate::testing::gpu()) {
        assert_eq!(stats.fragments_dropped, Some(0));
        assert_exact("coincident-dual", &dual, &expected, opts.frame.effect);
    } else {
        assert_eq!(stats.fragments_dropped, Some(24 * 24));
    }
}

/// The command line's names for methods (clap's `ValueEnum`) are the catalogue's ids, and every
/// id has exactly one entry in the method table.
#[cfg(feature = "clap")]
#[test]
fn value_enum_names_are_the_ids() {
    use clap::ValueEnum;
    for &m in super::MethodId::value_variants() {
        assert_eq!(m.to_possible_value().unwrap().get_name(), m.as_str());
        let entries = super::TABLE.iter().filter(|d| d.id == m).count();
        assert_eq!(entries, 1, "{m} is registered {entries} times");
    }
    assert_eq!(super::TABLE.len(), super::MethodId::value_variants().len());
}

/// The S-buffer's pool sized below the frame's fragments: the frame keeps the regions that fit,
/// reports the overflow, and exact mode renders again with the grown pool (2 + 2 passes); the
/// picture is exact.
#[test]
fn sbuffer_pool_overflow_is_reported_and_the_image_stays_exact() {
    let (s, mut opts) = pool_overflows_and_stays_exact("sbuffer", 4);
    opts.frame.budget_mb = Some(0.2);
    let e = renderer(&s, &opts).render("sbuffer").unwrap_err();
    assert_input_error("sbuffer", &e, "--budget-mb");
}

/// Over 65,536 pixels the prefix sum takes three levels (96,000 → 375 → 2): the S-buffer is
/// still exact.
#[test]
fn sbuffer_is_exact_with_a_three_level_prefix_sum() {
    let s = scene("builtin:layers?n=6&coverage=0.7&order=random&seed=8");
    let mut opts = options(320, Effect::Transparency);
    opts.frame.height = 300;
    assert_eq!(
        crate::methods::kbuffer::sbuffer::scan_levels(opts.pixels())
            .0
            .len(),
        3
    );
    let expected = render_reference(&s, &opts);
    let (actual, stats) = render_gpu(&s, &opts, "sbuffer");
    assert_exact("sbuffer-3-levels", &actual, &expected, opts.frame.effect);
    assert_eq!(stats.fragments_dropped, Some(0));
}

/// The memory ledger: every method reports what it allocates, fits a budget of exactly that,
/// and refuses a budget one byte smaller (pool methods may shrink their pool into it instead)
/// or far too small with one clear error naming --budget-mb.
#[test]
fn every_method_keeps_within_the_budget() {
    let s = scene("builtin:nvpro?objects=48&subdiv=10&seed=4");
    let mut base = options(32, Effect::Transparency);
    base.frame.k = Some(4);
    let mib = |bytes: u64| bytes as f64 / 1048576.0;
    for m in super::MethodId::gpu_methods() {
        let mut opts = runnable(m, &base);
        let (_, stats) = render_gpu(&s, &opts, m.as_str());
        let bytes = stats.bytes_allocated;
        assert!(bytes > 0, "{m}: reports no allocation");
        for budget in [bytes, bytes - 1] {
            let mut tight = opts.clone();
            tight.frame.budget_mb = Some(mib(budget));
            let mut r = renderer(&s, &tight);
            match r.render(m.as_str()) {
                Ok((_, st)) => {
                    assert!(st.bytes_allocated <= budget, "{m}: over budget");
                    assert!(
                        budget == bytes || pool_method(m),
                        "{m}: took {budget} < {bytes}"
                    );
                }
                Err(e) => {
                    assert!(budget < bytes, "{m}: refused its own size: {e}");
                    assert!(e.to_string().contains("--budget-mb"), "{m}: {e}");
                }
            }
        }
        opts.frame.budget_mb = Some(0.001);
        let mut r = renderer(&s, &opts);
        let e = r.render(m.as_str()).expect_err("1 KiB holds no method");
        assert_input_error(m.as_str(), &e, "--budget-mb");
    }
}

/// Methods whose fragment pool is sized from measured need (it shrinks into a budget).
fn pool_method(m: super::MethodId) -> bool {
    use super::MethodId::*;
    matches!(
        m,
        AbufferLl | KbAbLl | KbLl | Sbuffer | KbSbuffer | KplusSbuffer
    )
}

/// Each descriptor builds its own method (issue 66): a family's descriptor file has no `_ =>`
/// arm (one made a forgotten method silently another: a new list k-buffer became abuffer-ll and
/// passed its exactness test), every entry in the table builds on this device, and a builder an
/// entry inherits from another (`..KPLUS_ARRAY`) refuses it rather than build the other method.
#[test]
fn each_descriptor_builds_its_own_method() {
    use super::{table, MethodId, TABLE};
    for (file, source) in [
        ("baseline", include_str!("baseline/descriptor.rs")),
        ("weighted", include_str!("weighted/descriptor.rs")),
        ("peeling", include_str!("peeling/descriptor.rs")),
        ("kbuffer", include_str!("kbuffer/descriptor.rs")),
        ("convex", include_str!("convex/descriptor.rs")),
        ("tiled", include_str!("tiled/descriptor.rs")),
    ] {
        assert!(
            !source.contains("_ =>"),
            "{file}/descriptor.rs has a fallthrough arm"
        );
    }
    let gpu = crate::testing::gpu();
    let scene = scene("builtin:layers?n=3");
    let options = RenderOptions::sized(8, 8);
    let mut scene_gpu = crate::frame::SceneGpu::new(gpu, &scene, &options).unwrap();
    for d in TABLE.iter().filter(|d| d.id != MethodId::Reference) {
        let mut options = options.clone();
        options.build.msaa = d.min_samples;
        scene_gpu.samples = d.min_samples;
        let made = (d.create)(
            d.id,
            &table::Setup {
                gpu,
                scene: &scene_gpu,
                options: &options,
            },
        );
        assert!(made.is_ok(), "{}: {:?}", d.name, made.err());
    }
    scene_gpu.samples = 1;
    let inherited = crate::methods::kbuffer::descriptor::KPLUS_ARRAY.create;
    let setup = table::Setup {
        gpu,
        scene: &scene_gpu,
        options: &options,
    };
    let e = inherited(MethodId::KplusHeap, &setup)
        .err()
        .expect("kplus-array's builder refuses kplus-heap")
        .to_string();
    assert!(e.contains("kplus-heap") && e.contains("kplus-array"), "{e}");
}

/// The README's methods table is `strata methods --markdown`, from the method table: a method
/// added, or a fact of one changed, without the README following fails here.
#[test]
fn the_readme_carries_the_methods_table() {
    let readme = std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/../../README.md"))
        .expect("the workspace README");
    let table = super::markdown_table();
    assert!(
        readme.contains(&table),
        "README.md's methods table differs from `strata methods --markdown`:\n{table}"
    );
    assert_eq!(table.lines().count(), super::TABLE.len() + 2);
}
