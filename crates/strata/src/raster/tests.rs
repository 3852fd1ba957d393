use super::*;
use crate::frame::{BuildOptions, FrameOptions};
use crate::methods::kbuffer::KBufferOptions;
use crate::methods::MethodId;
use proptest::prelude::*;

/// Coordinates the guard band allows: ±2²⁹ subpixels, differences below 2³⁰.
const RANGE: i32 = 1 << 30;

proptest! {
    /// The shader's 64-bit products, sums and signs equal i64 arithmetic over the guard band's
    /// range.
    #[test]
    fn wide_arithmetic_matches_i64(a in -RANGE..RANGE, b in -RANGE..RANGE, c in -RANGE..RANGE, d in -RANGE..RANGE) {
        let e = wide::add(wide::mul(a, b), wide::negate(wide::mul(c, d)));
        let exact = a as i64 * b as i64 - c as i64 * d as i64;
        prop_assert_eq!(wide::to_i64(e), exact);
        prop_assert_eq!(wide::negative(e), exact < 0);
        prop_assert_eq!(wide::zero(e), exact == 0);
        prop_assert_eq!(wide::from_i64(exact), e);
    }
}

#[test]
fn params_layout() {
    crate::gpu::twin::assert_twin::<RasterParams>();
}

/// The guard band keeps window coordinates within ±2²¹ pixels at every size.
#[test]
fn guard_band_bounds_window_coordinates() {
    for (w, h) in [(1, 1), (512, 512), (1920, 1080), (16384, 16384)] {
        let g = guard_band(w, h) as f64;
        let far = (g + 1.0) * 0.5 * w.max(h) as f64;
        assert!(far <= (1u64 << 21) as f64, "{w}x{h}: {far}");
        assert!(g >= 255.0);
    }
}

// ---- Shaders -------------------------------------------------------------------------------

use crate::gpu::shader::validate;

/// The bin and args stages, and every method's fragment stage compiled for the compute
/// rasterizer, validate with naga (so a shader error fails without a GPU), and compile to SPIR-V
/// with ordered atomics (so `compute_stage` never falls back to relaxed ones).
#[test]
fn every_compute_capture_validates() {
    use crate::gpu::shader::Stage;
    use crate::methods::kbuffer::{self, definitions, kpeel, list, mdt, sbuffer, Layout};
    use crate::methods::peeling;
    validate(&bin_stage(Binning::Items));
    validate(&bin_stage(Binning::SetupRecords));
    validate(&args_stage());
    let kbuffer = |source: &'static str, layout: Layout| {
        Stage::new("capture", source)
            .with(kbuffer::LIBRARY)
            .defs(&definitions(layout, 1, false))
    };
    let mut stages: Vec<(Stage, &[&str])> = vec![
        (
            kbuffer(kbuffer::SLOTS_ENTRIES_WGSL, Layout::Slots),
            &[
                "fs_kplus_array",
                "fs_kplus_heap",
                "fs_kplus_array_r",
                "fs_kb",
                "fs_kb_ps",
                "fs_fixed",
                "fs_kplus_semiheap",
                "fs_mlab",
            ],
        ),
        (
            kbuffer(mdt::Mdt::Mdt32.capture_source(), Layout::Mdt32),
            &["fs_mdt32_depth", "fs_mdt32_color", "fs_mdt_pack"],
        ),
        (
            kbuffer(mdt::Mdt::Mdt64.capture_source(), Layout::Mdt64),
            &["fs_mdt64"],
        ),
        (
            kbuffer(list::ENTRIES_WGSL, Layout::List),
            &["fs_ab_ll", "fs_sorted_ll"],
        ),
        (
            kbuffer(
                sbuffer::RegionKind::Abuffer.capture_source(),
                Layout::Sbuffer,
            ),
            &["fs_sbuffer_count", "fs_sbuffer_store"],
        ),
        (
            kbuffer(
                sbuffer::RegionKind::Kplus.capture_source(),
                Layout::KplusSbuffer,
            ),
            &["fs_kplus_sbuffer_count", "fs_kplus_sbuffer_store"],
        ),
        (kbuffer(kpeel::CAPTURE_WGSL, Layout::Slots), &["fs_kpeel"]),
        (
            kbuffer(kpeel::CASCADE_WGSL, Layout::Slots),
            &["fs_kpeel_keys", "fs_kpeel_colors"],
        ),
    ];
    for wide in [false, true] {
        stages.push((
            peeling::dual_stage("dual", peeling::DUAL_PEEL_WGSL, wide),
            &["fs_bounds", "fs_peel"],
        ));
    }
    for (stage, entries) in &stages {
        for entry in *entries {
            // The rasterizer's group follows the method's (kpeel's cascade has a group 2).
            let group = if entry.starts_with("fs_kpeel_") { 3 } else { 2 };
            validate(&capture_stage(stage, entry, group, 64).unwrap());
            // What `compute_stage` makes for a method that orders: acquire/release atomics in
            // workgroups of one SIMD vector (old lavapipe).
            let ordered = capture_stage(stage, entry, group, 8).unwrap();
            crate::gpu::ordered::spirv(&ordered).unwrap_or_else(|e| panic!("{entry}: {e}"));
        }
    }
    // A stage that writes a color has no compute twin.
    assert!(capture_stage(&crate::methods::baseline::blend_stage(), "fs_blend", 2, 64).is_err());
}

// ---- The compute path against the GPU's rasterizer and the reference -------------------------

use crate::frame::{Effect, RenderOptions};
use crate::render::LinearImage;
use crate::scene::{loaders, Camera, Material, Mesh, Object, Projection, Scene, Shading};
use crate::testing::{assert_close, assert_poison_changes_nothing, gpu};
use crate::FrameStats;

fn options(size: u32, raster: Raster) -> RenderOptions {
    RenderOptions {
        build: BuildOptions {
            raster,
            ..Default::default()
        },
        frame: FrameOptions {
            width: size,
            height: size,
            ..Default::default()
        },
    }
}

fn render(scene: &Scene, opts: &RenderOptions, method: MethodId) -> (LinearImage, FrameStats) {
    let mut r =
        crate::Renderer::new(gpu(), scene, opts).unwrap_or_else(|e| panic!("{method}: {e}"));
    r.render_method(method, None)
        .unwrap_or_else(|e| panic!("{method}: {e}"))
}

/// Panics naming the first pixel whose fragment count differs.
fn assert_same_counts(name: &str, actual: &LinearImage, expected: &LinearImage, width: u32) {
    let (a, e) = (actual.counts(), expected.counts());
    if let Some(i) = (0..a.len()).find(|&i| a[i] != e[i]) {
        let differing = (0..a.len()).filter(|&i| a[i] != e[i]).count();
        panic!(
            "{name}: {differing} pixels covered differently, the first at ({}, {}): {} fragments on the compute path, {} on the GPU's",
            i as u32 % width,
            i as u32 / width,
            a[i],
            e[i]
        );
    }
}

/// Whether frames of `method` may be rendered again after counted lock failures: only a spin
/// lock on a CPU adapter, where a lock holder's thread can be descheduled for longer than any
/// bounded spin (lavapipe runs more threads than cores, and tests run side by side). On a GPU
/// nothing preempts a lock holder, and every frame must be free of lock failures.
fn may_starve(method: MethodId) -> bool {
    gpu().info.device_type == wgpu::DeviceType::Cpu && method.descriptor().locks()
}

/// `opts` with the longest spin allowed where [`may_starve`] holds.
fn patient(method: MethodId, opts: &RenderOptions) -> RenderOptions {
    let mut opts = opts.clone();
    if may_starve(method) {
        opts.frame.family_mut::<KBufferOptions>().max_tries =
            Some(crate::methods::kbuffer::MAX_TRIES_LIMIT);
    }
    opts
}

/// The first of `frame`'s frames of `method` with no lock failure: on a GPU the first frame,
/// which must have none; where [`may_starve`] holds, one of at most 8, the failures of the
/// others reported. A frame without lock failures is held to the full test either way.
fn without_lock_failures(
    method: MethodId,
    mut frame: impl FnMut() -> (LinearImage, FrameStats),
) -> (LinearImage, FrameStats) {
    let attempts = if may_starve(method) { 8 } else { 1 };
    let mut starved = Vec::new();
    for _ in 0..attempts {
        let (image, stats) = frame();
        match stats.lock_failures.unwrap_or(0) {
            0 => {
                if !starved.is_empty() {
                    eprintln!("{method}: lock failures of the frames before a clean one (CPU adapter): {starved:?}");
                }
                return (image, stats);
            }
            n => starved.push(n),
        }
    }
    panic!("{method}: lock failures in every frame: {starved:?}");
}

/// The compute path covers exactly the pixels the GPU's rasterizer covers, and its colors are
/// within 1/255 of the GPU path's (both shade in f32 from the same inputs; depth and
/// attributes agree to rounding) — but at the pixels where the hardware made some fragment
/// otherwise than the reference, whose rasterization the compute path follows
/// (`the_devices_fragments_are_the_references` reports those: the H100 interpolates on the
/// planes through its snapped corners). There the compute path's pixel stands in; on lavapipe
/// there are none.
fn assert_matches_hw(name: &str, scene: &Scene, size: u32, method: MethodId) -> FrameStats {
    assert_matches_hw_with(name, scene, &options(size, Raster::Hw), method)
}

/// [`assert_matches_hw`] with the options `opts` (on either rasterizer).
fn assert_matches_hw_with(
    name: &str,
    scene: &Scene,
    opts: &RenderOptions,
    method: MethodId,
) -> FrameStats {
    let on = |raster| {
        let mut opts = patient(method, opts);
        opts.build.raster = raster;
        opts
    };
    // A starved lock names its cause before the picture it spoils.
    let hw_frame = || render(scene, &on(Raster::Hw), method);
    let (mut hw, hw_stats) = without_lock_failures(method, hw_frame);
    let compute_frame = || render(scene, &on(Raster::Compute), method);
    let (compute, stats) = without_lock_failures(method, compute_frame);
    assert_same_counts(&format!("{name}-{method}"), &compute, &hw, opts.frame.width);
    let hardware = crate::methods::kbuffer::tests::reference_fragments_at_device_depths(
        scene,
        &on(Raster::Hw),
    );
    for (p, &differs) in hardware.disagreeing.iter().enumerate() {
        if differs {
            hw.pixels[p] = compute.pixels[p];
        }
    }
    assert_close(
        &format!("raster-{name}-{method}"),
        &compute,
        &hw,
        Effect::Transparency,
        1,
        0.0,
    );
    assert_eq!(stats.fragments_generated, hw_stats.fragments_generated);
    assert_eq!(stats.raster, "compute");
    let raster = stats.compute_raster.clone().expect("compute raster stats");
    assert!(!raster.overflow && raster.tile_items > 0, "{raster:?}");
    stats
}

#[test]
fn coverage_and_colors_match_the_gpu_path_on_the_test_scenes() {
    for (name, spec, size) in [
        (
            "layers",
            "builtin:layers?n=8&coverage=0.75&order=random&seed=2",
            64,
        ),
        ("spheres", "builtin:spheres?layers=6", 96),
        ("nvpro", "builtin:nvpro?objects=64&subdiv=12&seed=1", 96),
        ("dragon", "builtin:dragon", 128),
    ] {
        let scene = loaders::load_scene(spec).unwrap();
        assert_matches_hw(name, &scene, size, MethodId::AbufferLl);
    }
}

/// Every method the compute rasterizer supports gives the GPU path's picture, and the exact ones
/// the reference's.
#[test]
fn every_supported_method_matches_the_gpu_path_and_the_reference() {
    let scene = loaders::load_scene("builtin:nvpro?objects=24&subdiv=10&seed=5").unwrap();
    let size = 48;
    let expected = crate::testing::render_reference(&scene, &options(size, Raster::Hw));
    for method in MethodId::gpu_methods().filter(|m| m.descriptor().compute_raster.yes()) {
        if method == MethodId::Kb {
            continue; // unlocked read-modify-writes race by design; its picture is not fixed
        }
        let mut opts = options(size, Raster::Hw);
        // mlab merges past k in the order fragments arrive, which differs between rasterizers:
        // with room for every fragment (as in the frame tests) it merges none.
        if method == MethodId::Mlab {
            opts.frame.k = Some(64);
        }
        assert_matches_hw_with("nvpro-small", &scene, &opts, method);
        if method.descriptor().exact {
            let opts = patient(method, &options(size, Raster::Compute));
            let (actual, _) = without_lock_failures(method, || render(&scene, &opts, method));
            // The exact methods' usual tolerance (methods/tests.rs): 2/255 on 99.9% of pixels.
            assert_close(
                &format!("raster-reference-{method}"),
                &actual,
                &expected,
                Effect::Transparency,
                2,
                0.001,
            );
        }
    }
}

/// Methods that draw through color targets refuse the compute path with one clear error.
#[test]
fn color_target_methods_refuse_the_compute_path() {
    let scene = loaders::load_scene("builtin:layers?n=2").unwrap();
    for method in MethodId::gpu_methods().filter(|m| !m.descriptor().compute_raster.yes()) {
        let mut r = crate::Renderer::new(gpu(), &scene, &options(16, Raster::Compute)).unwrap();
        let e = r.render_method(method, None).unwrap_err().to_string();
        assert!(
            e.contains("--raster compute") && !e.contains('\n'),
            "{method}: {e}"
        );
    }
}

// ---- Edge cases ----------------------------------------------------------------------------

fn unlit(opacity: f32) -> Material {
    Material {
        color: [0.2, 0.6, 0.9],
        opacity,
        shading: Shading::Unlit,
        ..Default::default()
    }
}

fn mesh(positions: Vec<[f32; 3]>, indices: Vec<u32>) -> Mesh {
    let normals = vec![[0.0, 0.0, 1.0]; positions.len()];
    Mesh {
        positions,
        normals,
        indices,
    }
}

fn scene_of(meshes: Vec<Mesh>, camera: Camera) -> Scene {
    Scene {
        objects: meshes
            .into_iter()
            .enumerate()
            .map(|(i, mesh)| Object {
                name: format!("object{i}"),
                mesh,
                material: 0,
            })
            .collect(),
        materials: vec![unlit(0.5)],
        camera: Some(camera),
        ..Default::default()
    }
}

fn perspective(eye: [f32; 3], near: f32) -> Camera {
    Camera {
        eye: eye.into(),
        target: glam::Vec3::ZERO,
        up: glam::Vec3::Y,
        projection: Projection::Perspective { fov_y_deg: 50.0 },
        near,
        far: 100.0,
    }
}

fn orthographic() -> Camera {
    Camera {
        eye: glam::Vec3::new(0.0, 0.0, 5.0),
        target: glam::Vec3::ZERO,
        up: glam::Vec3::Y,
        projection: Projection::Orthographic { height: 2.0 },
        near: 0.1,
        far: 10.0,
    }
}

/// A quad from corner `a` over edges `u` and `v`.
fn quad(a: [f32; 3], u: [f32; 3], v: [f32; 3]) -> Mesh {
    let p = |s: f32, t: f32| std::array::from_fn(|i| a[i] + s * u[i] + t * v[i]);
    mesh(
        vec![p(0.0, 0.0), p(1.0, 0.0), p(1.0, 1.0), p(0.0, 1.0)],
        vec![0, 1, 2, 0, 2, 3],
    )
}

/// Triangles crossing the near plane (and reaching behind the camera), and triangles far larger
/// than the screen (clipped at the guard band), are covered as on the GPU path and as the
/// reference covers them.
#[test]
fn near_plane_crossings_and_huge_triangles_match() {
    let floor = quad([-3.0, -0.6, -6.0], [6.0, 0.0, 0.0], [0.0, 0.3, 12.0]);
    let wall = quad([-2.0e4, -2.0e4, -1.0], [4.0e4, 0.0, 0.0], [0.0, 4.0e4, 0.0]);
    let slanted = quad([-1.0, 1.0, 3.0], [2.0, 0.0, 0.0], [0.0, -1.5, -8.0]);
    let scene = scene_of(
        vec![floor, wall, slanted],
        perspective([0.0, 0.0, 2.0], 0.5),
    );
    let stats = assert_matches_hw("clipped", &scene, 64, MethodId::AbufferLl);
    assert_eq!(stats.fragments_dropped, Some(0));
    let (actual, _) = render(&scene, &options(64, Raster::Compute), MethodId::AbufferLl);
    let expected = crate::testing::render_reference(&scene, &options(64, Raster::Hw));
    assert_same_counts("clipped-reference", &actual, &expected, 64);
}

/// Zero-area triangles produce nothing, sub-pixel triangles cover exactly the pixel centers the
/// GPU's rasterizer gives them.
#[test]
fn degenerate_and_sub_pixel_triangles_match() {
    let mut positions = vec![
        // Collinear, repeated corners, a point.
        [-0.5, -0.5, 0.0],
        [0.0, 0.0, 0.0],
        [0.5, 0.5, 0.0],
        [0.3, -0.2, 0.0],
        [0.3, -0.2, 0.0],
        [0.6, 0.1, 0.0],
    ];
    let mut indices = vec![0, 1, 2, 3, 4, 5, 1, 1, 1];
    let mut rng = crate::scene::rng::SplitMix64::new(7);
    for _ in 0..3000 {
        let c = [
            rng.range(-0.95, 0.95),
            rng.range(-0.95, 0.95),
            rng.range(-1.0, 1.0),
        ];
        let base = positions.len() as u32;
        for _ in 0..3 {
            positions.push([
                c[0] + rng.range(-0.02, 0.02),
                c[1] + rng.range(-0.02, 0.02),
                c[2],
            ]);
        }
        indices.extend([base, base + 1, base + 2]);
    }
    let scene = scene_of(vec![mesh(positions, indices)], orthographic());
    assert_matches_hw("tiny", &scene, 64, MethodId::AbufferLl);
}

/// A grid of triangles sharing every edge (jittered inside, so edges run at all angles) covers
/// each pixel center inside it exactly once: no pixel twice, none missed.
#[test]
fn shared_edges_cover_each_pixel_exactly_once() {
    let n = 24;
    let mut rng = crate::scene::rng::SplitMix64::new(3);
    let mut positions = Vec::new();
    for j in 0..=n {
        for i in 0..=n {
            let interior = i > 0 && j > 0 && i < n && j < n;
            let jitter = |rng: &mut crate::scene::rng::SplitMix64| {
                if interior {
                    // Less than a quarter cell: no triangle folds over.
                    rng.range(-0.012, 0.012)
                } else {
                    0.0
                }
            };
            let x = -0.8 + 1.6 * i as f32 / n as f32 + jitter(&mut rng);
            let y = -0.8 + 1.6 * j as f32 / n as f32 + jitter(&mut rng);
            positions.push([x, y, 0.0]);
        }
    }
    let mut indices = Vec::new();
    let at = |i: u32, j: u32| j * (n + 1) + i;
    for j in 0..n {
        for i in 0..n {
            // Alternate the diagonal so edges meet at every orientation.
            if (i + j) % 2 == 0 {
                indices.extend([at(i, j), at(i + 1, j), at(i + 1, j + 1)]);
                indices.extend([at(i, j), at(i + 1, j + 1), at(i, j + 1)]);
            } else {
                indices.extend([at(i, j), at(i + 1, j), at(i, j + 1)]);
                indices.extend([at(i + 1, j), at(i + 1, j + 1), at(i, j + 1)]);
            }
        }
    }
    let scene = scene_of(vec![mesh(positions, indices)], orthographic());
    let size = 80;
    let (image, _) = render(&scene, &options(size, Raster::Compute), MethodId::AbufferLl);
    let counts = image.counts();
    for y in 0..size {
        for x in 0..size {
            // Pixel centers in NDC; the grid's outer border is at ±0.8.
            let ndc = |p: u32| (p as f32 + 0.5) / size as f32 * 2.0 - 1.0;
            let inside = ndc(x).abs() < 0.79 && ndc(y).abs() < 0.79;
            let c = counts[(y * size + x) as usize];
            assert!(c <= 1, "pixel ({x}, {y}) covered {c} times");
            if inside {
                assert_eq!(c, 1, "pixel ({x}, {y}) inside the grid missed");
            }
        }
    }
    assert_matches_hw("grid", &scene, size, MethodId::AbufferLl);
}

/// A mesh of a million sub-pixel triangles: the same coverage as the GPU's rasterizer.
#[test]
fn a_million_tiny_triangles_match() {
    let (nx, ny) = (708u32, 707u32);
    let mut positions = Vec::with_capacity(((nx + 1) * (ny + 1)) as usize);
    for j in 0..=ny {
        for i in 0..=nx {
            let x = -0.9 + 1.8 * i as f32 / nx as f32;
            let y = -0.9 + 1.8 * j as f32 / ny as f32;
            positions.push([x, y, 0.3 * (x * 7.0).sin() * (y * 5.0).cos()]);
        }
    }
    let at = |i: u32, j: u32| j * (nx + 1) + i;
    let mut indices = Vec::with_capacity((nx * ny * 6) as usize);
    for j in 0..ny {
        for i in 0..nx {
            indices.extend([at(i, j), at(i + 1, j), at(i + 1, j + 1)]);
            indices.extend([at(i, j), at(i + 1, j + 1), at(i, j + 1)]);
        }
    }
    assert!(indices.len() / 3 >= 1_000_000);
    let scene = scene_of(vec![mesh(positions, indices)], orthographic());
    assert_matches_hw("million", &scene, 128, MethodId::AbufferFixed);
}

// ---- Multi-layer peeling, overflow, poison -----------------------------------------------------

/// Seed 002's multi-layer peeling (kpeel, M layers per pass) equals the reference for M = 1, 4,
/// 16 on both rasterizers (through the lock-free cascade where there are 64-bit atomics: two
/// geometry passes per M layers).
#[test]
fn multi_layer_peeling_matches_the_reference_on_both_paths() {
    let scene =
        loaders::load_scene("builtin:layers?n=16&coverage=0.75&order=random&seed=4").unwrap();
    let size = 40;
    let expected = crate::testing::render_reference(&scene, &options(size, Raster::Hw));
    for raster in [Raster::Hw, Raster::Compute] {
        for m in [1, 4, 16] {
            let mut opts = options(size, raster);
            opts.frame.k = Some(m);
            let (actual, _) = render(&scene, &opts, MethodId::Kpeel);
            assert_close(
                &format!("kpeel-m{m}-{}", raster.name()),
                &actual,
                &expected,
                Effect::Transparency,
                2,
                0.001,
            );
            let steady = steady_frame(&scene, &opts, MethodId::Kpeel);
            // Two geometry passes per M layers through the lock-free cascade: always on the
            // compute rasterizer, on the hardware's where the adapter has 64-bit atomics.
            let cascade = raster == Raster::Compute
                || crate::testing::gpu().has(wgpu::Features::SHADER_INT64_ATOMIC_ALL_OPS);
            let per_group = if cascade { 2 } else { 1 };
            assert_eq!(
                steady.geometry_passes,
                per_group * 16u32.div_ceil(m),
                "M = {m}"
            );
            assert_eq!(steady.fragments_dropped, Some(0));
        }
    }
}

/// The statistics of a third real-time frame (feedback from the first ones applied).
fn steady_frame(scene: &Scene, opts: &RenderOptions, method: MethodId) -> FrameStats {
    let mut rec = crate::FrameRecorder::new(gpu(), scene, method, opts).unwrap();
    let mut last = None;
    for _ in 0..3 {
        let mut encoder = gpu().device.create_command_encoder(&Default::default());
        rec.record(&mut encoder, &Default::default(), None).unwrap();
        gpu().queue.submit([encoder.finish()]);
        last = Some(rec.wait_stats().unwrap());
    }
    let last = last.unwrap();
    assert!(
        !last.incomplete,
        "{method}: a third frame is still incomplete"
    );
    last.stats
}

/// A first frame whose work items outgrow the first guess says so (incomplete, overflow); the
/// next frame has room, and exact mode's picture equals the GPU path's.
#[test]
fn an_item_overflow_is_reported_and_grown_out_of() {
    let scene = loaders::load_scene("builtin:layers?n=24&coverage=1").unwrap();
    let mut opts = options(64, Raster::Compute);
    // A fixed array, so no pool of the method's own grows from what the first frame measured.
    opts.frame.k = Some(32);
    let mut rec = crate::FrameRecorder::new(gpu(), &scene, MethodId::AbufferFixed, &opts).unwrap();
    let mut frame = || {
        let mut encoder = gpu().device.create_command_encoder(&Default::default());
        rec.record(&mut encoder, &Default::default(), None).unwrap();
        gpu().queue.submit([encoder.finish()]);
        rec.wait_stats().unwrap()
    };
    let first = frame();
    let raster = first.stats.compute_raster.clone().unwrap();
    assert!(raster.overflow && first.incomplete, "{raster:?}");
    assert_eq!(first.stats.overflow, Some(true), "the frame's own flag");
    assert!(raster.tile_items > raster.item_capacity);
    let second = frame();
    let raster = second.stats.compute_raster.clone().unwrap();
    assert!(!raster.overflow && !second.incomplete, "{raster:?}");
    assert_eq!(second.stats.fragments_generated, Some(24 * 64 * 64));
}

/// The rasterizer's items, counters and arguments poisoned before a frame change nothing.
#[test]
fn poisoned_raster_buffers_change_nothing() {
    let scene = loaders::load_scene("builtin:nvpro?objects=32&subdiv=10&seed=2").unwrap();
    let opts = options(40, Raster::Compute);
    assert_poison_changes_nothing(&scene, &opts, MethodId::AbufferLl);
}

/// The methods whose captures order memory (locks, kb-ll's links) run on the compute rasterizer
/// with acquire/release atomics: a second frame over poisoned storage equals the first.
#[test]
fn ordered_captures_on_poisoned_storage_repeat_their_picture() {
    let scene = loaders::load_scene("builtin:nvpro?objects=32&subdiv=10&seed=2").unwrap();
    for method in crate::methods::kbuffer::ordered_methods() {
        let mut opts = patient(method, &options(40, Raster::Compute));
        // mlab merges past k in arrival order, which changes between frames on a parallel
        // device: with room for every fragment it merges none.
        if method == MethodId::Mlab {
            opts.frame.k = Some(64);
        }
        let mut r = crate::Renderer::new(gpu(), &scene, &opts).unwrap();
        let (clean, a) = without_lock_failures(method, || r.render_method(method, None).unwrap());
        let (poisoned, b) = without_lock_failures(method, || {
            r.recorder().unwrap().poison();
            r.render_method(method, None).unwrap()
        });
        assert!(
            clean == poisoned,
            "{method}: poisoned memory changed the picture"
        );
        assert_eq!(a.fragments_generated, b.fragments_generated, "{method}");
    }
}

/// An application's draw callback or shaders need the GPU's rasterizer: one clear error.
#[test]
fn application_draws_need_the_gpu_rasterizer() {
    let scene = loaders::load_scene("builtin:layers?n=2").unwrap();
    let opts = options(16, Raster::Compute);
    let mut rec = crate::FrameRecorder::new(gpu(), &scene, MethodId::AbufferFixed, &opts).unwrap();
    let mut encoder = gpu().device.create_command_encoder(&Default::default());
    let draw = |pass: &mut wgpu::RenderPass<'_>| pass.draw(0..6, 0..1);
    let e = rec
        .record(&mut encoder, &Default::default(), Some(&draw))
        .unwrap_err();
    assert!(e.to_string().contains("--raster hw"), "{e}");
    let shader = crate::frame::application::AppShader::new("", "vs", "fs");
    let e = crate::FrameRecorder::for_application(gpu(), MethodId::AbufferFixed, &opts, shader)
        .err()
        .expect("an application's recorder refuses the compute rasterizer");
    assert!(e.to_string().contains("--raster compute"), "{e}");
}
