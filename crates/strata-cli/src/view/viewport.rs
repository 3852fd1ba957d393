//! The viewer's 3D frame: a [`FrameRecorder`] drawing into a render target of the picture's
//! size (independent of the window), over the picture's background, and the statistics that
//! come back a frame or more later. The window shows the target through [`Blit`].

use std::collections::VecDeque;

use bytemuck::{Pod, Zeroable};
use strata::error::{Error, Result};
use strata::frame::{FrameStats, FrameTargets, RenderOptions};
use strata::gpu::binding::{self, Slot};
use strata::gpu::passes::screen_pipeline;
use strata::gpu::{readback, Gpu};
use strata::methods::MethodId;
use strata::scene::{Background, Scene};
use strata::FrameRecorder;
use wgpu::util::DeviceExt;

use super::state::{Change, ViewState};

/// The render target's format: what `strata render` writes to its PNG.
pub const TARGET_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba8UnormSrgb;
/// Frames of statistics the graph keeps.
pub const HISTORY: usize = 240;

/// Keep in sync with `Background` in background.wgsl.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
struct BackgroundParams {
    light: [f32; 4],
    dark: [f32; 4],
    checker: u32,
    _pad: [u32; 3],
}

/// Keep in sync with `Blit` in blit.wgsl.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
struct BlitParams {
    origin: [i32; 2],
    encode_srgb: u32,
    _pad: u32,
}

pub struct Viewport {
    gpu: Gpu,
    recorder: FrameRecorder,
    /// The scene as loaded, the camera being the view's.
    scene: Scene,
    /// The time the recorder shows (`scene` stays at its own).
    time: f32,
    target: wgpu::Texture,
    background: wgpu::RenderPipeline,
    background_group: wgpu::BindGroup,
    background_params: wgpu::Buffer,
    /// Statistics of the latest frames, oldest first.
    pub history: VecDeque<FrameStats>,
    /// The latest depth-complexity histogram that came back.
    pub histogram: Option<Vec<u64>>,
}

impl Viewport {
    pub fn new(gpu: &Gpu, state: &ViewState) -> Result<Viewport> {
        let (scene, options) = prepared(state)?;
        let recorder = FrameRecorder::new(gpu, &scene, state.method.id(), &options)?;
        let (background, layout) = fullscreen_pipeline(
            gpu,
            "strata.view.background",
            (include_str!("background.wgsl"), "fs_background"),
            &[Slot::Uniform],
            TARGET_FORMAT,
        );
        let background_params = gpu.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("strata.view.background"),
            size: std::mem::size_of::<BackgroundParams>() as u64,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let background_group = binding::group(
            &gpu.device,
            "strata.view.background",
            &layout,
            &[background_params.as_entire_binding()],
        );
        let mut viewport = Viewport {
            target: target(gpu, &options),
            gpu: gpu.clone(),
            recorder,
            time: scene.time,
            scene,
            background,
            background_group,
            background_params,
            history: VecDeque::new(),
            histogram: None,
        };
        viewport.recorder.set_histogram(state.histogram);
        viewport.write_background(&options);
        Ok(viewport)
    }

    /// Takes a new state; on error the viewport is unchanged.
    pub fn apply(&mut self, state: &ViewState, change: Change) -> Result<()> {
        match change {
            Change::None => {}
            Change::Time => {
                self.recorder.set_time(state.time());
                self.time = state.time();
                self.recorder.set_method(state.method.id())?;
                self.recorder.set_camera(&state.camera());
            }
            Change::Camera | Change::Method => {
                self.recorder.set_method(state.method.id())?;
                self.recorder.set_camera(&state.camera());
            }
            Change::Options | Change::Geometry => {
                let (scene, options) = prepared(state)?;
                if change == Change::Geometry {
                    self.recorder.set_geometry(&scene)?;
                    self.time = scene.time;
                    self.scene = scene;
                }
                self.recorder.set_frame_options(&options.frame)?;
                self.recorder.set_method(state.method.id())?;
                self.recorder.set_camera(&state.camera());
                if (self.target.width(), self.target.height())
                    != (options.frame.width, options.frame.height)
                {
                    self.target = target(&self.gpu, &options);
                }
                self.write_background(&options);
            }
            Change::Rebuild => {
                *self = Viewport::new(&self.gpu, state)?;
                return Ok(());
            }
        }
        self.scene.camera = Some(state.camera());
        self.recorder.set_histogram(state.histogram);
        Ok(())
    }

    fn write_background(&self, options: &RenderOptions) {
        let params = match options.frame.background {
            Background::Checker => BackgroundParams {
                light: rgba(Background::Checker.at(0, 0)),
                dark: rgba(Background::Checker.at(16, 0)),
                checker: 1,
                _pad: [0; 3],
            },
            Background::Color(c) => BackgroundParams {
                light: rgba(c),
                dark: rgba(c),
                checker: 0,
                _pad: [0; 3],
            },
        };
        self.gpu
            .queue
            .write_buffer(&self.background_params, 0, bytemuck::bytes_of(&params));
    }

    /// Records a frame into the render target: the background (without a pipeline, whose tone
    /// map draws it), then the method.
    pub fn record(&mut self, encoder: &mut wgpu::CommandEncoder) -> Result<u64> {
        let view = self.target.create_view(&Default::default());
        if self.recorder.options().build.lighting.pipeline.is_none() {
            let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
                label: Some("strata.view.background"),
                color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                    view: &view,
                    depth_slice: None,
                    resolve_target: None,
                    ops: wgpu::Operations {
                        load: wgpu::LoadOp::Clear(wgpu::Color::BLACK),
                        store: wgpu::StoreOp::Store,
                    },
                })],
                ..Default::default()
            });
            pass.set_pipeline(&self.background);
            pass.set_bind_group(0, &self.background_group, &[]);
            pass.draw(0..3, 0..1);
        }
        let targets = FrameTargets {
            color: Some((&view, TARGET_FORMAT)),
            opaque_depth: None,
        };
        self.recorder.record(encoder, &targets, None)
    }

    /// Collects the statistics that came back (never waits).
    pub fn poll(&mut self) {
        for stats in self.recorder.poll_stats() {
            if let Some(h) = &stats.depth_histogram {
                self.histogram = Some(h.clone());
            }
            self.history.push_back(stats);
            while self.history.len() > HISTORY {
                self.history.pop_front();
            }
        }
    }

    pub fn target(&self) -> &wgpu::Texture {
        &self.target
    }

    /// The scene and options of the current view (what the reference renders).
    pub fn picture(&self) -> (Scene, RenderOptions) {
        let mut scene = self.scene.clone();
        if scene.time != self.time {
            let camera = scene.camera;
            scene.set_time(self.time);
            scene.camera = camera;
        }
        (scene, self.recorder.options().clone())
    }

    /// The fragment count of every pixel of the last frame (a blocking readback).
    pub fn read_counts(&self) -> Result<Vec<u32>> {
        let options = self.recorder.options();
        let bytes = readback::read_buffer(
            &self.gpu,
            self.recorder.resolved(),
            options.pixels() * strata::frame::RESOLVED_BYTES,
        )?;
        let resolved: Vec<strata::frame::Resolved> = bytemuck::pod_collect_to_vec(&bytes);
        Ok(resolved.iter().map(|r| r.count).collect())
    }

    /// The picture to compare with the reference's: the render target, or for the complexity
    /// effect the still pictures' heatmap of the counts (the live one scales to k, the still
    /// one to the image's maximum).
    pub fn comparable_picture(&self) -> Result<image::RgbaImage> {
        let options = self.recorder.options();
        if options.frame.effect != strata::frame::Effect::Complexity {
            return self.read_target();
        }
        let counts = self.read_counts()?;
        Ok(strata::metrics::complexity_heatmap(
            &counts,
            options.frame.width,
            options.frame.height,
            None,
        ))
    }

    /// The render target as it is now (a blocking readback: screenshots and comparisons only).
    pub fn read_target(&self) -> Result<image::RgbaImage> {
        texture_image(&self.gpu, &self.target)
    }
}

/// The scene and render options of a state, through the same path as `strata render`.
pub fn prepared(state: &ViewState) -> Result<(Scene, RenderOptions)> {
    if state.method.id() == MethodId::Reference {
        return Err(Error::input(
            "the viewer shows the GPU methods; the reference is its \"Compare with reference\"",
        ));
    }
    let (mut scene, options) = crate::prepare_render(&state.method, &state.picture)?;
    scene.camera = Some(state.camera());
    Ok((scene, options))
}

fn rgba(c: [f32; 3]) -> [f32; 4] {
    [c[0], c[1], c[2], 1.0]
}

fn target(gpu: &Gpu, options: &RenderOptions) -> wgpu::Texture {
    gpu.texture_2d(
        "strata.view.target",
        (options.frame.width, options.frame.height),
        TARGET_FORMAT,
        wgpu::TextureUsages::RENDER_ATTACHMENT
            | wgpu::TextureUsages::TEXTURE_BINDING
            | wgpu::TextureUsages::COPY_SRC,
    )
}

/// An 8-bit RGBA or BGRA texture read back as RGBA.
pub fn texture_image(gpu: &Gpu, texture: &wgpu::Texture) -> Result<image::RgbaImage> {
    let mut bytes = readback::read_texture(gpu, texture)?;
    let bgra = matches!(
        texture.format(),
        wgpu::TextureFormat::Bgra8Unorm | wgpu::TextureFormat::Bgra8UnormSrgb
    );
    if bgra {
        for px in bytes.chunks_exact_mut(4) {
            px.swap(0, 2);
        }
    }
    image::RgbaImage::from_raw(texture.width(), texture.height(), bytes)
        .ok_or_else(|| Error::runtime("the texture readback has the wrong size"))
}

/// An image uploaded as a texture the blit can show.
pub fn image_texture(gpu: &Gpu, label: &str, img: &image::RgbaImage) -> wgpu::Texture {
    gpu.device.create_texture_with_data(
        &gpu.queue,
        &wgpu::TextureDescriptor {
            label: Some(label),
            size: wgpu::Extent3d {
                width: img.width(),
                height: img.height(),
                depth_or_array_layers: 1,
            },
            mip_level_count: 1,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D2,
            format: TARGET_FORMAT,
            usage: wgpu::TextureUsages::TEXTURE_BINDING,
            view_formats: &[],
        },
        wgpu::util::TextureDataOrder::LayerMajor,
        img.as_raw(),
    )
}

/// One of the viewer's full-screen pipelines, all its parts named `label`: `vs_fullscreen`, then
/// the fragment stage (the WGSL source and its entry point) reading bind group 0 of `slots`,
/// into one `format` target, no culling, no depth. Returns the pipeline and the group's layout.
fn fullscreen_pipeline(
    gpu: &Gpu,
    label: &str,
    (source, entry): (&str, &str),
    slots: &[Slot],
    format: wgpu::TextureFormat,
) -> (wgpu::RenderPipeline, wgpu::BindGroupLayout) {
    let layout = binding::layout(&gpu.device, label, slots);
    let module = gpu
        .device
        .create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some(label),
            source: wgpu::ShaderSource::Wgsl(source.into()),
        });
    let pipeline = screen_pipeline(
        gpu,
        label,
        (gpu.fullscreen_vertex_module(), "vs_fullscreen"),
        (&module, entry),
        &[&layout],
        &[Some(format.into())],
        None,
        None,
    );
    (pipeline, layout)
}

/// Draws an image into the window at one texel per pixel.
pub struct Blit {
    pipeline: wgpu::RenderPipeline,
    layout: wgpu::BindGroupLayout,
    params: wgpu::Buffer,
    encode_srgb: bool,
}

impl Blit {
    pub fn new(gpu: &Gpu, format: wgpu::TextureFormat) -> Blit {
        let (pipeline, layout) = fullscreen_pipeline(
            gpu,
            "strata.view.blit",
            (include_str!("blit.wgsl"), "fs_blit"),
            &[Slot::Uniform, Slot::TextureFloat],
            format,
        );
        let blit = BlitParams {
            origin: [0; 2],
            encode_srgb: 0,
            _pad: 0,
        };
        let params = gpu.buffer_with(
            "strata.view.blit",
            std::slice::from_ref(&blit),
            wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
        );
        Blit {
            pipeline,
            layout,
            params,
            encode_srgb: !format.is_srgb(),
        }
    }

    /// Draws `image` with its top-left texel at `origin`, clipped to `clip` (x, y, w, h; all
    /// window pixels).
    pub fn draw(
        &self,
        gpu: &Gpu,
        pass: &mut wgpu::RenderPass<'_>,
        image: &wgpu::Texture,
        origin: [i32; 2],
        clip: [u32; 4],
    ) {
        if clip[2] == 0 || clip[3] == 0 {
            return;
        }
        let params = BlitParams {
            origin,
            encode_srgb: self.encode_srgb as u32,
            _pad: 0,
        };
        gpu.queue
            .write_buffer(&self.params, 0, bytemuck::bytes_of(&params));
        let view = image.create_view(&Default::default());
        let group = binding::group(
            &gpu.device,
            "strata.view.blit",
            &self.layout,
            &[
                self.params.as_entire_binding(),
                wgpu::BindingResource::TextureView(&view),
            ],
        );
        pass.set_pipeline(&self.pipeline);
        pass.set_bind_group(0, &group, &[]);
        pass.set_scissor_rect(clip[0], clip[1], clip[2], clip[3]);
        pass.draw(0..3, 0..1);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn gpu_struct_layouts() {
        assert_eq!(std::mem::size_of::<BackgroundParams>(), 48);
        assert_eq!(std::mem::size_of::<BlitParams>(), 16);
    }
}
