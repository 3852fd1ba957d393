//! wboit's part of a downlevel frame: the weighted family's accumulate and composite stages
//! composed with UNIFORM_SCENE, their pipelines and passes.

use crate::frame::passes::{
    attachment, blend_add, color_target, fullscreen_pass, kept_attachment, render_pipeline,
    screen_pipeline, Rasterization,
};
use crate::gpu::binding::{self, Slot};
use crate::gpu::shader::Stage;
use crate::gpu::Gpu;
use crate::methods::weighted::WeightedOptions;
use crate::methods::weighted::{WboitParams, ACCUMULATION_FORMAT, REVEALAGE_FORMAT};

use super::{DownlevelFrame, COUNT_FORMAT, STATE_FORMAT};

/// wboit's pipelines on a downlevel device.
pub(super) struct Wboit {
    params_layout: wgpu::BindGroupLayout,
    composite_layout: wgpu::BindGroupLayout,
    accumulate: wgpu::RenderPipeline,
    composite: wgpu::RenderPipeline,
}

/// wboit's pipelines: `vertex` the scene's vertex stage and its buffers, `stages` the accumulate
/// and composite stages.
pub(super) fn pipelines(
    gpu: &Gpu,
    frame_layout: &wgpu::BindGroupLayout,
    (vertex_module, vertex_buffers): (&wgpu::ShaderModule, &[Option<wgpu::VertexBufferLayout<'_>>]),
    [wboit_accumulate, wboit_composite]: [&Stage; 2],
) -> Wboit {
    let device = &gpu.device;
    let params_layout = binding::layout(
        device,
        "strata.wboit_downlevel.params.layout",
        &[Slot::Uniform],
    );
    let composite_layout = binding::layout(
        device,
        "strata.wboit_downlevel.composite.layout",
        &[Slot::TextureFloat; 3],
    );
    let blended = |format, src, dst| color_target(format, Some(blend_add(src, dst)));
    use wgpu::BlendFactor::{One, OneMinusSrc, Zero};
    let accumulate = render_pipeline(
        gpu,
        "strata.wboit_downlevel.accumulate",
        wgpu::VertexState {
            module: vertex_module,
            entry_point: Some("vs_scene"),
            compilation_options: Default::default(),
            buffers: vertex_buffers,
        },
        (&wboit_accumulate.module(device), "fs_wboit"),
        &[frame_layout, &params_layout],
        &[
            blended(ACCUMULATION_FORMAT, One, One),
            blended(REVEALAGE_FORMAT, Zero, OneMinusSrc),
            blended(COUNT_FORMAT, One, One),
        ],
        Rasterization {
            cull_mode: None,
            depth: None,
            samples: 1,
        },
    );
    let composite = screen_pipeline(
        gpu,
        "strata.wboit_downlevel.composite",
        (gpu.fullscreen_vertex_module(), "vs_fullscreen"),
        (&wboit_composite.module(device), "fs_composite"),
        &[frame_layout, &composite_layout],
        &[
            color_target(STATE_FORMAT, None),
            color_target(STATE_FORMAT, None),
        ],
        None,
        None,
    );
    Wboit {
        params_layout,
        composite_layout,
        accumulate,
        composite,
    }
}

impl DownlevelFrame {
    /// wboit's accumulate pass and its composite into the state pair `state`.
    pub(super) fn record_wboit(
        &mut self,
        gpu: &Gpu,
        encoder: &mut wgpu::CommandEncoder,
        frame_group: &wgpu::BindGroup,
        state: &[wgpu::TextureView; 2],
    ) {
        let wboit = self.wboit.as_ref().expect("made for wboit");
        let (w, h) = (self.options.frame.width, self.options.frame.height);
        let usage = wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::TEXTURE_BINDING;
        let mut view = |label: &'static str, format| {
            self.cache
                .texture(gpu, label, (w, h), format, usage)
                .create_view(&Default::default())
        };
        let accumulation = view("strata.wboit_downlevel.accumulation", ACCUMULATION_FORMAT);
        let revealage = view("strata.wboit_downlevel.revealage", REVEALAGE_FORMAT);
        let count = view("strata.wboit_downlevel.count", COUNT_FORMAT);
        let params = WboitParams::new(&self.options.frame.family::<WeightedOptions>());
        let params = self.cache.uniform(
            gpu,
            "strata.wboit_downlevel.params",
            bytemuck::bytes_of(&params),
        );
        let device = &gpu.device;
        let params_group = binding::group(
            device,
            "strata.wboit_downlevel.params.group",
            &wboit.params_layout,
            &[params.as_entire_binding()],
        );
        let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
            label: Some("strata.wboit_downlevel.accumulate"),
            color_attachments: &[
                attachment(&accumulation, wgpu::Color::TRANSPARENT),
                attachment(&revealage, wgpu::Color::WHITE),
                attachment(&count, wgpu::Color::TRANSPARENT),
            ],
            ..Default::default()
        });
        pass.set_pipeline(&wboit.accumulate);
        pass.set_bind_group(0, Some(frame_group), &[]);
        pass.set_bind_group(1, Some(&params_group), &[]);
        self.draw_scene(&mut pass);
        drop(pass);
        let texture = wgpu::BindingResource::TextureView;
        let composite_group = binding::group(
            device,
            "strata.wboit_downlevel.composite.group",
            &wboit.composite_layout,
            &[texture(&count), texture(&accumulation), texture(&revealage)],
        );
        fullscreen_pass(
            encoder,
            ("strata.wboit_downlevel.composite", None),
            &[kept_attachment(&state[0]), kept_attachment(&state[1])],
            &wboit.composite,
            &[frame_group, &composite_group],
        );
    }
}
