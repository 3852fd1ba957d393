//! Every method on every wgpu backend this machine has — Vulkan (lavapipe without a GPU) and GL
//! (Mesa llvmpipe through EGL, headless) — renders or is refused in one line: never a panic.
//! What renders on GL, and its pictures, is the every-backend issue's; this holds the floor.

use strata::gpu::Gpu;
use strata::{MethodId, RenderOptions, Renderer};

/// The first adapter of `backend`, opened with the features strata can use. A backend without
/// an adapter fails the test (scripts/test installs Mesa's Vulkan and GL drivers).
fn open(backend: wgpu::Backends) -> Gpu {
    let instance = wgpu::Instance::new(wgpu::InstanceDescriptor {
        backends: backend,
        ..wgpu::InstanceDescriptor::new_without_display_handle()
    });
    let adapter = pollster::block_on(instance.request_adapter(&Default::default()))
        .unwrap_or_else(|e| panic!("no {backend:?} adapter: {e}"));
    let (device, queue) = pollster::block_on(adapter.request_device(&wgpu::DeviceDescriptor {
        label: Some("backends.device"),
        required_features: adapter.features() & strata::gpu::wanted_features(),
        required_limits: adapter.limits(),
        ..Default::default()
    }))
    .unwrap_or_else(|e| panic!("the {backend:?} adapter opens no device: {e}"));
    Gpu::from_device(device, queue)
}

#[test]
fn every_method_renders_or_refuses_in_one_line_on_every_backend() {
    let scene = strata::scene::loaders::load_scene("builtin:nvpro?objects=8&subdiv=4").unwrap();
    let options = RenderOptions::sized(24, 24);
    let mut outcomes = Vec::new();
    for (name, backend) in [
        ("vulkan", wgpu::Backends::VULKAN),
        ("gl", wgpu::Backends::GL),
    ] {
        let gpu = open(backend);
        for method in MethodId::gpu_methods() {
            let mut options = options.clone();
            options.build.msaa = method.descriptor().min_samples;
            let outcome = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
                Renderer::new(&gpu, &scene, &options)
                    .and_then(|mut r| r.render_method(method, None))
            }));
            let line = match outcome {
                Ok(Ok(_)) => "rendered".to_string(),
                Ok(Err(e)) => format!("refused: {e}"),
                Err(_) => "PANICKED".to_string(),
            };
            outcomes.push(format!("{name} {method}: {line}"));
        }
    }
    eprintln!("{}", outcomes.join("\n"));
    for o in &outcomes {
        assert!(!o.ends_with("PANICKED") && !o.contains('\n'), "{o}");
    }
    // Vulkan renders every method lavapipe has the features for.
    let vulkan_rendered = outcomes
        .iter()
        .filter(|o| o.starts_with("vulkan ") && o.ends_with("rendered"))
        .count();
    assert!(vulkan_rendered >= 28, "{outcomes:#?}");
}
