//! The present pass: puts the resolved frame over the application's color target — the target
//! becomes color + transmittance·target — with premultiplied alpha in one draw, or, when some
//! material multiplies (an RGB transmittance), a draw that multiplies the target and one that
//! adds the color; pipelines per target format and draw, built on first use.

use std::collections::HashMap;

use crate::gpu::binding::{self, Slot};
use crate::gpu::shader::{Library, Stage};
use crate::gpu::twin::{gpu_struct, wgsl_module};
use crate::gpu::Gpu;

gpu_struct! {
    /// The present pass's uniforms (`strata::frame::present_params`), bound as `params` by
    /// present.wgsl.
    pub struct PresentParams {
        /// Frame size in pixels.
        pub size: [u32; 2],
        /// 1 to draw the fragment counts as an opaque heatmap (the complexity effect), 0 to
        /// blend the color OVER.
        pub complexity: u32,
        /// The count at which the heatmap saturates: the fragment count drawn at the top of its
        /// scale.
        pub complexity_full: u32,
    }
}

/// `strata::frame::present_params`: [`PresentParams`] for present.wgsl.
const PARAMS: Library = &[wgsl_module!("strata::frame::present_params", PresentParams)];

/// The present pass's stage.
fn stage() -> Stage {
    Stage::new("strata.present", include_str!("present.wgsl")).with(PARAMS)
}

/// Formats the present pass is tested on; any blendable color format works.
pub const TESTED_FORMATS: [wgpu::TextureFormat; 3] = [
    wgpu::TextureFormat::Rgba8UnormSrgb,
    wgpu::TextureFormat::Bgra8UnormSrgb,
    wgpu::TextureFormat::Rgba16Float,
];

/// The present pass's draws: its fragment entry point and blend.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
enum Draw {
    /// Premultiplied over (grey transmittance) or the heatmap.
    Over,
    /// target ·= transmittance.
    Filter,
    /// target += color.
    Add,
}

impl Draw {
    fn entry(self) -> &'static str {
        match self {
            Draw::Over => "fs_present",
            Draw::Filter => "fs_present_filter",
            Draw::Add => "fs_present_add",
        }
    }

    fn blend(self) -> wgpu::BlendState {
        let component = |src_factor, dst_factor| wgpu::BlendComponent {
            src_factor,
            dst_factor,
            operation: wgpu::BlendOperation::Add,
        };
        use wgpu::BlendFactor::{One, Src, SrcAlpha, Zero};
        match self {
            Draw::Over => wgpu::BlendState::PREMULTIPLIED_ALPHA_BLENDING,
            Draw::Filter => wgpu::BlendState {
                color: component(Zero, Src),
                alpha: component(Zero, SrcAlpha),
            },
            Draw::Add => wgpu::BlendState {
                color: component(One, One),
                alpha: component(One, One),
            },
        }
    }
}

/// The present pass's layout, shader and one pipeline per target format and draw it has met.
pub struct Present {
    layout: wgpu::BindGroupLayout,
    module: wgpu::ShaderModule,
    pipelines: HashMap<(wgpu::TextureFormat, Draw), wgpu::RenderPipeline>,
    params: wgpu::Buffer,
    colormap: wgpu::Buffer,
}

impl Present {
    /// Makes the layout, shader and colormap; pipelines are made on first use per format.
    pub fn new(gpu: &Gpu) -> Present {
        let device = &gpu.device;
        let layout = binding::layout(
            device,
            "strata.present.layout",
            &[Slot::Uniform, Slot::Storage, Slot::Storage],
        );
        let module = stage().module(device);
        let lut: Vec<u32> = (0..256)
            .map(|i| {
                let [r, g, b] = super::colormap::colormap(i as f32 / 255.0);
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
            colormap: gpu.buffer_with("strata.present.colormap", &lut, wgpu::BufferUsages::STORAGE),
        }
    }

    fn pipeline(
        &mut self,
        gpu: &Gpu,
        format: wgpu::TextureFormat,
        draw: Draw,
    ) -> &wgpu::RenderPipeline {
        let (layout, module) = (&self.layout, &self.module);
        self.pipelines.entry((format, draw)).or_insert_with(|| {
            let target = wgpu::ColorTargetState {
                format,
                blend: Some(draw.blend()),
                write_mask: wgpu::ColorWrites::ALL,
            };
            crate::gpu::passes::screen_pipeline(
                gpu,
                "strata.present",
                (gpu.fullscreen_vertex_module(), "vs_fullscreen"),
                (module, draw.entry()),
                &[layout],
                &[Some(target)],
                None,
                None,
            )
        })
    }

    /// Records the present pass: `resolved` (one [`crate::frame::Resolved`] per pixel of a
    /// `size` frame) over `target`, whose contents are kept; `tinted`: some transmittance may
    /// differ between channels (a multiply material), which takes two draws.
    #[allow(clippy::too_many_arguments)]
    pub fn record(
        &mut self,
        gpu: &Gpu,
        encoder: &mut wgpu::CommandEncoder,
        target: &wgpu::TextureView,
        format: wgpu::TextureFormat,
        resolved: &wgpu::Buffer,
        params: PresentParams,
        tinted: bool,
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
        let draws: &[Draw] = if tinted && params.complexity == 0 {
            &[Draw::Filter, Draw::Add]
        } else {
            &[Draw::Over]
        };
        for &draw in draws {
            self.pipeline(gpu, format, draw);
        }
        let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
            label: Some("strata.present"),
            color_attachments: &[crate::gpu::passes::kept_attachment(target)],
            depth_stencil_attachment: None,
            timestamp_writes: timestamps,
            occlusion_query_set: None,
            multiview_mask: None,
        });
        pass.set_bind_group(0, Some(&group), &[]);
        for draw in draws {
            pass.set_pipeline(&self.pipelines[&(format, *draw)]);
            pass.draw(0..3, 0..1);
        }
    }
}

#[cfg(test)]
mod tests {
    #[test]
    fn present_stage_and_its_uniforms_validate() {
        crate::gpu::twin::assert_twin::<super::PresentParams>();
        crate::gpu::shader::validate(&super::stage());
    }
}

/// The present pass blends the resolved frame OVER an application's target of every tested
/// format and matches the exact renderer's picture over the same background.
#[cfg(test)]
mod format_tests {
    use super::TESTED_FORMATS;
    use crate::frame::FrameOptions;
    use crate::frame::FrameTargets;
    use crate::scene::{loaders, Background, Blend};
    use crate::testing::gpu;
    use crate::FrameRecorder;
    use crate::{Effect, MethodId, RenderOptions, Renderer};

    /// Reads a 4-channel texture back as 8-bit sRGB.
    fn read_target(texture: &wgpu::Texture) -> image::RgbaImage {
        let (w, h) = (texture.width(), texture.height());
        let texel = texture.format().block_copy_size(None).unwrap();
        let row = w * texel;
        let data = crate::gpu::readback::read_texture(gpu(), texture).unwrap();
        let mut img = image::RgbaImage::new(w, h);
        for y in 0..h {
            for x in 0..w {
                let at = (y * row + x * texel) as usize;
                let px = match texture.format() {
                    wgpu::TextureFormat::Rgba16Float => {
                        let c: Vec<f32> = (0..4)
                            .map(|i| {
                                half::f16::from_le_bytes([data[at + 2 * i], data[at + 2 * i + 1]])
                                    .to_f32()
                            })
                            .collect();
                        let e = |v: f32| (crate::scene::linear_to_srgb(v) * 255.0).round() as u8;
                        [e(c[0]), e(c[1]), e(c[2]), 255]
                    }
                    wgpu::TextureFormat::Bgra8UnormSrgb => {
                        [data[at + 2], data[at + 1], data[at], 255]
                    }
                    _ => [data[at], data[at + 1], data[at + 2], 255],
                };
                img.put_pixel(x, y, image::Rgba(px));
            }
        }
        img
    }

    #[test]
    fn present_blends_over_every_tested_format() {
        present_equals_the_renderer_on_every_tested_format(
            "present",
            loaders::load_scene("builtin:spheres?layers=6").unwrap(),
        );
    }

    /// Multiply materials tint the target per channel: the two-draw present.
    #[test]
    fn present_tints_every_tested_format() {
        let mut scene = loaders::load_scene("builtin:spheres?layers=6").unwrap();
        let modes = [Blend::Multiply, Blend::Over, Blend::Add];
        for (i, m) in scene.materials.iter_mut().enumerate() {
            m.blend = modes[i % 3];
        }
        assert!(scene.blend_modes().contains(&Blend::Multiply));
        present_equals_the_renderer_on_every_tested_format("present-tinted", scene);
    }

    fn present_equals_the_renderer_on_every_tested_format(name: &str, scene: crate::scene::Scene) {
        let g = gpu();
        // Bright enough that a multiply material's tint of it shows.
        let bg = [0.7f32, 0.75, 0.8];
        let options = RenderOptions {
            frame: FrameOptions {
                width: 48,
                height: 40,
                effect: Effect::Transparency,
                background: Background::Color(bg),
                ..Default::default()
            },
            ..Default::default()
        };
        let (expected, _) = Renderer::new(g, &scene, &options)
            .unwrap()
            .render("kplus-heap")
            .unwrap();
        let expected = expected.to_rgba8(Effect::Transparency);
        for format in TESTED_FORMATS {
            let target = g.texture_2d(
                "strata.test.target",
                (options.frame.width, options.frame.height),
                format,
                wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::COPY_SRC,
            );
            let view = target.create_view(&Default::default());
            let mut rec = FrameRecorder::new(g, &scene, MethodId::KplusHeap, &options).unwrap();
            let mut enc = g.device.create_command_encoder(&Default::default());
            // The application's background: its own clear of its own target.
            enc.begin_render_pass(&wgpu::RenderPassDescriptor {
                label: Some("strata.test.clear"),
                color_attachments: &[crate::gpu::passes::attachment(
                    &view,
                    wgpu::Color {
                        r: bg[0] as f64,
                        g: bg[1] as f64,
                        b: bg[2] as f64,
                        a: 1.0,
                    },
                )],
                ..Default::default()
            });
            let targets = FrameTargets {
                color: Some((&view, format)),
                opaque_depth: None,
            };
            rec.record(&mut enc, &targets, None).unwrap();
            g.queue.submit([enc.finish()]);
            let actual = read_target(&target);
            // The exact-method bar (see methods/tests.rs): both pictures come from the same GPU
            // resolve, so only the target's storage precision separates them.
            if let Err(m) = crate::metrics::testing::check_image(
                &format!("{name}-{format:?}"),
                &actual,
                &expected,
                2,
                0.001,
            ) {
                panic!("{m}");
            }
        }
    }
}
