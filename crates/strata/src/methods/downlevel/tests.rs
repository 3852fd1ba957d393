use super::*;
use crate::frame::FrameTargets;
use crate::methods::peeling::PeelingOptions;
use crate::methods::MethodId;
use crate::metrics::LinearImage;
use crate::scene::{Background, Blend};
use crate::testing::{gpu, render_reference, Failures};
use crate::{RenderOptions, Renderer};

/// A WebGL2-class device (no storage buffers, no compute) at the adapter's sizes.
fn webgl2() -> &'static Gpu {
    static GPU: std::sync::OnceLock<Gpu> = std::sync::OnceLock::new();
    GPU.get_or_init(|| {
        let limits =
            wgpu::Limits::downlevel_webgl2_defaults().using_resolution(gpu().limits.clone());
        Gpu::new_restricted(wgpu::Features::empty(), limits).expect("lavapipe opens")
    })
}

fn scene(spec: &str) -> Scene {
    crate::scene::loaders::load_scene(spec).unwrap()
}

fn render(on: &Gpu, scene: &Scene, options: &RenderOptions) -> (LinearImage, FrameStats) {
    render_with(on, MethodId::F2b, scene, options)
}

fn render_with(
    on: &Gpu,
    method: MethodId,
    scene: &Scene,
    options: &RenderOptions,
) -> (LinearImage, FrameStats) {
    Renderer::new(on, scene, options)
        .and_then(|mut r| r.render_method(method, None))
        .unwrap_or_else(|e| panic!("{method} on {}: {e}", on.info.name))
}

/// f2b's picture against the exact truth, as the exact methods' tests hold them to it: the
/// reference where the device's rasterizer agrees with it, the reference over the device's own
/// fragments where it does not (a real GPU's depths may differ from the reference's).
fn assert_exact(name: &str, s: &Scene, options: &RenderOptions, image: &LinearImage) {
    let expected = render_reference(s, options);
    let truth = crate::methods::kbuffer::tests::exact_truth(s, options, expected);
    let mut failures = Failures::default();
    failures.check_exact_picture("f2b", name, image, &truth, options.frame.effect);
    failures.finish(name);
}

/// The downlevel frame counted the fragments and the deepest pixel as the full device did.
fn assert_same_counts(name: &str, downlevel: &FrameStats, full: &FrameStats) {
    assert_eq!(
        (
            downlevel.fragments_generated,
            downlevel.max_depth_complexity
        ),
        (full.fragments_generated, full.max_depth_complexity),
        "{name}"
    );
}

/// The largest difference of two pictures' color channels.
fn worst_difference(a: &LinearImage, b: &LinearImage) -> f32 {
    a.pixels
        .iter()
        .zip(&b.pixels)
        .flat_map(|(x, y)| (0..3).map(move |c| (x[c] - y[c]).abs()))
        .fold(0.0f32, f32::max)
}

/// Layered quads blending over, add and multiply in turn.
fn blended_layers() -> Scene {
    let mut s = scene("builtin:layers?n=9&coverage=0.75&order=random&seed=5");
    let modes = [Blend::Over, Blend::Add, Blend::Multiply];
    for (i, m) in s.materials.iter_mut().enumerate() {
        m.blend = modes[i % 3];
    }
    s
}

/// On the WebGL2-class device f2b's picture is the reference's, and its statistics count what
/// f2b on the full device counts: every fragment, the deepest pixel, nothing dropped.
#[test]
fn downlevel_f2b_equals_the_reference_and_the_full_devices_f2b() {
    assert!(is_downlevel(webgl2()));
    let cases = [
        (
            "spheres",
            scene("builtin:spheres?layers=4&segments=12"),
            Effect::Translucency,
            Background::Checker,
        ),
        (
            "blend",
            blended_layers(),
            Effect::Transparency,
            Background::Color([0.3, 0.5, 0.7]),
        ),
        (
            "demo",
            scene("builtin:demo"),
            Effect::Complexity,
            Background::Checker,
        ),
    ];
    for (name, s, effect, background) in cases {
        // Large enough that the exact truth's 0.1% allowance is more than a pixel or two.
        let mut options = RenderOptions::sized(96, 80);
        options.frame.effect = effect;
        options.frame.background = background;
        let (image, stats) = render(webgl2(), &s, &options);
        let (full, full_stats) = render(gpu(), &s, &options);
        assert_exact(&format!("downlevel-{name}"), &s, &options, &image);
        let worst = worst_difference(&image, &full);
        assert!(
            worst < 1e-5,
            "{name}: differs from the full device's f2b by {worst}"
        );
        assert_eq!(stats.exact, Some(true), "{name}");
        assert_eq!(stats.fragments_dropped, Some(0), "{name}");
        assert_same_counts(name, &stats, &full_stats);
        assert!(stats.fragments_generated.unwrap() > 0, "{name}");
    }
}

/// Exact mode counts the deepest pixel's fragments first and peels that many layers: one
/// frame, complete, whose probe finds nothing deeper (real-time frames, which do not count,
/// grow from the probe: see the present's test). With `--layers` fixed, the frame says it is
/// not exact and counts only what it kept.
#[test]
fn downlevel_frames_peel_more_until_nothing_lies_deeper() {
    let s = scene("builtin:layers?n=20&coverage=1&order=random&seed=3");
    let options = RenderOptions::sized(24, 24);
    let (image, stats) = render(webgl2(), &s, &options);
    assert_eq!(stats.max_depth_complexity, Some(20));
    assert_eq!(stats.exact, Some(true));
    // The count, then 20 layers and the probe.
    assert_eq!(stats.geometry_passes, 1 + 21);
    assert_exact("downlevel-deep", &s, &options, &image);
    let mut fixed = options.clone();
    fixed.frame.family_mut::<PeelingOptions>().layers = Some(3);
    let (_, stats) = render(webgl2(), &s, &fixed);
    assert_eq!(stats.exact, Some(false));
    assert_eq!(stats.fragments_generated, None);
    assert_eq!(stats.fragments_stored, Some(3 * 24 * 24));
    assert_eq!(stats.geometry_passes, 4);
}

/// In real time the frame records into the application's encoder and presents over its
/// target: the target becomes the picture the batch renderer reads back. The scene has 9
/// layers: the first frame peels 8 and learns it a frame later; the next one is complete.
#[test]
fn downlevel_present_puts_the_frame_over_the_applications_target() {
    let g = webgl2();
    let s = blended_layers();
    let mut options = RenderOptions::sized(32, 32);
    let background = [0.3f32, 0.5, 0.7];
    options.frame.background = Background::Color(background);
    let (expected, _) = render(g, &s, &options);
    let mut peeling = DownlevelFrame::new(g, &s, MethodId::F2b, &options).unwrap();
    let format = wgpu::TextureFormat::Rgba16Float;
    let target = g.texture_2d(
        "test.target",
        (32, 32),
        format,
        wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::COPY_SRC,
    );
    let view = target.create_view(&Default::default());
    let mut encoder = g.device.create_command_encoder(&Default::default());
    peeling
        .record(g, &mut encoder, &FrameTargets::default())
        .unwrap();
    g.queue.submit([encoder.finish()]);
    let first = peeling.wait_stats(g).unwrap();
    assert_eq!((first.frame, first.exact), (0, Some(false)));
    assert_eq!(peeling.layers(), 16);
    let mut encoder = g.device.create_command_encoder(&Default::default());
    let [r, g_, b] = background.map(f64::from);
    encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
        label: None,
        color_attachments: &[attachment(
            &view,
            wgpu::Color {
                r,
                g: g_,
                b,
                a: 1.0,
            },
        )],
        ..Default::default()
    });
    let targets = FrameTargets {
        color: Some((&view, format)),
        opaque_depth: None,
    };
    peeling.record(g, &mut encoder, &targets).unwrap();
    g.queue.submit([encoder.finish()]);
    let presented = crate::gpu::readback::read_rgba16f(g, &target).unwrap();
    // The target holds f16: each of the two draws rounds.
    let worst = presented
        .iter()
        .zip(&expected.pixels)
        .flat_map(|(p, e)| (0..3).map(move |c| (p[c] - e[c]).abs()))
        .fold(0.0f32, f32::max);
    assert!(
        worst < 2e-3,
        "the present differs from the picture by {worst}"
    );
    let second = peeling.wait_stats(g).unwrap();
    assert_eq!(
        (second.frame, second.exact, second.submits),
        (1, Some(true), 0)
    );
}

/// What a downlevel frame cannot hold is refused in one line naming it.
#[test]
fn downlevel_refusals_are_one_line() {
    let s = scene("builtin:spheres?layers=2&segments=8");
    let mut msaa = RenderOptions::sized(16, 16);
    msaa.build.msaa = 4;
    let mut many = s.clone();
    many.materials = vec![many.materials[0].clone(); UNIFORM_MATERIALS + 1];
    let cases = [
        (
            s.clone(),
            msaa,
            "--msaa: not available on a downlevel device",
        ),
        (
            many,
            RenderOptions::sized(16, 16),
            "the scene has 257 materials; on a downlevel device f2b holds at most 256",
        ),
    ];
    for (scene, options, expected) in cases {
        let e = match Renderer::new(webgl2(), &scene, &options)
            .and_then(|mut r| r.render_method(MethodId::F2b, None))
        {
            Ok(_) => panic!("rendered: {expected}"),
            Err(e) => e.to_string(),
        };
        assert!(e.contains(expected) && !e.contains('\n'), "{e}");
    }
    let e = Renderer::new(webgl2(), &s, &RenderOptions::sized(16, 16))
        .and_then(|mut r| r.render_method(MethodId::KbKeys, None))
        .expect_err("refused")
        .to_string();
    assert!(
        e.starts_with("kb-keys does not run here:")
            && e.contains("of strata's methods only wboit and f2b run on it"),
        "{e}"
    );
}

/// wboit on the WebGL2-class device is the full device's wboit: the same closed form from the
/// same blended targets (its count from a blended target instead of atomics), and the same
/// fragment count; refused for blend modes, as on the full device.
#[test]
fn downlevel_wboit_equals_the_full_devices_wboit() {
    for (name, s, effect) in [
        (
            "spheres",
            scene("builtin:spheres?layers=4&segments=12"),
            Effect::Translucency,
        ),
        ("demo", scene("builtin:demo"), Effect::Transparency),
    ] {
        let mut options = RenderOptions::sized(48, 40);
        options.frame.effect = effect;
        let (image, stats) = render_with(webgl2(), MethodId::Wboit, &s, &options);
        let (full, full_stats) = render_with(gpu(), MethodId::Wboit, &s, &options);
        let worst = worst_difference(&image, &full);
        assert!(
            worst < 1e-5,
            "{name}: differs from the full device's wboit by {worst}"
        );
        assert_eq!(stats.method, "wboit");
        assert_eq!(stats.exact, Some(false), "{name}");
        assert_eq!(stats.geometry_passes, 1, "{name}");
        assert_same_counts(name, &stats, &full_stats);
    }
    let e = Renderer::new(webgl2(), &blended_layers(), &RenderOptions::sized(16, 16))
        .and_then(|mut r| r.render_method(MethodId::Wboit, None))
        .expect_err("refused")
        .to_string();
    assert!(e.starts_with("wboit cannot blend 'add' materials"), "{e}");
}
