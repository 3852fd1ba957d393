//! Reverse-reprojection temporal culling (seed 000, `--temporal on`) for the slot k-buffers
//! whose capture decides at capture time which fragments are outside the k nearest:
//! `kplus-array`, `kplus-heap`, `kplus-array-r`, `kplus-semiheap`, `kb-ps` and `kb`.
//!
//! Each frame writes, per pixel, the depth of the nearest fragment the cache did not keep — the
//! (k+1)-th nearest — into one of two interface buffers (ping-pong by frame parity; 4 bytes per
//! pixel each, plus the frame's culled count). The next frame's capture reprojects each
//! fragment's world position with the previous frame's view-projection and culls it before any
//! lock when it lies more than ε behind the interface at all four texels around its previous
//! position (a border or an uncovered texel means far: no culling). Storage buffers stand in
//! for the paper's depth textures: the lookup is the farthest of the 2×2 neighbourhood rather
//! than a bilinear blend of depths across silhouettes. 16×16 tiles skip culling one frame in
//! `refresh` (rotating), so that what was culled wrongly returns.
//!
//! Approximate by design: the first frame culls nothing; a static scene and camera lose
//! nothing from the second frame on (each pixel's k nearest lie in front of its own (k+1)-th
//! depth). Objects the GPU moves ([`crate::animation`]) are carried back along their own motion
//! before the previous camera reprojects them (each triangle's object, and per object the
//! transform from this frame's position to last frame's); geometry the application moves
//! itself, or replaces with [`crate::FrameRecorder::set_geometry`], is reprojected with the
//! camera only. Either way what moved into the k nearest from behind the interface, or whose
//! neighbourhood changed, can be lost until its tile refreshes. The error against
//! `reference --k N` is measured per frame (`strata bench online-culling`), never hidden.
//!
//! Not taken by: the fixed arrays (`abuffer-fixed`, `kb-ab-fixed`: they keep fragments by
//! arrival), the A-buffer k-selectors and lists (`kb-ab-ll`, `kb-ll`, `kb-sbuffer`,
//! `kplus-sbuffer`: chosen in the resolve or by a pool), the MDT cascades (two passes that
//! would have to cull identically), `kpeel`, and an application's capture pass.

use bytemuck::Zeroable;
use glam::Mat4;

use crate::gpu::twin::{gpu_struct, wgsl_module};

use crate::error::Result;
pub use crate::frame::values::{TemporalCulling, DEFAULT_EPSILON, DEFAULT_REFRESH};
use crate::frame::FrameContext;
use crate::gpu::Gpu;

gpu_struct! {
    /// Temporal culling's parameters (`strata::kbuffer::temporal_params`), bound as `temporal`
    /// by temporal.wgsl.
    pub struct TemporalParams {
        /// Last frame's view-projection, to reproject this frame's fragments.
        pub previous_view_proj: [[f32; 4]; 4],
        /// How far (window depth) behind the interface a fragment must lie to be culled.
        pub epsilon: f32,
        /// Frames between refreshes of one tile.
        pub refresh_period: u32,
        /// The frame's number, which picks the tiles that refresh.
        pub frame: u32,
        /// 1 when last frame's interface is valid for this frame.
        pub cull: u32,
        /// 1 when this frame records its interface.
        pub record: u32,
        /// Frame width in pixels.
        pub width: u32,
        /// Frame height in pixels.
        pub height: u32,
        /// 1 when the scene's objects move on the GPU ([`crate::animation`]): bindings 9 and 10
        /// hold their motion.
        pub moving: u32,
    }
}

/// `strata::kbuffer::temporal_params`: [`TemporalParams`] for temporal.wgsl.
pub(crate) const PARAMS_WGSL: &str =
    wgsl_module!("strata::kbuffer::temporal_params", TemporalParams);

/// The interface buffers, the parameters, and what last frame recorded.
pub struct TemporalState {
    params: wgpu::Buffer,
    /// Bound in place of the interfaces while culling is off, and of the motion while nothing
    /// moves.
    stubs: [wgpu::Buffer; 2],
    motion_stubs: [wgpu::Buffer; 2],
    interfaces: Option<[wgpu::Buffer; 2]>,
    /// The interface this frame writes.
    parity: usize,
    /// Last frame's view-projection and size, when it recorded an interface.
    last: Option<(Mat4, u32, u32)>,
    frames: u32,
}

/// What a frame binds: the parameters, last frame's interface, this frame's, and the objects'
/// motion (stubs when nothing moves).
pub struct TemporalBindings {
    /// The [`TemporalParams`].
    pub params: wgpu::Buffer,
    /// Last frame's interface.
    pub previous: wgpu::Buffer,
    /// This frame's interface, and the count of culled fragments.
    pub current: wgpu::Buffer,
    /// Each triangle's object (moving scenes).
    pub triangle_objects: wgpu::Buffer,
    /// Per object, the transform from where it is to where it was last frame.
    pub to_previous: wgpu::Buffer,
    /// Whether temporal culling runs this frame.
    pub on: bool,
}

impl TemporalState {
    /// No interface yet, and stub bindings for frames without temporal culling.
    pub fn new(gpu: &Gpu) -> TemporalState {
        let stub = |label: &str| {
            gpu.device.create_buffer(&wgpu::BufferDescriptor {
                label: Some(label),
                size: 64,
                usage: wgpu::BufferUsages::STORAGE,
                mapped_at_creation: false,
            })
        };
        TemporalState {
            params: gpu.device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("strata.kbuffer.temporal"),
                size: std::mem::size_of::<TemporalParams>() as u64,
                usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            }),
            stubs: [
                stub("strata.kbuffer.temporal.off0"),
                stub("strata.kbuffer.temporal.off1"),
            ],
            motion_stubs: [
                stub("strata.kbuffer.temporal.still_objects"),
                stub("strata.kbuffer.temporal.still_motion"),
            ],
            interfaces: None,
            parity: 0,
            last: None,
            frames: 0,
        }
    }

    /// Bytes this frame's interfaces take (0 when culling is off), before [`TemporalState::frame`]
    /// makes them: a frame checks its memory budget before anything advances.
    pub fn bytes(ctx: &FrameContext<'_>) -> u64 {
        match ctx.options.frame.temporal {
            None => 0,
            Some(_) => 2 * (ctx.pixels() + 2) * 4 + std::mem::size_of::<TemporalParams>() as u64,
        }
    }

    /// This frame's bindings: writes the parameters, clears the interface it records and
    /// advances to the next frame's, so it is the frame's last step that can fail.
    pub fn frame(&mut self, ctx: &mut FrameContext<'_>) -> Result<TemporalBindings> {
        let gpu = ctx.gpu;
        let (w, h) = ctx.size();
        let [triangle_objects, to_previous] = match &ctx.scene.animation {
            Some(a) => [a.triangle_objects().clone(), a.to_previous().clone()],
            None => self.motion_stubs.clone(),
        };
        let moving = ctx.scene.animation.is_some() as u32;
        let Some(settings) = ctx.options.frame.temporal else {
            self.last = None;
            let params = TemporalParams {
                width: w,
                height: h,
                ..Zeroable::zeroed()
            };
            gpu.queue
                .write_buffer(&self.params, 0, bytemuck::bytes_of(&params));
            return Ok(TemporalBindings {
                params: self.params.clone(),
                previous: self.stubs[0].clone(),
                current: self.stubs[1].clone(),
                triangle_objects,
                to_previous,
                on: false,
            });
        };
        let words = ctx.pixels() + 2;
        if self
            .interfaces
            .as_ref()
            .is_none_or(|b| b[0].size() != words * 4)
        {
            let make = |i: usize| {
                gpu.storage_buffer(
                    &format!("strata.kbuffer.temporal.interface{i}"),
                    words * 4,
                    wgpu::BufferUsages::COPY_SRC,
                )
            };
            self.interfaces = Some([make(0)?, make(1)?]);
            self.last = None;
        }
        let interfaces = self.interfaces.as_ref().expect("made above");
        let view_proj = crate::frame::uniforms::band_projection(&ctx.scene.camera, ctx.options);
        let previous = self.last.filter(|l| (l.1, l.2) == (w, h));
        let params = TemporalParams {
            previous_view_proj: previous.map_or(Mat4::IDENTITY, |l| l.0).to_cols_array_2d(),
            epsilon: settings.epsilon,
            refresh_period: settings.refresh,
            frame: self.frames,
            cull: previous.is_some() as u32,
            record: 1,
            width: w,
            height: h,
            moving,
        };
        gpu.queue
            .write_buffer(&self.params, 0, bytemuck::bytes_of(&params));
        let current = interfaces[self.parity].clone();
        ctx.encoder.clear_buffer(&current, 0, None);
        let bindings = TemporalBindings {
            params: self.params.clone(),
            previous: interfaces[1 - self.parity].clone(),
            current,
            triangle_objects,
            to_previous,
            on: true,
        };
        self.last = Some((view_proj, w, h));
        self.parity = 1 - self.parity;
        self.frames = self.frames.wrapping_add(1);
        Ok(bindings)
    }
}

/// The culled count from the interface's last two words.
pub fn culled(words: &[u32]) -> u64 {
    crate::frame::wide(words, 0)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::frame::FrameOptions;
    use crate::frame::RenderOptions;
    use crate::methods::kbuffer::Tail;
    use crate::methods::MethodId;
    use crate::scene::loaders;
    use crate::testing::{assert_close, gpu, render_reference};
    use crate::Renderer;

    fn temporal_options(refresh: u32) -> RenderOptions {
        RenderOptions {
            frame: FrameOptions {
                width: 64,
                height: 64,
                k: Some(4),
                temporal: Some(TemporalCulling {
                    refresh,
                    ..Default::default()
                }),
                ..Default::default()
            },
            ..Default::default()
        }
    }

    #[test]
    fn a_static_view_loses_nothing_from_the_second_frame_on() {
        // Depth complexity up to ~12 at k = 4: most fragments lie behind the interface.
        let scene = loaders::load_scene("builtin:nvpro?objects=24&subdiv=8&seed=4").unwrap();
        for refresh in [0, DEFAULT_REFRESH] {
            let options = temporal_options(refresh);
            let expected = render_reference(&scene, &options);
            for method in [
                "kplus-heap",
                "kplus-semiheap",
                "kplus-array",
                "kplus-array-r",
                "kb-ps",
            ] {
                let mut r = Renderer::new(gpu(), &scene, &options).unwrap();
                let (_, first) = r.render(method).unwrap();
                assert_eq!(
                    first.culled_temporal,
                    Some(0),
                    "{method}: the first frame has no interface"
                );
                for frame in 1..3 {
                    let (image, stats) = r.render(method).unwrap();
                    let culled = stats.culled_temporal.unwrap();
                    assert!(culled > 0, "{method} frame {frame}: nothing culled");
                    assert_eq!(
                        stats.fragments_generated, first.fragments_generated,
                        "{method}"
                    );
                    // Tolerance as in methods/tests.rs (rasterization at pixel-center edges).
                    assert_close(
                        &format!("temporal-{method}-{refresh}-{frame}"),
                        &image,
                        &expected,
                        options.frame.effect,
                        2,
                        0.001,
                    );
                }
            }
        }
    }

    /// `frames` of balls moving on the GPU (`set_time`: culling follows each ball's motion) or
    /// replaced from the CPU each frame (`set_geometry`: the camera's reprojection only), with
    /// kplus-semiheap and temporal culling: fragments culled, and per frame the share of pixels
    /// over 2/255 against `reference --k 4` of the scene at that time.
    fn moving_balls(options: &RenderOptions, on_gpu: bool, frames: u32) -> (u64, Vec<f64>) {
        let exact = {
            let mut options = options.clone();
            options.frame.temporal = None;
            options
        };
        let scene = loaders::load_scene("builtin:balls?count=200").unwrap();
        let mut r = Renderer::new(gpu(), &scene, options).unwrap();
        let (mut culled, mut over) = (0, Vec::new());
        for t in 0..frames {
            let moved = scene.at_time(t as f32);
            if on_gpu {
                r.set_time(t as f32);
            } else if t > 0 {
                r.set_geometry(&moved).unwrap();
            }
            let (image, stats) = r.render("kplus-semiheap").unwrap();
            culled += stats.culled_temporal.unwrap();
            let expected = render_reference(&moved, &exact);
            let c = crate::metrics::compare(
                &expected.to_rgba8(options.frame.effect),
                &image.to_rgba8(options.frame.effect),
            )
            .unwrap();
            over.push(c.pct_over_2);
        }
        (culled, over)
    }

    /// Measured on lavapipe over these 30 frames (64x64, k = 4, refresh 8): with the balls'
    /// own motion, 637 fragments culled, the worst frame 0.098% of pixels (4 of 4096) over
    /// 2/255, the mean 0.033%; reprojected with the camera only, 609 culled, 0.098% and 0.024%.
    /// At 160x160 with 1000 balls the two agree too (mean 0.259% and 0.255%, worst 0.352%):
    /// a ball moves under two pixels a frame, which the 2x2 lookup already spans, and the
    /// error comes from neighbours that moved differently. The bound allows 20 pixels, for
    /// other rasterizers' edge rounding; it is a measurement's bound, not a target.
    #[test]
    fn moving_balls_stay_within_the_measured_error() {
        const MOVING_MAX_PCT_OVER_2: f64 = 0.5;
        let options = temporal_options(DEFAULT_REFRESH);
        for on_gpu in [true, false] {
            let (culled, over) = moving_balls(&options, on_gpu, 30);
            let worst = over.iter().cloned().fold(0.0, f64::max);
            let mean = over.iter().sum::<f64>() / over.len() as f64;
            eprintln!(
                "balls, 30 frames, moved on the GPU: {on_gpu}: {culled} culled, worst {worst:.3}%, mean {mean:.4}% of pixels over 2/255"
            );
            assert!(culled > 0, "the animation culled nothing");
            assert!(
                worst <= MOVING_MAX_PCT_OVER_2,
                "worst frame: {worst:.3}% over 2/255"
            );
        }
    }

    /// A frame refused by its memory budget records nothing, so it must not advance the
    /// interfaces: the next frame culls against the last recorded one.
    #[test]
    fn a_refused_frame_leaves_the_interface_to_the_next() {
        use crate::render::recorder::FrameRecorder;
        let scene = loaders::load_scene("builtin:nvpro?objects=24&subdiv=8&seed=4").unwrap();
        let options = temporal_options(0);
        let mut rec = FrameRecorder::new(gpu(), &scene, MethodId::KplusHeap, &options).unwrap();
        let frame = |rec: &mut FrameRecorder| {
            let mut encoder = gpu().device.create_command_encoder(&Default::default());
            let recorded = rec.record(&mut encoder, &Default::default(), None);
            gpu().queue.submit([encoder.finish()]);
            recorded
        };
        frame(&mut rec).unwrap();
        assert!(rec.wait_stats().unwrap().stats.culled_temporal == Some(0));
        let starved = {
            let mut options = options.clone();
            options.frame.budget_mb = Some(0.01);
            options
        };
        rec.set_frame_options(&starved.frame).unwrap();
        let e = frame(&mut rec).unwrap_err().to_string();
        assert!(e.contains("--budget-mb"), "{e}");
        rec.set_frame_options(&options.frame).unwrap();
        frame(&mut rec).unwrap();
        let culled = rec.wait_stats().unwrap().stats.culled_temporal.unwrap();
        assert!(culled > 0, "the frame after a refused one culled nothing");
    }

    #[test]
    fn culled_fragments_join_the_tail() {
        let scene = loaders::load_scene("builtin:nvpro?objects=24&subdiv=8&seed=4").unwrap();
        let options = {
            let mut options = temporal_options(0);
            options
                .frame
                .family_mut::<crate::methods::kbuffer::KBufferOptions>()
                .tail = Tail::Blend;
            options
        };
        let mut r = Renderer::new(gpu(), &scene, &options).unwrap();
        let (first, _) = r.render("kplus-heap").unwrap();
        let (second, stats) = r.render("kplus-heap").unwrap();
        assert!(stats.culled_temporal.unwrap() > 0);
        // The tail's sums are integers, so the same fragments give the same tail in any order.
        assert_close(
            "temporal-tail",
            &second,
            &first,
            options.frame.effect,
            1,
            0.0,
        );
    }

    #[test]
    fn temporal_params_layout_matches_wgsl() {
        crate::gpu::twin::assert_twin::<TemporalParams>();
    }

    #[test]
    fn only_captures_that_choose_at_capture_time_take_it() {
        let takes = |m: MethodId| m.descriptor().check_temporal(true).is_ok();
        assert!(takes(MethodId::KplusSemiheap) && takes(MethodId::KplusHeap));
        assert!(!takes(MethodId::AbufferFixed) && !takes(MethodId::KbMdt32));
        let e = MethodId::AbufferLl
            .descriptor()
            .check_temporal(true)
            .unwrap_err()
            .to_string();
        assert!(e.contains("not abuffer-ll"), "{e}");
        let mut bad = crate::frame::FrameOptions {
            temporal: Some(TemporalCulling {
                epsilon: f32::NAN,
                ..Default::default()
            }),
            ..Default::default()
        };
        assert!(bad.validate().is_err());
        bad.temporal = None;
        assert!(bad.validate().is_ok());
        assert!(MethodId::AbufferLl
            .descriptor()
            .check_temporal(false)
            .is_ok());
    }
}
