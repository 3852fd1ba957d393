//! `kpeel`: k-depth peeling (seed 003 §4.3), the unified buffer used as a multi-pass A-buffer in
//! bounded memory.
//!
//! Passes: clear; init (compute: an empty running composite per pixel, kept in the frame's
//! output); then P times a *capture* geometry pass — the k+-buffer capture (max-array for
//! k ≤ 16, max-heap above, culling against a full pixel's maximum) of the fragments strictly
//! after the pixel's last composited fragment in (depth, primitive) order — and a *resolve*
//! (compute: sort the captured fragments, composite them behind the running result, whose last
//! fragment becomes the next pass's bound); finish (compute: the accounting of pixels still
//! unfinished). P = ⌈N/k⌉ with N `--layers`, else the depth complexity the previous frame
//! measured (8 for a first frame); a frame whose depth complexity exceeds P·k reports the
//! fragments it did not reach as dropped, the next frame peels enough, and exact mode renders
//! again.
//!
//! The paper bounds each pass by the previous pass's farthest depth, so fragments at exactly that
//! depth beyond the k captured are lost. The bound here is the (depth, primitive) pair, unique per
//! fragment of a pixel, so nothing is lost at equal depths: exact, equal to the A-buffer (k = 1
//! is front-to-back peeling one layer per pass; k ≥ N is a one-pass k+-buffer).
//!
//! Where the adapter has SHADER_INT64_ATOMIC_ALL_OPS, the capture is lock-free on both
//! rasterizers when single-sampled (kpeel_cascade.wgsl, seed 002's multi-layer peeling over
//! MDTS, the capture of `kb-keys`): per pass a *keys* pass cascades 64-bit (depth, tag) keys
//! with atomicMax through the pixel's k slots and a *colors* pass writes the kept fragments into
//! their slots, so 2·P geometry passes and 8 more bytes per slot for the keys; nothing spins.
//! As kb-keys', the keys pass searches where a key enters after one load of the last slot, and
//! on the hardware rasterizer the colors pass passes over a fragment clearly behind the k-th key,
//! or clearly in front of the first (composited by an earlier pass), after a load or two
//! (ARCHITECTURE, "No lock where none is needed").
//! Without those atomics (and with `--msaa`, whose samples peel on their own) the hardware
//! rasterizer takes the locked k+-buffer capture; `--raster compute` needs the cascade.
//!
//! With `--msaa S` every sample peels on its own (per-sample storage, [`crate::frame::msaa`]):
//! a fragment, shaded once, enters the capture of each covered sample where it is still behind
//! that sample's last composited fragment; each sample keeps its running composite after the
//! slots; a last *account* geometry pass counts each fragment once, each sample's depth
//! complexity (which sets the next frame's passes) and the fragments some sample composited,
//! and finish averages the samples. P + 1 geometry passes.
//!
//! Memory: 16 bytes per slot (k per pixel), 16 per pixel of counters, lock and culling bound,
//! 156 of parameters and counters; the running composite lives in the frame's own output, with
//! 4 bytes per pixel for its last fragment's depth, so memory does not grow with the depth
//! complexity. With `--msaa S`: S× the slots and words, 36·S per pixel of running composites
//! (color, count, RGB transmittance, the last fragment's tag and depth), 4 per pixel. Limits: k ≤ 1024 (the max-heap's lock).

use super::{k_of, params_for, KFrame, Layout, Storage, SLOT_BYTES};
use crate::error::{Error, Result};
use crate::frame::passes::{
    compute_pipeline, dispatch_pixels, storage_geometry_pass, GeometryStage, NullTarget,
};
use crate::frame::{FrameContext, MethodStats, Recorded, SceneGpu, Totals};
use crate::gpu::binding::{self, Slot};
use crate::gpu::{Gpu, ResourceCache};
use crate::methods::peeling::{layers_fixed, layers_for, peel_feedback};
use crate::methods::{Method, MethodId};

/// kpeel's capture stage (the k+-buffer's under a lock).
pub const CAPTURE_WGSL: &str = include_str!("kpeel_capture.wgsl");
/// kpeel's lock-free key cascade stage.
pub const CASCADE_WGSL: &str = include_str!("kpeel_cascade.wgsl");
/// kpeel's resolve, compositing a pass's k nearest and keeping where it stopped.
pub const RESOLVE_WGSL: &str = include_str!("kpeel_resolve.wgsl");

/// The compute rasterizer's lock-free capture: the keys buffer's layout, the keys and colors
/// stages (kpeel_cascade.wgsl).
struct Cascade {
    layout: wgpu::BindGroupLayout,
    keys: GeometryStage,
    colors: GeometryStage,
    cache: ResourceCache,
}

/// Bytes per pixel of the running composite's state beside the frame's output (the last
/// composited fragment's depth), single-sampled (kpeel_state.wgsl).
pub const PIXEL_STATE_BYTES: u64 = 4;
/// Bytes per sample of the running composites with `--msaa` (kpeel_state.wgsl's
/// KPEEL_STATE_WORDS: color, count, transmittance, the last fragment's tag and depth).
pub const SAMPLE_STATE_BYTES: u64 = 36;

/// Bytes per key of the compute capture's cascade.
pub const KEY_BYTES: u64 = 8;

/// `kpeel`: k nearest per pass behind the last composited (depth, primitive), until every pixel is done.
pub struct KPeel {
    frame: KFrame,
    /// The locked capture, on the GPU's rasterizer.
    capture: Option<GeometryStage>,
    /// `--msaa`'s account pass (on the GPU's rasterizer).
    account: Option<GeometryStage>,
    /// With `--raster compute`, which runs this capture instead of the locked one.
    cascade: Option<Cascade>,
    init: wgpu::ComputePipeline,
    finish: wgpu::ComputePipeline,
    /// The depth complexity the last frame measured.
    measured: Option<u32>,
    /// The last frame peeled `--layers` layers, not a measured count.
    layers_fixed: bool,
    null_target: Option<NullTarget>,
}

impl KPeel {
    /// The pipelines for `scene`: the key cascade where there are 64-bit atomics and one sample per pixel, else the locked capture.
    pub fn new(gpu: &Gpu, scene: &SceneGpu) -> Result<KPeel> {
        let id = MethodId::Kpeel;
        let resolve = super::stage(gpu, "strata.kpeel.resolve", RESOLVE_WGSL, Layout::Slots)
            .defs(&crate::gpu::shader::target_samples(scene.samples));
        let mut frame = KFrame::with_resolve(gpu, scene, id, &resolve, "cs_kpeel_resolve");
        let lock_free = gpu.has(wgpu::Features::SHADER_INT64_ATOMIC_ALL_OPS) && scene.samples == 1;
        let cascade = if scene.raster_layout.is_some() || lock_free {
            Some(Cascade::new(gpu, scene, &frame)?)
        } else {
            None
        };
        // The locked capture orders its lock (the cascade needs no ordering: the frame then
        // reports relaxed atomics and no adapter refuses it).
        let module = cascade
            .is_none()
            .then(|| frame.capture_module(gpu, scene, CAPTURE_WGSL, Layout::Slots, true));
        let compute = resolve.module(&gpu.device);
        let layouts = [&scene.frame_layout, &frame.layout];
        let pipeline = |entry: &str| {
            compute_pipeline(
                gpu,
                &format!("strata.kpeel.{entry}"),
                (&compute, entry),
                &layouts,
            )
        };
        let stage = |entry: &str| {
            module
                .as_ref()
                .map(|module| frame.capture_pipeline(gpu, scene, module, entry))
                .transpose()
        };
        Ok(KPeel {
            capture: stage("fs_kpeel")?,
            account: stage("fs_kpeel_account")?,
            cascade,
            init: pipeline("cs_kpeel_init"),
            finish: pipeline("cs_kpeel_finish"),
            frame,
            measured: None,
            layers_fixed: false,
            null_target: None,
        })
    }
}

impl Cascade {
    fn new(gpu: &Gpu, scene: &SceneGpu, frame: &KFrame) -> Result<Cascade> {
        if !gpu.has(wgpu::Features::SHADER_INT64_ATOMIC_ALL_OPS) {
            return Err(Error::unsupported(format!(
                "kpeel on --raster compute cascades 64-bit keys (SHADER_INT64_ATOMIC_ALL_OPS), which '{}' lacks; use --raster hw",
                gpu.info.name
            )));
        }
        let layout = binding::layout(&gpu.device, "strata.kpeel.keys.layout", &[Slot::StorageRw]);
        // Compiled only where the adapter has 64-bit atomics.
        let stage = super::stage(gpu, "strata.kpeel.cascade", CASCADE_WGSL, Layout::Slots)
            .defs(&super::stages::capture_definitions(scene));
        let layouts = [&scene.frame_layout, &frame.layout, &layout];
        let module = stage.module(&gpu.device);
        let storage_stage = |entry: &str| {
            let label = format!("strata.kpeel.{entry}");
            crate::raster::storage_stage(
                gpu,
                scene,
                &label,
                &stage,
                (&module, false),
                entry,
                &layouts,
            )
        };
        Ok(Cascade {
            keys: storage_stage("fs_kpeel_keys")?,
            colors: storage_stage("fs_kpeel_colors")?,
            layout,
            cache: ResourceCache::default(),
        })
    }
}

impl Method for KPeel {
    fn record(&mut self, ctx: &mut FrameContext<'_>) -> Result<Recorded> {
        let k = k_of(ctx.k, MethodId::Kpeel)?;
        let layers = layers_for(ctx, self.measured);
        self.layers_fixed = layers_fixed(ctx);
        let passes = layers.div_ceil(k);
        // The slots, then the running composites' state (kpeel_state.wgsl).
        let samples = super::sample_storage(MethodId::Kpeel, ctx.options.build.msaa) as u64;
        let states = if samples > 1 {
            samples * SAMPLE_STATE_BYTES
        } else {
            PIXEL_STATE_BYTES
        };
        let storage = Storage {
            label: "strata.kbuffer.slots",
            bytes: ctx.pixels() * (samples * k as u64 * SLOT_BYTES + states),
            clear: false,
        };
        // Every fragment is composited in order: no tail.
        let mut params = params_for(ctx, k, k, false);
        params.tail_blend = 0;
        params.sample_slots = samples as u32;
        let keys_bytes = ctx.pixels() * k as u64 * KEY_BYTES;
        let (group, bytes) = match self.cascade {
            Some(_) => {
                // The budget covers the keys too.
                ctx.check_budget(
                    storage.bytes
                        + keys_bytes
                        + super::frame_bytes_besides_storage(ctx.pixels(), false),
                )?;
                let (group, bytes) = self.frame.begin(ctx, params, storage)?;
                (group, bytes + keys_bytes)
            }
            None => self.frame.begin(ctx, params, storage)?,
        };
        let keys = match &mut self.cascade {
            Some(c) => {
                let buffer = c.cache.storage(ctx.gpu, "strata.kpeel.keys", keys_bytes)?;
                let keys_group = binding::group(
                    &ctx.gpu.device,
                    "strata.kpeel.keys.group",
                    &c.layout,
                    &[buffer.as_entire_binding()],
                );
                Some((buffer, keys_group))
            }
            None => None,
        };
        let target = ctx.null_target(&mut self.null_target, "strata.kpeel.null_target");
        let frame_group = ctx.frame_group;
        dispatch_pixels(ctx, "init", &self.init, &[frame_group, &group]);
        for pass in 0..passes {
            if pass > 0 {
                self.frame.clear_pixels(ctx);
            }
            match (&self.cascade, &keys, &self.capture) {
                (Some(cascade), Some((buffer, keys_group)), _) => {
                    ctx.encoder.clear_buffer(buffer, 0, None);
                    let groups = [frame_group, &group, keys_group];
                    storage_geometry_pass(ctx, "capture_keys", target, &cascade.keys, &groups);
                    storage_geometry_pass(ctx, "capture_colors", target, &cascade.colors, &groups);
                }
                (_, _, Some(capture)) => {
                    storage_geometry_pass(ctx, "capture", target, capture, &[frame_group, &group])
                }
                _ => unreachable!("a capture for the scene's rasterizer is made in new"),
            }
            self.frame.resolve(ctx, &group);
        }
        let account = match (&self.account, samples > 1) {
            (Some(account), true) => {
                self.frame.clear_pixels(ctx);
                storage_geometry_pass(ctx, "account", target, account, &[frame_group, &group]);
                1
            }
            _ => 0,
        };
        dispatch_pixels(ctx, "finish", &self.finish, &[frame_group, &group]);
        self.frame.read_counters(ctx);
        let passes_per_layer_group = if self.cascade.is_some() { 2 } else { 1 };
        Ok(Recorded {
            geometry_passes: passes * passes_per_layer_group + account,
            k: Some(k),
            bytes_allocated: bytes,
            capacity: passes as u64 * k as u64,
            memory_ordering: Some(self.frame.memory_ordering()),
            temporal: false,
            family: None,
            setup_capacity: 0,
        })
    }

    fn stats(&mut self, recorded: &Recorded, totals: &Totals, words: &[u32]) -> MethodStats {
        let mut stats = peel_feedback(&mut self.measured, recorded, totals, self.layers_fixed);
        stats.lock_failures = Some(super::lock_failures(words));
        stats
    }

    fn resources(&self) -> Vec<&ResourceCache> {
        let mut all = self.frame.resources();
        all.extend(self.cascade.as_ref().map(|c| &c.cache));
        all
    }
}
