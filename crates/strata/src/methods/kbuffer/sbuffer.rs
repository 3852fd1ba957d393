//! The S-buffer (seed 003 §4): per-pixel regions of one shared pool, sized by a count pass and a
//! GPU prefix sum. `sbuffer` stores and composites every fragment (exact); `kb-sbuffer` stores
//! every fragment and selects the k nearest in the resolve; `kplus-sbuffer`, the memory-aware
//! k+-buffer (§4.1), gives each pixel exactly min(f, k) slots and keeps its k nearest there (both
//! exact, equal to `reference --k N`).
//!
//! Passes: clear; *count* (geometry pass: per-pixel counts); *scan* (compute: exclusive prefix
//! sum of the region sizes over the pixels in levels of 256 — gather, scan each level's blocks,
//! add the blocks' offsets back down, scatter to the pixels' region starts); *store* (geometry
//! pass: `sbuffer`/`kb-sbuffer` put each fragment at its region start + an atomic fill count;
//! `kplus-sbuffer` appends without a lock in pixels with f ≤ k and keeps the k nearest of deeper
//! pixels under the k+-buffer's spin lock, in a max-array for k ≤ 16 and a max-heap above); the
//! shared k resolve.
//! Memory: 16 bytes per pooled fragment (no per-pixel slack: pixels without fragments take
//! none), 16 per pixel of counters and region start (`kplus-sbuffer`: 20, its starts beside the
//! lock), 4·(W·H + W·H/256 + …) of scan levels, 156 of parameters and counters. Real-time frames
//! size the pool from the previous frame's need plus a quarter (the need is Σ region sizes, read
//! back with the counters); a frame whose regions do not fit keeps those that do, counts the rest
//! as overflowed (dropped), reports `overflow` and grows the pool for the next frame; exact mode
//! renders again (2 + 2 geometry passes). Frames over the memory limits (`--budget-mb`, the largest
//! storage binding) are an error in exact mode. Prefix sums saturate rather than wrap.
//! With `--msaa S` `kplus-sbuffer` counts, sizes and fills a region per sample pixel (the scan
//! runs over S·W·H entries): each sample's min(f, k) slots hold its own k nearest; `sbuffer` and
//! `kb-sbuffer` keep one region per pixel whose fragments carry their coverage masks.

use crate::gpu::twin::{gpu_struct, wgsl_module};
use crate::methods::kbuffer::KBufferOptions;

use super::{k_of, params_for, KFrame, Layout, Pool, Storage, COUNTERS, COUNTER_OVERFLOWED};
use crate::error::Result;
use crate::frame::passes::{
    compute_pipeline, dispatch, storage_geometry_pass, GeometryStage, NullTarget,
};
use crate::frame::{wide, FrameContext, MethodStats, Recorded, RenderOptions, SceneGpu, Totals};
use crate::gpu::binding::{self, Slot};
use crate::gpu::{Gpu, ResourceCache};
use crate::methods::{Method, MethodId};

/// Bytes per pooled fragment.
pub const FRAGMENT_BYTES: u64 = 16;
const SCAN_BLOCK: u64 = 256;
const MAX_GROUPS_X: u64 = 65535;

const SBUFFER_WGSL: &str = include_str!("sbuffer.wgsl");
/// The prefix sum's stages.
pub const SCAN_WGSL: &str = include_str!("sbuffer_scan.wgsl");

gpu_struct! {
    /// One level of the prefix sum (`strata::kbuffer::scan_level`).
    #[derive(PartialEq, Eq)]
    pub struct ScanLevel {
        /// Where this level's values start in the scan buffer.
        pub offset: u32,
        /// How many values the level has.
        pub len: u32,
        /// Where its block totals (the next level) start.
        pub sums: u32,
        /// Workgroups along x of a dispatch (dispatches wider than 65535 groups wrap into y).
        pub groups_x: u32,
    }
}

/// The WGSL declaration of [`ScanLevel`].
pub(crate) const SCAN_LEVEL_WGSL: &str = wgsl_module!("strata::kbuffer::scan_level", ScanLevel);

impl ScanLevel {
    fn groups(&self) -> (u32, u32) {
        let groups = (self.len as u64).div_ceil(SCAN_BLOCK).max(1);
        (self.groups_x, groups.div_ceil(self.groups_x as u64) as u32)
    }
}

/// The levels of a prefix sum over `n` values and the scan buffer's length in words: level 0
/// holds the values, each next level its blocks' totals, up to a level of one block.
pub fn scan_levels(n: u64) -> (Vec<ScanLevel>, u64) {
    let mut levels = Vec::new();
    let (mut offset, mut len) = (0u64, n.max(1));
    loop {
        let groups = len.div_ceil(SCAN_BLOCK);
        levels.push(ScanLevel {
            offset: offset as u32,
            len: len as u32,
            sums: (offset + len) as u32,
            groups_x: groups.min(MAX_GROUPS_X) as u32,
        });
        if groups == 1 {
            return (levels, offset + len + 1);
        }
        offset += len;
        len = groups;
    }
}

/// What an S-buffer method keeps in each pixel's region.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum RegionKind {
    /// `sbuffer`: every fragment, all composited (no k).
    Abuffer,
    /// `kb-sbuffer`: every fragment, the k nearest selected in the resolve.
    KNearest,
    /// `kplus-sbuffer`: min(f, k) slots a pixel, a k+-buffer in them.
    Kplus,
}

impl RegionKind {
    /// The method this kind is.
    pub fn id(self) -> MethodId {
        match self {
            RegionKind::Abuffer => MethodId::Sbuffer,
            RegionKind::KNearest => MethodId::KbSbuffer,
            RegionKind::Kplus => MethodId::KplusSbuffer,
        }
    }

    /// The storage layout: S-buffer regions of pooled fragments, or k+-buffer slots in
    /// regions.
    pub fn layout(self) -> Layout {
        match self {
            RegionKind::Kplus => Layout::KplusSbuffer,
            RegionKind::Abuffer | RegionKind::KNearest => Layout::Sbuffer,
        }
    }

    /// The capture stage's source (its count and store entry points).
    pub fn capture_source(self) -> &'static str {
        match self {
            RegionKind::Kplus => include_str!("kplus_sbuffer_entries.wgsl"),
            RegionKind::Abuffer | RegionKind::KNearest => SBUFFER_WGSL,
        }
    }
}

/// A prefix sum's levels for one frame size: each level's parameters and bind group, and the
/// scan buffer's length in words.
struct ScanPlan {
    pixels: u64,
    levels: Vec<(ScanLevel, wgpu::BindGroup)>,
    words: u64,
    buffer: wgpu::Buffer,
}

/// The S-buffer methods (`sbuffer`, `kb-sbuffer`, `kplus-sbuffer`): count, prefix sum, store, resolve.
pub struct SBuffer {
    id: MethodId,
    kind: RegionKind,
    frame: KFrame,
    count: GeometryStage,
    store: GeometryStage,
    gather: wgpu::ComputePipeline,
    scan_blocks: wgpu::ComputePipeline,
    add_block_offsets: wgpu::ComputePipeline,
    scatter: wgpu::ComputePipeline,
    scan_layout: wgpu::BindGroupLayout,
    /// The scan's levels for the frame size they were made for.
    scan: Option<ScanPlan>,
    /// The fragment pool, sized from measured need.
    pool: Pool,
    /// kplus-sbuffer: the k of the last frame whose need came back, and that need.
    need_at_k: Option<(u32, u64)>,
    null_target: Option<NullTarget>,
    cache: ResourceCache,
}

impl SBuffer {
    /// The S-buffer method `kind` for `scene`.
    pub fn new(
        gpu: &Gpu,
        scene: &SceneGpu,
        kind: RegionKind,
        options: &RenderOptions,
    ) -> crate::error::Result<SBuffer> {
        let (id, layout) = (kind.id(), kind.layout());
        let kplus = kind == RegionKind::Kplus;
        let mut frame = KFrame::new(gpu, scene, id, layout);
        // The k+-buffer's spin lock wants acquire/release ordering where the adapter has it.
        let module = frame.capture_module(gpu, scene, kind.capture_source(), layout, kplus);
        let scan =
            super::stage(gpu, format!("strata.{id}.scan"), SCAN_WGSL, layout).module(&gpu.device);
        let (count, store) = if kplus {
            ("fs_kplus_sbuffer_count", "fs_kplus_sbuffer_store")
        } else {
            ("fs_sbuffer_count", "fs_sbuffer_store")
        };
        let scan_layout = binding::layout(
            &gpu.device,
            "strata.sbuffer.scan.layout",
            &[Slot::Uniform, Slot::StorageRw],
        );
        let layouts = [&scene.frame_layout, &frame.layout, &scan_layout];
        let compute = |entry: &str| {
            compute_pipeline(
                gpu,
                &format!("strata.{id}.{entry}"),
                (&scan, entry),
                &layouts,
            )
        };
        Ok(SBuffer {
            id,
            kind,
            count: frame.capture_pipeline(gpu, scene, &module, count)?,
            store: frame.capture_pipeline(gpu, scene, &module, store)?,
            gather: compute("cs_gather"),
            scan_blocks: compute("cs_scan_blocks"),
            add_block_offsets: compute("cs_add_block_offsets"),
            scatter: compute("cs_scatter"),
            frame,
            scan_layout,
            scan: None,
            pool: Pool::new(options, FRAGMENT_BYTES),
            need_at_k: None,
            null_target: None,
            cache: ResourceCache::default(),
        })
    }

    /// The scan's levels for this frame size: uniforms and bind groups, made once per size.
    fn scan_levels(&mut self, gpu: &Gpu, pixels: u64) -> Result<(Vec<ScanLevel>, u64)> {
        if self.scan.as_ref().is_none_or(|s| s.pixels != pixels) {
            let (levels, words) = scan_levels(pixels);
            let buffer = self.cache.readable(gpu, "strata.sbuffer.scan", words * 4)?;
            let groups = levels
                .iter()
                .map(|level| {
                    let uniform = gpu.device.create_buffer(&wgpu::BufferDescriptor {
                        label: Some("strata.sbuffer.scan.level"),
                        size: std::mem::size_of::<ScanLevel>() as u64,
                        usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
                        mapped_at_creation: false,
                    });
                    gpu.queue
                        .write_buffer(&uniform, 0, bytemuck::bytes_of(level));
                    let group = binding::group(
                        &gpu.device,
                        "strata.sbuffer.scan.group",
                        &self.scan_layout,
                        &[uniform.as_entire_binding(), buffer.as_entire_binding()],
                    );
                    (*level, group)
                })
                .collect();
            self.scan = Some(ScanPlan {
                pixels,
                levels: groups,
                words,
                buffer,
            });
        }
        let plan = self.scan.as_ref().expect("made above");
        Ok((plan.levels.iter().map(|g| g.0).collect(), plan.words))
    }
}

impl Method for SBuffer {
    fn record(&mut self, ctx: &mut FrameContext<'_>) -> Result<Recorded> {
        // sbuffer composites every fragment: its k is unbounded.
        let k = if self.kind == RegionKind::Abuffer {
            u32::MAX
        } else {
            k_of(ctx.k, self.id)?
        };
        let gpu = ctx.gpu;
        let pixels = ctx.pixels();
        // --msaa: kplus-sbuffer gives each sample pixel its own region.
        let sample_slots = super::sample_storage(self.id, ctx.options.build.msaa);
        let regions = pixels * sample_slots as u64;
        let (levels, scan_words) = self.scan_levels(gpu, regions)?;
        // kplus-sbuffer's region starts share the pool's buffer.
        let header = if self.kind == RegionKind::Kplus {
            regions * 4
        } else {
            0
        };
        let fixed = super::sample_frame_bytes_besides_storage(
            pixels,
            sample_slots,
            ctx.options.frame.family::<KBufferOptions>().tail.kept(),
        ) + header
            + scan_words * 4;
        // A larger k than the need was measured at (--k auto following the scene) needs at most
        // k/k₀ times the slots, since min(f, k) ≤ (k/k₀)·min(f, k₀): grow to that bound rather
        // than overflow a frame.
        if let Some((k0, need)) = self.need_at_k.filter(|&(k0, _)| k > k0) {
            let bound = need.saturating_mul(k as u64).div_ceil(k0 as u64);
            self.pool.capacity = self.pool.capacity.max(bound + bound / 4);
        }
        let pool_bytes = self.pool.fit(ctx, self.id, fixed, header)?;
        let storage = Storage {
            label: "strata.sbuffer.pool",
            bytes: header + pool_bytes,
            clear: false,
        };
        let params = super::KParams {
            sample_slots,
            ..params_for(ctx, k, k, false)
        };
        let (group, bytes) = self.frame.begin(ctx, params, storage)?;
        let target = ctx.null_target(&mut self.null_target, "strata.sbuffer.null_target");
        let frame_group = ctx.frame_group;
        storage_geometry_pass(ctx, "count", target, &self.count, &[frame_group, &group]);
        let scan = &self.scan.as_ref().expect("made by scan_levels").levels;
        let bind = |i: usize| [frame_group, &group, &scan[i].1];
        let top = levels.len() - 1;
        dispatch(ctx, "scan", &self.gather, &bind(0), levels[0].groups());
        for (i, level) in levels.iter().enumerate() {
            dispatch(ctx, "scan", &self.scan_blocks, &bind(i), level.groups());
        }
        for i in (0..top).rev() {
            dispatch(
                ctx,
                "scan",
                &self.add_block_offsets,
                &bind(i),
                levels[i].groups(),
            );
        }
        dispatch(ctx, "scan", &self.scatter, &bind(0), levels[0].groups());
        storage_geometry_pass(ctx, "store", target, &self.store, &[frame_group, &group]);
        self.frame.end(ctx, &group);
        // The scan's total, Σ region sizes: the pool the frame needed.
        let scan = self.scan.as_ref().expect("made by scan_levels");
        ctx.readback.words(&scan.buffer, (scan_words - 1) * 4, 1);
        Ok(Recorded {
            geometry_passes: 2,
            k: (self.kind != RegionKind::Abuffer).then_some(k),
            bytes_allocated: bytes + scan_words * 4,
            capacity: self.pool.capacity,
            memory_ordering: Some(self.frame.memory_ordering()),
            temporal: false,
            family: None,
            setup_capacity: 0,
        })
    }

    fn stats(&mut self, recorded: &Recorded, totals: &Totals, words: &[u32]) -> MethodStats {
        // A saturated total (2³² − 1 or more slots) needs more than any pool holds.
        let needed = match words.get(COUNTERS as usize) {
            Some(&u32::MAX) | None => totals.generated.max(u32::MAX as u64),
            Some(&total) => total as u64,
        };
        let overflowed = wide(words, COUNTER_OVERFLOWED) > 0 || needed > recorded.capacity;
        let mut stats = self
            .pool
            .feedback(self.id, needed, overflowed, recorded.capacity);
        if self.kind == RegionKind::Kplus {
            self.need_at_k = recorded.k.map(|k| (k, needed));
            stats.lock_failures = Some(super::lock_failures(words));
        }
        stats
    }

    fn resources(&self) -> Vec<&ResourceCache> {
        let mut r = self.frame.resources();
        r.push(&self.cache);
        r
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn scan_level_layout_matches_wgsl() {
        crate::gpu::twin::assert_twin::<ScanLevel>();
    }

    /// Levels shrink by 256 to one block; the buffer holds every level and the top's total.
    #[test]
    fn scan_levels_cover_every_size() {
        let (levels, words) = scan_levels(1);
        assert_eq!(levels.len(), 1);
        assert_eq!(words, 2);
        let n = 1u64 << 24; // 4096²
        let (levels, words) = scan_levels(n);
        let lens: Vec<u32> = levels.iter().map(|l| l.len).collect();
        assert_eq!(lens, [1 << 24, 1 << 16, 1 << 8]);
        assert_eq!(levels[0].groups(), (65535, 2));
        assert_eq!(levels[1].offset, 1 << 24);
        assert_eq!(words, (1 << 24) + (1 << 16) + (1 << 8) + 1);
        for pair in levels.windows(2) {
            assert_eq!(pair[0].sums, pair[1].offset);
        }
    }
}
