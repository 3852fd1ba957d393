use super::*;
use crate::frame::RESOLVED_BYTES;
use crate::scene::loaders;
use crate::testing::gpu;

fn resolved_after_one_frame(rec: &mut FrameRecorder) -> Vec<u8> {
    resolved_after_one_frame_on(gpu(), rec)
}

fn resolved_after_one_frame_on(g: &crate::gpu::Gpu, rec: &mut FrameRecorder) -> Vec<u8> {
    let mut enc = g.device.create_command_encoder(&Default::default());
    rec.record(&mut enc, &Default::default(), None).unwrap();
    g.queue.submit([enc.finish()]);
    rec.wait_stats().unwrap();
    let size = rec.options().pixels() * RESOLVED_BYTES;
    crate::gpu::readback::read_buffer(g, rec.resolved(), size).unwrap()
}

/// An animation's next time step written into the same recorder gives the frame a fresh
/// recorder of that step gives (same camera).
#[test]
fn animated_geometry_updates_in_place() {
    let s0 = loaders::load_scene("builtin:balls?count=40&frame=0").unwrap();
    let s1 = loaders::load_scene("builtin:balls?count=40&frame=3").unwrap();
    let options = RenderOptions::sized(32, 32);
    let mut rec = FrameRecorder::new(gpu(), &s0, MethodId::KplusHeap, &options).unwrap();
    let first = resolved_after_one_frame(&mut rec);
    rec.set_geometry(&s1).unwrap();
    let moved = resolved_after_one_frame(&mut rec);
    assert!(first != moved, "the balls moved");
    let mut fresh = FrameRecorder::new(gpu(), &s1, MethodId::KplusHeap, &options).unwrap();
    fresh.set_camera(&s0.camera_or_framing());
    assert!(moved == resolved_after_one_frame(&mut fresh));
}

/// Real-time `--k auto`: the first frame guesses within the budget; each later frame takes
/// its k from the latest histogram back (frame t's for frame t + 1 when the application
/// waits a frame), and the k follows the animation's depth complexity.
#[test]
fn auto_k_follows_the_last_histogram() {
    let g = gpu();
    let sparse = loaders::load_scene("builtin:balls?count=6&frame=0").unwrap();
    let dense = loaders::load_scene("builtin:balls?count=120&frame=0").unwrap();
    let options = RenderOptions {
        frame: FrameOptions {
            width: 48,
            height: 48,
            k_auto: Some(1.0),
            ..Default::default()
        },
        ..Default::default()
    };
    let mut rec = FrameRecorder::new(g, &sparse, MethodId::KplusSbuffer, &options).unwrap();
    let frame = |rec: &mut FrameRecorder| {
        let mut enc = g.device.create_command_encoder(&Default::default());
        rec.record(&mut enc, &Default::default(), None).unwrap();
        g.queue.submit([enc.finish()]);
        rec.wait_stats().unwrap().stats
    };
    let first = frame(&mut rec);
    let auto = first.k_auto.clone().unwrap();
    assert_eq!(first.k, Some(DEFAULT_K));
    assert_eq!(auto.histogram_frame, None);
    let depth = first.max_depth_complexity.unwrap();
    let second = frame(&mut rec);
    let auto = second.k_auto.clone().unwrap();
    assert_eq!(auto.histogram_frame, Some(0));
    assert_eq!(
        second.k,
        Some(depth.max(1)),
        "R = 1 keeps the deepest pixel"
    );
    assert_eq!(auto.achieved_robustness, Some(1.0));
    rec.set_geometry(&dense).unwrap();
    let third = frame(&mut rec);
    assert_eq!(
        third.k, second.k,
        "frame 2's k comes from frame 1's histogram"
    );
    let fourth = frame(&mut rec);
    assert_eq!(fourth.k_auto.unwrap().histogram_frame, Some(2));
    assert_eq!(fourth.k, third.max_depth_complexity);
    assert!(fourth.k > second.k, "more balls, deeper pixels");
}

/// A one-shot render is complete in one call: where the first frame's pool overflows (deep
/// pixels, abuffer-ll's first guess), `render_once` renders again, and its picture is the one a
/// real-time recorder reaches a frame later.
#[test]
fn render_once_is_complete_in_one_call() {
    let g = gpu();
    let scene = loaders::load_scene("builtin:layers?n=48").unwrap();
    let options = RenderOptions::sized(48, 48);
    let mut once = FrameRecorder::new(g, &scene, MethodId::AbufferLl, &options).unwrap();
    let stats = once.render_once(&Default::default(), None).unwrap();
    assert_eq!(stats.fragments_dropped, Some(0));
    assert_eq!(stats.exact, Some(true));
    assert!(
        stats.submits >= 2,
        "the first frame fit: {} submits",
        stats.submits
    );
    let size = options.pixels() * RESOLVED_BYTES;
    let picture = crate::gpu::readback::read_buffer(g, once.resolved(), size).unwrap();
    // Real time: the first frame overflows and says so; the next one is complete.
    let mut live = FrameRecorder::new(g, &scene, MethodId::AbufferLl, &options).unwrap();
    let first = resolved_after_one_frame(&mut live);
    let second = resolved_after_one_frame(&mut live);
    assert!(first != picture);
    assert!(second == picture);
}

/// Issue 65: the device lost mid-session (destroyed here, as a driver reset or a removed GPU
/// loses it) — every recorder call then returns `Error::DeviceLost` in one line naming the
/// loss, none panics and no statistics wait hangs; a new recorder on a new device renders the
/// same frame as before.
#[test]
fn a_lost_device_fails_every_call_in_one_line_and_a_new_device_works() {
    let scene = loaders::load_scene("builtin:layers?n=4&coverage=0.8").unwrap();
    let opts = crate::methods::tests::options(32, crate::Effect::Transparency);
    let frame = |gpu: &crate::gpu::Gpu, rec: &mut FrameRecorder| -> crate::Result<FrameReport> {
        let mut encoder = gpu.device.create_command_encoder(&Default::default());
        rec.record(&mut encoder, &Default::default(), None)?;
        gpu.queue.submit([encoder.finish()]);
        rec.wait_stats()
    };
    let lost = crate::gpu::Gpu::new().unwrap();
    let mut rec = FrameRecorder::new(&lost, &scene, crate::MethodId::AbufferLl, &opts).unwrap();
    let before = frame(&lost, &mut rec).unwrap();
    let picture = resolved_after_one_frame_on(&lost, &mut rec);
    // An encoder the application made before the loss.
    let mut encoder = lost.device.create_command_encoder(&Default::default());
    lost.device.destroy();
    let is_loss = |what: &str, r: crate::Result<()>| {
        let e = r.expect_err(what);
        assert!(matches!(e, Error::DeviceLost(_)), "{what}: {e:?}");
        let text = e.to_string();
        assert!(
            text.contains("was lost") && !text.contains('\n'),
            "{what}: {text}"
        );
    };
    is_loss(
        "record",
        rec.record(&mut encoder, &Default::default(), None)
            .map(drop),
    );
    let started = std::time::Instant::now();
    is_loss("wait_stats", rec.wait_stats().map(drop));
    assert!(started.elapsed() < std::time::Duration::from_secs(5));
    is_loss("resize", rec.resize(16, 16));
    is_loss("set_method", rec.set_method(crate::MethodId::KbAbLl));
    is_loss("set_geometry", rec.set_geometry(&scene));
    is_loss(
        "a new recorder",
        FrameRecorder::new(&lost, &scene, crate::MethodId::AbufferLl, &opts).map(drop),
    );
    assert!(rec.poll_stats().is_empty());
    drop(encoder);
    // An application's device (`Gpu::from_device`): strata keeps the application's lost
    // callback, so until the application tells it, what fails says what wgpu reported — an
    // error, not a panic — and once told, every call names the loss.
    let opened = crate::gpu::Gpu::new().unwrap();
    let app = crate::gpu::Gpu::from_device(opened.device.clone(), opened.queue.clone());
    let mut rec = FrameRecorder::new(&app, &scene, crate::MethodId::AbufferLl, &opts).unwrap();
    frame(&app, &mut rec).unwrap();
    let mut encoder = app.device.create_command_encoder(&Default::default());
    app.device.destroy();
    let untold = rec
        .record(&mut encoder, &Default::default(), None)
        .and_then(|_| rec.wait_stats().map(drop));
    assert!(untold.is_err(), "the lost device's frame completed");
    app.device_lost("the application's device-lost callback: destroyed");
    is_loss(
        "record, told",
        rec.record(&mut encoder, &Default::default(), None)
            .map(drop),
    );
    is_loss("wait_stats, told", rec.wait_stats().map(drop));
    drop(encoder);
    let fresh = crate::gpu::Gpu::new().unwrap();
    let mut rec = FrameRecorder::new(&fresh, &scene, crate::MethodId::AbufferLl, &opts).unwrap();
    let after = frame(&fresh, &mut rec).unwrap();
    assert_eq!(
        after.stats.fragments_generated,
        before.stats.fragments_generated
    );
    assert_eq!(resolved_after_one_frame_on(&fresh, &mut rec), picture);
}

/// Issue 65: an allocation past what the device allows (restricted limits stand in for a
/// smaller device) is an error naming the buffer, its size and the limit — when the recorder
/// is made, when it is resized, and when a frame's pool outgrows it — and the recorder goes on
/// at a size that fits.
#[test]
fn an_allocation_past_the_devices_limit_names_its_size_and_the_recorder_goes_on() {
    let mut limits = gpu().limits.clone();
    limits.max_storage_buffer_binding_size = 1 << 20;
    limits.max_buffer_size = 1 << 20;
    let small = crate::gpu::Gpu::new_restricted(wgpu::Features::empty(), limits).unwrap();
    let scene = loaders::load_scene("builtin:layers?n=8&coverage=0.9").unwrap();
    let names_size = |what: &str, e: Error| {
        let text = e.to_string();
        // Either the size check's phrasing (what the pixels need, what one buffer binds) or
        // the allocation's (the buffer, its size, more than the device binds).
        let named = text.contains("MiB")
            && (text.contains(crate::error::OVER_BINDING) || text.contains("binds 1 MiB"));
        assert!(named, "{what}: {text}");
        assert!(!text.contains('\n'), "{what}: {text}");
    };
    let big = crate::methods::tests::options(512, crate::Effect::Transparency);
    let e = FrameRecorder::new(&small, &scene, crate::MethodId::AbufferLl, &big).err();
    names_size("made at 512²", e.expect("512² fits in 1 MiB buffers"));
    let fits = crate::methods::tests::options(32, crate::Effect::Transparency);
    let mut rec = FrameRecorder::new(&small, &scene, crate::MethodId::AbufferLl, &fits).unwrap();
    let frame = |rec: &mut FrameRecorder| -> crate::Result<FrameReport> {
        let mut encoder = small.device.create_command_encoder(&Default::default());
        rec.record(&mut encoder, &Default::default(), None)?;
        small.queue.submit([encoder.finish()]);
        rec.wait_stats()
    };
    let first = frame(&mut rec).unwrap();
    names_size("resized to 512²", rec.resize(512, 512).unwrap_err());
    assert_eq!(
        rec.options().frame.width,
        32,
        "a refused resize changed the size"
    );
    // 160² fits the per-pixel buffers; the fragments' pool (8 layers) does not: the frame that
    // would need it is refused naming it, not cut short silently.
    rec.resize(160, 160).unwrap();
    let pool = frame(&mut rec).and_then(|_| frame(&mut rec));
    match pool {
        Err(e) => names_size("a pool past the limit", e),
        Ok(report) => {
            let why = report.cannot_complete.map(|s| s.why).unwrap_or_default();
            assert!(why.contains(crate::error::OVER_BINDING), "{why}");
        }
    }
    rec.resize(32, 32).unwrap();
    let again = frame(&mut rec).unwrap();
    assert_eq!(
        again.stats.fragments_generated,
        first.stats.fragments_generated
    );
}

/// Draws split by triangle range (docs/watchdog.md, S1) leave every picture as it was: the
/// ranges go in the scene's order (unsorted blends, f2b's peels), in `--order`'s index order
/// (kb-ll under `--order back`), and in the sorted method's, and order-independent captures
/// see the same fragments. 7 triangles a draw turns the scene into dozens of draws.
#[test]
fn draws_split_by_triangle_range_leave_the_picture_as_it_was() {
    let scene = loaders::load_scene("builtin:spheres?layers=4&segments=12").unwrap();
    let mut back = RenderOptions::sized(40, 40);
    back.frame.order = Some(crate::order::Order::Back);
    for (method, options) in [
        (MethodId::Unsorted, RenderOptions::sized(40, 40)),
        (MethodId::Sorted, RenderOptions::sized(40, 40)),
        (MethodId::F2b, RenderOptions::sized(40, 40)),
        (MethodId::AbufferLl, RenderOptions::sized(40, 40)),
        (MethodId::KbLl, back),
    ] {
        let mut whole = FrameRecorder::new(gpu(), &scene, method, &options).unwrap();
        let mut split = FrameRecorder::new(gpu(), &scene, method, &options).unwrap();
        split.scene.set_triangles_per_draw(7);
        assert!(scene.triangle_count() > 7 * 8, "several draws");
        assert!(
            resolved_after_one_frame(&mut whole) == resolved_after_one_frame(&mut split),
            "{method:?}: the split draws changed the picture"
        );
    }
}

/// Draws split into bands of rows under scissors (docs/watchdog.md, S2) leave every method's
/// picture as it was: each pixel's fragments come from one band's draw, in the same order. Every
/// GPU method that draws the scene, three bands of a 40-row frame and 50 triangles a draw, with
/// `--order back` where it applies; multisampled too on a GPU. Lavapipe (Mesa 23–24) lets a
/// multisampled draw through the scissor's row above its rectangle, so every method drew that
/// row twice there: a CPU device draws no bands (it has no display watchdog either), and here
/// its multisampled frames are not banded.
#[test]
fn draws_split_into_bands_of_rows_leave_every_picture_as_it_was() {
    let scene = loaders::load_scene("builtin:spheres?layers=4&segments=12").unwrap();
    let cpu = gpu().info.device_type == wgpu::DeviceType::Cpu;
    let samples = match cpu {
        true => vec![1],
        false => vec![1, 4],
    };
    for (method, samples) in
        MethodId::gpu_methods().flat_map(|m| samples.iter().map(move |&s| (m, s)))
    {
        let d = method.descriptor();
        let mut options = RenderOptions::sized(40, 40);
        options.build.msaa = samples.max(d.min_samples);
        if d.takes_order {
            options.frame.order = Some(crate::order::Order::Back);
        }
        if options.build.msaa > 1 && cpu {
            continue;
        }
        if !d.msaa.yes() && options.build.msaa > 1 {
            continue;
        }
        let mut whole = FrameRecorder::new(gpu(), &scene, method, &options).unwrap();
        let mut banded = FrameRecorder::new(gpu(), &scene, method, &options).unwrap();
        banded.scene.force_draw_bands(3);
        banded.scene.set_triangles_per_draw(50);
        assert!(
            resolved_after_one_frame(&mut whole) == resolved_after_one_frame(&mut banded),
            "{method:?}: the banded draws changed the picture"
        );
    }
}

#[test]
fn draw_bands_follow_the_last_frames_fragments() {
    use crate::frame::scene_gpu::{draw_bands_for, MAX_FRAGMENTS_PER_DRAW};
    assert_eq!(draw_bands_for(0, 64), 1);
    assert_eq!(draw_bands_for(MAX_FRAGMENTS_PER_DRAW, 64), 1);
    assert_eq!(draw_bands_for(MAX_FRAGMENTS_PER_DRAW + 1, 64), 2);
    // The heavy 4096² scene of docs/watchdog.md: 1.6 G fragments.
    assert_eq!(draw_bands_for(1_600_000_000, 4096), 96);
    assert_eq!(draw_bands_for(u64::MAX, 16), 16);
}

#[test]
fn draw_ranges_cover_every_triangle_once_in_order() {
    use crate::frame::scene_gpu::draw_ranges;
    let ranges: Vec<_> = draw_ranges(17, 7).collect();
    assert_eq!(ranges, [0..21, 21..42, 42..51]);
    assert_eq!(draw_ranges(14, 7).collect::<Vec<_>>(), [0..21, 21..42]);
    assert_eq!(draw_ranges(0, 7).count(), 0);
    let limit = crate::scene::MAX_SCENE_TRIANGLES as u32;
    let per_draw = crate::frame::scene_gpu::MAX_TRIANGLES_PER_DRAW;
    let at_limit: Vec<_> = draw_ranges(limit, per_draw).collect();
    assert_eq!(at_limit.len(), 4);
    assert_eq!(at_limit.last().unwrap().end, limit * 3);
}
