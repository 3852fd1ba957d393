//! The frame: options, GPU scene buffers, the method-independent parts of a frame (uniforms,
//! output, timing, readback) and the statistics every frame reports.
//!
//! A frame reads as a short script:
//! 1. upload the frame uniforms (camera, lights, effect, background);
//! 2. the method runs its passes — capture (one or more geometry passes) and resolve — and writes
//!    each pixel's `(rgb, fragment count)` into the shared output buffer;
//! 3. the output and the pass timestamps are read back, and [`FrameStats`] filled in.

pub mod uniforms;

use std::collections::BTreeMap;
use std::str::FromStr;

use serde::Serialize;
use wgpu::util::DeviceExt;

use crate::error::{Error, Result};
use crate::gpu::binding::{self, Slot};
use crate::gpu::timing::Timer;
use crate::gpu::{readback, Gpu};
use crate::methods::{self, Method, MethodStats};
use crate::scene::{linear_to_srgb, Background, Camera, Scene};

/// How a pixel's depth-ordered fragments become a color.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Effect {
    #[default]
    Transparency,
    Translucency,
    Complexity,
}

impl FromStr for Effect {
    type Err = Error;
    fn from_str(s: &str) -> Result<Self> {
        match s {
            "transparency" => Ok(Effect::Transparency),
            "translucency" => Ok(Effect::Translucency),
            "complexity" => Ok(Effect::Complexity),
            _ => Err(Error::input(format!(
                "unknown effect '{s}' (expected transparency, translucency or complexity)"
            ))),
        }
    }
}

impl Effect {
    pub fn name(self) -> &'static str {
        match self {
            Effect::Transparency => "transparency",
            Effect::Translucency => "translucency",
            Effect::Complexity => "complexity",
        }
    }
}

/// What k-buffer methods do with fragments beyond the k nearest.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Tail {
    /// Discard them (counted in `fragments_dropped`).
    #[default]
    Drop,
    /// Blend them, unsorted, into one tail term behind the k nearest (weighted average color,
    /// opacity from the sum of their optical depths), as engines do.
    Blend,
}

impl FromStr for Tail {
    type Err = Error;
    fn from_str(s: &str) -> Result<Self> {
        match s {
            "drop" => Ok(Tail::Drop),
            "blend" => Ok(Tail::Blend),
            _ => Err(Error::input(format!("--tail '{s}' is not drop or blend"))),
        }
    }
}

/// Everything about a picture that is not the scene.
#[derive(Clone, Debug)]
pub struct RenderOptions {
    pub width: u32,
    pub height: u32,
    pub effect: Effect,
    pub background: Background,
    /// Per-pixel capacity for k-buffer methods, and the reference's `--k`.
    pub k: Option<u32>,
    /// Memory a method may allocate, in MiB.
    pub budget_mb: Option<f64>,
    /// Initial node pool of `abuffer-ll` (nodes); by default sized from the previous frame.
    pub abuffer_initial_nodes: Option<u64>,
    /// k-buffers: fragments beyond k.
    pub tail: Tail,
    /// k-buffers: cull fragments behind a full pixel's maximum before taking the lock.
    pub culling: bool,
    /// k-buffers: spin-lock tries per fragment (default 4096).
    pub max_tries: Option<u32>,
}

impl Default for RenderOptions {
    fn default() -> Self {
        RenderOptions {
            width: 512,
            height: 512,
            effect: Effect::Transparency,
            background: Background::Checker,
            k: None,
            budget_mb: None,
            abuffer_initial_nodes: None,
            tail: Tail::Drop,
            culling: true,
            max_tries: None,
        }
    }
}

impl RenderOptions {
    pub fn pixels(&self) -> u64 {
        self.width as u64 * self.height as u64
    }

    pub fn budget_bytes(&self) -> Option<u64> {
        self.budget_mb.map(|m| (m * 1048576.0) as u64)
    }

    pub fn validate(&self) -> Result<()> {
        if self.width == 0 || self.height == 0 || self.width > 16384 || self.height > 16384 {
            return Err(Error::input(format!(
                "size {}x{} is out of range (1..16384 per side)",
                self.width, self.height
            )));
        }
        if let Some(b) = self.budget_mb {
            if b.is_nan() || b <= 0.0 {
                return Err(Error::input(format!("--budget-mb {b} must be positive")));
            }
        }
        Ok(())
    }
}

/// What every frame reports (`--stats FILE.json`). Unknown values are `None` (`null`).
#[derive(Clone, Debug, Default, Serialize)]
pub struct FrameStats {
    pub method: String,
    pub width: u32,
    pub height: u32,
    pub k: Option<u32>,
    pub effect: String,
    pub geometry_passes: Option<u32>,
    pub gpu_ms: Option<BTreeMap<String, f64>>,
    pub gpu_ms_total: Option<f64>,
    pub fragments_generated: Option<u64>,
    pub fragments_stored: Option<u64>,
    pub fragments_dropped: Option<u64>,
    pub max_depth_complexity: Option<u32>,
    pub bytes_allocated: Option<u64>,
    pub overflow: Option<bool>,
    pub lock_failures: Option<u64>,
    pub adapter: Option<String>,
    pub backend: Option<String>,
}

/// A rendered frame before encoding: per pixel linear RGB and the number of fragments composited.
#[derive(Clone, Debug, PartialEq)]
pub struct LinearImage {
    pub width: u32,
    pub height: u32,
    /// Row-major from the top-left: `[r, g, b, fragment count]`.
    pub pixels: Vec<[f32; 4]>,
}

impl LinearImage {
    pub fn counts(&self) -> Vec<u32> {
        self.pixels.iter().map(|p| p[3].round() as u32).collect()
    }

    pub fn max_count(&self) -> u32 {
        self.pixels
            .iter()
            .map(|p| p[3].round() as u32)
            .max()
            .unwrap_or(0)
    }

    /// The picture as 8-bit sRGB: colors for the transparency effects, a heatmap with a legend
    /// for `complexity`.
    pub fn to_rgba8(&self, effect: Effect) -> image::RgbaImage {
        if effect == Effect::Complexity {
            return crate::metrics::complexity_heatmap(
                &self.counts(),
                self.width,
                self.height,
                None,
            );
        }
        let mut img = image::RgbaImage::new(self.width, self.height);
        for (dst, src) in img.pixels_mut().zip(&self.pixels) {
            let e = |c: f32| (linear_to_srgb(c) * 255.0).round() as u8;
            *dst = image::Rgba([e(src[0]), e(src[1]), e(src[2]), 255]);
        }
        img
    }
}

/// Writes a PNG, creating it only once the image is complete (no partial file on error).
pub fn save_png(img: &image::RgbaImage, path: &std::path::Path) -> Result<()> {
    let tmp = path.with_extension("png.partial");
    img.save_with_format(&tmp, image::ImageFormat::Png)
        .map_err(|e| Error::runtime(format!("cannot write '{}': {e}", path.display())))?;
    std::fs::rename(&tmp, path)
        .map_err(|e| Error::runtime(format!("cannot write '{}': {e}", path.display())))
}

/// The scene on the GPU: the flattened triangles, materials, lights and the frame uniforms,
/// with the group-0 layout every method's pipelines start with.
pub struct SceneGpu {
    pub triangle_count: u32,
    pub vertices: wgpu::Buffer,
    pub materials: wgpu::Buffer,
    pub lights: wgpu::Buffer,
    pub identity_order: wgpu::Buffer,
    pub uniforms: wgpu::Buffer,
    pub frame_layout: wgpu::BindGroupLayout,
    pub camera: Camera,
    /// Positions of every triangle's vertices, for methods that order triangles on the CPU.
    pub cpu_positions: Vec<[f32; 3]>,
}

pub const FRAME_SLOTS: [Slot; 6] = [
    Slot::Uniform,
    Slot::Storage,
    Slot::Storage,
    Slot::Storage,
    Slot::Storage,
    Slot::TextureDepth,
];

impl SceneGpu {
    pub fn new(gpu: &Gpu, scene: &Scene, options: &RenderOptions) -> Result<SceneGpu> {
        scene.validate()?;
        let tris = scene.triangles();
        let triangle_count = (tris.len() / 3) as u32;
        let vertex_bytes = (tris.len() * std::mem::size_of::<crate::scene::GpuVertex>()) as u64;
        if vertex_bytes > gpu.max_storage_binding() {
            return Err(Error::unsupported(format!(
                "scene has {triangle_count} triangles ({:.0} MiB), more than the device binds in one buffer",
                vertex_bytes as f64 / 1048576.0
            )));
        }
        let init = |label: &str, contents: &[u8], usage| {
            gpu.device
                .create_buffer_init(&wgpu::util::BufferInitDescriptor {
                    label: Some(label),
                    contents,
                    usage,
                })
        };
        let storage = wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST;
        let materials: Vec<_> = scene.materials.iter().map(uniforms::gpu_material).collect();
        let setup = uniforms::lighting(scene);
        let mut lights = setup.lights.clone();
        if lights.is_empty() {
            lights.push(bytemuck::Zeroable::zeroed()); // bindings cannot be empty
        }
        let camera = scene.camera_or_framing();
        let order: Vec<u32> = (0..triangle_count).collect();
        let u = uniforms::frame_uniforms(&camera, options, &setup);
        Ok(SceneGpu {
            triangle_count,
            vertices: init(
                "strata.scene.vertices",
                bytemuck::cast_slice(&tris),
                storage,
            ),
            materials: init(
                "strata.scene.materials",
                bytemuck::cast_slice(&materials),
                storage,
            ),
            lights: init(
                "strata.scene.lights",
                bytemuck::cast_slice(&lights),
                storage,
            ),
            identity_order: init("strata.scene.order", bytemuck::cast_slice(&order), storage),
            uniforms: init(
                "strata.frame.uniforms",
                bytemuck::bytes_of(&u),
                wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            ),
            frame_layout: binding::layout(&gpu.device, "strata.frame.layout", &FRAME_SLOTS),
            camera,
            cpu_positions: tris.iter().map(|v| v.position).collect(),
        })
    }

    /// Group 0 for a frame, drawing triangles in `order` (default: primitive order).
    pub fn frame_group(
        &self,
        gpu: &Gpu,
        opaque_depth: &wgpu::TextureView,
        order: Option<&wgpu::Buffer>,
    ) -> wgpu::BindGroup {
        binding::group(
            &gpu.device,
            "strata.frame.group",
            &self.frame_layout,
            &[
                self.uniforms.as_entire_binding(),
                self.vertices.as_entire_binding(),
                self.materials.as_entire_binding(),
                self.lights.as_entire_binding(),
                order.unwrap_or(&self.identity_order).as_entire_binding(),
                wgpu::BindingResource::TextureView(opaque_depth),
            ],
        )
    }
}

/// What a method gets for one frame.
pub struct FrameContext<'a> {
    pub gpu: &'a Gpu,
    pub scene: &'a SceneGpu,
    pub options: &'a RenderOptions,
    pub timer: &'a mut Timer,
    /// Group 0 bound to the scene in primitive order.
    pub frame_group: &'a wgpu::BindGroup,
    /// The depth of opaque surfaces (cleared to 1.0 when there are none).
    pub opaque_depth: &'a wgpu::TextureView,
    /// Per pixel `vec4<f32>(rgb, fragment count)`, the method's result.
    pub output: &'a wgpu::Buffer,
    /// Issues the geometry's draw calls; `None` draws every triangle of the scene.
    pub draw: Option<&'a DrawCallback<'a>>,
}

/// Issues draw calls into a geometry pass whose pipeline and bind groups the method has set: the
/// vertex stage pulls triangle `t` as vertices 3t..3t+3 of the scene's triangle list, so a
/// callback draws any ranges (culled subsets, chunks) of it.
pub type DrawCallback<'a> = dyn Fn(&mut wgpu::RenderPass<'_>) + 'a;

impl FrameContext<'_> {
    /// Records the geometry's draws into a pass whose pipeline and bind groups are set.
    pub fn draw_geometry(&self, pass: &mut wgpu::RenderPass<'_>) {
        match self.draw {
            Some(draw) => draw(pass),
            None => pass.draw(0..self.scene.triangle_count * 3, 0..1),
        }
    }

    pub fn pixels(&self) -> u64 {
        self.options.pixels()
    }

    /// Workgroups of 8×8 covering the image.
    pub fn pixel_workgroups(&self) -> (u32, u32) {
        (
            self.options.width.div_ceil(8),
            self.options.height.div_ceil(8),
        )
    }
}

/// Renders a scene with the GPU methods. Holds the scene buffers and each method's resources
/// between frames, so a second frame reuses what the first sized.
pub struct Renderer<'g> {
    gpu: &'g Gpu,
    scene: SceneGpu,
    options: RenderOptions,
    timer: Timer,
    opaque: wgpu::Texture,
    output: wgpu::Buffer,
    methods: BTreeMap<String, Box<dyn Method>>,
}

impl<'g> Renderer<'g> {
    pub fn new(gpu: &'g Gpu, scene: &Scene, options: &RenderOptions) -> Result<Renderer<'g>> {
        options.validate()?;
        let max_dim = gpu.limits.max_texture_dimension_2d;
        if options.width > max_dim || options.height > max_dim {
            return Err(Error::unsupported(format!(
                "size {}x{} exceeds the device's texture limit {max_dim}",
                options.width, options.height
            )));
        }
        let scene_gpu = SceneGpu::new(gpu, scene, options)?;
        let opaque = gpu.texture_2d(
            "strata.opaque_depth",
            (options.width, options.height),
            wgpu::TextureFormat::Depth32Float,
            wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::TEXTURE_BINDING,
        );
        clear_depth(gpu, &opaque.create_view(&Default::default()), 1.0);
        let output = gpu.storage_buffer(
            "strata.output",
            options.pixels() * 16,
            wgpu::BufferUsages::COPY_SRC,
        )?;
        Ok(Renderer {
            gpu,
            scene: scene_gpu,
            options: options.clone(),
            timer: Timer::new(gpu),
            opaque,
            output,
            methods: BTreeMap::new(),
        })
    }

    pub fn options(&self) -> &RenderOptions {
        &self.options
    }

    /// The depth texture fragments are tested against (Depth32Float, the frame's size); render
    /// opaque geometry into it to hide fragments behind it.
    pub fn opaque_depth(&self) -> &wgpu::Texture {
        &self.opaque
    }

    /// Renders one frame with `method_id` and reads it back.
    pub fn render(&mut self, method_id: &str) -> Result<(LinearImage, FrameStats)> {
        self.render_frame(method_id, None)
    }

    /// Like [`Renderer::render`], with the application issuing the draw calls of every geometry
    /// pass (see [`DrawCallback`]).
    pub fn render_with(
        &mut self,
        method_id: &str,
        draw: &DrawCallback<'_>,
    ) -> Result<(LinearImage, FrameStats)> {
        self.render_frame(method_id, Some(draw))
    }

    fn render_frame(
        &mut self,
        method_id: &str,
        draw: Option<&DrawCallback<'_>>,
    ) -> Result<(LinearImage, FrameStats)> {
        if !self.methods.contains_key(method_id) {
            let m = methods::create(method_id, self.gpu, &self.scene, &self.options)?;
            self.methods.insert(method_id.to_string(), m);
        }
        let method = self.methods.get_mut(method_id).expect("inserted above");
        self.timer.reset();
        let opaque_view = self.opaque.create_view(&Default::default());
        let frame_group = self.scene.frame_group(self.gpu, &opaque_view, None);
        let mut ctx = FrameContext {
            gpu: self.gpu,
            scene: &self.scene,
            options: &self.options,
            timer: &mut self.timer,
            frame_group: &frame_group,
            opaque_depth: &opaque_view,
            output: &self.output,
            draw,
        };
        let ms: MethodStats = method.render(&mut ctx)?;
        let bytes = readback::read_buffer(self.gpu, &self.output, self.options.pixels() * 16)?;
        let pixels: Vec<[f32; 4]> = bytemuck::pod_collect_to_vec(&bytes);
        let image = LinearImage {
            width: self.options.width,
            height: self.options.height,
            pixels,
        };
        let gpu_ms = self.timer.collect(self.gpu)?;
        let composited: u64 = image.counts().iter().map(|&c| c as u64).sum();
        let stats = FrameStats {
            method: method_id.to_string(),
            width: self.options.width,
            height: self.options.height,
            k: ms.k,
            effect: self.options.effect.name().to_string(),
            geometry_passes: Some(ms.geometry_passes),
            gpu_ms_total: gpu_ms.as_ref().map(|m| m.values().sum()),
            gpu_ms,
            fragments_generated: Some(
                ms.fragments_generated
                    .unwrap_or(composited + ms.fragments_dropped.unwrap_or(0)),
            ),
            fragments_stored: Some(ms.fragments_stored.unwrap_or(composited)),
            fragments_dropped: ms.fragments_dropped,
            max_depth_complexity: ms.max_depth_complexity.or(Some(image.max_count())),
            bytes_allocated: Some(ms.bytes_allocated),
            overflow: ms.overflow,
            lock_failures: ms.lock_failures,
            adapter: Some(self.gpu.info.name.clone()),
            backend: Some(self.gpu.backend_name()),
        };
        Ok((image, stats))
    }
}

pub fn clear_depth(gpu: &Gpu, view: &wgpu::TextureView, value: f32) {
    let mut enc = gpu
        .device
        .create_command_encoder(&wgpu::CommandEncoderDescriptor {
            label: Some("strata.clear_depth"),
        });
    enc.begin_render_pass(&wgpu::RenderPassDescriptor {
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
    gpu.queue.submit([enc.finish()]);
}
