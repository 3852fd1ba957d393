//! The submission order on lavapipe: the sort's permutation, Kendall distances of known
//! orders, exact pictures whatever the order, and the combinations that refuse it.

use super::*;
use crate::frame::FrameOptions;
use crate::frame::{FrameStats, RenderOptions};
use crate::gpu::readback;
use crate::methods::MethodId;
use crate::render::FrameRecorder;
use crate::scene::{loaders, Scene};
use crate::testing::{assert_close, gpu, render_reference, renderer};

#[test]
fn order_stages_and_their_uniforms_validate() {
    crate::gpu::twin::assert_twin::<OrderParams>();
    for (label, stage) in [("keys", KEYS), ("indices", INDICES), ("kendall", KENDALL)] {
        crate::gpu::shader::validate(&crate::gpu::shader::Stage::new(label, stage).with(LIBRARY));
    }
}

#[test]
fn frame_seeds_differ_between_frames_and_seeds() {
    let seeds: std::collections::HashSet<u32> = (0..4u64)
        .flat_map(|s| (0..64u64).map(move |f| frame_seed(s, f)))
        .collect();
    assert_eq!(seeds.len(), 256);
    assert_eq!(frame_seed(7, 3), frame_seed(7, 3));
}

#[test]
fn order_names_parse_back() {
    for o in [Order::Scene, Order::Front, Order::Back, Order::Random] {
        assert_eq!(o.name().parse::<Order>().unwrap(), o);
    }
    let e = "sideways".parse::<Order>().unwrap_err().to_string();
    assert!(e.contains("--order 'sideways'"), "{e}");
}

/// Frames of `spec` with `order`; the statistics of the last.
fn frames(spec: &str, method: MethodId, order: Order, count: u64) -> FrameStats {
    let scene = loaders::load_scene(spec).unwrap();
    let options = RenderOptions {
        frame: FrameOptions {
            width: 64,
            height: 64,
            order: Some(order),
            order_seed: 5,
            ..Default::default()
        },
        ..Default::default()
    };
    let mut rec = FrameRecorder::new(gpu(), &scene, method, &options).unwrap();
    for _ in 0..count {
        let mut encoder = gpu().device.create_command_encoder(&Default::default());
        rec.record(&mut encoder, &Default::default(), None).unwrap();
        gpu().queue.submit([encoder.finish()]);
    }
    rec.wait_stats().unwrap().stats
}

#[test]
fn front_order_is_kendall_zero_and_back_order_one() {
    // Screen-aligned layers submitted in a random order: every triangle of a layer has the
    // same depth, so only pairs across layers count.
    let spec = "builtin:layers?n=64&coverage=1&order=random&seed=2";
    let tau = |order| {
        let stats = frames(spec, MethodId::AbufferLl, order, 1);
        assert_eq!(stats.order.as_deref(), Some(order.name()));
        stats.kendall_tau.expect("a Kendall distance")
    };
    assert_eq!(tau(Order::Front), 0.0);
    assert_eq!(tau(Order::Back), 1.0);
    // A random permutation of 64 layers is ~0.5 from depth order (its spread is ~0.04).
    assert!((tau(Order::Scene) - 0.5).abs() < 0.15);
    // The scene's own order, measured: layers built nearest first or farthest first.
    let own = |o| {
        frames(
            &format!("builtin:layers?n=16&order={o}"),
            MethodId::AbufferLl,
            Order::Scene,
            1,
        )
    };
    assert_eq!(own("front").kendall_tau, Some(0.0));
    assert_eq!(own("back").kendall_tau, Some(1.0));
}

#[test]
fn random_orders_are_half_way_from_depth_order() {
    // 1024 layers: a random permutation's distance to depth order is 0.5 ± 0.01.
    let stats = frames(
        "builtin:layers?n=1024&coverage=1&order=front",
        MethodId::Unsorted,
        Order::Random,
        2,
    );
    let tau = stats.kendall_tau.unwrap();
    assert!((tau - 0.5).abs() < 0.05, "tau {tau}");
    assert_eq!(stats.frame, 1);
}

/// The index buffer a `TriangleOrder` writes for `centroids` seen by `camera` at `frame`.
fn drawn(order: &TriangleOrder, camera: &Camera, frame: u64) -> Vec<u32> {
    let g = gpu();
    let mut encoder = g.device.create_command_encoder(&Default::default());
    let mut timer = Timer::new(g);
    order.record(g, &mut encoder, &mut timer, camera, frame);
    g.queue.submit([encoder.finish()]);
    let indices = order.indices().expect("a sorted order has indices");
    readback::read_u32s(g, indices, 3 * order.count() as u64).unwrap()
}

/// The triangles of an index buffer, checked to be whole triangles and a permutation.
fn triangles_of(indices: &[u32], count: usize) -> Vec<u32> {
    let mut seen = vec![false; count];
    indices
        .chunks_exact(3)
        .map(|c| {
            let t = c[0] / 3;
            assert_eq!(c, [3 * t, 3 * t + 1, 3 * t + 2], "whole triangles");
            assert!(!std::mem::replace(&mut seen[t as usize], true), "{t} twice");
            t
        })
        .collect()
}

#[test]
fn sorted_orders_draw_every_triangle_once_in_depth_order() {
    // 20000 centroids (20 sort blocks) with many equal depths, poisoned scratch buffers.
    let centroids: Vec<glam::Vec3> = (0..20000u32)
        .map(|i| {
            let h = i.wrapping_mul(2654435761);
            glam::Vec3::new(
                (h % 1000) as f32 * 0.01,
                (h >> 10 & 1023) as f32 * 0.01,
                (h >> 20 & 63) as f32 * -0.5,
            )
        })
        .collect();
    let camera = Camera {
        eye: glam::Vec3::new(1.0, 2.0, 20.0),
        target: glam::Vec3::new(3.0, 4.0, -10.0),
        up: glam::Vec3::Y,
        projection: crate::scene::Projection::Perspective { fov_y_deg: 60.0 },
        near: 0.1,
        far: 100.0,
    };
    let row = depth_row(&camera);
    let depth = |t: u32| {
        let c = centroids[t as usize];
        (row[0] * c.x + row[1] * c.y + row[2] * c.z + row[3]) as f64
    };
    for order in [Order::Front, Order::Back] {
        let o = TriangleOrder::new(gpu(), order, 0, &centroids).unwrap();
        for b in [
            &o.sort.as_ref().unwrap().keys[1],
            &o.sort.as_ref().unwrap().values[1],
        ] {
            gpu()
                .queue
                .write_buffer(b, 0, &crate::gpu::garbage(b.size()));
        }
        let tris = triangles_of(&drawn(&o, &camera, 0), centroids.len());
        for pair in tris.windows(2) {
            let (a, b) = (depth(pair[0]), depth(pair[1]));
            // The GPU's depth may round differently from this one in the last bit.
            let slack = 1e-5 * a.abs().max(1.0);
            match order {
                Order::Front => assert!(a <= b + slack, "{a} before {b}"),
                _ => assert!(a + slack >= b, "{a} before {b}"),
            }
        }
    }
    let random = TriangleOrder::new(gpu(), Order::Random, 9, &centroids).unwrap();
    let first = triangles_of(&drawn(&random, &camera, 0), centroids.len());
    let again = triangles_of(&drawn(&random, &camera, 0), centroids.len());
    let next = triangles_of(&drawn(&random, &camera, 1), centroids.len());
    assert_eq!(
        first, again,
        "a frame's permutation follows from the seed and frame"
    );
    assert_ne!(first, next, "every frame draws a new permutation");
}

fn scene(spec: &str) -> Scene {
    loaders::load_scene(spec).unwrap()
}

#[test]
fn exact_pictures_do_not_change_with_the_order() {
    // Equal depths order by primitive, so an order-independent method's picture is the
    // reference's whatever the submission order. Tolerance as in methods/tests.rs.
    let scene = scene("builtin:nvpro?objects=24&subdiv=8&seed=4");
    // kpeel's k is its layers per pass: it keeps every fragment.
    for (method, k, keeps) in [
        ("abuffer-ll", None, None),
        ("kpeel", Some(4), None),
        ("kplus-heap", Some(8), Some(8)),
    ] {
        let base = RenderOptions {
            frame: FrameOptions {
                width: 64,
                height: 64,
                k,
                ..Default::default()
            },
            ..Default::default()
        };
        let expected = render_reference(&scene, &{
            let mut options = base.clone();
            options.frame.k = keeps;
            options
        });
        for order in [Order::Back, Order::Random, Order::Front] {
            let options = {
                let mut options = base.clone();
                options.frame.order = Some(order);
                options.frame.order_seed = 3;
                options
            };
            let (actual, stats) = crate::testing::render_gpu(&scene, &options, method);
            assert_close(
                &format!("order-{}-{method}", order.name()),
                &actual,
                &expected,
                options.frame.effect,
                2,
                0.001,
            );
            assert!(stats.kendall_tau.is_some());
            assert!(stats.bytes_allocated >= bytes(order, scene.triangle_count() as u32));
        }
    }
}

#[test]
fn orders_refuse_what_has_no_submission_order() {
    let s = scene("builtin:layers?n=4");
    let options = RenderOptions {
        frame: FrameOptions {
            width: 32,
            height: 32,
            order: Some(Order::Back),
            ..Default::default()
        },
        ..Default::default()
    };
    let refusal = |method| {
        renderer(&s, &options)
            .render(method)
            .unwrap_err()
            .to_string()
    };
    let sorted = refusal("sorted");
    assert!(sorted.contains("--order back"), "{sorted}");
    // f2b settles equal depths by draw order, so it peels in primitive order only.
    let f2b = refusal("f2b");
    assert!(f2b.contains("--order back"), "{f2b}");
    let scene_order = {
        let mut options = options.clone();
        options.frame.order = Some(Order::Scene);
        options
    };
    assert!(crate::Renderer::new(gpu(), &s, &scene_order)
        .unwrap()
        .render("f2b")
        .is_ok());
    let compute = {
        let mut options = options.clone();
        options.build.raster = crate::raster::Raster::Compute;
        options
    };
    let e = compute.validate().unwrap_err().to_string();
    assert!(e.contains("--raster compute"), "{e}");
    let mut rec = FrameRecorder::new(gpu(), &s, MethodId::AbufferLl, &options).unwrap();
    let mut encoder = gpu().device.create_command_encoder(&Default::default());
    let draw = |pass: &mut wgpu::RenderPass<'_>| pass.draw(0..6, 0..1);
    let e = rec
        .record(&mut encoder, &Default::default(), Some(&draw))
        .unwrap_err()
        .to_string();
    assert!(e.contains("draw callback"), "{e}");
    let shader = crate::frame::application::AppShader::new("", "vs", "fs");
    let e = FrameRecorder::for_application(gpu(), MethodId::AbufferLl, &options, shader)
        .err()
        .expect("an application's recorder refuses --order")
        .to_string();
    assert!(e.contains("--order") && e.contains("own shaders"), "{e}");
}
