//! The own-shaders example (an application with its own vertex format, bind group, opaque pass
//! and fragment stage) held to hand-computed pictures for every method that takes the
//! application's shaders, and every misuse of the application path answered with one error.

#[path = "../../../examples/own_shaders.rs"]
mod app;

use std::sync::OnceLock;

use strata::frame::application::{AppShader, VertexLayout};
use strata::frame::FrameTargets;
use strata::gpu::Gpu;
use strata::{FrameRecorder, MethodId, RenderOptions};

fn device() -> &'static (wgpu::Device, wgpu::Queue) {
    static DEVICE: OnceLock<(wgpu::Device, wgpu::Queue)> = OnceLock::new();
    DEVICE.get_or_init(|| app::device().expect("an adapter (lavapipe in CI)"))
}

fn srgb(c: f64) -> u8 {
    let c = c.clamp(0.0, 1.0);
    let s = if c <= 0.0031308 {
        12.92 * c
    } else {
        1.055 * c.powf(1.0 / 2.4) - 0.055
    };
    (s * 255.0).round() as u8
}

/// A quad at a pixel: its depth there, straight-alpha colour and id.
type Layer = (f64, [f64; 4], u32);

/// The quads covering pixel (x, y)'s center in front of the opaque depth, in submission order
/// (depth, straight-alpha colour, the quad's id), and what lies behind them (the wall or the
/// background).
fn layers(x: u32, y: u32) -> (Vec<Layer>, [f64; 3]) {
    let half = app::SIZE as f64 / 2.0;
    let cx = (x as f64 + 0.5) / half - 1.0;
    let cy = 1.0 - (y as f64 + 0.5) / half;
    let (rect, wall_depth, wall_color) = app::WALL;
    let on_wall = cx > rect[0] as f64 && cx < rect[2] as f64;
    let (opaque, behind) = match on_wall {
        true => (wall_depth as f64, wall_color.map(f64::from)),
        false => (1.0, app::BACKGROUND.map(f64::from)),
    };
    let layers = (0u32..)
        .zip(app::QUADS.iter())
        .filter(|(_, q)| {
            let [x0, y0, x1, y1] = q.rect.map(f64::from);
            cx > x0 && cx < x1 && cy > y0 && cy < y1
        })
        .map(|(id, q)| {
            let [z0, z1] = q.depth.map(f64::from);
            (
                z0 + (z1 - z0) * (cx + 1.0) / 2.0,
                q.color.map(f64::from),
                id,
            )
        })
        .filter(|(z, _, _)| *z < opaque)
        .collect();
    (layers, behind)
}

/// Each layer in `order` adds α·c of what still shows (front to back), over `behind`.
fn over(order: &[Layer], behind: [f64; 3]) -> [f64; 3] {
    let mut color = [0.0f64; 3];
    let mut shows = 1.0f64;
    for (_, c, _) in order {
        for i in 0..3 {
            color[i] += shows * c[3] * c[i];
        }
        shows *= 1.0 - c[3];
    }
    [0, 1, 2].map(|i| color[i] + shows * behind[i])
}

/// Pixel (x, y) of `method`, worked out from the layers by hand: exact methods composite them
/// nearest first; `unsorted` blends them in submission order (the last submitted in front);
/// the approximate methods follow their f64 closed forms (`Descriptor::closed_form`), with the
/// application's default camera (view distance = window depth) and the fewest samples they run
/// with (stochastic's 4, which every quad covers whole or not at all: its edges lie between
/// pixels).
fn expected(method: MethodId, x: u32, y: u32) -> [u8; 3] {
    let (mut layers, behind) = layers(x, y);
    let d = method.descriptor();
    let linear = match (method, d.closed_form) {
        (MethodId::Unsorted, _) => {
            layers.reverse();
            over(&layers, behind)
        }
        (_, Some(closed_form)) => {
            let fragments: Vec<strata::resolve::RefFragment> = layers
                .iter()
                .map(|(z, c, id)| strata::resolve::RefFragment {
                    depth: *z,
                    prim: *id,
                    front_facing: true,
                    color: [c[0], c[1], c[2]],
                    alpha: c[3],
                    absorption: 0.0,
                    distance: *z,
                    coverage: 0b1111,
                    blend: Default::default(),
                })
                .collect();
            let mut options = RenderOptions::default();
            options.build.msaa = d.min_samples;
            let site = strata::methods::PixelSite {
                index: y * app::SIZE + x,
                background: behind,
                camera: &strata::frame::application::depth_camera(),
                options: &options,
            };
            closed_form(&fragments, &site)
        }
        (_, None) => {
            layers.sort_by(|a, b| a.0.total_cmp(&b.0));
            over(&layers, behind)
        }
    };
    linear.map(srgb)
}

/// Largest channel difference from the hand-computed picture, and where.
fn worst(method: MethodId, picture: &image::RgbaImage) -> (u8, (u32, u32)) {
    let mut worst = (0, (0, 0));
    for (x, y, p) in picture.enumerate_pixels() {
        let e = expected(method, x, y);
        let d = (0..3).map(|i| p[i].abs_diff(e[i])).max().unwrap_or(0);
        if d > worst.0 {
            worst = (d, (x, y));
        }
    }
    worst
}

/// The largest difference any method may have from its expected picture: the 8-bit rounding
/// of the application's wall and of the result. The packed cascades keep within it on these
/// colours too (kb-mdt-pack's 6-bit sRGB channels measured 2/255, kb-mdt64's 8-bit ones 1/255).
const ALLOWED: u8 = 2;

/// Every method that takes the application's shaders draws the example's crossing and
/// occluded quads as worked out by hand (or by its closed form), in the first frame of a
/// one-shot render, single-sampled and with `--msaa 4` where it takes them (every quad edge
/// lies between pixels, so the pictures are the same): nothing of the blue quad shows through
/// the wall, the tilted green quad crosses the red one.
#[test]
fn every_application_method_matches_the_hand_computed_picture() {
    let (device, queue) = device();
    let methods: Vec<MethodId> = MethodId::gpu_methods()
        .filter(|m| m.descriptor().app_shaders.yes())
        .collect();
    assert!(methods.len() >= 25, "{methods:?}");
    let runs = methods.into_iter().flat_map(|m| {
        let d = m.descriptor();
        [1, 4]
            .into_iter()
            .filter(move |&s| s >= d.min_samples && (s == 1 || d.msaa.yes()))
            .map(move |s| (m, s))
    });
    let failures = check(device, queue, runs);
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

/// On wgpu's GL backend (Mesa llvmpipe through EGL), every application method the backend runs
/// (`strata methods --backend gl`), single-sampled: the example's GL shader passes mask 1.
#[test]
fn the_application_methods_gl_runs_match_the_hand_computed_picture() {
    let instance = wgpu::Instance::new(wgpu::InstanceDescriptor {
        backends: wgpu::Backends::GL,
        ..wgpu::InstanceDescriptor::new_without_display_handle()
    });
    let adapter = pollster::block_on(instance.request_adapter(&Default::default()))
        .expect("a GL adapter (Mesa's llvmpipe: scripts/test installs it)");
    let (device, queue) = pollster::block_on(adapter.request_device(&wgpu::DeviceDescriptor {
        label: Some("own_shaders.gl"),
        required_features: adapter.features() & strata::gpu::wanted_features(),
        required_limits: adapter.limits(),
        ..Default::default()
    }))
    .expect("a GL device");
    let offer =
        strata::methods::backends::Offer::of_gpu(&Gpu::from_device(device.clone(), queue.clone()));
    let methods: Vec<MethodId> = MethodId::gpu_methods()
        .filter(|m| {
            let d = m.descriptor();
            d.app_shaders.yes() && strata::methods::backends::verdict(d, &offer).runs()
        })
        .collect();
    assert!(methods.len() >= 13, "{methods:?}");
    let failures = check(&device, &queue, methods.into_iter().map(|m| (m, 1)));
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

/// Each run of the example against the hand-computed picture: what failed, one line each.
fn check(
    device: &wgpu::Device,
    queue: &wgpu::Queue,
    runs: impl Iterator<Item = (MethodId, u32)>,
) -> Vec<String> {
    let mut failures = Vec::new();
    for (method, samples) in runs {
        let (picture, stats) = match app::run(device, queue, method, samples) {
            Ok(r) => r,
            Err(e) => {
                failures.push(format!("{method} x{samples}: {e}"));
                continue;
            }
        };
        let method_name = format!("{method} x{samples}");
        let (d, at) = worst(method, &picture);
        if d > ALLOWED {
            let path = std::env::temp_dir().join(format!("own_shaders-{method}-x{samples}.png"));
            let _ = picture.save(&path);
            failures.push(format!(
                "{method_name}: {d}/255 off at {at:?} (got {:?}, expected {:?}; {})",
                picture.get_pixel(at.0, at.1),
                expected(method, at.0, at.1),
                path.display()
            ));
        }
        // Three layers at most, k = 16: nothing is dropped, nothing fails a lock.
        if stats.fragments_dropped != Some(0) || stats.lock_failures.unwrap_or(0) != 0 {
            failures.push(format!(
                "{method_name}: dropped {:?}, lock failures {:?}",
                stats.fragments_dropped, stats.lock_failures
            ));
        }
        if method.descriptor().exact && stats.exact != Some(true) {
            failures.push(format!(
                "{method_name}: the frame says exact {:?}",
                stats.exact
            ));
        }
    }
    failures
}

/// A minimal valid application shader and its layout, for the misuse tests.
fn shader(source_tail: &str) -> AppShader {
    let source = format!(
        "
struct Varying {{
    @builtin(position) @invariant position: vec4<f32>,
    @location(0) color: vec4<f32>,
}}
@vertex
fn vs(@location(0) clip: vec4<f32>, @location(1) color: vec4<f32>) -> Varying {{
    return Varying(clip, color);
}}
{source_tail}"
    );
    let attributes = wgpu::vertex_attr_array![0 => Float32x4, 1 => Float32x4];
    AppShader::new(source, "vs", "fs").vertex_buffer(VertexLayout::new(32, &attributes))
}

const FRAGMENT: &str = "
@fragment
fn fs(v: Varying, @builtin(front_facing) ff: bool, @builtin(sample_mask) mask: u32) -> StrataOut {
    return strata_capture(v.position, v.color, 0u, ff, mask);
}";

fn gpu() -> Gpu {
    let (device, queue) = device();
    Gpu::from_device(device.clone(), queue.clone())
}

fn refusal(method: MethodId, options: &RenderOptions, shader: AppShader) -> String {
    match FrameRecorder::for_application(&gpu(), method, options, shader) {
        Ok(_) => panic!("{method}: accepted"),
        Err(e) => e.to_string(),
    }
}

fn one_line(e: &str) {
    assert!(!e.contains('\n'), "more than one line: {e}");
}

/// Shaders strata cannot compose with its capture are refused when the recorder is made, each
/// in one line naming what is wrong.
#[test]
fn bad_application_shaders_are_refused_in_one_line() {
    let options = RenderOptions::sized(16, 16);
    let cases = [
        (shader("fn fs( {"), "does not parse"),
        (
            AppShader {
                fragment_entry: "fragment".into(),
                ..shader(FRAGMENT)
            },
            "no Fragment entry point 'fragment'",
        ),
        (
            shader(&FRAGMENT.replace(
                "return strata_capture(v.position, v.color, 0u, ff, mask);",
                "var o: StrataOut; return o;",
            )),
            "never calls strata_capture",
        ),
        (
            AppShader {
                vertex_entry: "vertex".into(),
                ..shader(FRAGMENT)
            },
            "no Vertex entry point 'vertex'",
        ),
    ];
    for (shader, says) in cases {
        let e = refusal(MethodId::AbufferLl, &options, shader);
        one_line(&e);
        assert!(e.contains(says), "expected '{says}': {e}");
    }
    let mut s = shader(FRAGMENT);
    s.source = s.source.replace("@invariant ", "");
    let e = refusal(MethodId::AbufferLl, &options, s);
    one_line(&e);
    assert!(e.contains("@invariant"), "{e}");
    // Too many bind groups for the device with strata's after them.
    let layout = gpu()
        .device
        .create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: None,
            entries: &[],
        });
    let mut s = shader(FRAGMENT);
    for _ in 0..gpu().limits.max_bind_groups {
        s = s.bind_group_layout(&layout);
    }
    let e = refusal(MethodId::AbufferLl, &options, s);
    one_line(&e);
    assert!(e.contains("max_bind_groups"), "{e}");
}

/// Methods and options that cannot take the application's shaders are refused naming why
/// (and, for a method, which methods can).
#[test]
fn methods_and_options_without_an_application_path_are_refused() {
    let options = RenderOptions::sized(16, 16);
    for method in MethodId::gpu_methods().filter(|m| !m.descriptor().app_shaders.yes()) {
        let e = refusal(method, &options, shader(FRAGMENT));
        one_line(&e);
        assert!(
            e.contains("own shaders") && e.contains("abuffer-ll"),
            "{method}: {e}"
        );
    }
    let mut translucent = options.clone();
    translucent.frame.effect = strata::Effect::Translucency;
    let e = refusal(MethodId::AbufferLl, &translucent, shader(FRAGMENT));
    assert!(e.contains("translucency"), "{e}");
    let mut auto_k = options.clone();
    auto_k.frame.k_auto = Some(0.95);
    let e = refusal(MethodId::KbKeys, &auto_k, shader(FRAGMENT));
    assert!(e.contains("--k auto"), "{e}");
    // The same options are refused between frames.
    let mut oit =
        FrameRecorder::for_application(&gpu(), MethodId::KbKeys, &options, shader(FRAGMENT))
            .unwrap();
    let e = oit
        .set_frame_options(&auto_k.frame)
        .unwrap_err()
        .to_string();
    assert!(e.contains("--k auto"), "{e}");
}

/// A method whose feature the device lacks is refused in one line, not a panic.
#[test]
fn a_missing_feature_is_refused_in_one_line() {
    let gpu = Gpu::new_without(wgpu::Features::SHADER_INT64_ATOMIC_ALL_OPS).unwrap();
    let e = FrameRecorder::for_application(
        &gpu,
        MethodId::KbKeys,
        &RenderOptions::sized(16, 16),
        shader(FRAGMENT),
    )
    .err()
    .expect("kb-keys needs 64-bit atomics")
    .to_string();
    one_line(&e);
    assert!(e.contains("SHADER_INT64_ATOMIC_ALL_OPS"), "{e}");
}

fn texture(size: u32, format: wgpu::TextureFormat, usage: wgpu::TextureUsages) -> wgpu::Texture {
    device().0.create_texture(&wgpu::TextureDescriptor {
        label: None,
        size: wgpu::Extent3d {
            width: size,
            height: size,
            depth_or_array_layers: 1,
        },
        mip_level_count: 1,
        sample_count: 1,
        dimension: wgpu::TextureDimension::D2,
        format,
        usage,
        view_formats: &[],
    })
}

/// Targets that do not fit the frame, and a frame without the application's draw, are errors
/// returned by `record` before anything is recorded.
#[test]
fn misused_targets_are_errors_not_panics() {
    let gpu = gpu();
    let mut oit = FrameRecorder::for_application(
        &gpu,
        MethodId::AbufferLl,
        &RenderOptions::sized(16, 16),
        shader(FRAGMENT),
    )
    .unwrap();
    let attach = wgpu::TextureUsages::RENDER_ATTACHMENT;
    let bindable = attach | wgpu::TextureUsages::TEXTURE_BINDING;
    let color = texture(16, app::FORMAT, attach);
    let small = texture(8, app::FORMAT, attach);
    let depth = texture(16, wgpu::TextureFormat::Depth32Float, bindable);
    let unbindable = texture(16, wgpu::TextureFormat::Depth32Float, attach);
    let not_depth = texture(16, wgpu::TextureFormat::R32Float, bindable);
    let view = |t: &wgpu::Texture| t.create_view(&Default::default());
    let (color, small, depth, unbindable, not_depth) = (
        view(&color),
        view(&small),
        view(&depth),
        view(&unbindable),
        view(&not_depth),
    );
    let draw = |_: &mut wgpu::RenderPass<'_>| {};
    let cases: [(FrameTargets<'_>, &str); 5] = [
        (
            FrameTargets {
                color: Some((&small, app::FORMAT)),
                opaque_depth: Some(&depth),
            },
            "8x8 and the frame 16x16",
        ),
        (
            FrameTargets {
                color: Some((&color, app::FORMAT)),
                opaque_depth: Some(&unbindable),
            },
            "TEXTURE_BINDING",
        ),
        (
            FrameTargets {
                color: Some((&color, app::FORMAT)),
                opaque_depth: Some(&not_depth),
            },
            "has no depth",
        ),
        (
            FrameTargets {
                color: Some((&color, wgpu::TextureFormat::Bgra8UnormSrgb)),
                opaque_depth: Some(&depth),
            },
            "format is given as",
        ),
        (
            FrameTargets {
                color: Some((&depth, wgpu::TextureFormat::Depth32Float)),
                opaque_depth: None,
            },
            "not a blendable color format",
        ),
    ];
    for (targets, says) in cases {
        let mut encoder = gpu.device.create_command_encoder(&Default::default());
        let e = oit
            .record(&mut encoder, &targets, Some(&draw))
            .err()
            .unwrap_or_else(|| panic!("accepted ({says})"))
            .to_string();
        one_line(&e);
        assert!(e.contains(says), "expected '{says}': {e}");
    }
    let mut encoder = gpu.device.create_command_encoder(&Default::default());
    let targets = FrameTargets {
        color: Some((&color, app::FORMAT)),
        opaque_depth: Some(&depth),
    };
    let e = oit
        .record(&mut encoder, &targets, None)
        .unwrap_err()
        .to_string();
    assert!(e.contains("draw callback"), "{e}");
    // The recorder still works after the refusals.
    oit.record(&mut encoder, &targets, Some(&draw)).unwrap();
    gpu.queue.submit([encoder.finish()]);
    oit.wait_stats().unwrap();
}
