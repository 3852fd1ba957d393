//! The methods a downlevel (WebGL2-class) device runs: [`DownlevelFrame`], for `f2b` (exact) and
//! `wboit` (approximate).
//!
//! Such a device has no storage buffers and no compute shaders, which every other frame of
//! strata keeps its scene, its per-pixel state and its totals in. Depth peeling and weighted
//! blended OIT need neither: here every step is a render pass over textures. The scene is
//! composed with `UNIFORM_SCENE`: materials and lights in uniform arrays ([`UNIFORM_MATERIALS`],
//! [`UNIFORM_LIGHTS`]), each vertex carrying its triangle's material, and the material inside
//! each fragment's tag. Both end in the same pair of state targets per pixel — (color, count)
//! and (transmittance, unused), their f32 bits in Rgba32Uint: 32 bytes, a downlevel device's most per sample —
//! which the present and [`DownlevelFrame::read_resolved`] read.
//!
//! **f2b** (passes in `f2b.wgsl`): for L layers, L + 1 geometry passes (the last only asks an
//! occlusion query whether anything lies behind layer L) and L full-screen accumulate passes,
//! which composite with `strata::composite`, the resolve every exact method shares: the picture
//! is f2b's, exact, with ties in primitive order, every blend mode and translucency. Memory per
//! pixel: two layers of color, tag and depth (2 × 16 B), two pairs of state targets (2 × 32 B)
//! and the depth buffer (4 B) = 100·W·H. A frame found incomplete makes the next one peel twice
//! the layers (up to [`MAX_LAYERS`]) unless `--layers` fixed them; exact mode instead counts
//! every pixel's fragments first ([`DownlevelFrame::count_layers`], one blended pass into an
//! R16Float target, read back) and peels as many layers as the deepest pixel has.
//!
//! **wboit** (`weighted/wboit_accumulate.wgsl` and `weighted/composite.wgsl`, composed with
//! `UNIFORM_SCENE`): one geometry pass into the accumulation and revealage targets and a third,
//! R16Float, that counts fragments by additive blending (exact up to 2048 per pixel), then a
//! full-screen composite into the state targets: the full device's wboit picture. Memory per
//! pixel: 8 + 2 + 2 + 64 = 76·W·H.
//!
//! What a downlevel frame cannot report: without storage there are no frame totals, so a
//! real-time frame's statistics say whether it was complete (f2b's occlusion query) but not how
//! many fragments it saw; [`DownlevelFrame::read_resolved`] (the batch renderer) counts them on
//! the CPU from the pixels' counts. No `--msaa`, `--raster compute`, `--order`, `--pipeline` or
//! `--temporal` here; the complexity effect is read back but not presented.

use crate::methods::kbuffer::KBufferOptions;
use bytemuck::Zeroable;

use crate::error::{Error, Result};
use crate::frame::passes::{
    attachment, blend_add, clear_depth_pass, color_target, kept_attachment, render_pipeline,
    screen_pipeline, Rasterization,
};
use crate::frame::stats::StatsRing;
use crate::frame::uniforms::{self, GpuLight, GpuMaterial, LightingSetup};
use crate::frame::{Effect, FrameStats, FrameTargets, Raster, RenderOptions, Resolved};
use crate::gpu::binding::{self, Slot};
use crate::gpu::shader::{Defs, Stage};
use crate::gpu::{Gpu, ResourceCache};
use crate::methods::peeling::PeelingOptions;
use crate::methods::peeling::MAX_LAYERS;
use crate::scene::{Camera, GpuVertex, Scene};

use super::peeling::FIRST_GUESS_LAYERS;
use super::weighted::{self, ACCUMULATION_FORMAT, REVEALAGE_FORMAT};
use super::MethodId;

/// Materials a downlevel scene may have (a uniform array; `UNIFORM_MATERIALS` in scene.wgsl,
/// whose tags give the material 8 bits).
pub const UNIFORM_MATERIALS: usize = 256;
/// Lights other than ambient a downlevel scene may have (`UNIFORM_LIGHTS` in scene.wgsl).
pub const UNIFORM_LIGHTS: usize = 64;
/// Triangles a downlevel tag holds: primitive << 9 | material << 1 | facing.
pub const DOWNLEVEL_MAX_TRIANGLES: u64 = 1 << 23;
/// f2b's bytes per pixel (module docs).
pub const F2B_PIXEL_BYTES: u64 = 100;
/// wboit's bytes per pixel (module docs).
pub const WBOIT_PIXEL_BYTES: u64 = 76;

const COLOR_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba16Float;
const TAG_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::R32Uint;
/// Depths and states as their f32 bits: 32-bit integer targets render on every device, 32-bit
/// float ones not on WebGL2 without EXT_color_buffer_float, nor on wgpu's GL backend.
const DEPTH_COPY_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::R32Uint;
const STATE_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba32Uint;
/// wboit's fragment count: f16 counts exactly up to 2048.
const COUNT_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::R16Float;

/// Why `method` cannot run on `gpu`, a downlevel device, in one line naming what the device
/// lacks and the methods that do run there (the table's `downlevel` ones).
pub fn refusal(gpu: &Gpu, method: MethodId) -> Error {
    let why = crate::frame::scene_gpu::check_device(gpu)
        .err()
        .map(|e| e.to_string())
        .unwrap_or_else(|| format!("'{}' is not a downlevel device", gpu.info.name));
    let running: Vec<&str> = super::catalogue()
        .filter(|d| d.downlevel)
        .map(|d| d.name)
        .collect();
    Error::unsupported(format!(
        "{method} does not run here: {why}; of strata's methods only {} run on it, through render targets (`DownlevelFrame`, which `Renderer` and `strata render` use)",
        running.join(" and ")
    ))
}

/// Whether `gpu` is a downlevel device that strata's other frames refuse: no storage buffers or
/// no compute (see [`crate::frame::scene_gpu::check_device`]).
pub fn is_downlevel(gpu: &Gpu) -> bool {
    crate::frame::scene_gpu::check_device(gpu).is_err()
}

/// One pair of state targets: (color, count) and (transmittance, unused).
struct State {
    color: wgpu::Texture,
    transmittance: wgpu::Texture,
}

/// What a frame recorded, kept with its statistics slot.
#[derive(Clone, Copy)]
struct FrameTag {
    frame: u64,
    layers: u32,
}

/// A frame of f2b or wboit on a device without storage buffers or compute: the scene, the
/// method's pipelines and targets. Records into the caller's encoder like
/// [`crate::FrameRecorder`] and presents over the caller's color target; statistics come back a
/// frame or more later.
///
/// ```no_run
/// use strata::methods::downlevel::{is_downlevel, DownlevelFrame};
/// use strata::{frame::FrameTargets, gpu::Gpu, scene::Scene, MethodId};
///
/// fn transparent_pass(
///     gpu: &Gpu, // Gpu::from_device(device, queue) on a WebGL2 adapter
///     scene: &Scene,
///     color: &wgpu::TextureView,
///     depth: &wgpu::TextureView, // the opaque scene's Depth32Float depth, bindable
/// ) -> strata::Result<()> {
///     assert!(is_downlevel(gpu)); // else use FrameRecorder
///     let options = strata::RenderOptions::sized(1280, 720);
///     let mut oit = DownlevelFrame::new(gpu, scene, MethodId::F2b, &options)?;
///     // Every frame (and `oit.set_camera(gpu, &camera)` when the camera moves):
///     let mut encoder = gpu.device.create_command_encoder(&Default::default());
///     let format = wgpu::TextureFormat::Rgba8UnormSrgb;
///     let targets = FrameTargets { color: Some((color, format)), opaque_depth: Some(depth) };
///     oit.record(gpu, &mut encoder, &targets)?;
///     gpu.queue.submit([encoder.finish()]);
///     for stats in oit.poll_stats(gpu) {
///         println!("frame {}: complete {:?}, {} layers", stats.frame, stats.exact, oit.layers());
///     }
///     Ok(())
/// }
/// ```
pub struct DownlevelFrame {
    method: MethodId,
    wboit: Option<wboit::Wboit>,
    options: RenderOptions,
    triangle_count: u32,
    vertices: wgpu::Buffer,
    vertex_materials: wgpu::Buffer,
    uniforms: wgpu::Buffer,
    lighting: LightingSetup,
    blend_modes: bool,
    camera: Camera,
    frame_layout: wgpu::BindGroupLayout,
    materials: wgpu::Buffer,
    lights: wgpu::Buffer,
    layer_layout: wgpu::BindGroupLayout,
    accumulate_layout: wgpu::BindGroupLayout,
    present_layout: wgpu::BindGroupLayout,
    peel_first: wgpu::RenderPipeline,
    /// Exact mode's fragment count per pixel ([`DownlevelFrame::count_layers`]), made when
    /// first asked for.
    count: Option<wgpu::RenderPipeline>,
    vertex_module: wgpu::ShaderModule,
    module: wgpu::ShaderModule,
    peel: wgpu::RenderPipeline,
    accumulate: wgpu::RenderPipeline,
    present_module: wgpu::ShaderModule,
    /// Present pipelines (filter, add) per target format.
    presents: Vec<(
        wgpu::TextureFormat,
        wgpu::RenderPipeline,
        wgpu::RenderPipeline,
    )>,
    probe: wgpu::QuerySet,
    probe_results: wgpu::Buffer,
    ring: StatsRing<FrameTag>,
    cache: ResourceCache,
    /// Layers the next frame peels when `--layers` does not fix them.
    next_layers: u32,
    frame: u64,
    /// The last recorded frame's layers.
    last_layers: u32,
    /// The last recorded frame's state targets.
    states: Option<[State; 2]>,
}

impl DownlevelFrame {
    /// Uploads `scene` and makes `method`'s pipelines (one whose descriptor says `downlevel`), refusing
    /// in one line what a downlevel frame cannot hold (options, more than
    /// [`UNIFORM_MATERIALS`] materials or [`UNIFORM_LIGHTS`] lights, more than
    /// [`DOWNLEVEL_MAX_TRIANGLES`] triangles, blend modes wboit cannot blend).
    pub fn new(
        gpu: &Gpu,
        scene: &Scene,
        method: MethodId,
        options: &RenderOptions,
    ) -> Result<DownlevelFrame> {
        options.validate()?;
        scene.validate()?;
        if !method.descriptor().downlevel {
            return Err(refusal(gpu, method));
        }
        check_options(options)?;
        method.descriptor().check_blend(
            &scene.blend_modes(),
            options.frame.family::<KBufferOptions>().tail,
        )?;
        let device = &gpu.device;
        if scene.materials.len() > UNIFORM_MATERIALS {
            return Err(Error::unsupported(format!(
                "the scene has {} materials; on a downlevel device {method} holds at most {UNIFORM_MATERIALS} (a uniform array)",
                scene.materials.len()
            )));
        }
        let lighting = uniforms::lighting(scene);
        if lighting.lights.len() > UNIFORM_LIGHTS {
            return Err(Error::unsupported(format!(
                "the scene has {} lights; on a downlevel device {method} holds at most {UNIFORM_LIGHTS} (a uniform array)",
                lighting.lights.len()
            )));
        }
        let triangles = scene.triangle_count() as u64;
        if triangles > DOWNLEVEL_MAX_TRIANGLES {
            return Err(Error::unsupported(format!(
                "the scene has {triangles} triangles; on a downlevel device {method}'s tags hold at most {DOWNLEVEL_MAX_TRIANGLES}"
            )));
        }
        check_formats(gpu, method)?;
        let list = scene.triangles();
        let vertex_bytes = list.vertices.len() as u64 * std::mem::size_of::<GpuVertex>() as u64;
        if vertex_bytes > gpu.limits.max_buffer_size {
            return Err(Error::unsupported(format!(
                "the scene's {triangles} triangles take {:.1} MiB of vertices, more than the device's largest buffer ({:.1} MiB)",
                vertex_bytes as f64 / 1048576.0,
                gpu.limits.max_buffer_size as f64 / 1048576.0
            )));
        }
        crate::gpu::validated(gpu, &format!("{method} (downlevel)"), || {
            let mut vertices = list.vertices.clone();
            let mut vertex_materials: Vec<u32> =
                list.materials.iter().flat_map(|&m| [m; 3]).collect();
            if vertices.is_empty() {
                // Buffers cannot be empty.
                vertices.push(GpuVertex::default());
                vertex_materials.push(0);
            }
            let mut materials = vec![GpuMaterial::zeroed(); UNIFORM_MATERIALS];
            for (slot, m) in materials.iter_mut().zip(&scene.materials) {
                *slot = uniforms::gpu_material(m);
            }
            let mut lights = vec![GpuLight::zeroed(); UNIFORM_LIGHTS];
            lights[..lighting.lights.len()].copy_from_slice(&lighting.lights);
            let camera = scene.camera_or_framing();
            let blend_modes = !scene.blend_modes().is_empty();
            let u = uniforms::frame_uniforms(&camera, options, &lighting, blend_modes);
            let vertex_usage = wgpu::BufferUsages::VERTEX | wgpu::BufferUsages::COPY_DST;
            let uniform_usage = wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST;
            let frame_layout = binding::layout(
                device,
                "strata.f2b_downlevel.frame.layout",
                &[
                    Slot::Uniform,
                    Slot::Uniform,
                    Slot::Uniform,
                    Slot::TextureDepth,
                ],
            );
            let layer_slots = [Slot::TextureUint, Slot::TextureUint];
            let layer_layout =
                binding::layout(device, "strata.f2b_downlevel.peel.layout", &layer_slots);
            let accumulate_layout = binding::layout(
                device,
                "strata.f2b_downlevel.accumulate.layout",
                &[
                    Slot::TextureUint,
                    Slot::TextureUint,
                    Slot::TextureUint,
                    Slot::TextureUint,
                    Slot::TextureFloat,
                    Slot::TextureUint,
                    Slot::TextureUint,
                ],
            );
            let present_layout = binding::layout(
                device,
                "strata.f2b_downlevel.present.layout",
                &[Slot::TextureUint; 4],
            );
            let [vertex_stage, stage, present_stage, wboit_accumulate, wboit_composite] = stages();
            let vertex_module = vertex_stage.module(device);
            let module = stage.module(device);
            let target = |format| color_target(format, None);
            let vertex_buffers = [Some(GpuVertex::layout()), Some(material_buffer_layout())];
            let peel_pipeline = |entry: &str| {
                render_pipeline(
                    gpu,
                    &format!("strata.f2b_downlevel.{entry}"),
                    wgpu::VertexState {
                        module: &vertex_module,
                        entry_point: Some("vs_scene"),
                        compilation_options: Default::default(),
                        buffers: &vertex_buffers,
                    },
                    (&module, entry),
                    &[&frame_layout, &layer_layout],
                    &[
                        target(COLOR_FORMAT),
                        target(TAG_FORMAT),
                        target(DEPTH_COPY_FORMAT),
                    ],
                    Rasterization {
                        cull_mode: None,
                        depth: Some(wgpu::DepthStencilState {
                            format: wgpu::TextureFormat::Depth32Float,
                            depth_write_enabled: Some(true),
                            depth_compare: Some(wgpu::CompareFunction::Less),
                            stencil: Default::default(),
                            bias: Default::default(),
                        }),
                        samples: 1,
                    },
                )
            };
            let present_module = present_stage.module(device);
            let accumulate = screen_pipeline(
                gpu,
                "strata.f2b_downlevel.accumulate",
                (gpu.fullscreen_vertex_module(), "vs_fullscreen"),
                (&module, "fs_accumulate"),
                &[&frame_layout, &accumulate_layout],
                &[target(STATE_FORMAT), target(STATE_FORMAT)],
                None,
                None,
            );
            let wboit = (method == MethodId::Wboit).then(|| {
                wboit::pipelines(
                    gpu,
                    &frame_layout,
                    (&vertex_module, &vertex_buffers),
                    [&wboit_accumulate, &wboit_composite],
                )
            });
            Ok(DownlevelFrame {
                method,
                wboit,
                triangle_count: list.materials.len() as u32,
                vertices: gpu.buffer_with("strata.f2b_downlevel.vertices", &vertices, vertex_usage),
                vertex_materials: gpu.buffer_with(
                    "strata.f2b_downlevel.vertex_materials",
                    &vertex_materials,
                    vertex_usage,
                ),
                uniforms: gpu.buffer_with(
                    "strata.f2b_downlevel.uniforms",
                    std::slice::from_ref(&u),
                    uniform_usage,
                ),
                materials: gpu.buffer_with(
                    "strata.f2b_downlevel.materials",
                    &materials,
                    uniform_usage,
                ),
                lights: gpu.buffer_with("strata.f2b_downlevel.lights", &lights, uniform_usage),
                options: options.clone(),
                lighting,
                blend_modes,
                camera,
                peel_first: peel_pipeline("fs_peel_first"),
                count: None,
                peel: peel_pipeline("fs_peel"),
                accumulate,
                present_module,
                presents: Vec::new(),
                frame_layout,
                layer_layout,
                accumulate_layout,
                present_layout,
                probe: device.create_query_set(&wgpu::QuerySetDescriptor {
                    label: Some("strata.f2b_downlevel.probe"),
                    ty: wgpu::QueryType::Occlusion,
                    count: 1,
                }),
                probe_results: device.create_buffer(&wgpu::BufferDescriptor {
                    label: Some("strata.f2b_downlevel.probe_results"),
                    size: 8,
                    usage: wgpu::BufferUsages::QUERY_RESOLVE | wgpu::BufferUsages::COPY_SRC,
                    mapped_at_creation: false,
                }),
                ring: StatsRing::default(),
                vertex_module,
                module,
                cache: ResourceCache::default(),
                next_layers: FIRST_GUESS_LAYERS,
                frame: 0,
                last_layers: 0,
                states: None,
            })
        })
    }

    /// The method the frames are recorded with.
    pub fn method(&self) -> MethodId {
        self.method
    }

    /// The options frames are recorded with.
    pub fn options(&self) -> &RenderOptions {
        &self.options
    }

    /// Moves the camera for the next frame.
    pub fn set_camera(&mut self, gpu: &Gpu, camera: &Camera) {
        self.camera = *camera;
        self.write_uniforms(gpu);
    }

    fn write_uniforms(&self, gpu: &Gpu) {
        let u = uniforms::frame_uniforms(
            &self.camera,
            &self.options,
            &self.lighting,
            self.blend_modes,
        );
        gpu.queue
            .write_buffer(&self.uniforms, 0, bytemuck::bytes_of(&u));
    }

    /// Layers the next frame peels: `--layers`, else the first guess grown by every frame
    /// found incomplete.
    pub fn layers(&self) -> u32 {
        self.options
            .frame
            .family::<PeelingOptions>()
            .layers
            .unwrap_or(self.next_layers)
            .clamp(1, MAX_LAYERS)
    }

    /// Peels at least `layers` from the next frame on (the batch renderer, which counted a
    /// picture's depth complexity, sets it).
    pub fn set_layers(&mut self, layers: u32) {
        self.next_layers = layers.clamp(1, MAX_LAYERS);
    }

    /// Binds the scene's vertices and their materials and draws every triangle.
    fn draw_scene(&self, pass: &mut wgpu::RenderPass<'_>) {
        pass.set_vertex_buffer(0, self.vertices.slice(..));
        pass.set_vertex_buffer(1, self.vertex_materials.slice(..));
        pass.draw(0..self.triangle_count * 3, 0..1);
    }

    /// Group 0 of every pass: the uniforms, materials, lights and `opaque`, the opaque depth.
    fn frame_group(&self, gpu: &Gpu, opaque: &wgpu::TextureView) -> wgpu::BindGroup {
        binding::group(
            &gpu.device,
            "strata.downlevel.frame.group",
            &self.frame_layout,
            &[
                self.uniforms.as_entire_binding(),
                self.materials.as_entire_binding(),
                self.lights.as_entire_binding(),
                wgpu::BindingResource::TextureView(opaque),
            ],
        )
    }

    /// Records one frame into `encoder`: the peels and accumulates, the probe, and with a
    /// color target the present over it (`targets.opaque_depth`: fragments at or behind it are
    /// rejected). Submits nothing and waits for nothing; the statistics come back through
    /// [`DownlevelFrame::poll_stats`].
    pub fn record(
        &mut self,
        gpu: &Gpu,
        encoder: &mut wgpu::CommandEncoder,
        targets: &FrameTargets<'_>,
    ) -> Result<()> {
        let (w, h) = (self.options.frame.width, self.options.frame.height);
        if let Some(budget) = self.options.budget_bytes() {
            let need = w as u64 * h as u64 * self.pixel_bytes();
            if need > budget {
                return Err(Error::input(format!(
                    "{} (downlevel): needs {:.2} MiB at {w}x{h}, more than --budget-mb {}",
                    self.method,
                    need as f64 / 1048576.0,
                    self.options.frame.budget_mb.unwrap_or(0.0)
                )));
            }
        }
        if targets.color.is_some() && self.options.frame.effect == Effect::Complexity {
            return Err(Error::unsupported(
                "a downlevel frame presents transparency and translucency; the complexity effect is read back only (Renderer)",
            ));
        }
        let attachment_usage =
            wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::TEXTURE_BINDING;
        let own_opaque = targets.opaque_depth.is_none().then(|| {
            self.cache
                .texture(
                    gpu,
                    "strata.downlevel.no_opaque",
                    (w, h),
                    wgpu::TextureFormat::Depth32Float,
                    attachment_usage,
                )
                .create_view(&Default::default())
        });
        let copy_usage = attachment_usage | wgpu::TextureUsages::COPY_SRC;
        let states = [0, 1].map(|i| State {
            color: self
                .cache
                .texture(gpu, STATE_LABELS[i][0], (w, h), STATE_FORMAT, copy_usage)
                .clone(),
            transmittance: self
                .cache
                .texture(gpu, STATE_LABELS[i][1], (w, h), STATE_FORMAT, copy_usage)
                .clone(),
        });
        let state_views = states.each_ref().map(|s| {
            [
                s.color.create_view(&Default::default()),
                s.transmittance.create_view(&Default::default()),
            ]
        });
        if let Some(own) = &own_opaque {
            clear_depth_pass(encoder, own, 1.0);
        }
        let opaque = targets
            .opaque_depth
            .or(own_opaque.as_ref())
            .expect("one of them");
        let frame_group = self.frame_group(gpu, opaque);
        // Both pairs start as an empty composite: no color, count 0, transmittance 1 (the
        // targets hold f32 bits, and an integer target is cleared to the clear value's integer).
        let one = f64::from(1.0f32.to_bits());
        let transmittance_one = wgpu::Color {
            r: one,
            g: one,
            b: one,
            a: 0.0,
        };
        for pair in &state_views {
            encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
                label: Some("strata.f2b_downlevel.init"),
                color_attachments: &[
                    attachment(&pair[0], wgpu::Color::TRANSPARENT),
                    attachment(&pair[1], transmittance_one),
                ],
                ..Default::default()
            });
        }
        let layers = match self.method {
            MethodId::Wboit => {
                self.record_wboit(gpu, encoder, &frame_group, &state_views[0]);
                0
            }
            _ => self.record_peels(gpu, encoder, &frame_group, &state_views),
        };
        let tag = FrameTag {
            frame: self.frame,
            layers,
        };
        self.ring
            .record(gpu, encoder, &[(self.probe_results.clone(), 0, 2)], tag);
        if let Some((view, format)) = targets.color {
            self.present(gpu, encoder, &state_views, view, format);
        }
        self.frame += 1;
        self.last_layers = layers;
        self.states = Some(states);
        Ok(())
    }

    /// Bytes per pixel of the frame's targets.
    fn pixel_bytes(&self) -> u64 {
        match self.method {
            MethodId::Wboit => WBOIT_PIXEL_BYTES,
            _ => F2B_PIXEL_BYTES,
        }
    }

    /// The present's two draws over `view`: times the transmittance, then plus the color.
    fn present(
        &mut self,
        gpu: &Gpu,
        encoder: &mut wgpu::CommandEncoder,
        states: &[[wgpu::TextureView; 2]; 2],
        view: &wgpu::TextureView,
        format: wgpu::TextureFormat,
    ) {
        if !self.presents.iter().any(|p| p.0 == format) {
            let pipeline = |entry: &str, src, dst| {
                screen_pipeline(
                    gpu,
                    &format!("strata.f2b_downlevel.{entry}"),
                    (gpu.fullscreen_vertex_module(), "vs_fullscreen"),
                    (&self.present_module, entry),
                    &[&self.present_layout],
                    &[color_target(
                        format,
                        Some(wgpu::BlendState {
                            alpha: wgpu::BlendComponent::OVER,
                            ..blend_add(src, dst)
                        }),
                    )],
                    None,
                    None,
                )
            };
            let filter = pipeline(
                "fs_present_filter",
                wgpu::BlendFactor::Zero,
                wgpu::BlendFactor::Src,
            );
            let add = pipeline(
                "fs_present_add",
                wgpu::BlendFactor::One,
                wgpu::BlendFactor::One,
            );
            self.presents.push((format, filter, add));
        }
        let (_, filter, add) = self
            .presents
            .iter()
            .find(|p| p.0 == format)
            .expect("made above");
        let group = binding::group(
            &gpu.device,
            "strata.f2b_downlevel.present.group",
            &self.present_layout,
            &[
                wgpu::BindingResource::TextureView(&states[0][0]),
                wgpu::BindingResource::TextureView(&states[0][1]),
                wgpu::BindingResource::TextureView(&states[1][0]),
                wgpu::BindingResource::TextureView(&states[1][1]),
            ],
        );
        let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
            label: Some("strata.f2b_downlevel.present"),
            color_attachments: &[kept_attachment(view)],
            ..Default::default()
        });
        pass.set_bind_group(0, Some(&group), &[]);
        for pipeline in [filter, add] {
            pass.set_pipeline(pipeline);
            pass.draw(0..3, 0..1);
        }
    }

    /// The statistics of every frame whose results have come back, oldest first, without
    /// waiting. A frame found incomplete (something lay behind its last layer) makes the next
    /// frame peel twice the layers, unless `--layers` fixed them.
    pub fn poll_stats(&mut self, gpu: &Gpu) -> Vec<FrameStats> {
        let done = self.ring.poll(gpu);
        done.into_iter()
            .map(|(tag, words)| self.frame_stats(gpu, tag, words))
            .collect()
    }

    /// Waits for the oldest recorded frame's statistics (exact mode and tests: the CPU blocks).
    pub fn wait_stats(&mut self, gpu: &Gpu) -> Result<FrameStats> {
        loop {
            if let Some(stats) = self.poll_stats(gpu).pop() {
                return Ok(stats);
            }
            if !self.ring.pending() {
                return Err(Error::runtime(
                    "downlevel frame: no frame is waiting for its statistics",
                ));
            }
            gpu.wait()?;
        }
    }

    fn frame_stats(&mut self, gpu: &Gpu, tag: FrameTag, words: Option<Vec<u32>>) -> FrameStats {
        let (w, h) = (self.options.frame.width, self.options.frame.height);
        let mut stats = FrameStats {
            frame: tag.frame,
            method: self.method.as_str().into(),
            width: w,
            height: h,
            effect: self.options.frame.effect.name().into(),
            geometry_passes: 1,
            // wboit approximates, by design.
            exact: Some(false),
            bytes_allocated: w as u64 * h as u64 * self.pixel_bytes(),
            raster: Raster::Hw.name().into(),
            adapter: Some(gpu.info.name.clone()),
            backend: Some(gpu.backend_name()),
            ..Default::default()
        };
        if self.method == MethodId::Wboit {
            return stats;
        }
        let deeper = words.map(|w| w[0] != 0 || w[1] != 0);
        stats.geometry_passes = tag.layers + 1;
        stats.exact = deeper.map(|d| !d);
        let fixed = self
            .options
            .frame
            .family::<PeelingOptions>()
            .layers
            .is_some();
        if deeper == Some(true) && !fixed {
            self.next_layers = self
                .next_layers
                .max(tag.layers.saturating_mul(2))
                .min(MAX_LAYERS);
        }
        stats
    }

    /// Layers the last recorded frame peeled.
    pub fn last_layers(&self) -> u32 {
        self.last_layers
    }

    /// Reads the last recorded frame's pixels back after it was submitted (blocking): each
    /// pixel's [`Resolved`] value, its count the layers composited there.
    pub fn read_resolved(&self, gpu: &Gpu) -> Result<Vec<Resolved>> {
        let states = self
            .states
            .as_ref()
            .ok_or_else(|| Error::runtime("downlevel frame: no frame was recorded"))?;
        let texels = |texture: &wgpu::Texture| -> Result<Vec<[f32; 4]>> {
            let bytes = crate::gpu::readback::read_texture(gpu, texture)?;
            Ok(bytemuck::pod_collect_to_vec(&bytes))
        };
        let [a_color, a_trans, b_color, b_trans] = [
            texels(&states[0].color)?,
            texels(&states[0].transmittance)?,
            texels(&states[1].color)?,
            texels(&states[1].transmittance)?,
        ];
        Ok((0..a_color.len())
            .map(|i| {
                let (c, t) = if b_color[i][3] > a_color[i][3] {
                    (b_color[i], b_trans[i])
                } else {
                    (a_color[i], a_trans[i])
                };
                Resolved {
                    color: [c[0], c[1], c[2]],
                    count: c[3] as u32,
                    transmittance: [t[0], t[1], t[2]],
                    _spare: 0,
                }
            })
            .collect())
    }
}

const STATE_LABELS: [[&str; 2]; 2] = [
    [
        "strata.f2b_downlevel.state0.color",
        "strata.f2b_downlevel.state0.transmittance",
    ],
    [
        "strata.f2b_downlevel.state1.color",
        "strata.f2b_downlevel.state1.transmittance",
    ],
];

/// The material index at vertex-buffer slot 1, `@location(2)` of `vs_scene` with UNIFORM_SCENE.
const MATERIAL_ATTRIBUTE: [wgpu::VertexAttribute; 1] = wgpu::vertex_attr_array![2 => Uint32];

/// Vertex-buffer slot 1: each vertex's material.
fn material_buffer_layout() -> wgpu::VertexBufferLayout<'static> {
    wgpu::VertexBufferLayout {
        array_stride: 4,
        step_mode: wgpu::VertexStepMode::Vertex,
        attributes: &MATERIAL_ATTRIBUTE,
    }
}

/// The stages of a downlevel frame, all composed with UNIFORM_SCENE: the scene's vertex stage,
/// f2b's peels and accumulate, the present (with the full-screen vertex stage), wboit's
/// accumulate and composite.
pub(crate) fn stages() -> [Stage; 5] {
    let defs = Defs::default().flag("UNIFORM_SCENE");
    let weighted = |label: &str, source: &'static str| {
        Stage::new(label, source)
            .with(weighted::LIBRARY)
            .defs(&defs)
    };
    [
        Stage::new("strata.downlevel.vertex", crate::gpu::shader::SCENE).defs(&defs),
        Stage::new("strata.f2b_downlevel", include_str!("f2b.wgsl")).defs(&defs),
        Stage::new("strata.downlevel.present", include_str!("present.wgsl")),
        weighted(
            "strata.wboit_downlevel.accumulate",
            include_str!("../weighted/wboit_accumulate.wgsl"),
        ),
        weighted("strata.wboit_downlevel.composite", weighted::COMPOSITE_WGSL),
    ]
}

/// Refuses, in one line, a device that cannot draw into `method`'s targets (a WebGL2 context
/// without EXT_color_buffer_float renders to none of the float formats) or blend into wboit's.
fn check_formats(gpu: &Gpu, method: MethodId) -> Result<()> {
    let Some(adapter) = &gpu.adapter else {
        // The application's device: its adapter is not known here, and wgpu refuses a target
        // it cannot render to when the frame makes it.
        return Ok(());
    };
    let (formats, blended): (&[wgpu::TextureFormat], bool) = match method {
        MethodId::Wboit => (&[ACCUMULATION_FORMAT, REVEALAGE_FORMAT, COUNT_FORMAT], true),
        _ => (&[COLOR_FORMAT, TAG_FORMAT, DEPTH_COPY_FORMAT], false),
    };
    let missing: Vec<String> = formats
        .iter()
        .chain(&[STATE_FORMAT])
        .filter(|&&f| {
            let features = adapter.get_texture_format_features(f);
            let blends = features
                .flags
                .contains(wgpu::TextureFormatFeatureFlags::BLENDABLE);
            !features
                .allowed_usages
                .contains(wgpu::TextureUsages::RENDER_ATTACHMENT)
                || (blended && f != STATE_FORMAT && !blends)
        })
        .map(|f| format!("{f:?}"))
        .collect();
    if missing.is_empty() {
        return Ok(());
    }
    Err(Error::unsupported(format!(
        "'{}' cannot {} {}, which {method}'s targets on a downlevel device need (on WebGL2: EXT_color_buffer_float)",
        gpu.info.name,
        if blended { "render and blend to" } else { "render to" },
        missing.join(", ")
    )))
}

/// Refuses, in one line, the options a downlevel frame has no way to honour.
fn check_options(options: &RenderOptions) -> Result<()> {
    let (build, frame) = (&options.build, &options.frame);
    let refused = if build.msaa > 1 {
        Some("--msaa")
    } else if build.raster != Raster::Hw {
        Some("--raster compute")
    } else if build.lighting.pipeline.is_some() {
        Some("--pipeline")
    } else if frame.order.is_some_and(|o| o != crate::order::Order::Scene) {
        Some("--order")
    } else if frame.temporal.is_some() {
        Some("--temporal")
    } else if frame.band.is_some() {
        Some("pictures in bands")
    } else {
        None
    };
    match refused {
        Some(what) => Err(Error::unsupported(format!(
            "{what}: not available on a downlevel device, where f2b peels through render targets (no storage buffers, no compute)"
        ))),
        None => Ok(()),
    }
}

mod peel;
#[cfg(test)]
mod tests;
mod wboit;
