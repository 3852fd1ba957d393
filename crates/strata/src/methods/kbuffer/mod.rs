//! The k-buffer family (seed 003 §3, Table 1): the k nearest fragments per pixel in bounded
//! memory, in one geometry pass, sorted and composited in a shared resolve.
//!
//! Methods over fixed per-pixel slot arrays (this module):
//! - `kplus-array`, `kplus-heap`: the k+-buffer — k fragments captured unsorted under a per-pixel
//!   spin lock, the farthest kept in slot 0 (max-array, O(k) re-scan on replace) or at the root
//!   of a binary max-heap (O(log k)); a fragment not before the maximum of a full pixel is culled
//!   before taking the lock, and the test is repeated inside it.
//! - `kplus-array-r`: the revised max-array — the first k fragments take slots from a counter
//!   without the lock.
//! - `kb-ps`: sorted insertion inside the lock (pixel synchronisation emulated as the paper did);
//!   `kb`: the original k-buffer, sorted insertion with no lock — its read-modify-write hazards
//!   between concurrent fragments of a pixel are its known flaw and are left as they are.
//! - `abuffer-fixed`: the FABS A-buffer, a counter into a fixed array of k slots per pixel;
//!   fragments past it are counted as dropped (and blended into the tail with `--tail blend`).
//! - `kb-ab-fixed`: the same with the array sized from measured need (an overflowing frame is
//!   re-rendered with a larger array) and the k nearest selected in the resolve.
//!
//! Passes: clear; capture (1 geometry pass); resolve (compute: insertion sort ≤ 16, shell sort
//! ≤ 64, k-depth sort beyond, composite the k nearest, then the tail). Memory: 16 bytes per slot,
//! 16 per pixel of counters and lock, 20 per pixel of tail sums with `--tail blend`, 84 bytes of
//! parameters and counters.
//!
//! Spin lock guarantees: every word a critical section touches is accessed atomically, so no
//! holder reads a stale cached copy of the previous holder's writes (WGSL has no `@coherent`).
//! WGSL atomics are relaxed, though, and fragment shaders have no fences: that the previous
//! holder's slot stores are visible before its unlock is what GPUs do in practice (atomics go to
//! the coherent cache level), not something the WGSL memory model guarantees; the same holds for
//! `kplus-array-r`'s publication count and `kb-ll`'s node links. Every walk is bounded. The lock is
//! taken with atomicExchange inside a loop whose body runs the critical section and breaks, so a
//! SIMD lane that wins the lock finishes and releases it within the same iteration: no lane waits
//! on another lane of its own group, and progress does not depend on independent thread
//! scheduling. Each fragment tries at most `max_tries` times; a fragment that never gets the lock
//! is counted in `lock_failures` (and joins the tail), never silently lost. One exception to
//! scheduling independence: `kplus-array-r`'s slow path waits, within the try bound, for the
//! fast stores of its pixel to be published; on a GPU without independent thread scheduling a
//! fast store diverged in the same SIMD group may only run after that wait, and the slow
//! fragment then counts as a lock failure.

pub mod list;
pub mod mdt;

pub mod cpu;

use bytemuck::{Pod, Zeroable};

use crate::error::{Error, Result};
use crate::gpu::binding::{self, Slot};
use crate::gpu::{readback, shader, Gpu, ResourceCache};
use crate::methods::{
    capture_pipeline, compute_pipeline, storage_geometry_pass, submit_pixels, Method, MethodStats,
    NullTarget,
};
use crate::render::{FrameContext, RenderOptions, SceneGpu, Tail};

/// Keep in sync with `KParams` in storage.wgsl.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub struct KParams {
    pub k: u32,
    pub stride: u32,
    pub max_tries: u32,
    pub culling: u32,
    pub tail_blend: u32,
    pub count_by_seen: u32,
    pub _pad: [u32; 2],
}

/// Counter words, in the order of storage.wgsl's COUNTER_ constants.
const COUNTERS: u64 = 8;
const COUNTER_LOCK_FAILURES: usize = 0;
const COUNTER_DROPPED: usize = 1;
const COUNTER_MAX_SEEN: usize = 2;
const COUNTER_SEEN_TOTAL: usize = 5;

/// Bytes of per-frame constants: parameters (32), counters (32), the tail stub (20) when the
/// tail is dropped.
pub const CONSTANT_BYTES: u64 = 84;
pub const SLOT_BYTES: u64 = 16;
pub const PIXEL_BYTES: u64 = 16;
pub const TAIL_BYTES: u64 = 20;

pub const DEFAULT_K: u32 = 16;
/// Spin-lock tries per fragment before it counts as a lock failure.
pub const DEFAULT_MAX_TRIES: u32 = 4096;

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Variant {
    KplusArray,
    KplusHeap,
    KplusArrayR,
    Kb,
    KbPs,
    AbufferFixed,
    KbAbFixed,
}

impl Variant {
    pub fn from_id(id: &str) -> Option<Variant> {
        Some(match id {
            "kplus-array" => Variant::KplusArray,
            "kplus-heap" => Variant::KplusHeap,
            "kplus-array-r" => Variant::KplusArrayR,
            "kb" => Variant::Kb,
            "kb-ps" => Variant::KbPs,
            "abuffer-fixed" => Variant::AbufferFixed,
            "kb-ab-fixed" => Variant::KbAbFixed,
            _ => return None,
        })
    }

    fn capture(self) -> (&'static str, &'static str, &'static str) {
        match self {
            Variant::KplusArray => (
                "kplus",
                include_str!("kplus_capture.wgsl"),
                "fs_kplus_array",
            ),
            Variant::KplusHeap => ("kplus", include_str!("kplus_capture.wgsl"), "fs_kplus_heap"),
            Variant::KplusArrayR => (
                "kplus",
                include_str!("kplus_capture.wgsl"),
                "fs_kplus_array_r",
            ),
            Variant::Kb => ("kb", include_str!("kb_capture.wgsl"), "fs_kb"),
            Variant::KbPs => ("kb", include_str!("kb_capture.wgsl"), "fs_kb_ps"),
            Variant::AbufferFixed | Variant::KbAbFixed => {
                ("fixed", include_str!("fixed_capture.wgsl"), "fs_fixed")
            }
        }
    }

    fn fixed(self) -> bool {
        matches!(self, Variant::AbufferFixed | Variant::KbAbFixed)
    }
}

pub const STORAGE_WGSL: &str = include_str!("storage.wgsl");
pub const RESOLVE_WGSL: &str = include_str!("resolve.wgsl");
pub const SLOTS_WGSL: &str = include_str!("slots.wgsl");
pub const SLOTS_RESOLVE_WGSL: &str = include_str!("slots_resolve.wgsl");

/// The k the options ask for, checked.
pub fn k_of(options: &RenderOptions) -> Result<u32> {
    let k = options.k.unwrap_or(DEFAULT_K);
    if k == 0 || k > 4096 {
        return Err(Error::input(format!("--k {k} is outside 1..4096")));
    }
    Ok(k)
}

/// Checks a per-pixel allocation against the budget and the device's binding limit.
pub fn check_memory(
    ctx: &FrameContext<'_>,
    method: &str,
    buffer_bytes: u64,
    total_bytes: u64,
) -> Result<()> {
    if let Some(budget) = ctx.options.budget_bytes() {
        if total_bytes > budget {
            return Err(Error::input(format!(
                "{method}: needs {:.1} MiB at k={} and {}x{}, more than --budget-mb {}",
                total_bytes as f64 / 1048576.0,
                ctx.options.k.unwrap_or(DEFAULT_K),
                ctx.options.width,
                ctx.options.height,
                ctx.options.budget_mb.unwrap_or(0.0)
            )));
        }
    }
    if buffer_bytes > ctx.gpu.max_storage_binding() {
        return Err(Error::unsupported(format!(
            "{method}: needs a {:.1} MiB buffer, more than the device binds ({:.1} MiB); lower --k or --size",
            buffer_bytes as f64 / 1048576.0,
            ctx.gpu.max_storage_binding() as f64 / 1048576.0
        )));
    }
    Ok(())
}

/// The parts every k-buffer frame shares: parameters, per-pixel words, counters, tail.
pub struct FrameBuffers {
    pub params: wgpu::Buffer,
    pub pixels: wgpu::Buffer,
    pub counters: wgpu::Buffer,
    pub tail: wgpu::Buffer,
    pub bytes: u64,
}

impl FrameBuffers {
    pub fn new(
        ctx: &FrameContext<'_>,
        cache: &mut ResourceCache,
        params: KParams,
    ) -> Result<FrameBuffers> {
        let gpu = ctx.gpu;
        let px = ctx.pixels();
        let params_buffer =
            cache.uniform(gpu, "strata.kbuffer.params", bytemuck::bytes_of(&params));
        let tail_bytes = if params.tail_blend != 0 {
            px * TAIL_BYTES
        } else {
            TAIL_BYTES
        };
        let none = wgpu::BufferUsages::empty();
        Ok(FrameBuffers {
            params: params_buffer,
            pixels: cache.storage(gpu, "strata.kbuffer.pixels", px * PIXEL_BYTES, none)?,
            counters: cache.storage(
                gpu,
                "strata.kbuffer.counters",
                COUNTERS * 4,
                wgpu::BufferUsages::COPY_SRC,
            )?,
            tail: cache.storage(gpu, "strata.kbuffer.tail", tail_bytes, none)?,
            bytes: px * PIXEL_BYTES + tail_bytes + 64,
        })
    }

    pub fn clear(&self, enc: &mut wgpu::CommandEncoder) {
        enc.clear_buffer(&self.pixels, 0, None);
        enc.clear_buffer(&self.counters, 0, None);
        enc.clear_buffer(&self.tail, 0, None);
    }

    /// Group 1: parameters, the method's storage, pixels, counters, tail, output.
    pub fn group(
        &self,
        gpu: &Gpu,
        layout: &wgpu::BindGroupLayout,
        storage: &wgpu::Buffer,
        output: &wgpu::Buffer,
    ) -> wgpu::BindGroup {
        binding::group(
            &gpu.device,
            "strata.kbuffer.group",
            layout,
            &[
                self.params.as_entire_binding(),
                storage.as_entire_binding(),
                self.pixels.as_entire_binding(),
                self.counters.as_entire_binding(),
                self.tail.as_entire_binding(),
                output.as_entire_binding(),
            ],
        )
    }

    pub fn read_counters(&self, gpu: &Gpu) -> Result<Vec<u32>> {
        readback::read_u32s(gpu, &self.counters, COUNTERS)
    }
}

pub fn group_layout(gpu: &Gpu) -> wgpu::BindGroupLayout {
    binding::layout(
        &gpu.device,
        "strata.kbuffer.layout",
        &[
            Slot::Uniform,
            Slot::StorageRw,
            Slot::StorageRw,
            Slot::StorageRw,
            Slot::StorageRw,
            Slot::StorageRw,
        ],
    )
}

/// Stats from the resolve's counters.
pub fn stats_from_counters(c: &[u32], k: u32, passes: u32, bytes: u64) -> MethodStats {
    let seen = c[COUNTER_SEEN_TOTAL] as u64;
    let dropped = c[COUNTER_DROPPED] as u64;
    MethodStats {
        geometry_passes: passes,
        k: Some(k),
        fragments_generated: Some(seen),
        fragments_stored: Some(seen - dropped.min(seen)),
        fragments_dropped: Some(dropped),
        max_depth_complexity: Some(c[COUNTER_MAX_SEEN]),
        bytes_allocated: bytes,
        overflow: None,
        lock_failures: Some(c[COUNTER_LOCK_FAILURES] as u64),
    }
}

pub fn params_for(options: &RenderOptions, k: u32, stride: u32, count_by_seen: bool) -> KParams {
    KParams {
        k,
        stride,
        max_tries: options.max_tries.unwrap_or(DEFAULT_MAX_TRIES).max(1),
        culling: options.culling as u32,
        tail_blend: (options.tail == Tail::Blend) as u32,
        count_by_seen: count_by_seen as u32,
        _pad: [0; 2],
    }
}

/// The fragment storage of a k-buffer frame.
pub struct Storage {
    pub label: &'static str,
    pub bytes: u64,
    /// Zeroed before capture (cascades and their empty-slot marker need it).
    pub clear: bool,
}

/// What every k-buffer method runs the same way: the group-1 layout, the resolve pipeline, the
/// buffers kept between frames, and a frame — clear, capture passes, resolve, counters.
pub struct KFrame {
    pub id: &'static str,
    pub layout: wgpu::BindGroupLayout,
    resolve: wgpu::ComputePipeline,
    cache: ResourceCache,
    null_target: Option<NullTarget>,
}

impl KFrame {
    pub fn new(gpu: &Gpu, scene: &SceneGpu, id: &'static str, resolve_source: &str) -> KFrame {
        let layout = group_layout(gpu);
        let module = shader::module(&gpu.device, &format!("strata.{id}.resolve"), resolve_source);
        let resolve = compute_pipeline(
            gpu,
            &format!("strata.{id}.resolve"),
            &module,
            "cs_resolve",
            &[&scene.frame_layout, &layout],
        );
        KFrame {
            id,
            layout,
            resolve,
            cache: ResourceCache::default(),
            null_target: None,
        }
    }

    /// A capture pipeline of this method over `source`'s fragment entry point.
    pub fn capture_pipeline(
        &self,
        gpu: &Gpu,
        scene: &SceneGpu,
        module: &wgpu::ShaderModule,
        entry: &str,
    ) -> wgpu::RenderPipeline {
        capture_pipeline(
            gpu,
            &format!("strata.{}.{entry}", self.id),
            module,
            entry,
            &[&scene.frame_layout, &self.layout],
            &[NullTarget::target_state()],
            None,
        )
    }

    /// Runs one frame; returns the counters and the bytes allocated.
    pub fn run(
        &mut self,
        ctx: &mut FrameContext<'_>,
        params: KParams,
        storage: Storage,
        passes: &[(&'static str, &wgpu::RenderPipeline)],
    ) -> Result<(Vec<u32>, u64)> {
        let gpu = ctx.gpu;
        let shared = FrameBuffers::new(ctx, &mut self.cache, params)?;
        let total = storage.bytes + shared.bytes;
        check_memory(ctx, self.id, storage.bytes, total)?;
        let buffer = self.cache.storage(
            gpu,
            storage.label,
            storage.bytes,
            wgpu::BufferUsages::empty(),
        )?;
        let group = shared.group(gpu, &self.layout, &buffer, ctx.output);
        let target = NullTarget::ensure(
            &mut self.null_target,
            gpu,
            "strata.kbuffer.null_target",
            ctx.options.width,
            ctx.options.height,
        );
        let frame_group = ctx.frame_group;
        let mut enc = gpu.device.create_command_encoder(&Default::default());
        shared.clear(&mut enc);
        if storage.clear {
            enc.clear_buffer(&buffer, 0, None);
        }
        for (name, pipeline) in passes {
            storage_geometry_pass(
                ctx,
                &mut enc,
                name,
                target,
                pipeline,
                &[frame_group, &group],
            );
        }
        gpu.queue.submit([enc.finish()]);
        submit_pixels(ctx, "resolve", &self.resolve, &[frame_group, &group]);
        Ok((shared.read_counters(gpu)?, total))
    }
}

/// Methods over fixed per-pixel slot arrays.
pub struct SlotKBuffer {
    variant: Variant,
    frame: KFrame,
    capture: wgpu::RenderPipeline,
    /// kb-ab-fixed: slots per pixel the next frame starts with (measured need).
    measured_stride: u32,
}

impl SlotKBuffer {
    pub fn new(gpu: &Gpu, scene: &SceneGpu, id: &'static str, variant: Variant) -> SlotKBuffer {
        let frame = KFrame::new(
            gpu,
            scene,
            id,
            &[STORAGE_WGSL, SLOTS_WGSL, SLOTS_RESOLVE_WGSL, RESOLVE_WGSL].join("\n"),
        );
        let (family, stage, entry) = variant.capture();
        let module = shader::module(
            &gpu.device,
            &format!("strata.{family}.capture"),
            &[STORAGE_WGSL, SLOTS_WGSL, stage].join("\n"),
        );
        SlotKBuffer {
            variant,
            capture: frame.capture_pipeline(gpu, scene, &module, entry),
            frame,
            measured_stride: 0,
        }
    }

    fn frame(
        &mut self,
        ctx: &mut FrameContext<'_>,
        k: u32,
        stride: u32,
    ) -> Result<(Vec<u32>, u64)> {
        let storage = Storage {
            label: "strata.kbuffer.slots",
            bytes: ctx.pixels() * stride as u64 * SLOT_BYTES,
            clear: false,
        };
        let params = params_for(ctx.options, k, stride, self.variant.fixed());
        self.frame
            .run(ctx, params, storage, &[("capture", &self.capture)])
    }
}

impl Method for SlotKBuffer {
    fn render(&mut self, ctx: &mut FrameContext<'_>) -> Result<MethodStats> {
        let k = k_of(ctx.options)?;
        if self.variant != Variant::KbAbFixed {
            let (c, bytes) = self.frame(ctx, k, k)?;
            let mut stats = stats_from_counters(&c, k, 1, bytes);
            if self.variant == Variant::AbufferFixed {
                stats.overflow = Some(c[COUNTER_MAX_SEEN] > k);
            }
            return Ok(stats);
        }
        // kb-ab-fixed stores every fragment: an array too small for the deepest pixel is found
        // by the resolve (max seen), grown, and the frame rendered again.
        let mut stride = self.measured_stride.max(k);
        let mut passes = 0;
        let mut overflowed = false;
        loop {
            passes += 1;
            let (c, bytes) = self.frame(ctx, k, stride)?;
            let need = c[COUNTER_MAX_SEEN];
            if need <= stride {
                self.measured_stride = need;
                let mut stats = stats_from_counters(&c, k, passes, bytes);
                stats.overflow = Some(overflowed);
                return Ok(stats);
            }
            overflowed = true;
            stride = need;
        }
    }
}

#[cfg(test)]
mod tests;
