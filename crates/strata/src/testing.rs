//! Helpers for the crate's own tests: one shared GPU per test process (a missing adapter fails
//! the test — never a skip), small scenes, and GPU-vs-reference image checks that write the
//! actual and diff images under `target/` when they fail.

use std::sync::OnceLock;

use crate::frame::RenderOptions;
use crate::gpu::Gpu;
use crate::render::{LinearImage, Renderer};
use crate::scene::Scene;

pub fn gpu() -> &'static Gpu {
    static GPU: OnceLock<Gpu> = OnceLock::new();
    GPU.get_or_init(|| match Gpu::new() {
        Ok(g) => g,
        Err(e) => panic!("GPU tests need an adapter (lavapipe in CI): {e}"),
    })
}

pub fn render_gpu(
    scene: &Scene,
    options: &RenderOptions,
    method: &str,
) -> (LinearImage, crate::FrameStats) {
    let mut r = Renderer::new(gpu(), scene, options).unwrap_or_else(|e| panic!("{method}: {e}"));
    r.render(method).unwrap_or_else(|e| panic!("{method}: {e}"))
}

pub fn render_reference(scene: &Scene, options: &RenderOptions) -> LinearImage {
    crate::reference::render(scene, options)
        .expect("reference")
        .0
}

/// Compares 8-bit sRGB pictures: at most `max_fraction` of pixels may differ by more than
/// `max_diff` in some channel. Panics with where the images were written.
pub fn assert_close(
    name: &str,
    actual: &LinearImage,
    expected: &LinearImage,
    effect: crate::Effect,
    max_diff: u8,
    max_fraction: f64,
) {
    let a = actual.to_rgba8(effect);
    let e = expected.to_rgba8(effect);
    if let Err(msg) = crate::metrics::testing::check_image(name, &a, &e, max_diff, max_fraction) {
        panic!("{msg}");
    }
}
