//! The k-buffer family (seed 003 §3, Table 1): the k nearest fragments per pixel in bounded
//! memory, in one geometry pass, sorted and composited in a shared resolve.
//!
//! Methods over fixed per-pixel slot arrays (this module):
//! - `kplus-array`, `kplus-heap`: the k+-buffer — k fragments captured unsorted under a per-pixel
//!   spin lock, the farthest kept in slot 0 (max-array, O(k) re-scan on replace) or at the root
//!   of a binary max-heap (O(log k)); a fragment not before the maximum of a full pixel is culled
//!   before taking the lock, and the test is repeated inside it.
//! - `kplus-bitonic`: `kplus-array`'s capture with a resolve that sorts every list by the bitonic
//!   network (the others sort up to 16 fragments by insertion): the resolve's sort compared at
//!   small k, where insertion sort's data-dependent loop and the network's fixed one differ most.
//! - `kplus-array-r`: the revised max-array — the first k fragments take slots from a counter
//!   without the lock.
//! - `kplus-semiheap`: the semi-heap (seed 000) — a max-heap of the h farthest (`--heap-size`,
//!   default 1) and an unordered rest; the first k − h fragments take slots without the lock, the
//!   later ones move the farthest of the rest and themselves into the heap under it.
//! - `kb-ps`: sorted insertion inside the lock (pixel synchronisation emulated as the paper did);
//!   `kb`: the original k-buffer, sorted insertion with no lock — its read-modify-write hazards
//!   between concurrent fragments of a pixel are its known flaw and are left as they are.
//! - `mlab`: multi-layer alpha blending (Salvi & Vaidyanathan 2014) — k layers kept in order
//!   under the lock; a fragment takes its place and when that makes k + 1 layers the two
//!   farthest merge into one (OVER, the nearer one's key; no culling, no tail). Exact while a
//!   pixel has at most k fragments; beyond, the merges put the error at the back, and because a
//!   lock (unlike pixel synchronisation) takes fragments in whatever order they arrive, which
//!   layers merge varies from run to run on a GPU. The total opacity is exact whatever the
//!   order (each merge keeps the product of transmittances). The resolve is the slot
//!   k-buffers': a merged layer is a fragment record whose color and opacity are the pair's.
//!   Fragments past k count as dropped from the exact set: they are in the picture only through
//!   the merges.
//! - `abuffer-fixed`: the FABS A-buffer, a counter into a fixed array of k slots per pixel;
//!   fragments past it are counted as dropped (and blended into the tail with `--tail blend`).
//! - `kb-ab-fixed`: the same with the array sized from measured need (an overflowing frame is
//!   re-rendered with a larger array) and the k nearest selected in the resolve.
//!
//! Passes: clear (per-pixel words, counters, tail); capture (1 geometry pass); resolve (compute:
//! insertion sort ≤ 16, bitonic sort ≤ 64, k-depth sort beyond, composite the k nearest, then the
//! tail). Memory: 16 bytes per slot, 16 per pixel of counters, lock and culling bound, 40 per
//! pixel of tail sums with `--tail blend`, 156 bytes of parameters and counters. With `--msaa S`
//! the capture-time k-buffers (all but the fixed A-buffers, here; `kb-ll` and `kb-mdt32` too)
//! keep it all per sample — S× the slots, words and tail, + 4 bytes per pixel — and each
//! sample keeps its own k nearest ([`crate::frame::msaa`], [`sample_storage`]).
//!
//! Frames: nothing is read back while recording. The counters (lock failures, losses, pool use)
//! come back with the frame's statistics; `kb-ab-fixed` and the linked lists grow from the
//! measured need for the next frame and report the frame incomplete, which exact mode renders
//! again. Every per-pixel word a concurrent reader may see is cleared before each frame; slots
//! and nodes are read only after this frame published them, so garbage left in them (tests
//! poison them) never shows. Counters saturate or carry into a second word: none wraps.
//!
//! Limits on k: work under a per-pixel lock is serialized across all fragments of the pixel, and
//! a GPU that runs too long loses the device. The O(k) critical sections (`kplus-array`,
//! `kplus-array-r`, `kb-ps`, and `kb`'s unlocked equivalent) accept k ≤ 256, `kplus-heap`'s O(log k)
//! one k ≤ 1024, the MDT cascades (O(k) atomics per fragment) k ≤ 512, `kb-ll`'s walks k ≤ 256;
//! the A-buffers select k ≤ 4096 in the resolve. These are conservative bounds, not measured
//! GPU limits.
//!
//! Spin lock guarantees: every word a critical section touches is accessed atomically, so no
//! holder reads a stale cached copy of the previous holder's writes. Where the adapter offers
//! MEMORY_DECORATION_COHERENT the storage is also declared `@coherent` (SPIR-V Coherent). Where
//! it takes SPIR-V passthrough shaders (Vulkan), the captures that order memory run their
//! `acquire_*` and `release_*` functions (storage.wgsl, list.wgsl) with that ordering
//! (`gpu::ordered`): the lock's exchange and release, the count that publishes lock-free slot
//! stores (kplus-array-r, kplus-semiheap) and kb-ll's links; every other atomic stays relaxed.
//! Without passthrough (Metal, DX12, GL) those captures are refused ([`orders`]), and an
//! application's own capture shader (relaxed WGSL) may call only the lock-free ones.
//! `FrameStats.memory_ordering` reports which. The locking methods are exact when
//! `lock_failures` is 0. Every walk is bounded: list walks by min(seen, pool), kb-ll's
//! insertion walk by k plus one re-read per try (a failed exchange walks on from the
//! predecessor, not from the head).
//!
//! The lock is taken with a test-and-test-and-set inside a loop of at most `max_tries` tries
//! (at most [`MAX_TRIES_LIMIT`]) per shader invocation, not per fragment: an invocation of the
//! compute rasterizer captures up to 64 fragments, and its tries in all stay within the bound a
//! display watchdog allows (`try_budget` in storage.wgsl; each fragment still gets one try). The loop has no `return`, `break` or `continue`: the winner's
//! critical section sits inside the `if` that took the lock and the loop ends only at its own
//! condition, so lanes of one SIMD group that failed the try wait at the `if`'s merge while the
//! winner works. Before each try a waiter tests the culling bound again (it only falls: a
//! fragment culled while waiting goes to the tail without the lock). The first form returned
//! from inside the `if`; on an H100 it counted 20 to 2540 lock failures in a test frame at 4096
//! tries and took seconds per frame at 65536. The present form ran on an H100 on 2026-11-26 with
//! no lock failure in any test or benchmark (`bench/gpu-runs/2026-11-26-h100`). A fragment that
//! never gets the lock is counted in `lock_failures` (and joins the tail), never silently lost.
//! `kplus-array-r` and `kplus-semiheap` store their first fragments without the lock, in an `if`
//! of their own that comes first in program order, and publish them with a release add; a later
//! fragment waits (within the try bound) until the acquired count says all are published
//! before it tries the lock.
//!
//! `kb-keys` ([`mdt`]) keeps the k nearest with no lock at all: an atomicMax cascade of 64-bit
//! (depth, tag) keys and a second pass that stores each kept payload by its tag. The contention
//! harness ([`contention`]) drives every capture function from compute dispatches into a few
//! pixels at once, on lavapipe's parallel threads and on GPUs.

/// The `Method` functions of a k-buffer drawn in one capture pass over a [`KFrame`], for a type
/// with fields `frame` and `capture` and a `plan(ctx)` giving the frame's parameters, storage
/// and record: recording it, and the application capture (begin, end).
macro_rules! one_capture_pass_method {
    () => {
        fn record(&mut self, ctx: &mut FrameContext<'_>) -> Result<Recorded> {
            let (params, storage, mut recorded) = self.plan(ctx)?;
            recorded.bytes_allocated =
                self.frame
                    .record(ctx, params, storage, &[("capture", &self.capture)])?;
            Ok(recorded)
        }
    };
}

pub mod contention;
pub mod descriptor;
pub mod kpeel;
pub mod list;
pub mod mdt;
pub mod options;
pub mod predict;
pub mod sbuffer;
pub mod stages;
pub mod tail;
pub mod temporal;
pub mod variant;

pub mod cpu;

use crate::gpu::twin::{gpu_struct, wgsl_constants, wgsl_module};

use crate::error::{Error, Result};
use crate::frame::passes::{
    compute_pipeline, dispatch_pixels, storage_geometry_pass, GeometryStage, NullTarget,
};
use crate::frame::{FrameContext, MethodStats, Recorded, RenderOptions, SceneGpu, Totals};
use crate::gpu::binding::{self, Slot};
use crate::gpu::shader::{Defs, Stage};
use crate::gpu::{Gpu, ResourceCache};
use crate::methods::{Method, MethodId};
pub use options::{KBufferOptions, StorageLayout, Tail, MAX_TRIES_LIMIT};
pub use stages::{definitions, stage, Layout, LIBRARY, RESOLVE_WGSL, SLOTS_ENTRIES_WGSL};
pub use tail::{tail_depth, tail_settings, TailSettings, TAIL_ORTHOGRAPHIC};
pub use variant::Variant;

gpu_struct! {
    /// The k-buffer family's uniforms (`strata::kbuffer::params`), bound as `kp` by storage.wgsl.
    pub struct KParams {
        /// Fragments a pixel keeps.
        pub k: u32,
        /// Slots per pixel in storage (k, or a fixed A-buffer's measured need).
        pub stride: u32,
        /// Lock or link tries before a fragment counts as a lock failure.
        pub max_tries: u32,
        /// 1 with `--culling on`: fragments behind a full pixel's farthest kept one are dropped
        /// before the lock.
        pub culling: u32,
        /// [`crate::Tail::index`]: fragments past k are dropped (0), blended (1) or weighted (2)
        /// into the tail term.
        pub tail_blend: u32,
        /// A method's own parameter: fixed A-buffers 1 when their stored count is min(seen,
        /// stride) (they keep no FILLED count); kplus-semiheap its heap size h.
        pub aux: u32,
        /// Frame width in pixels.
        pub width: u32,
        /// Pixels of the frame.
        pub pixels: u32,
        /// `--msaa` with per-sample storage (the capture-time k-buffers): S, each pixel's storage
        /// being S sample pixels `p * S + s` with their own words, slots and tail (see
        /// [`sample_storage`]); else 1.
        pub sample_slots: u32,
        /// `--tail weighted`: the weight function ([`crate::Weight::index`]) in the low byte, and
        /// [`TAIL_ORTHOGRAPHIC`] for an orthographic view.
        pub tail_weight: u32,
        /// `--tail weighted`: p of [`tail_depth`]. p and q take a window depth to the scaled view
        /// distance the weight reads (`tail_distance` in storage.wgsl), so a capture needs no
        /// scene bindings (the contention harness and an application's capture have none).
        pub tail_depth_p: f32,
        /// `--tail weighted`: q of [`tail_depth`].
        pub tail_depth_q: f32,
        /// [`crate::StorageLayout::index`]: where item i of storage pixel p lies in a per-pixel
        /// array (`pixel_item` in storage.wgsl).
        pub storage_layout: u32,
    }
}

/// `strata::kbuffer::params`: [`KParams`] for storage.wgsl (every stage of the family and an
/// application's capture).
pub(crate) const PARAMS_WGSL: &str = wgsl_module!("strata::kbuffer::params", KParams);

/// Counter words (64-bit counters take two words).
pub const COUNTERS: u64 = 8;
/// 64-bit count of fragments that gave up on a lock.
pub const COUNTER_LOCK_FAILURES: usize = 0;
/// 64-bit count of pool items allocated (lists, S-buffers).
pub const COUNTER_ALLOCATED: usize = 2;
/// 64-bit count of fragments lost (a full pool, a failed link).
pub const COUNTER_LOST: usize = 4;
/// Nonzero when the pool overflowed.
pub const COUNTER_OVERFLOWED: usize = 6;

/// `strata::kbuffer::counters`: the counter words for the shaders.
pub(crate) const COUNTERS_WGSL: &str = wgsl_constants!(
    "strata::kbuffer::counters",
    COUNTER_LOCK_FAILURES = COUNTER_LOCK_FAILURES,
    COUNTER_ALLOCATED = COUNTER_ALLOCATED,
    COUNTER_LOST = COUNTER_LOST,
    COUNTER_OVERFLOWED = COUNTER_OVERFLOWED,
);

/// Bytes of per-frame constants: parameters ([`KParams`], 52), counters and their initial values
/// (2 × 32), the tail stub (40) when the tail is dropped.
pub const CONSTANT_BYTES: u64 =
    std::mem::size_of::<KParams>() as u64 + 2 * COUNTERS * 4 + TAIL_BYTES;
/// Bytes of one stored fragment slot.
pub const SLOT_BYTES: u64 = 16;
/// A pixel's words in the per-pixel array (storage.wgsl's `pixels`): seen, filled, lock, bound.
pub const PIXEL_WORDS: u64 = 4;
/// Every fragment that reached the pixel.
pub const SEEN_WORD: u64 = 0;
/// Slots in use; a list's head.
pub const FILLED_WORD: u64 = 1;
/// The spin lock.
pub const LOCK_WORD: u64 = 2;
/// The culling bound: a full pixel's farthest kept depth's bits + 1, 0 while it is not full.
pub const BOUND_WORD: u64 = 3;
/// Bytes of one pixel's words.
pub const PIXEL_BYTES: u64 = 4 * PIXEL_WORDS;
/// Words of the tail sums a pixel keeps with `--tail blend|weighted`: five 64-bit sums.
pub const TAIL_WORDS: u64 = 10;
/// Bytes of the tail term a pixel keeps with `--tail blend`.
pub const TAIL_BYTES: u64 = 4 * TAIL_WORDS;

/// `strata::kbuffer::words`: the places of a pixel's words and the tail's size for the shaders.
pub(crate) const WORDS_WGSL: &str = wgsl_constants!(
    "strata::kbuffer::words",
    PIXEL_WORDS = PIXEL_WORDS,
    SEEN = SEEN_WORD,
    FILLED = FILLED_WORD,
    LOCK = LOCK_WORD,
    BOUND = BOUND_WORD,
    TAIL_WORDS = TAIL_WORDS,
);

/// `--k` when not given.
pub const DEFAULT_K: u32 = 16;
/// Spin-lock tries per invocation (a fragment, under the GPU's rasterizer) before a fragment
/// counts as a lock failure. A failed try is one load of
/// the lock word, while a holder's critical section is tens of ordered atomics and up to 150
/// fragments of a test pixel queue for it: 65536 tries leave room for that queue (4096 was
/// chosen on lavapipe) and still bound the spin to milliseconds.
pub const DEFAULT_MAX_TRIES: u32 = 1 << 16;

/// The largest k a method accepts (see the module docs).
pub fn max_k(id: MethodId) -> u32 {
    id.descriptor().max_k
}

/// The frame's k ([`FrameContext::k`]; `None`: the default), checked against the method's limit.
pub fn k_of(k: Option<u32>, id: MethodId) -> Result<u32> {
    let k = k.unwrap_or(id.descriptor().default_k);
    let max = max_k(id);
    if k == 0 || k > max {
        return Err(Error::input(format!(
            "--k {k} is outside 1..{max} for {id} (longer critical sections risk a GPU timeout)"
        )));
    }
    Ok(k)
}

/// Bytes of the tail sums: per pixel with `--tail blend`, else one stub.
pub fn tail_bytes(pixels: u64, blend: bool) -> u64 {
    if blend {
        pixels * TAIL_BYTES
    } else {
        TAIL_BYTES
    }
}

/// What a k-buffer frame allocates besides its fragment storage: per-pixel words, tail sums,
/// parameters and counters.
pub fn frame_bytes_besides_storage(pixels: u64, tail_blend: bool) -> u64 {
    sample_frame_bytes_besides_storage(pixels, 1, tail_blend)
}

/// [`frame_bytes_besides_storage`] with `sample_slots` storage pixels per pixel: their words
/// and tails, and one fragment count per pixel when there is more than one.
pub fn sample_frame_bytes_besides_storage(pixels: u64, sample_slots: u32, tail_blend: bool) -> u64 {
    let storage_pixels = pixels * sample_slots as u64;
    pixel_words_bytes(pixels, sample_slots)
        + tail_bytes(storage_pixels, tail_blend)
        + CONSTANT_BYTES
        - TAIL_BYTES
}

/// The per-pixel words: 4 per storage pixel, and with per-sample storage a fragment count per
/// pixel after them.
fn pixel_words_bytes(pixels: u64, sample_slots: u32) -> u64 {
    let extra = if sample_slots > 1 { pixels * 4 } else { 0 };
    pixels * sample_slots as u64 * PIXEL_BYTES + extra
}

/// Storage pixels per pixel of `id` at `msaa` samples: the capture-time k-buffers keep each
/// sample's k nearest in its own storage (their choice of which to keep is per sample), the
/// others store fragments per pixel with their coverage masks.
pub fn sample_storage(id: MethodId, msaa: u32) -> u32 {
    if id.descriptor().per_sample_storage && msaa > 1 {
        msaa
    } else {
        1
    }
}

/// kplus-semiheap's |H|: `--heap-size`, default 1 (the paper's), at most k.
pub fn heap_size(options: &RenderOptions, k: u32) -> Result<u32> {
    let h = options
        .frame
        .family::<KBufferOptions>()
        .heap_size
        .unwrap_or(1);
    if h == 0 || h > k {
        return Err(Error::input(format!(
            "--heap-size {h} is outside 1..{k} (k)"
        )));
    }
    Ok(h)
}

/// Checks a per-pixel allocation against the budget and the device's binding limit.
pub fn check_memory(
    ctx: &FrameContext<'_>,
    method: &str,
    buffer_bytes: u64,
    total_bytes: u64,
) -> Result<()> {
    ctx.check_budget(total_bytes)?;
    if buffer_bytes > ctx.gpu.max_storage_binding() {
        return Err(Error::unsupported(format!(
            "{method}: needs a {:.1} MiB buffer, {} ({:.1} MiB)",
            buffer_bytes as f64 / 1048576.0,
            crate::error::OVER_BINDING,
            ctx.gpu.max_storage_binding() as f64 / 1048576.0
        )));
    }
    Ok(())
}

/// Group 1's layout, shared by every k-buffer method: parameters, counters, pixels, slots, tail, temporal culling's buffers.
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
            // Temporal culling (temporal.wgsl): parameters, last frame's interface, this one's.
            // The parameters are storage, not a second uniform in this group: lavapipe 22.3
            // crashed running the compute captures with one.
            Slot::Storage,
            Slot::Storage,
            Slot::StorageRw,
            // Moving objects (temporal.wgsl): each triangle's object, their motion.
            Slot::Storage,
            Slot::Storage,
        ],
    )
}

/// The frame's [`KParams`] for `k` and `stride`; `count_by_seen`: a fixed A-buffer's stored count is min(seen, stride).
pub fn params_for(ctx: &FrameContext<'_>, k: u32, stride: u32, count_by_seen: bool) -> KParams {
    let options = ctx.options;
    let tail = tail_settings(options, ctx.scene);
    KParams {
        k,
        stride,
        max_tries: options
            .frame
            .family::<KBufferOptions>()
            .max_tries
            .unwrap_or(DEFAULT_MAX_TRIES)
            .clamp(1, crate::methods::kbuffer::MAX_TRIES_LIMIT),
        culling: options.frame.family::<KBufferOptions>().culling as u32,
        tail_blend: tail.mode,
        aux: count_by_seen as u32,
        width: options.frame.width,
        pixels: (ctx.pixels()).min(u32::MAX as u64) as u32,
        sample_slots: 1,
        tail_weight: tail.weight,
        tail_depth_p: tail.depth_p,
        tail_depth_q: tail.depth_q,
        storage_layout: options.frame.family::<KBufferOptions>().layout.index(),
    }
}

/// The lock failures (or compare-exchange losses) a frame counted.
pub fn lock_failures(words: &[u32]) -> u64 {
    crate::frame::wide(words, COUNTER_LOCK_FAILURES)
}

/// A fragment pool sized from measured need (the linked lists and the S-buffer): it starts at
/// `--abuffer-initial-nodes` or 4 per pixel, grows to the need + 25% after a frame that
/// overflowed, shrinks to it when more than twice too large, and is bounded by `--budget-mb` and
/// the device's largest storage binding.
pub struct Pool {
    /// Items the next frame's pool holds.
    pub capacity: u64,
    item_bytes: u64,
    /// The most items memory allowed when the last frame was recorded, and whether the budget
    /// set that limit.
    limit: (u64, bool),
}

impl Pool {
    const FIRST_GUESS_PER_PIXEL: u64 = 4;
    const MIN_ITEMS: u64 = 1024;

    /// A pool for items of `item_bytes`, first sized by `--initial-nodes` or 4 per pixel.
    pub fn new(options: &RenderOptions, item_bytes: u64) -> Pool {
        Pool {
            capacity: options
                .frame
                .family::<KBufferOptions>()
                .initial_nodes
                .unwrap_or(options.pixels() * Self::FIRST_GUESS_PER_PIXEL)
                .max(1),
            item_bytes,
            limit: (u64::MAX, false),
        }
    }

    /// Fits the capacity to what memory allows besides the frame's `fixed_bytes`, of which
    /// `header_bytes` share the pool's buffer; returns the pool's bytes. An error when not one
    /// item fits.
    pub fn fit(
        &mut self,
        ctx: &FrameContext<'_>,
        id: MethodId,
        fixed_bytes: u64,
        header_bytes: u64,
    ) -> Result<u64> {
        let by_binding =
            ctx.gpu.max_storage_binding().saturating_sub(header_bytes) / self.item_bytes;
        let by_budget = ctx
            .options
            .budget_bytes()
            .map(|b| b.saturating_sub(fixed_bytes) / self.item_bytes)
            .unwrap_or(u64::MAX);
        let max = by_binding.min(by_budget).min(u32::MAX as u64 / 2);
        if max == 0 {
            return Err(Error::input(format!(
                "{id}: --budget-mb {} cannot even hold the {}x{} per-pixel words ({fixed_bytes} bytes)",
                ctx.options.frame.budget_mb.unwrap_or(0.0),
                ctx.options.frame.width,
                ctx.options.frame.height,
            )));
        }
        self.limit = (max, ctx.options.frame.budget_mb.is_some());
        self.capacity = self.capacity.clamp(1, max);
        Ok(self.capacity * self.item_bytes)
    }

    /// Feedback from a frame recorded with `recorded` items that needed `needed`: grows after an
    /// overflow, shrinks a pool more than twice too large, and says when no frame can fit.
    pub fn feedback(
        &mut self,
        id: MethodId,
        needed: u64,
        overflowed: bool,
        recorded: u64,
    ) -> MethodStats {
        let fitted = (needed + needed / 4).max(Self::MIN_ITEMS);
        if overflowed {
            // The limit applies when the next frame is recorded.
            self.capacity = fitted.max(recorded + 1);
        } else if self.capacity > 2 * fitted {
            self.capacity = fitted;
        }
        let (max, by_budget) = self.limit;
        let mib = |items: u64| (items * self.item_bytes) as f64 / 1048576.0;
        MethodStats {
            overflow: Some(overflowed),
            incomplete: overflowed,
            cannot_complete: (needed > max).then(|| crate::frame::Shortfall {
                why: format!(
                    "{id}: the frame has {needed} fragments ({:.1} MiB of pool), {} ({:.1} MiB)",
                    mib(needed),
                    if by_budget {
                        "more than --budget-mb allows"
                    } else {
                        crate::error::OVER_BINDING
                    },
                    mib(max)
                ),
                binding: (!by_budget).then_some((needed, max)),
            }),
            ..Default::default()
        }
    }
}

/// The fragment storage of a k-buffer frame.
pub struct Storage {
    /// The buffer's debug label, also its key in the frame's [`ResourceCache`] (kept between
    /// frames while the size holds).
    pub label: &'static str,
    /// Size in bytes this frame needs; a change re-creates the buffer.
    pub bytes: u64,
    /// Zeroed before capture (cascades and their empty-slot marker need it).
    pub clear: bool,
}

/// A capture stage: the WGSL module (vertex stage, and fragment stage without ordering) and,
/// where the adapter takes it, the fragment stage with acquire/release atomics.
pub struct CaptureModule {
    /// The module with relaxed atomics only, which the capture pipelines use where
    /// [`CaptureModule::ordered`] is None.
    pub wgsl: wgpu::ShaderModule,
    /// The fragment stage with acquire/release atomics, where the adapter has them.
    pub ordered: Option<wgpu::ShaderModule>,
    /// The compute rasterizer's captures get acquire/release atomics (the method orders, the
    /// adapter has them).
    pub ordered_compute: bool,
    /// The stage, which the compute rasterizer composes again with its own entry point.
    pub stage: Stage,
}

/// Whether a method's capture orders memory through a lock or list links (the ordered words of
/// storage.wgsl and list.wgsl): without acquire/release atomics it is unsound.
pub fn orders(id: MethodId) -> bool {
    id.descriptor().orders()
}

/// The methods whose captures need ordered atomics ([`orders`]).
pub fn ordered_methods() -> impl Iterator<Item = MethodId> {
    MethodId::gpu_methods().filter(|&m| orders(m))
}

/// What every k-buffer method records the same way: the group-1 layout, the resolve pipeline,
/// the buffers kept between frames, and a frame — clear, capture passes, resolve, counters.
pub struct KFrame {
    /// The method this frame records, which names its pipelines and labels.
    pub id: MethodId,
    /// Group 1's layout ([`group_layout`]), which the method's capture pipelines are built on.
    pub layout: wgpu::BindGroupLayout,
    resolve: wgpu::ComputePipeline,
    cache: ResourceCache,
    null_target: Option<NullTarget>,
    /// The counters' values at the start of a frame (not per-pixel storage: outside the cache)
    /// and the allocation start they were written for.
    counters_init: wgpu::Buffer,
    counter_start: Option<u32>,
    counters: Option<wgpu::Buffer>,
    memory_ordering: &'static str,
    /// Why this method cannot run on this adapter: its capture needs ordering the adapter lacks.
    unordered: Option<String>,
    temporal: temporal::TemporalState,
    /// With `--temporal on`: the interface this frame writes, whose last words count the culled.
    temporal_interface: Option<wgpu::Buffer>,
}

impl KFrame {
    /// A frame with the family's resolve (resolve.wgsl) over the method's storage `layout`.
    pub fn new(gpu: &Gpu, scene: &SceneGpu, id: MethodId, layout: Layout) -> KFrame {
        Self::with_resolve_defs(gpu, scene, id, layout, &Defs::default())
    }

    /// A frame with the family's resolve made with the method's `defs` (its sort).
    pub fn with_resolve_defs(
        gpu: &Gpu,
        scene: &SceneGpu,
        id: MethodId,
        layout: Layout,
        defs: &Defs,
    ) -> KFrame {
        let stage = stage(gpu, format!("strata.{id}.resolve"), RESOLVE_WGSL, layout)
            .defs(&crate::gpu::shader::target_samples(scene.samples))
            .defs(defs);
        Self::with_resolve(gpu, scene, id, &stage, "cs_resolve")
    }

    /// A frame whose resolve is the entry point `entry` of `resolve`.
    pub fn with_resolve(
        gpu: &Gpu,
        scene: &SceneGpu,
        id: MethodId,
        resolve: &Stage,
        entry: &str,
    ) -> KFrame {
        let layout = group_layout(gpu);
        let label = format!("strata.{id}.resolve");
        let module = resolve.module(&gpu.device);
        let resolve = compute_pipeline(
            gpu,
            &label,
            (&module, entry),
            &[&scene.frame_layout, &layout],
        );
        KFrame {
            id,
            layout,
            resolve,
            cache: ResourceCache::default(),
            null_target: None,
            counters_init: gpu.device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("strata.kbuffer.counters_init"),
                size: COUNTERS * 4,
                usage: wgpu::BufferUsages::COPY_SRC | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            }),
            counter_start: None,
            counters: None,
            memory_ordering: "relaxed",
            unordered: None,
            temporal: temporal::TemporalState::new(gpu),
            temporal_interface: None,
        }
    }

    /// A capture stage of this method over `module`'s fragment entry point, on the scene's
    /// rasterizer.
    pub fn capture_pipeline(
        &self,
        gpu: &Gpu,
        scene: &SceneGpu,
        module: &CaptureModule,
        entry: &str,
    ) -> Result<GeometryStage> {
        let label = format!("strata.{}.{entry}", self.id);
        if module.ordered_compute {
            return Ok(crate::raster::compute_stage(
                gpu,
                scene,
                &format!("{label}.compute"),
                &module.stage,
                entry,
                &[&scene.frame_layout, &self.layout],
                true,
            ));
        }
        crate::raster::storage_stage(
            gpu,
            scene,
            &label,
            &module.stage,
            (
                module.ordered.as_ref().unwrap_or(&module.wgsl),
                module.ordered.is_some(),
            ),
            entry,
            &[&scene.frame_layout, &self.layout],
        )
    }

    /// The capture module of `source` over the method's storage `layout`; with `ordered`, its
    /// fragment stages also get acquire/release atomics where the adapter can
    /// ([`crate::gpu::ordered`]), and so do its compute captures where the method [`orders`].
    pub fn capture_module(
        &mut self,
        gpu: &Gpu,
        scene: &SceneGpu,
        source: &'static str,
        layout: Layout,
        ordered: bool,
    ) -> CaptureModule {
        let stage = stage(gpu, format!("strata.{}.capture", self.id), source, layout)
            .defs(&stages::capture_definitions(scene));
        let compute = scene.raster_layout.is_some();
        // The compute rasterizer composes the stage again with its own entry point, and orders
        // that (`raster::compute_stage`) only for a method that needs it.
        let ordered_compute =
            ordered && compute && orders(self.id) && crate::gpu::ordered::available(gpu);
        let ordered = if ordered && !compute {
            crate::gpu::ordered::module(gpu, &stage)
        } else {
            None
        };
        let is_ordered = ordered.is_some() || ordered_compute;
        let coherent = gpu.has(wgpu::Features::MEMORY_DECORATION_COHERENT);
        let diagnosis = crate::gpu::ordered::relaxed_for_diagnosis();
        self.memory_ordering = match (is_ordered && orders(self.id), coherent) {
            _ if diagnosis && orders(self.id) => {
                "relaxed (STRATA_RELAXED_CAPTURES diagnostic: unsound where fragments of a pixel run at once)"
            }
            (true, true) => {
                "acquire-release on the lock, counts and links (SPIR-V passthrough), coherent storage"
            }
            (true, false) => "acquire-release on the lock, counts and links (SPIR-V passthrough)",
            (false, true) => "relaxed, coherent storage",
            (false, false) => "relaxed",
        };
        // A lock or a link chain without ordering can read stale slots or last frame's links:
        // such a method is refused on this adapter, on either rasterizer.
        self.unordered = (orders(self.id) && !is_ordered && !diagnosis).then(|| {
                format!(
                    "{} takes a per-pixel lock or links lists concurrently, which needs acquire/release atomics (SPIR-V passthrough on Vulkan); '{}' ({}) has none, so its captures could read stale slots; use kb-keys where the adapter has 64-bit atomics, else abuffer-ll, sbuffer or kpeel",
                    self.id,
                    gpu.info.name,
                    gpu.backend_name()
                )
            });
        CaptureModule {
            wgsl: stage.module(&gpu.device),
            ordered,
            ordered_compute,
            stage,
        }
    }

    /// How the capture's atomics are ordered on this adapter.
    pub fn memory_ordering(&self) -> &'static str {
        self.memory_ordering
    }

    /// The buffers kept between frames.
    pub fn resources(&self) -> Vec<&ResourceCache> {
        vec![&self.cache]
    }

    /// Records one frame and asks for the counters; returns the bytes allocated.
    pub fn record(
        &mut self,
        ctx: &mut FrameContext<'_>,
        params: KParams,
        storage: Storage,
        passes: &[(&'static str, &GeometryStage)],
    ) -> Result<u64> {
        let (group, total) = self.begin(ctx, params, storage)?;
        let frame_group = ctx.frame_group;
        let target = ctx.null_target(&mut self.null_target, "strata.kbuffer.null_target");
        for (name, pipeline) in passes {
            storage_geometry_pass(ctx, name, target, pipeline, &[frame_group, &group]);
        }
        self.end(ctx, &group);
        Ok(total)
    }

    /// Allocates and clears the frame's storage; returns the group-1 bind group (which an
    /// application's capture pass may place) and the bytes allocated.
    pub fn begin(
        &mut self,
        ctx: &mut FrameContext<'_>,
        params: KParams,
        storage: Storage,
    ) -> Result<(wgpu::BindGroup, u64)> {
        if let Some(why) = &self.unordered {
            return Err(Error::unsupported(why.clone()));
        }
        let gpu = ctx.gpu;
        let px = ctx.pixels();
        let samples = params.sample_slots.max(1);
        let tail_bytes = tail_bytes(px * samples as u64, params.tail_blend != 0);
        let total = storage.bytes
            + sample_frame_bytes_besides_storage(px, samples, params.tail_blend != 0)
            + temporal::TemporalState::bytes(ctx);
        check_memory(ctx, self.id.as_str(), storage.bytes, total)?;
        // Tests read the per-pixel words and the storage back (the lists against the reference).
        let readable = wgpu::BufferUsages::COPY_SRC;
        let cache = &mut self.cache;
        let params_buffer =
            cache.uniform(gpu, "strata.kbuffer.params", bytemuck::bytes_of(&params));
        let pixels = cache.storage_with(
            gpu,
            "strata.kbuffer.pixels",
            pixel_words_bytes(px, samples),
            readable,
        )?;
        let counters = cache.readable(gpu, "strata.kbuffer.counters", COUNTERS * 4)?;
        let counters_init = &self.counters_init;
        let start = ctx
            .options
            .frame
            .family::<KBufferOptions>()
            .allocation_counter_start;
        if self.counter_start != Some(start) {
            let mut init = [0u32; COUNTERS as usize];
            init[COUNTER_ALLOCATED] = start;
            gpu.queue
                .write_buffer(counters_init, 0, bytemuck::cast_slice(&init));
            self.counter_start = Some(start);
        }
        let tail = cache.storage_with(gpu, "strata.kbuffer.tail", tail_bytes, readable)?;
        let buffer = cache.storage_with(gpu, storage.label, storage.bytes, readable)?;
        let temporal = self.temporal.frame(ctx)?;
        let group = binding::group(
            &gpu.device,
            "strata.kbuffer.group",
            &self.layout,
            &[
                params_buffer.as_entire_binding(),
                buffer.as_entire_binding(),
                pixels.as_entire_binding(),
                counters.as_entire_binding(),
                tail.as_entire_binding(),
                ctx.output.as_entire_binding(),
                temporal.params.as_entire_binding(),
                temporal.previous.as_entire_binding(),
                temporal.current.as_entire_binding(),
                temporal.triangle_objects.as_entire_binding(),
                temporal.to_previous.as_entire_binding(),
            ],
        );
        self.temporal_interface = temporal.on.then_some(temporal.current);
        ctx.encoder.clear_buffer(&pixels, 0, None);
        ctx.encoder.clear_buffer(&tail, 0, None);
        ctx.encoder
            .copy_buffer_to_buffer(counters_init, 0, &counters, 0, COUNTERS * 4);
        if storage.clear {
            ctx.encoder.clear_buffer(&buffer, 0, None);
        }
        self.counters = Some(counters);
        Ok((group, total))
    }

    /// Records the resolve and asks for the counters.
    pub fn end(&mut self, ctx: &mut FrameContext<'_>, group: &wgpu::BindGroup) {
        self.resolve(ctx, group);
        self.read_counters(ctx);
    }

    /// Records the resolve pass.
    pub fn resolve(&self, ctx: &mut FrameContext<'_>, group: &wgpu::BindGroup) {
        let frame_group = ctx.frame_group;
        dispatch_pixels(ctx, "resolve", &self.resolve, &[frame_group, group]);
    }

    /// Asks for the frame's counters.
    pub fn read_counters(&self, ctx: &mut FrameContext<'_>) {
        if let Some(counters) = &self.counters {
            ctx.readback.words(counters, 0, COUNTERS);
        }
        if let Some(interface) = &self.temporal_interface {
            ctx.readback.words(interface, ctx.pixels() * 4, 2);
        }
    }

    /// Clears the per-pixel words again (between the passes of a multi-pass frame).
    pub fn clear_pixels(&self, ctx: &mut FrameContext<'_>) {
        if let Some(pixels) = self.cache.get("strata.kbuffer.pixels") {
            ctx.encoder.clear_buffer(pixels, 0, None);
        }
    }
}

/// Methods over fixed per-pixel slot arrays.
pub struct SlotKBuffer {
    variant: Variant,
    frame: KFrame,
    capture: GeometryStage,
    /// kb-ab-fixed: slots per pixel the next frame starts with (measured need).
    measured_stride: u32,
}

impl SlotKBuffer {
    /// The method `id` of `variant` for `scene`.
    pub fn new(
        gpu: &Gpu,
        scene: &SceneGpu,
        id: MethodId,
        variant: Variant,
    ) -> crate::error::Result<SlotKBuffer> {
        let layout = variant.layout();
        let mut frame = KFrame::with_resolve_defs(gpu, scene, id, layout, &variant.resolve_defs());
        let module = frame.capture_module(gpu, scene, SLOTS_ENTRIES_WGSL, layout, true);
        Ok(SlotKBuffer {
            variant,
            capture: frame.capture_pipeline(gpu, scene, &module, variant.entry())?,
            frame,
            measured_stride: 0,
        })
    }

    /// The frame's k, storage and parameters.
    fn plan(&self, ctx: &FrameContext<'_>) -> Result<(KParams, Storage, Recorded)> {
        let k = k_of(ctx.k, self.frame.id)?;
        // kb-ab-fixed stores every fragment: its array takes the depth complexity the last
        // frame measured (at least k).
        let stride = if self.variant == Variant::KbAbFixed {
            self.measured_stride.max(k)
        } else {
            k
        };
        let sample_slots = sample_storage(self.frame.id, ctx.options.build.msaa);
        let storage = Storage {
            label: "strata.kbuffer.slots",
            bytes: ctx.pixels() * sample_slots as u64 * stride as u64 * SLOT_BYTES,
            clear: false,
        };
        let recorded = Recorded {
            geometry_passes: 1,
            k: Some(k),
            bytes_allocated: 0,
            capacity: stride as u64,
            memory_ordering: Some(self.frame.memory_ordering()),
            temporal: false,
            family: None,
            setup_capacity: 0,
        };
        let mut params = params_for(ctx, k, stride, self.variant.fixed());
        params.sample_slots = sample_slots;
        if self.variant == Variant::KplusSemiheap {
            params.aux = heap_size(ctx.options, k)?;
        }
        let recorded = Recorded {
            temporal: ctx.options.frame.temporal.is_some(),
            ..recorded
        };
        Ok((params, storage, recorded))
    }
}

impl Method for SlotKBuffer {
    one_capture_pass_method!();

    fn stats(&mut self, recorded: &Recorded, totals: &Totals, words: &[u32]) -> MethodStats {
        let over = totals.max_depth as u64 > recorded.capacity;
        let mut stats = MethodStats {
            lock_failures: Some(lock_failures(words)),
            culled_temporal: recorded
                .temporal
                .then(|| words.get(COUNTERS as usize..COUNTERS as usize + 2))
                .flatten()
                .map(temporal::culled),
            ..Default::default()
        };
        match self.variant {
            Variant::AbufferFixed => stats.overflow = Some(over),
            Variant::KbAbFixed => {
                self.measured_stride = totals.max_depth;
                stats.overflow = Some(over);
                stats.incomplete = over;
            }
            _ => {}
        }
        stats
    }

    fn resources(&self) -> Vec<&ResourceCache> {
        self.frame.resources()
    }
}

#[cfg(test)]
pub(crate) mod tests;
