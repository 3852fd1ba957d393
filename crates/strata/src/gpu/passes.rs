//! Pipeline builders that need no frame: compute and full-screen pipelines, color attachments,
//! and the throwaway color target a storage-only pass needs. The passes of a frame (capture
//! pipelines over the scene, geometry passes, timed dispatches) are in `crate::frame::passes`.

use crate::gpu::{binding, Gpu};

/// A pipeline drawing the vertex stage `vertex` (module and entry point; no vertex buffers) and
/// the fragment stage `fragment` into `targets`.
#[allow(clippy::too_many_arguments)]
pub fn screen_pipeline(
    gpu: &Gpu,
    label: &str,
    (vertex_module, vertex_entry): (&wgpu::ShaderModule, &str),
    fragment: (&wgpu::ShaderModule, &str),
    layouts: &[&wgpu::BindGroupLayout],
    targets: &[Option<wgpu::ColorTargetState>],
    cull_mode: Option<wgpu::Face>,
    depth: Option<wgpu::DepthStencilState>,
) -> wgpu::RenderPipeline {
    let vertex = wgpu::VertexState {
        module: vertex_module,
        entry_point: Some(vertex_entry),
        compilation_options: Default::default(),
        buffers: &[],
    };
    let raster = Rasterization {
        cull_mode,
        depth,
        samples: 1,
    };
    render_pipeline(gpu, label, vertex, fragment, layouts, targets, raster)
}

/// How a render pipeline rasterizes: which faces it culls, its depth test and its samples per
/// pixel.
pub struct Rasterization {
    /// The faces culled (`None`: every surface layer counts).
    pub cull_mode: Option<wgpu::Face>,
    /// The depth test and write, if any.
    pub depth: Option<wgpu::DepthStencilState>,
    /// Samples per pixel (the targets must have as many).
    pub samples: u32,
}

/// A triangle-list pipeline of `vertex` and the fragment stage `(module, entry)` into `targets`:
/// what every render pipeline of strata has in common.
pub fn render_pipeline(
    gpu: &Gpu,
    label: &str,
    vertex: wgpu::VertexState<'_>,
    (fragment_module, fragment_entry): (&wgpu::ShaderModule, &str),
    layouts: &[&wgpu::BindGroupLayout],
    targets: &[Option<wgpu::ColorTargetState>],
    raster: Rasterization,
) -> wgpu::RenderPipeline {
    let layout = binding::pipeline_layout(&gpu.device, label, layouts);
    gpu.device
        .create_render_pipeline(&wgpu::RenderPipelineDescriptor {
            label: Some(label),
            layout: Some(&layout),
            vertex,
            primitive: wgpu::PrimitiveState {
                cull_mode: raster.cull_mode,
                ..Default::default()
            },
            depth_stencil: raster.depth,
            multisample: wgpu::MultisampleState {
                count: raster.samples,
                ..Default::default()
            },
            fragment: Some(wgpu::FragmentState {
                module: fragment_module,
                entry_point: Some(fragment_entry),
                compilation_options: Default::default(),
                targets,
            }),
            multiview_mask: None,
            cache: None,
        })
}

/// A compute pipeline of the entry point `(module, entry)` over bind groups of `layouts`.
pub fn compute_pipeline(
    gpu: &Gpu,
    label: &str,
    (module, entry): (&wgpu::ShaderModule, &str),
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

/// The compute pipelines of `module`'s `entries` over bind groups of `layouts`, each labelled
/// `family.name`, its entry point without the `cs_` (`strata.dual` and `cs_init`:
/// `strata.dual.init`).
pub fn compute_pipelines<const N: usize>(
    gpu: &Gpu,
    family: &str,
    module: &wgpu::ShaderModule,
    entries: [&str; N],
    layouts: &[&wgpu::BindGroupLayout],
) -> [wgpu::ComputePipeline; N] {
    entries.map(|entry| {
        let name = entry.strip_prefix("cs_").unwrap_or(entry);
        compute_pipeline(gpu, &format!("{family}.{name}"), (module, entry), layouts)
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

/// Records one full-screen triangle (a pipeline whose vertex stage is `vs_fullscreen`) into
/// `attachments`, with `groups` bound from index 0.
pub fn fullscreen_pass(
    encoder: &mut wgpu::CommandEncoder,
    (label, timestamp_writes): (&str, Option<wgpu::RenderPassTimestampWrites<'_>>),
    attachments: &[Option<wgpu::RenderPassColorAttachment<'_>>],
    pipeline: &wgpu::RenderPipeline,
    groups: &[&wgpu::BindGroup],
) {
    let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
        label: Some(label),
        color_attachments: attachments,
        depth_stencil_attachment: None,
        timestamp_writes,
        occlusion_query_set: None,
        multiview_mask: None,
    });
    pass.set_pipeline(pipeline);
    for (i, group) in groups.iter().enumerate() {
        pass.set_bind_group(i as u32, Some(*group), &[]);
    }
    pass.draw(0..3, 0..1);
}

/// A color attachment the pass draws over, keeping what it holds.
pub fn kept_attachment(view: &wgpu::TextureView) -> Option<wgpu::RenderPassColorAttachment<'_>> {
    Some(wgpu::RenderPassColorAttachment {
        view,
        depth_slice: None,
        resolve_target: None,
        ops: wgpu::Operations {
            load: wgpu::LoadOp::Load,
            store: wgpu::StoreOp::Store,
        },
    })
}

/// A render pass over a throwaway color target, for capture passes whose output goes to
/// storage buffers (WebGPU needs at least one attachment). Multisampled with `--msaa`: its sample
/// count is the rasterizer's.
pub struct NullTarget {
    view: wgpu::TextureView,
    size: (u32, u32),
    samples: u32,
}

impl NullTarget {
    /// The format of the target: the smallest color format every backend renders to.
    pub const FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::R8Unorm;

    /// A `width` × `height` target of `samples` samples per pixel.
    pub fn new(gpu: &Gpu, label: &str, (width, height): (u32, u32), samples: u32) -> NullTarget {
        let t = gpu.texture_2d_samples(
            label,
            (width, height),
            Self::FORMAT,
            wgpu::TextureUsages::RENDER_ATTACHMENT,
            samples,
        );
        NullTarget {
            view: t.create_view(&Default::default()),
            size: (width, height),
            samples,
        }
    }

    /// The target in `slot` for the frame's size and the scene's samples, (re)created when
    /// they changed.
    pub fn ensure<'s>(
        slot: &'s mut Option<NullTarget>,
        gpu: &Gpu,
        label: &str,
        size: (u32, u32),
        samples: u32,
    ) -> &'s NullTarget {
        if slot
            .as_ref()
            .is_none_or(|t| t.size != size || t.samples != samples)
        {
            *slot = Some(NullTarget::new(gpu, label, size, samples));
        }
        slot.as_ref().expect("set above")
    }

    /// The color target state of a pipeline that draws into a null target: nothing is written.
    pub fn target_state() -> Option<wgpu::ColorTargetState> {
        Some(wgpu::ColorTargetState {
            format: Self::FORMAT,
            blend: None,
            write_mask: wgpu::ColorWrites::empty(),
        })
    }

    /// The render pass's color attachment: cleared, never stored.
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

/// Records a pass that clears a depth view to `value`.
pub fn clear_depth_pass(encoder: &mut wgpu::CommandEncoder, view: &wgpu::TextureView, value: f32) {
    encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
        label: Some("strata.clear_depth"),
        color_attachments: &[],
        depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
            view,
            depth_ops: Some(wgpu::Operations {
                load: wgpu::LoadOp::Clear(value),
                store: wgpu::StoreOp::Store,
            }),
            stencil_ops: None,
        }),
        timestamp_writes: None,
        occlusion_query_set: None,
        multiview_mask: None,
    });
}

/// A color target of `format`, written through `blend` (`None`: replaced).
pub fn color_target(
    format: wgpu::TextureFormat,
    blend: Option<wgpu::BlendState>,
) -> Option<wgpu::ColorTargetState> {
    Some(wgpu::ColorTargetState {
        format,
        blend,
        write_mask: wgpu::ColorWrites::ALL,
    })
}

/// The blend `src_factor`·source + `dst_factor`·destination, for color and alpha alike.
pub fn blend_add(src_factor: wgpu::BlendFactor, dst_factor: wgpu::BlendFactor) -> wgpu::BlendState {
    let component = wgpu::BlendComponent {
        src_factor,
        dst_factor,
        operation: wgpu::BlendOperation::Add,
    };
    wgpu::BlendState {
        color: component,
        alpha: component,
    }
}

/// A depth attachment cleared to the far plane and discarded after the pass (a peel's).
pub fn scratch_depth(
    view: &wgpu::TextureView,
) -> Option<wgpu::RenderPassDepthStencilAttachment<'_>> {
    Some(wgpu::RenderPassDepthStencilAttachment {
        view,
        depth_ops: Some(wgpu::Operations {
            load: wgpu::LoadOp::Clear(1.0),
            store: wgpu::StoreOp::Discard,
        }),
        stencil_ops: None,
    })
}
