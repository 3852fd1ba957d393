//! The GPU animation on lavapipe: vertices moved on the GPU against the CPU's scene at the same
//! time, in chunks and whole, and exact pictures of a moved scene against the reference.

use super::*;
use crate::frame::{RenderOptions, SceneGpu};
use crate::gpu::readback;
use crate::render::Renderer;
use crate::scene::{loaders, GpuVertex};
use crate::testing::{assert_close, gpu, render_reference};

#[test]
fn animation_structs_match_wgsl() {
    crate::gpu::twin::assert_twin::<AnimationParams>();
    crate::gpu::twin::assert_twin::<GpuMotion>();
}

#[test]
fn animation_stages_validate() {
    for (label, stage) in [("objects", OBJECTS), ("vertices", VERTICES)] {
        crate::gpu::shader::validate(&crate::gpu::shader::Stage::new(label, stage).with(LIBRARY));
    }
}

/// The scene's vertex buffer after one recorded frame at time `t`.
fn moved_vertices(scene_gpu: &mut SceneGpu, t: f32) -> Vec<GpuVertex> {
    let g = gpu();
    scene_gpu.set_time(t);
    let mut timer = crate::gpu::timing::Timer::new(g);
    let mut encoder = g.device.create_command_encoder(&Default::default());
    scene_gpu
        .animation
        .as_mut()
        .expect("balls move")
        .record(g, &mut encoder, &mut timer);
    g.queue.submit([encoder.finish()]);
    let bytes = readback::read_buffer(g, &scene_gpu.vertices, scene_gpu.vertices.size()).unwrap();
    bytemuck::cast_slice(&bytes).to_vec()
}

/// Largest coordinate difference between two vertex lists (positions, normals).
fn largest_difference(a: &[GpuVertex], b: &[GpuVertex]) -> (f32, f32) {
    assert_eq!(a.len(), b.len());
    a.iter().zip(b).fold((0.0f32, 0.0f32), |(p, n), (x, y)| {
        let d = |u: [f32; 3], v: [f32; 3]| (0..3).map(|i| (u[i] - v[i]).abs()).fold(0.0, f32::max);
        (
            p.max(d(x.position, y.position)),
            n.max(d(x.normal, y.normal)),
        )
    })
}

/// The GPU evaluates each orbit with its own sin and cos: positions agree with the CPU's to
/// within 2e-6 scene units (lavapipe: 1.2e-7, a ten-thousandth of a pixel at 512²), so the
/// reference at the same time sees the same triangles.
#[test]
fn gpu_moved_vertices_equal_the_cpu_scene_at_that_time() {
    let scene = loaders::load_scene("builtin:balls?count=12&segments=8").unwrap();
    let options = RenderOptions::default();
    let mut whole = SceneGpu::new(gpu(), &scene, &options).unwrap();
    let mut chunked = SceneGpu::new(gpu(), &scene, &options).unwrap();
    let vertices = chunked.vertices.clone();
    // 12 balls of 48 triangles: 9 chunks of 64, the last one partial.
    chunked
        .animation
        .as_mut()
        .unwrap()
        .set_chunk(gpu(), &vertices, 64);
    for t in [0.0, 1.0, 37.5, 900.0] {
        let expected = scene.at_time(t).triangles().vertices;
        for (name, s) in [("whole", &mut whole), ("chunked", &mut chunked)] {
            if t != 0.0 {
                // Everything the pass should write, poisoned first.
                let garbage = crate::gpu::garbage(s.vertices.size());
                gpu().queue.write_buffer(&s.vertices, 0, &garbage);
            }
            let (position, normal) = largest_difference(&moved_vertices(s, t), &expected);
            eprintln!("t = {t}, {name}: positions within {position:e}, normals {normal:e}");
            assert!(position <= 2e-6 && normal <= 1e-5, "t = {t}, {name}");
        }
    }
}

/// A scene moved on the GPU renders as the CPU's scene at that time renders — exact methods as
/// the reference, with the centroids `--order` sorts written by the vertices pass; `sorted`
/// (approximate: whole triangles by centroid) as a renderer made from the moved scene, with
/// the CPU's centroids — and a camera orbit moves the view. Tolerance as in methods/tests.rs.
#[test]
fn pictures_at_a_time_equal_the_reference_at_that_time() {
    let mut scene = loaders::load_scene("builtin:balls?count=40").unwrap();
    scene.camera_path = Some(crate::scene::CameraPath::orbit(scene.camera.unwrap(), 2.0).unwrap());
    let base = RenderOptions::sized(64, 64);
    let runs = [
        ("abuffer-ll", None, None),
        ("kplus-heap", Some(8), Some(crate::order::Order::Front)),
        ("sorted", None, None),
    ];
    for (method, k, order) in runs {
        let options = {
            let mut options = base.clone();
            options.frame.k = k;
            options.frame.order = order;
            options
        };
        let mut r = Renderer::new(gpu(), &scene, &options).unwrap();
        for t in [0.0, 6.0, 25.0] {
            r.set_time(t);
            let (actual, stats) = r.render(method).unwrap();
            let expected = if method == "sorted" {
                crate::testing::render_gpu(&scene.at_time(t), &options, method).0
            } else {
                render_reference(&scene.at_time(t), &options)
            };
            assert_close(
                &format!("animated-{method}-{t}"),
                &actual,
                &expected,
                options.frame.effect,
                2,
                0.001,
            );
            if order.is_some() {
                assert_eq!(
                    stats.kendall_tau,
                    Some(0.0),
                    "t = {t}: sorted by moved centroids"
                );
            }
        }
    }
}
