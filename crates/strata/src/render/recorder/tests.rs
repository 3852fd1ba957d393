use super::*;
use crate::frame::RESOLVED_BYTES;
use crate::scene::loaders;
use crate::testing::gpu;

fn resolved_after_one_frame(rec: &mut FrameRecorder) -> Vec<u8> {
    let g = gpu();
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
