//! Every method on every wgpu backend this machine has — Vulkan (lavapipe without a GPU) and GL
//! (Mesa llvmpipe through EGL, headless) — renders or is refused in one line, never a panic, and
//! does what the per-backend support table (`strata::methods::backends`, measured on the
//! device) says. What renders on GL equals its Vulkan picture, and the reference wherever the
//! frame says it was exact; the downlevel (WebGL2-class) path renders on GL too.

use strata::frame::Effect;
use strata::gpu::Gpu;
use strata::methods::backends::{verdict, Offer};
use strata::render::LinearImage;
use strata::scene::Scene;
use strata::{MethodId, RenderOptions, Renderer};

/// The first adapter of `backend`, opened with the features strata can use and `limits` (the
/// adapter's when `None`). A backend without an adapter fails the test (scripts/test installs
/// Mesa's Vulkan and GL drivers).
fn open(backend: wgpu::Backends, limits: Option<wgpu::Limits>) -> Gpu {
    let instance = wgpu::Instance::new(wgpu::InstanceDescriptor {
        backends: backend,
        ..wgpu::InstanceDescriptor::new_without_display_handle()
    });
    let adapter = pollster::block_on(instance.request_adapter(&Default::default()))
        .unwrap_or_else(|e| panic!("no {backend:?} adapter: {e}"));
    let (features, limits) = match limits {
        Some(limits) => (wgpu::Features::empty(), limits),
        None => (
            adapter.features() & strata::gpu::wanted_features(),
            adapter.limits(),
        ),
    };
    let (device, queue) = pollster::block_on(adapter.request_device(&wgpu::DeviceDescriptor {
        label: Some("backends.device"),
        required_features: features,
        required_limits: limits,
        ..Default::default()
    }))
    .unwrap_or_else(|e| panic!("the {backend:?} adapter opens no device: {e}"));
    Gpu::from_device(device, queue)
}

fn scene() -> Scene {
    strata::scene::loaders::load_scene("builtin:nvpro?objects=12&subdiv=5").unwrap()
}

/// More than `scene()`'s deepest pixel (12 at 40×40): no k-buffer drops a fragment, so every
/// exact method equals the plain reference (bucket takes at most 32).
const K: u32 = 64;

fn options(method: MethodId) -> RenderOptions {
    let d = method.descriptor();
    let mut options = RenderOptions::sized(40, 40);
    options.build.msaa = d.min_samples;
    options.frame.k = Some(K.min(d.max_k));
    options
}

/// What one method did on one device.
enum Outcome {
    /// The picture, and whether the frame says it was exact.
    Rendered(LinearImage, bool),
    Refused(String),
    Panicked,
}

fn run(gpu: &Gpu, scene: &Scene, method: MethodId) -> Outcome {
    let options = options(method);
    let outcome = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
        Renderer::new(gpu, scene, &options).and_then(|mut r| r.render_method(method, None))
    }));
    match outcome {
        Ok(Ok((image, stats))) => Outcome::Rendered(image, stats.exact == Some(true)),
        Ok(Err(e)) => Outcome::Refused(e.to_string()),
        Err(_) => Outcome::Panicked,
    }
}

/// Every method on `gpu`: none panics, every refusal is one line, and what renders is what the
/// table measured on the device says runs. Returns the pictures.
fn every_method(gpu: &Gpu, scene: &Scene) -> Vec<(MethodId, LinearImage, bool)> {
    let offer = Offer::of_gpu(gpu);
    let backend = gpu.backend_name();
    let mut problems = Vec::new();
    let mut pictures = Vec::new();
    for method in MethodId::gpu_methods() {
        let expected = verdict(method.descriptor(), &offer);
        match run(gpu, scene, method) {
            Outcome::Panicked => problems.push(format!("{backend} {method}: PANICKED")),
            Outcome::Refused(e) if e.contains('\n') => problems.push(format!(
                "{backend} {method}: a refusal of several lines: {e}"
            )),
            Outcome::Refused(e) if expected.runs() => problems.push(format!(
                "{backend} {method}: refused, where the table says it runs: {e}"
            )),
            Outcome::Rendered(..) if !expected.runs() => problems.push(format!(
                "{backend} {method}: rendered, where the table says {expected}"
            )),
            Outcome::Refused(_) => {}
            Outcome::Rendered(image, exact) => pictures.push((method, image, exact)),
        }
    }
    assert!(problems.is_empty(), "{}", problems.join("\n"));
    pictures
}

#[test]
fn vulkan_renders_every_method_the_device_has_the_features_for() {
    let gpu = open(wgpu::Backends::VULKAN, None);
    let pictures = every_method(&gpu, &scene());
    assert!(pictures.len() >= 28, "{} rendered", pictures.len());
}

#[test]
fn gl_renders_its_methods_equal_to_the_reference_or_to_vulkan() {
    let scene = scene();
    let gl = every_method(&open(wgpu::Backends::GL, None), &scene);
    let rendered: Vec<String> = gl.iter().map(|(m, ..)| m.to_string()).collect();
    for needed in ["abuffer-ll", "tiled", "f2b", "unsorted"] {
        assert!(
            rendered.iter().any(|m| m == needed),
            "{needed}: {rendered:?}"
        );
    }
    assert!(
        gl.len() >= 15,
        "only {} render on GL: {rendered:?}",
        gl.len()
    );
    let vulkan = open(wgpu::Backends::VULKAN, None);
    let reference = strata::reference::render(&scene, &options(MethodId::Reference))
        .unwrap()
        .0
        .to_rgba8(Effect::Transparency);
    let mut failures = Vec::new();
    let mut exact = 0;
    for (method, picture, frame_exact) in &gl {
        let on_vulkan = match run(&vulkan, &scene, *method) {
            Outcome::Rendered(image, _) => image.to_rgba8(Effect::Transparency),
            _ => panic!("{method} renders on GL but not on Vulkan"),
        };
        let picture = picture.to_rgba8(Effect::Transparency);
        // The exact methods' bar (src/methods/tests.rs), for every method against itself on
        // Vulkan, and against the reference where the frame says it was exact (convex is not
        // where the scene's parts intersect; the approximate methods never are).
        let mut expected = vec![("vulkan", &on_vulkan)];
        if *frame_exact {
            expected.push(("reference", &reference));
            exact += 1;
        }
        for (what, expected) in expected {
            if let Err(m) = strata::metrics::testing::check_image(
                &format!("backends-gl-{method}-vs-{what}"),
                &picture,
                expected,
                2,
                0.001,
            ) {
                failures.push(m);
            }
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
    assert!(exact >= 10, "only {exact} GL frames were exact");
}

#[test]
fn method_auto_renders_every_goal_on_gl() {
    use strata::methods::choice::{candidates, Geometry, Goal};
    let gl = open(wgpu::Backends::GL, None);
    let scene = scene();
    for goal in [Goal::Exact, Goal::Bounded, Goal::Approximate] {
        let list = candidates(&gl, goal, Geometry::Scene);
        assert!(!list.is_empty(), "{goal:?}: no candidate on GL");
        for choice in list {
            match run(&gl, &scene, choice.method) {
                Outcome::Rendered(..) => {}
                Outcome::Refused(e) => panic!("{goal:?} offers {} on GL: {e}", choice.method),
                Outcome::Panicked => panic!("{goal:?}: {} panicked on GL", choice.method),
            }
        }
    }
}

#[test]
fn the_downlevel_path_renders_on_gl() {
    let scene = scene();
    let gl = open(
        wgpu::Backends::GL,
        Some(wgpu::Limits::downlevel_webgl2_defaults()),
    );
    assert!(strata::methods::downlevel::is_downlevel(&gl));
    let vulkan = open(wgpu::Backends::VULKAN, None);
    let reference = strata::reference::render(&scene, &options(MethodId::Reference))
        .unwrap()
        .0
        .to_rgba8(Effect::Transparency);
    for method in [MethodId::F2b, MethodId::Wboit] {
        let picture = match run(&gl, &scene, method) {
            Outcome::Rendered(image, _) => image.to_rgba8(Effect::Transparency),
            Outcome::Refused(e) => panic!("downlevel {method} on GL: {e}"),
            Outcome::Panicked => panic!("downlevel {method} on GL panicked"),
        };
        let expected = if method == MethodId::F2b {
            reference.clone()
        } else {
            match run(&vulkan, &scene, method) {
                Outcome::Rendered(image, _) => image.to_rgba8(Effect::Transparency),
                _ => panic!("wboit on Vulkan"),
            }
        };
        strata::metrics::testing::check_image(
            &format!("backends-gl-downlevel-{method}"),
            &picture,
            &expected,
            2,
            0.001,
        )
        .unwrap_or_else(|m| panic!("{m}"));
    }
    // What does not run there is refused in one line.
    match run(&gl, &scene, MethodId::AbufferLl) {
        Outcome::Refused(e) => assert!(!e.contains('\n') && e.contains("downlevel"), "{e}"),
        _ => panic!("abuffer-ll on a downlevel GL device"),
    }
}

/// tiled finds its samples in compute, so `--msaa 4` renders on GL — where every method whose
/// fragment stage keeps coverage from `@builtin(sample_mask)` is refused — equal to
/// `reference --msaa 4` (8 samples take the same path: the lib's tests run them on Vulkan).
#[test]
fn tiled_renders_msaa_on_gl_equal_to_the_reference() {
    let gl = open(wgpu::Backends::GL, None);
    let scene =
        strata::scene::loaders::load_scene("builtin:nvpro?objects=48&subdiv=8&seed=3").unwrap();
    let samples = 4;
    let mut options = RenderOptions::sized(48, 48);
    options.build.msaa = samples;
    let (picture, stats) = Renderer::new(&gl, &scene, &options)
        .and_then(|mut r| r.render_method(MethodId::Tiled, None))
        .unwrap_or_else(|e| panic!("tiled --msaa {samples} on GL: {e}"));
    let (expected, reference) = strata::reference::render(&scene, &options).unwrap();
    assert_eq!(stats.fragments_generated, reference.fragments_generated);
    if let Err(m) = strata::metrics::testing::check_image(
        &format!("gl-tiled-msaa{samples}"),
        &picture.to_rgba8(Effect::Transparency),
        &expected.to_rgba8(Effect::Transparency),
        2,
        0.001,
    ) {
        panic!("{m}");
    }
    let refused = Renderer::new(&gl, &scene, &options)
        .and_then(|mut r| r.render_method(MethodId::AbufferLl, None))
        .map(drop)
        .expect_err("abuffer-ll --msaa 4 on GL");
    assert!(refused.to_string().contains("sample_mask"), "{refused}");
}
