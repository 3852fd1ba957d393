//! The present pass: blends the resolved frame OVER the application's color target with
//! premultiplied alpha, one pipeline per target format (built on first use).

use std::collections::HashMap;

use bytemuck::{Pod, Zeroable};
use wgpu::util::DeviceExt;

use crate::gpu::binding::{self, Slot};
use crate::gpu::Gpu;

/// Keep in sync with `PresentParams` in present.wgsl.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub struct PresentParams {
    pub size: [u32; 2],
    pub complexity: u32,
    pub complexity_full: u32,
}

/// Formats the present pass is tested on; any blendable color format works.
pub const TESTED_FORMATS: [wgpu::TextureFormat; 3] = [
    wgpu::TextureFormat::Rgba8UnormSrgb,
    wgpu::TextureFormat::Bgra8UnormSrgb,
    wgpu::TextureFormat::Rgba16Float,
];

pub struct Present {
    layout: wgpu::BindGroupLayout,
    module: wgpu::ShaderModule,
    pipelines: HashMap<wgpu::TextureFormat, wgpu::RenderPipeline>,
    params: wgpu::Buffer,
    colormap: wgpu::Buffer,
}

impl Present {
    pub fn new(gpu: &Gpu) -> Present {
        let device = &gpu.device;
        let layout = binding::layout(
            device,
            "strata.present.layout",
            &[Slot::Uniform, Slot::Storage, Slot::Storage],
        );
        let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("strata.present"),
            source: wgpu::ShaderSource::Wgsl(include_str!("present.wgsl").into()),
        });
        let lut: Vec<u32> = (0..256)
            .map(|i| {
                let [r, g, b] = crate::metrics::colormap::colormap(i as f32 / 255.0);
                r as u32 | (g as u32) << 8 | (b as u32) << 16
            })
            .collect();
        Present {
            layout,
            module,
            pipelines: HashMap::new(),
            params: device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("strata.present.params"),
                size: std::mem::size_of::<PresentParams>() as u64,
                usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            }),
            colormap: device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some("strata.present.colormap"),
                contents: bytemuck::cast_slice(&lut),
                usage: wgpu::BufferUsages::STORAGE,
            }),
        }
    }

    fn pipeline(&mut self, gpu: &Gpu, format: wgpu::TextureFormat) -> &wgpu::RenderPipeline {
        let (layout, module) = (&self.layout, &self.module);
        self.pipelines.entry(format).or_insert_with(|| {
            let pipeline_layout =
                binding::pipeline_layout(&gpu.device, "strata.present", &[layout]);
            gpu.device
                .create_render_pipeline(&wgpu::RenderPipelineDescriptor {
                    label: Some("strata.present"),
                    layout: Some(&pipeline_layout),
                    vertex: wgpu::VertexState {
                        module,
                        entry_point: Some("vs_present"),
                        compilation_options: Default::default(),
                        buffers: &[],
                    },
                    primitive: Default::default(),
                    depth_stencil: None,
                    multisample: Default::default(),
                    fragment: Some(wgpu::FragmentState {
                        module,
                        entry_point: Some("fs_present"),
                        compilation_options: Default::default(),
                        targets: &[Some(wgpu::ColorTargetState {
                            format,
                            blend: Some(wgpu::BlendState::PREMULTIPLIED_ALPHA_BLENDING),
                            write_mask: wgpu::ColorWrites::ALL,
                        })],
                    }),
                    multiview_mask: None,
                    cache: None,
                })
        })
    }

    /// Records the present pass: `resolved` (one [`crate::frame::Resolved`] per pixel of a
    /// `size` frame) OVER `target`, whose contents are kept.
    #[allow(clippy::too_many_arguments)]
    pub fn record(
        &mut self,
        gpu: &Gpu,
        encoder: &mut wgpu::CommandEncoder,
        target: &wgpu::TextureView,
        format: wgpu::TextureFormat,
        resolved: &wgpu::Buffer,
        params: PresentParams,
        timestamps: Option<wgpu::RenderPassTimestampWrites<'_>>,
    ) {
        gpu.queue
            .write_buffer(&self.params, 0, bytemuck::bytes_of(&params));
        let group = binding::group(
            &gpu.device,
            "strata.present.group",
            &self.layout,
            &[
                self.params.as_entire_binding(),
                resolved.as_entire_binding(),
                self.colormap.as_entire_binding(),
            ],
        );
        let pipeline = self.pipeline(gpu, format);
        let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
            label: Some("strata.present"),
            color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                view: target,
                depth_slice: None,
                resolve_target: None,
                ops: wgpu::Operations {
                    load: wgpu::LoadOp::Load,
                    store: wgpu::StoreOp::Store,
                },
            })],
            depth_stencil_attachment: None,
            timestamp_writes: timestamps,
            occlusion_query_set: None,
            multiview_mask: None,
        });
        pass.set_pipeline(pipeline);
        pass.set_bind_group(0, Some(&group), &[]);
        pass.draw(0..3, 0..1);
    }
}

#[cfg(test)]
mod tests {
    #[test]
    fn present_params_layout_matches_wgsl() {
        assert_eq!(std::mem::size_of::<super::PresentParams>(), 16);
    }
}
