//! f2b's part of a downlevel frame: the peels, the accumulates, the probe, and exact mode's count.

use crate::error::Result;
use crate::frame::passes::{
    attachment, blend_add, color_target, fullscreen_pass, kept_attachment, render_pipeline,
    scratch_depth, Rasterization,
};
use crate::gpu::binding;
use crate::gpu::Gpu;
use crate::scene::GpuVertex;

use super::{
    material_buffer_layout, DownlevelFrame, COLOR_FORMAT, COUNT_FORMAT, DEPTH_COPY_FORMAT,
    TAG_FORMAT,
};

/// One layer's targets.
struct Layer {
    color: wgpu::TextureView,
    tag: wgpu::TextureView,
    depth: wgpu::TextureView,
}

impl DownlevelFrame {
    /// Exact mode (the CPU waits): counts every pixel's fragments in front of `opaque` in one
    /// geometry pass and reads the largest count back, the layers a complete f2b frame needs.
    /// Real-time frames never call it: they grow from the probe instead.
    pub fn count_layers(&mut self, gpu: &Gpu, opaque: &wgpu::TextureView) -> Result<u32> {
        use wgpu::BlendFactor::One;
        let group = self.frame_group(gpu, opaque);
        let pipeline = self.count.get_or_insert_with(|| {
            render_pipeline(
                gpu,
                "strata.f2b_downlevel.count",
                wgpu::VertexState {
                    module: &self.vertex_module,
                    entry_point: Some("vs_scene"),
                    compilation_options: Default::default(),
                    buffers: &[Some(GpuVertex::layout()), Some(material_buffer_layout())],
                },
                (&self.module, "fs_count"),
                &[&self.frame_layout],
                &[color_target(COUNT_FORMAT, Some(blend_add(One, One)))],
                Rasterization {
                    cull_mode: None,
                    depth: None,
                    samples: 1,
                },
            )
        });
        let (w, h) = (self.options.frame.width, self.options.frame.height);
        let counts = gpu.texture_2d(
            "strata.f2b_downlevel.counts",
            (w, h),
            COUNT_FORMAT,
            wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::COPY_SRC,
        );
        let view = counts.create_view(&Default::default());
        let mut encoder = gpu
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                label: Some("strata.f2b_downlevel.count"),
            });
        let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
            label: Some("strata.f2b_downlevel.count"),
            color_attachments: &[attachment(&view, wgpu::Color::TRANSPARENT)],
            ..Default::default()
        });
        pass.set_pipeline(pipeline);
        pass.set_bind_group(0, Some(&group), &[]);
        self.draw_scene(&mut pass);
        drop(pass);
        gpu.queue.submit([encoder.finish()]);
        let bytes = crate::gpu::readback::read_texture(gpu, &counts)?;
        Ok(bytes
            .chunks_exact(2)
            .map(|b| half::f16::from_le_bytes([b[0], b[1]]).to_f32() as u32)
            .max()
            .unwrap_or(0))
    }

    /// f2b's peels and accumulates into `states`, and the probe; returns the layers peeled.
    pub(super) fn record_peels(
        &mut self,
        gpu: &Gpu,
        encoder: &mut wgpu::CommandEncoder,
        frame_group: &wgpu::BindGroup,
        state_views: &[[wgpu::TextureView; 2]; 2],
    ) -> u32 {
        let layers = self.layers();
        let device = &gpu.device;
        let (w, h) = (self.options.frame.width, self.options.frame.height);
        let attachment_usage =
            wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::TEXTURE_BINDING;
        let mut view = |label: &'static str, format| {
            self.cache
                .texture(gpu, label, (w, h), format, attachment_usage)
                .create_view(&Default::default())
        };
        let layer_views = [
            Layer {
                color: view("strata.f2b_downlevel.layer0.color", COLOR_FORMAT),
                tag: view("strata.f2b_downlevel.layer0.tag", TAG_FORMAT),
                depth: view("strata.f2b_downlevel.layer0.depth", DEPTH_COPY_FORMAT),
            },
            Layer {
                color: view("strata.f2b_downlevel.layer1.color", COLOR_FORMAT),
                tag: view("strata.f2b_downlevel.layer1.tag", TAG_FORMAT),
                depth: view("strata.f2b_downlevel.layer1.depth", DEPTH_COPY_FORMAT),
            },
        ];
        let depth = view(
            "strata.f2b_downlevel.depth",
            wgpu::TextureFormat::Depth32Float,
        );
        let texture = wgpu::BindingResource::TextureView;
        // Peel i reads layer (i + 1) % 2 (the previous one) and writes layer i % 2.
        let peel_groups = [0, 1].map(|i| {
            let previous = &layer_views[(i + 1) % 2];
            binding::group(
                device,
                "strata.f2b_downlevel.peel.group",
                &self.layer_layout,
                &[texture(&previous.tag), texture(&previous.depth)],
            )
        });
        // Accumulate i reads state i % 2, layer i % 2 and the previous layer; writes state
        // (i + 1) % 2.
        let accumulate_groups = [0, 1].map(|i| {
            let (layer, previous) = (&layer_views[i], &layer_views[(i + 1) % 2]);
            binding::group(
                device,
                "strata.f2b_downlevel.accumulate.group",
                &self.accumulate_layout,
                &[
                    texture(&previous.tag),
                    texture(&previous.depth),
                    texture(&state_views[i][0]),
                    texture(&state_views[i][1]),
                    texture(&layer.color),
                    texture(&layer.tag),
                    texture(&layer.depth),
                ],
            )
        });
        for layer in 0..=layers {
            let probe = layer == layers;
            let target = &layer_views[layer as usize % 2];
            let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
                label: Some(if probe {
                    "strata.f2b_downlevel.probe"
                } else {
                    "strata.f2b_downlevel.peel"
                }),
                color_attachments: &[
                    attachment(&target.color, wgpu::Color::TRANSPARENT),
                    attachment(
                        &target.tag,
                        wgpu::Color {
                            r: u32::MAX as f64,
                            g: 0.0,
                            b: 0.0,
                            a: 0.0,
                        },
                    ),
                    attachment(&target.depth, wgpu::Color::TRANSPARENT),
                ],
                depth_stencil_attachment: scratch_depth(&depth),
                occlusion_query_set: probe.then_some(&self.probe),
                ..Default::default()
            });
            pass.set_pipeline(if layer == 0 {
                &self.peel_first
            } else {
                &self.peel
            });
            pass.set_bind_group(0, Some(frame_group), &[]);
            pass.set_bind_group(1, Some(&peel_groups[layer as usize % 2]), &[]);
            if probe {
                pass.begin_occlusion_query(0);
            }
            self.draw_scene(&mut pass);
            if probe {
                pass.end_occlusion_query();
            }
            drop(pass);
            if probe {
                break;
            }
            let i = layer as usize % 2;
            let out = &state_views[(i + 1) % 2];
            fullscreen_pass(
                encoder,
                ("strata.f2b_downlevel.accumulate", None),
                &[kept_attachment(&out[0]), kept_attachment(&out[1])],
                &self.accumulate,
                &[frame_group, &accumulate_groups[i]],
            );
        }
        encoder.resolve_query_set(&self.probe, 0..1, &self.probe_results, 0);
        layers
    }
}
