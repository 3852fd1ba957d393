//! A-buffers. `abuffer-ll` (Yang et al. 2010): per-pixel linked lists in one node pool.
//!
//! Passes: clear (heads and the node counter), capture (1 geometry pass: atomic node allocation,
//! atomic head exchange), resolve (compute: sort each list, composite).
//! Memory: 4·W·H bytes of heads + 20 bytes per node; the pool is sized from measured need — the
//! counter keeps counting past the pool, so an overflowing frame is detected, the pool grown to
//! the measured count (+25%), and the frame rendered again: the output is always exact and
//! `overflow` says it happened. The pool is bounded by `--budget-mb` and the device's largest
//! storage binding; a frame needing more is an error, never a silently truncated picture. A pool
//! more than twice the last frame's need shrinks to it (+25%) for the next frame.

use crate::error::{Error, Result};
use crate::gpu::binding::{self, Slot};
use crate::gpu::{readback, shader, Gpu, ResourceCache};
use crate::methods::{
    capture_pipeline, compute_pipeline, storage_geometry_pass, submit_pixels, Method, MethodStats,
    NullTarget,
};
use crate::render::{FrameContext, RenderOptions, SceneGpu};

/// Bytes per node: a 16-byte fragment and a next index.
pub const NODE_BYTES: u64 = 20;
/// Without history or a hint, the first frame assumes this many fragments per pixel.
const FIRST_GUESS_PER_PIXEL: u64 = 4;
/// The pool never shrinks below this many nodes.
const MIN_NODES: u64 = 1024;

pub struct LinkedLists {
    capture_layout: wgpu::BindGroupLayout,
    resolve_layout: wgpu::BindGroupLayout,
    capture: wgpu::RenderPipeline,
    resolve: wgpu::ComputePipeline,
    /// Nodes the next frame starts with.
    capacity: u64,
    pool: Option<wgpu::Buffer>,
    null_target: Option<NullTarget>,
    cache: ResourceCache,
}

impl LinkedLists {
    pub fn new(gpu: &Gpu, scene: &SceneGpu, options: &RenderOptions) -> LinkedLists {
        let device = &gpu.device;
        let capture_layout = binding::layout(
            device,
            "strata.abuffer_ll.capture.layout",
            &[Slot::StorageRw; 3],
        );
        let resolve_layout = binding::layout(
            device,
            "strata.abuffer_ll.resolve.layout",
            &[Slot::StorageRw; 3],
        );
        let module = shader::module(
            device,
            "strata.abuffer_ll.capture",
            include_str!("ll_capture.wgsl"),
        );
        let capture = capture_pipeline(
            gpu,
            "strata.abuffer_ll.capture",
            &module,
            "fs_capture",
            &[&scene.frame_layout, &capture_layout],
            &[NullTarget::target_state()],
            None,
        );
        let module = shader::module(
            device,
            "strata.abuffer_ll.resolve",
            include_str!("ll_resolve.wgsl"),
        );
        let resolve = compute_pipeline(
            gpu,
            "strata.abuffer_ll.resolve",
            &module,
            "cs_resolve",
            &[&scene.frame_layout, &resolve_layout],
        );
        LinkedLists {
            capture_layout,
            resolve_layout,
            capture,
            resolve,
            capacity: options
                .abuffer_initial_nodes
                .unwrap_or(options.pixels() * FIRST_GUESS_PER_PIXEL)
                .max(1),
            pool: None,
            null_target: None,
            cache: ResourceCache::default(),
        }
    }

    /// The most nodes memory allows: the budget (less the heads) and the binding limit.
    fn max_nodes(ctx: &FrameContext<'_>) -> u64 {
        let by_binding = ctx.gpu.max_storage_binding() / NODE_BYTES;
        let by_budget = ctx
            .options
            .budget_bytes()
            .map(|b| b.saturating_sub(ctx.pixels() * 4) / NODE_BYTES)
            .unwrap_or(u64::MAX);
        by_binding.min(by_budget)
    }

    fn pool(&mut self, gpu: &Gpu) -> Result<&wgpu::Buffer> {
        let want = self.capacity * NODE_BYTES;
        if self.pool.as_ref().is_none_or(|p| p.size() != want) {
            self.pool = Some(gpu.storage_buffer(
                "strata.abuffer_ll.nodes",
                want,
                wgpu::BufferUsages::empty(),
            )?);
        }
        Ok(self.pool.as_ref().expect("set above"))
    }
}

impl Method for LinkedLists {
    fn render(&mut self, ctx: &mut FrameContext<'_>) -> Result<MethodStats> {
        let gpu = ctx.gpu;
        let (w, h) = (ctx.options.width, ctx.options.height);
        let max_nodes = Self::max_nodes(ctx);
        if max_nodes == 0 {
            return Err(Error::input(format!(
                "abuffer-ll: --budget-mb {} cannot even hold the {}x{} list heads ({} bytes)",
                ctx.options.budget_mb.unwrap_or(0.0),
                w,
                h,
                ctx.pixels() * 4
            )));
        }
        self.capacity = self.capacity.min(max_nodes);
        NullTarget::ensure(
            &mut self.null_target,
            gpu,
            "strata.abuffer_ll.null_target",
            w,
            h,
        );
        let heads = self.cache.storage(
            gpu,
            "strata.abuffer_ll.heads",
            ctx.pixels() * 4,
            wgpu::BufferUsages::empty(),
        )?;
        let allocated = self.cache.storage(
            gpu,
            "strata.abuffer_ll.allocated",
            4,
            wgpu::BufferUsages::COPY_SRC,
        )?;
        let frame_group = ctx.frame_group;
        let mut overflowed = false;
        let mut passes = 0;
        loop {
            passes += 1;
            let pool = self.pool(gpu)?.clone();
            let capture_group = binding::group(
                &gpu.device,
                "strata.abuffer_ll.capture.group",
                &self.capture_layout,
                &[
                    heads.as_entire_binding(),
                    pool.as_entire_binding(),
                    allocated.as_entire_binding(),
                ],
            );
            let mut enc = gpu.device.create_command_encoder(&Default::default());
            enc.clear_buffer(&heads, 0, None);
            enc.clear_buffer(&allocated, 0, None);
            let null_target = self.null_target.as_ref().expect("ensured above");
            storage_geometry_pass(
                ctx,
                &mut enc,
                "capture",
                null_target,
                &self.capture,
                &[frame_group, &capture_group],
            );
            gpu.queue.submit([enc.finish()]);
            let needed = readback::read_u32s(gpu, &allocated, 1)?[0] as u64;
            if needed <= self.capacity {
                let resolve_group = binding::group(
                    &gpu.device,
                    "strata.abuffer_ll.resolve.group",
                    &self.resolve_layout,
                    &[
                        heads.as_entire_binding(),
                        pool.as_entire_binding(),
                        ctx.output.as_entire_binding(),
                    ],
                );
                submit_pixels(
                    ctx,
                    "resolve",
                    &self.resolve,
                    &[frame_group, &resolve_group],
                );
                let bytes_allocated = ctx.pixels() * 4 + self.capacity * NODE_BYTES + 4;
                // Track the measured need: a pool more than twice what this frame needed shrinks
                // for the next frame (the one just rendered keeps its buffer until then).
                let fitted = (needed + needed / 4).max(MIN_NODES);
                if self.capacity > 2 * fitted {
                    self.capacity = fitted;
                }
                return Ok(MethodStats {
                    geometry_passes: passes,
                    fragments_generated: Some(needed),
                    fragments_stored: Some(needed),
                    fragments_dropped: Some(0),
                    bytes_allocated,
                    overflow: Some(overflowed),
                    ..Default::default()
                });
            }
            overflowed = true;
            if needed > max_nodes {
                return Err(Error::input(format!(
                    "abuffer-ll: the frame has {needed} fragments ({:.1} MiB of nodes), more than {} allows ({:.1} MiB)",
                    (needed * NODE_BYTES) as f64 / 1048576.0,
                    if ctx.options.budget_mb.is_some() { "--budget-mb" } else { "the device's largest storage buffer" },
                    (max_nodes * NODE_BYTES) as f64 / 1048576.0
                )));
            }
            self.capacity = (needed + needed / 4).min(max_nodes);
        }
    }
}
