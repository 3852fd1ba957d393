//! Per-pixel linked lists in one node pool (Yang et al. 2010), shared by `abuffer-ll` (every
//! fragment composited), `kb-ab-ll` (the k nearest selected in the resolve) and `kb-ll` (sorted
//! insertion by compare-exchange with bounded retries; losses are counted in `lock_failures` and
//! `fragments_dropped`).
//!
//! Passes: clear; capture (1 geometry pass); the shared k resolve. The pool is sized from
//! measured need: a frame whose pool ran out keeps what fit, counts the rest (dropped,
//! `overflow`), grows the pool to the need + 25% for the next frame and reports itself
//! incomplete, so exact mode renders it again (2 geometry passes). A pool more than twice the
//! need shrinks to it (+25%). The pool is bounded by `--budget-mb` and the device's largest
//! storage binding; a frame needing more is an error in exact mode. Memory: 20 bytes per node,
//! 16 per pixel of counters and head, 40 per pixel of tail sums with `--tail blend`.
use super::{
    k_of, lock_failures, params_for, KFrame, KParams, Layout, Pool, Storage, COUNTER_ALLOCATED,
    COUNTER_LOST, COUNTER_OVERFLOWED,
};
use crate::error::Result;
use crate::frame::passes::GeometryStage;
use crate::frame::{wide, FrameContext, MethodStats, Recorded, RenderOptions, SceneGpu, Totals};
use crate::gpu::{Gpu, ResourceCache};
use crate::methods::kbuffer::KBufferOptions;
use crate::methods::{Method, MethodId};

/// Bytes of one list node: a fragment and the next node's index.
pub const NODE_BYTES: u64 = 20;

/// The list methods' capture entry points (list_entries.wgsl).
pub const ENTRIES_WGSL: &str = include_str!("list_entries.wgsl");

/// What a list method keeps and how it links a fragment.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ListKind {
    /// `abuffer-ll`: every fragment pushed at its list's head, all composited (no k).
    Abuffer,
    /// `kb-ab-ll`: every fragment pushed, the k nearest selected in the resolve.
    KNearest,
    /// `kb-ll`: sorted insertion by compare-exchange, culled past the k-th node; losses counted.
    Sorted,
}

impl ListKind {
    /// Its storage layout: per-pixel lists.
    pub fn layout(self) -> Layout {
        Layout::List
    }

    /// The method this kind is.
    pub fn id(self) -> MethodId {
        match self {
            ListKind::Abuffer => MethodId::AbufferLl,
            ListKind::KNearest => MethodId::KbAbLl,
            ListKind::Sorted => MethodId::KbLl,
        }
    }

    /// The capture's fragment entry point (list_entries.wgsl).
    fn entry(self) -> &'static str {
        match self {
            ListKind::Abuffer | ListKind::KNearest => "fs_ab_ll",
            ListKind::Sorted => "fs_sorted_ll",
        }
    }
}

/// The linked-list methods (`abuffer-ll`, `kb-ab-ll`, `kb-ll`): a node pool sized from the last frame's need.
pub struct ListKBuffer {
    id: MethodId,
    kind: ListKind,
    frame: KFrame,
    capture: GeometryStage,
    /// The node pool, sized from measured need.
    pool: Pool,
}

impl ListKBuffer {
    /// The list method `kind` for `scene`.
    pub fn new(
        gpu: &Gpu,
        scene: &SceneGpu,
        kind: ListKind,
        options: &RenderOptions,
    ) -> crate::error::Result<ListKBuffer> {
        let id = kind.id();
        let mut frame = KFrame::new(gpu, scene, id, Layout::List);
        let module = frame.capture_module(gpu, scene, ENTRIES_WGSL, Layout::List, true);
        Ok(ListKBuffer {
            id,
            kind,
            capture: frame.capture_pipeline(gpu, scene, &module, kind.entry())?,
            frame,
            pool: Pool::new(options, NODE_BYTES),
        })
    }
}

impl ListKBuffer {
    /// The frame's k, pool and parameters.
    fn plan(&mut self, ctx: &FrameContext<'_>) -> Result<(KParams, Storage, Recorded)> {
        // abuffer-ll composites every fragment: its k is unbounded.
        let k = if self.kind == ListKind::Abuffer {
            u32::MAX
        } else {
            k_of(ctx.k, self.id)?
        };
        let sample_slots = super::sample_storage(self.id, ctx.options.build.msaa);
        let bytes = self.pool.fit(
            ctx,
            self.id,
            super::sample_frame_bytes_besides_storage(
                ctx.pixels(),
                sample_slots,
                ctx.options.frame.family::<KBufferOptions>().tail.kept(),
            ),
            0,
        )?;
        let storage = Storage {
            label: "strata.kbuffer.nodes",
            bytes,
            clear: false,
        };
        let recorded = Recorded {
            geometry_passes: 1,
            k: (self.kind != ListKind::Abuffer).then_some(k),
            bytes_allocated: 0,
            capacity: self.pool.capacity,
            memory_ordering: Some(self.frame.memory_ordering()),
            temporal: false,
            family: None,
            setup_capacity: 0,
        };
        let params = KParams {
            sample_slots,
            ..params_for(ctx, k, k, false)
        };
        Ok((params, storage, recorded))
    }
}

impl Method for ListKBuffer {
    one_capture_pass_method!();

    fn stats(&mut self, recorded: &Recorded, _: &Totals, words: &[u32]) -> MethodStats {
        let overflowed = wide(words, COUNTER_OVERFLOWED);
        let allocated = (words[COUNTER_ALLOCATED] as u64).min(recorded.capacity);
        let mut stats = self.pool.feedback(
            self.id,
            allocated + overflowed,
            overflowed > 0,
            recorded.capacity,
        );
        if self.kind == ListKind::Sorted {
            stats.lock_failures = Some(wide(words, COUNTER_LOST) + lock_failures(words));
        }
        stats
    }

    fn resources(&self) -> Vec<&ResourceCache> {
        self.frame.resources()
    }
}
