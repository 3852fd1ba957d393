//! k-buffers on per-pixel linked lists (seed 003 Table 1): `kb-ab-ll` (the A-buffer's lists, k
//! nearest selected in resolve) and `kb-ll` (sorted insertion by compare-exchange with bounded
//! retries; losses are counted in `lock_failures` and `fragments_dropped`).
//!
//! Passes: clear; capture (1 geometry pass, +1 when the node pool overflows: the pool is sized
//! from measured need and the frame re-rendered, as `abuffer-ll` does); the shared k resolve.
//! Memory: 20 bytes per node, 16 per pixel of counters and head, 20 per pixel of tail sums with
//! `--tail blend`.

use super::{k_of, params_for, stats_from_counters, KFrame, Storage, RESOLVE_WGSL, STORAGE_WGSL};
use crate::error::{Error, Result};
use crate::gpu::{shader, Gpu};
use crate::methods::{Method, MethodStats};
use crate::render::{FrameContext, SceneGpu};

pub const NODE_BYTES: u64 = 20;
const COUNTER_ALLOCATED: usize = 3;
const COUNTER_LOST: usize = 4;
const FIRST_GUESS_PER_PIXEL: u64 = 4;
const MIN_NODES: u64 = 1024;

const LIST_WGSL: &str = include_str!("list.wgsl");

pub fn capture_source() -> String {
    [STORAGE_WGSL, LIST_WGSL].join("\n")
}

pub fn resolve_source() -> String {
    [
        STORAGE_WGSL,
        LIST_WGSL,
        include_str!("list_resolve.wgsl"),
        RESOLVE_WGSL,
    ]
    .join("\n")
}

pub struct ListKBuffer {
    sorted: bool,
    frame: KFrame,
    capture: wgpu::RenderPipeline,
    capacity: u64,
}

impl ListKBuffer {
    pub fn new(
        gpu: &Gpu,
        scene: &SceneGpu,
        id: &'static str,
        sorted: bool,
        initial_nodes: Option<u64>,
        pixels: u64,
    ) -> ListKBuffer {
        let frame = KFrame::new(gpu, scene, id, &resolve_source());
        let module = shader::module(
            &gpu.device,
            &format!("strata.{id}.capture"),
            &capture_source(),
        );
        let capture = frame.capture_pipeline(
            gpu,
            scene,
            &module,
            if sorted { "fs_sorted_ll" } else { "fs_ab_ll" },
        );
        ListKBuffer {
            sorted,
            frame,
            capture,
            capacity: initial_nodes
                .unwrap_or(pixels * FIRST_GUESS_PER_PIXEL)
                .max(1),
        }
    }
}

impl Method for ListKBuffer {
    fn render(&mut self, ctx: &mut FrameContext<'_>) -> Result<MethodStats> {
        let k = k_of(ctx.options)?;
        let gpu = ctx.gpu;
        let max_nodes = gpu.max_storage_binding() / NODE_BYTES;
        let mut passes = 0;
        let mut overflowed = false;
        loop {
            passes += 1;
            let storage = Storage {
                label: "strata.kbuffer.nodes",
                bytes: self.capacity * NODE_BYTES,
                clear: false,
            };
            let (c, total) = self.frame.run(
                ctx,
                params_for(ctx.options, k, k, false),
                storage,
                &[("capture", &self.capture)],
            )?;
            let needed = c[COUNTER_ALLOCATED] as u64;
            if needed <= self.capacity {
                let fitted = (needed + needed / 4).max(MIN_NODES);
                if self.capacity > 2 * fitted {
                    self.capacity = fitted;
                }
                let mut stats = stats_from_counters(&c, k, passes, total);
                stats.overflow = Some(overflowed);
                if self.sorted {
                    stats.lock_failures = Some(c[COUNTER_LOST] as u64);
                }
                return Ok(stats);
            }
            overflowed = true;
            if needed > max_nodes {
                return Err(Error::unsupported(format!(
                    "{}: the frame needs {needed} nodes ({:.1} MiB), more than the device binds in one buffer",
                    self.frame.id,
                    (needed * NODE_BYTES) as f64 / 1048576.0
                )));
            }
            self.capacity = (needed + needed / 4).min(max_nodes);
        }
    }
}
