//! The multi-fragment methods, one folder per family, and the catalogue `strata methods` prints.
//!
//! A [`Method`] renders one frame into the shared output buffer (`vec4(rgb, count)` per pixel)
//! through its own passes. Pipelines are built once when the method is created; per-pixel
//! buffers are (re)allocated when a frame needs more.

pub mod abuffer;
pub mod baseline;
pub mod kbuffer;
pub mod peeling;

use serde::Serialize;

use crate::error::{Error, Result};
use crate::gpu::binding;
use crate::gpu::Gpu;
use crate::render::{FrameContext, RenderOptions, SceneGpu};

/// What a method reports about its frame; the renderer fills in the rest of `FrameStats`.
#[derive(Clone, Debug, Default)]
pub struct MethodStats {
    pub geometry_passes: u32,
    pub k: Option<u32>,
    /// `None`: every composited fragment (the output counts) plus the dropped ones.
    pub fragments_generated: Option<u64>,
    /// `None`: the composited fragments.
    pub fragments_stored: Option<u64>,
    pub fragments_dropped: Option<u64>,
    /// `None`: the largest per-pixel count composited.
    pub max_depth_complexity: Option<u32>,
    pub bytes_allocated: u64,
    pub overflow: Option<bool>,
    pub lock_failures: Option<u64>,
}

pub trait Method {
    fn render(&mut self, ctx: &mut FrameContext<'_>) -> Result<MethodStats>;
}

/// A catalogue entry.
#[derive(Clone, Debug, Serialize)]
pub struct MethodInfo {
    pub id: &'static str,
    pub family: &'static str,
    pub exact: bool,
    /// Geometry passes, N being the scene's depth complexity.
    pub geometry_passes: &'static str,
    /// Bytes the method allocates, W·H pixels, F fragments in the frame.
    pub memory: &'static str,
    pub summary: &'static str,
}

pub fn catalogue() -> Vec<MethodInfo> {
    vec![
        MethodInfo {
            id: "reference",
            family: "reference",
            exact: true,
            geometry_passes: "0 (CPU)",
            memory: "host: 64·F",
            summary: "CPU exact renderer: every fragment, sorted by depth then primitive, composited in f64",
        },
        MethodInfo {
            id: "unsorted",
            family: "baseline",
            exact: false,
            geometry_passes: "1",
            memory: "12·W·H",
            summary: "alpha blending in submission order (no OIT)",
        },
        MethodInfo {
            id: "sorted",
            family: "baseline",
            exact: false,
            geometry_passes: "1",
            memory: "12·W·H + 4·triangles",
            summary: "alpha blending after a back-to-front sort of triangle centroids",
        },
        MethodInfo {
            id: "f2b",
            family: "peeling",
            exact: true,
            geometry_passes: "N+1",
            memory: "52·W·H",
            summary: "front-to-back depth peeling, one layer per geometry pass",
        },
        MethodInfo {
            id: "dual",
            family: "peeling",
            exact: true,
            geometry_passes: "ceil(N/2)+1",
            memory: "120·W·H",
            summary: "dual depth peeling: nearest and farthest layer per pass (fragments at exactly equal depth in one pixel collapse and are counted as dropped)",
        },
        MethodInfo {
            id: "abuffer-ll",
            family: "abuffer",
            exact: true,
            geometry_passes: "1 (+1 when the node pool overflows)",
            memory: "4·W·H + 20·nodes + 4 (nodes ≥ F)",
            summary: "A-buffer of per-pixel linked lists; overflow is detected, the pool grown and the frame re-rendered",
        },
        MethodInfo {
            id: "abuffer-fixed",
            family: "abuffer",
            exact: false,
            geometry_passes: "1",
            memory: KB_MEMORY,
            summary: "A-buffer of fixed per-pixel arrays of k slots (FABS); fragments past k are counted as dropped",
        },
        MethodInfo {
            id: "kb",
            family: "kbuffer",
            exact: false,
            geometry_passes: "1",
            memory: KB_MEMORY,
            summary: "original k-buffer: sorted insertion with no lock (read-modify-write hazards between fragments of a pixel)",
        },
        MethodInfo {
            id: "kb-ps",
            family: "kbuffer",
            exact: true,
            geometry_passes: "1",
            memory: KB_MEMORY,
            summary: "k-buffer with sorted insertion inside a per-pixel spin lock (pixel synchronisation emulated)",
        },
        MethodInfo {
            id: "kb-ab-fixed",
            family: "kbuffer",
            exact: true,
            geometry_passes: "1 (+1 when the array overflows)",
            memory: "16·(n+1)·W·H + 64 + 20·(W·H with --tail blend, else 1); n: max depth complexity",
            summary: "every fragment in fixed arrays sized from measured need, the k nearest selected in resolve",
        },
        MethodInfo {
            id: "kplus-array",
            family: "kplus",
            exact: true,
            geometry_passes: "1",
            memory: KB_MEMORY,
            summary: "k+-buffer max-array: k nearest captured unsorted under a spin lock, max in slot 0, culling",
        },
        MethodInfo {
            id: "kplus-array-r",
            family: "kplus",
            exact: true,
            geometry_passes: "1",
            memory: KB_MEMORY,
            summary: "k+-buffer revised max-array: the first k fragments stored without the lock",
        },
        MethodInfo {
            id: "kplus-heap",
            family: "kplus",
            exact: true,
            geometry_passes: "1",
            memory: KB_MEMORY,
            summary: "k+-buffer max-heap: sift-up while filling, replace-root and sift-down when full, culling",
        },
        MethodInfo {
            id: "kb-mdt32",
            family: "kbuffer",
            exact: true,
            geometry_passes: "2",
            memory: "20·k·W·H + 16·W·H + 64 + 20·(W·H with --tail blend, else 1)",
            summary: "multi-depth test: atomicMax cascade of depth keys, colors fetched in a second geometry pass (ties beyond k share keys)",
        },
        MethodInfo {
            id: "kb-mdt64",
            family: "kbuffer",
            exact: false,
            geometry_passes: "1",
            memory: "8·k·W·H + 16·W·H + 64 + 20·(W·H with --tail blend, else 1)",
            summary: "multi-depth test on 64-bit keys: depth and 8-bit sRGB color in one cascade (SHADER_INT64_ATOMIC_ALL_OPS)",
        },
        MethodInfo {
            id: "kb-mdt-pack",
            family: "kbuffer",
            exact: false,
            geometry_passes: "1",
            memory: "8·k·W·H + 16·W·H + 84",
            summary: "multi-depth test packing: 20 depth bits + 12 color bits in two 32-bit cascades (seed 002)",
        },
        MethodInfo {
            id: "kb-ab-ll",
            family: "kbuffer",
            exact: true,
            geometry_passes: "1 (+1 when the node pool overflows)",
            memory: "20·nodes + 16·W·H + 64 + 20·(W·H with --tail blend, else 1); nodes ≥ F",
            summary: "A-buffer linked lists, the k nearest selected in resolve",
        },
        MethodInfo {
            id: "kb-ll",
            family: "kbuffer",
            exact: false,
            geometry_passes: "1 (+1 when the node pool overflows)",
            memory: "20·nodes + 16·W·H + 64 + 20·(W·H with --tail blend, else 1); nodes ≤ F",
            summary: "sorted linked-list insertion by compare-exchange, bounded retries, losses counted",
        },
    ]
}

/// Memory of the k-slot methods; `kbuffer::SLOT_BYTES` etc. keep it true.
const KB_MEMORY: &str = "16·(k+1)·W·H + 64 + 20·(W·H with --tail blend, else 1)";

pub fn info(id: &str) -> Option<MethodInfo> {
    catalogue().into_iter().find(|m| m.id == id)
}

pub fn unknown_method(id: &str) -> Error {
    let ids: Vec<_> = catalogue().iter().map(|m| m.id).collect();
    Error::input(format!(
        "unknown method '{id}' (available: {})",
        ids.join(", ")
    ))
}

/// Creates a GPU method by id.
pub fn create(
    id: &str,
    gpu: &Gpu,
    scene: &SceneGpu,
    options: &RenderOptions,
) -> Result<Box<dyn Method>> {
    Ok(match id {
        "unsorted" => Box::new(baseline::Blend::new(gpu, scene, false)),
        "sorted" => Box::new(baseline::Blend::new(gpu, scene, true)),
        "f2b" => Box::new(peeling::FrontToBack::new(gpu, scene)),
        "dual" => Box::new(peeling::Dual::new(gpu, scene)),
        "abuffer-ll" => Box::new(abuffer::LinkedLists::new(gpu, scene, options)),
        "kb-ab-ll" | "kb-ll" => {
            let info = info(id).expect("catalogued");
            Box::new(kbuffer::list::ListKBuffer::new(
                gpu,
                scene,
                info.id,
                id == "kb-ll",
                options.abuffer_initial_nodes,
                options.pixels(),
            ))
        }
        id if kbuffer::mdt::Mdt::from_id(id).is_some() => {
            let info = info(id).expect("catalogued");
            Box::new(kbuffer::mdt::MdtKBuffer::new(
                gpu,
                scene,
                info.id,
                kbuffer::mdt::Mdt::from_id(id).expect("checked"),
            )?)
        }
        id if kbuffer::Variant::from_id(id).is_some() => {
            let info = info(id).expect("catalogued");
            Box::new(kbuffer::SlotKBuffer::new(
                gpu,
                scene,
                info.id,
                kbuffer::Variant::from_id(id).expect("checked"),
            ))
        }
        "reference" => {
            return Err(Error::input(
                "method 'reference' runs on the CPU: use strata::reference::render",
            ))
        }
        _ => return Err(unknown_method(id)),
    })
}

/// A render pipeline drawing the scene with `vs_scene` and the stage's fragment entry point,
/// with no culling (every surface layer counts).
pub fn capture_pipeline(
    gpu: &Gpu,
    label: &str,
    module: &wgpu::ShaderModule,
    fragment_entry: &str,
    layouts: &[&wgpu::BindGroupLayout],
    targets: &[Option<wgpu::ColorTargetState>],
    depth: Option<wgpu::DepthStencilState>,
) -> wgpu::RenderPipeline {
    let layout = binding::pipeline_layout(&gpu.device, label, layouts);
    gpu.device
        .create_render_pipeline(&wgpu::RenderPipelineDescriptor {
            label: Some(label),
            layout: Some(&layout),
            vertex: wgpu::VertexState {
                module,
                entry_point: Some("vs_scene"),
                compilation_options: Default::default(),
                buffers: &[],
            },
            primitive: wgpu::PrimitiveState {
                cull_mode: None,
                ..Default::default()
            },
            depth_stencil: depth,
            multisample: Default::default(),
            fragment: Some(wgpu::FragmentState {
                module,
                entry_point: Some(fragment_entry),
                compilation_options: Default::default(),
                targets,
            }),
            multiview_mask: None,
            cache: None,
        })
}

pub fn compute_pipeline(
    gpu: &Gpu,
    label: &str,
    module: &wgpu::ShaderModule,
    entry: &str,
    layouts: &[&wgpu::BindGroupLayout],
) -> wgpu::ComputePipeline {
    let layout = binding::pipeline_layout(&gpu.device, label, layouts);
    gpu.device
        .create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
            label: Some(label),
            layout: Some(&layout),
            module,
            entry_point: Some(entry),
            compilation_options: Default::default(),
            cache: None,
        })
}

/// A color attachment the pass clears to `clear` and keeps.
pub fn attachment(
    view: &wgpu::TextureView,
    clear: wgpu::Color,
) -> Option<wgpu::RenderPassColorAttachment<'_>> {
    Some(wgpu::RenderPassColorAttachment {
        view,
        depth_slice: None,
        resolve_target: None,
        ops: wgpu::Operations {
            load: wgpu::LoadOp::Clear(clear),
            store: wgpu::StoreOp::Store,
        },
    })
}

/// Runs a compute pipeline over every pixel (8×8 workgroups) in its own timed pass.
pub fn dispatch_pixels(
    ctx: &mut FrameContext<'_>,
    enc: &mut wgpu::CommandEncoder,
    name: &'static str,
    pipeline: &wgpu::ComputePipeline,
    groups: &[&wgpu::BindGroup],
) {
    let (x, y) = ctx.pixel_workgroups();
    let mut pass = enc.begin_compute_pass(&wgpu::ComputePassDescriptor {
        label: Some(name),
        timestamp_writes: ctx.timer.compute_pass(name),
    });
    pass.set_pipeline(pipeline);
    for (i, g) in groups.iter().enumerate() {
        pass.set_bind_group(i as u32, Some(*g), &[]);
    }
    pass.dispatch_workgroups(x, y, 1);
}

/// Records and submits one timed compute pass over every pixel.
pub fn submit_pixels(
    ctx: &mut FrameContext<'_>,
    name: &'static str,
    pipeline: &wgpu::ComputePipeline,
    groups: &[&wgpu::BindGroup],
) {
    let mut enc = ctx.gpu.device.create_command_encoder(&Default::default());
    dispatch_pixels(ctx, &mut enc, name, pipeline, groups);
    ctx.gpu.queue.submit([enc.finish()]);
}

/// Records a timed geometry pass drawing into storage buffers only (over a [`NullTarget`]).
pub fn storage_geometry_pass(
    ctx: &mut FrameContext<'_>,
    enc: &mut wgpu::CommandEncoder,
    name: &'static str,
    target: &NullTarget,
    pipeline: &wgpu::RenderPipeline,
    groups: &[&wgpu::BindGroup],
) {
    let mut pass = enc.begin_render_pass(&wgpu::RenderPassDescriptor {
        label: Some(name),
        color_attachments: &[target.attachment()],
        depth_stencil_attachment: None,
        timestamp_writes: ctx.timer.render_pass(name),
        occlusion_query_set: None,
        multiview_mask: None,
    });
    pass.set_pipeline(pipeline);
    for (i, g) in groups.iter().enumerate() {
        pass.set_bind_group(i as u32, Some(*g), &[]);
    }
    ctx.draw_geometry(&mut pass);
}

/// A render pass over a throwaway color target, for capture passes whose output goes to
/// storage buffers (WebGPU needs at least one attachment).
pub struct NullTarget {
    view: wgpu::TextureView,
    size: (u32, u32),
}

impl NullTarget {
    pub const FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::R8Unorm;

    pub fn new(gpu: &Gpu, label: &str, width: u32, height: u32) -> NullTarget {
        let t = gpu.texture_2d(
            label,
            (width, height),
            Self::FORMAT,
            wgpu::TextureUsages::RENDER_ATTACHMENT,
        );
        NullTarget {
            view: t.create_view(&Default::default()),
            size: (width, height),
        }
    }

    /// The target in `slot`, (re)created when the frame size changed.
    pub fn ensure<'s>(
        slot: &'s mut Option<NullTarget>,
        gpu: &Gpu,
        label: &str,
        width: u32,
        height: u32,
    ) -> &'s NullTarget {
        if slot.as_ref().is_none_or(|t| t.size != (width, height)) {
            *slot = Some(NullTarget::new(gpu, label, width, height));
        }
        slot.as_ref().expect("set above")
    }

    pub fn target_state() -> Option<wgpu::ColorTargetState> {
        Some(wgpu::ColorTargetState {
            format: Self::FORMAT,
            blend: None,
            write_mask: wgpu::ColorWrites::empty(),
        })
    }

    pub fn attachment(&self) -> Option<wgpu::RenderPassColorAttachment<'_>> {
        Some(wgpu::RenderPassColorAttachment {
            view: &self.view,
            depth_slice: None,
            resolve_target: None,
            ops: wgpu::Operations {
                load: wgpu::LoadOp::Clear(wgpu::Color::TRANSPARENT),
                store: wgpu::StoreOp::Discard,
            },
        })
    }
}

#[cfg(test)]
mod tests;
