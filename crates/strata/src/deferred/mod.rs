//! Lit opaque surfaces under many lights (seed 004), and the full frame around a transparent
//! method: `--pipeline forward|deferred`.
//!
//! With a pipeline, a scene splits by opacity ([`Scene::split_by_opacity`]): opaque objects are
//! drawn here into a lit HDR image and a depth buffer; the transparent ones go through the
//! multi-fragment method, which rejects fragments behind that depth and presents OVER the lit
//! image; the tone map then composites the result over the picture's background.
//!
//! Passes of the **deferred** pipeline:
//! 1. `deferred.gbuffer` — geometry pass, depth test LESS, into seed 004's compressed layout:
//!    RGBA8 sRGB (albedo RGB + 8-bit material id: 256 materials), RGB10A2 (view-space normal in
//!    two 10-bit channels by the spheremap transform, or octahedral; the specular exponent / 1023
//!    in the third), Depth32Float. No position target: world positions come back from depth and
//!    the inverse view-projection.
//! 2. `deferred.ssao` and `deferred.ssao_blur` (with `--ssao`): 16-sample hemisphere occlusion
//!    from depth and normals, a 4×4 blur; it scales the ambient term.
//! 3. `deferred.lighting` — one instanced draw per volume kind: spheres (point lights, and spots
//!    wider than 75°), cones (spots), full-screen triangles (directional lights, and volumes that
//!    reach past the far plane). Frustum culling on the CPU when the camera moves. Back faces,
//!    depth GREATER_EQUAL against the G-buffer depth (correct with the camera inside a volume);
//!    diffuse and specular added into two Rgba16Float light buffers.
//! 4. `deferred.composite` — albedo × (ambient·AO + diffuse) + specular; unlit materials show
//!    their albedo; a scene without lights gets the headlight here.
//! 5. `deferred.debug` (with `--gbuffer-debug VIEW`) — a G-buffer view over the frame.
//!
//! The **forward** pipeline draws the opaque objects once with depth test LESS and shades every
//! fragment with every light (`shade`, the loop the transparent methods use too) — seed 004's
//! comparison. Both use one lighting formula (`light_terms` in scene.wgsl): Blinn–Phong with
//! attenuation 1 / (a + b·d + c·d²) windowed to zero at the light's range. Transparent surfaces
//! are lit per fragment with the whole light list by the method's own shading: every method
//! already shades in its capture stage, the list is the same buffer, and the answer stays exact
//! against the reference (a clustered light list would cut the cost with thousands of lights; it
//! is not built).
//!
//! Memory per pixel: deferred 12 B of G-buffer (4 + 4 + 4 with Depth32Float; seed 004's layout
//! with 24-bit depth is 11 B), 16 B of light buffers, 8 B of HDR color, 4 B of ambient
//! occlusion when on; forward 8 B of HDR color and 4 B of depth. The traditional layout seed 004
//! compares with (three RGBA16 targets and depth) is 28 B. See [`gbuffer_bytes_per_pixel`].
//!
//! Differences deferred vs forward come only from the G-buffer's quantization: albedo in 8-bit
//! sRGB (clamped to [0, 1]), the normal in 10-bit channels (spheremap: at most 0.22° for normals
//! facing the view axis, 0.30° within a square 45° view, 0.42° within a 97° diagonal;
//! octahedral: 0.24° for every direction; `encoding.rs` measures both), and world positions
//! rebuilt from f32 depth. Specular exponents are integers 1–1023 in both pipelines.

pub mod encoding;
pub mod volumes;

mod targets;

use std::collections::HashMap;

use bytemuck::Zeroable;

use crate::gpu::twin::{gpu_struct, wgsl_constants, wgsl_module};
use glam::Mat4;

use crate::error::{Error, Result};
use crate::frame::passes::{self, color_target, screen_pipeline};
use crate::frame::scene_gpu::SceneGpu;
use crate::frame::uniforms::{self, GpuLight};
use crate::frame::RenderOptions;
pub use crate::frame::{GbufferView, LightingStats, NormalEncoding, Tonemap};
use crate::gpu::binding::{self, Slot};
use crate::gpu::shader::{Library, Stage};
use crate::gpu::timing::Timer;
use crate::gpu::Gpu;
pub use crate::scene::Pipeline;
use crate::scene::{Camera, Scene};
use targets::{view, Targets};

/// G-buffer layouts for the bandwidth comparison.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum GbufferLayout {
    /// Seed 004's Table 2, with Depth32Float: RGBA8 + RGB10A2 + depth.
    Compressed,
    /// Seed 004's Table 1: three RGBA16 targets (position, normal, albedo) + depth.
    Traditional,
}

/// Bytes per pixel of a G-buffer layout (depth as 4 bytes).
pub fn gbuffer_bytes_per_pixel(layout: GbufferLayout) -> u64 {
    match layout {
        GbufferLayout::Compressed => 4 + 4 + 4,
        GbufferLayout::Traditional => 3 * 8 + 4,
    }
}

gpu_struct! {
    /// The deferred stages' uniforms (`strata::deferred::params`), bound as `params` by
    /// deferred_common.wgsl.
    pub struct DeferredParams {
        /// Clip to world, to rebuild positions from depth.
        pub inv_view_proj: [[f32; 4]; 4],
        /// [`NormalEncoding`] as the shaders number it: 0 spheremap (seed 004), 1 octahedral.
        pub normal_encoding: u32,
        /// 1 with screen-space ambient occlusion.
        pub ssao: u32,
        /// The debug view's [`GbufferView::index`] (read by the debug pass only).
        pub debug_view: u32,
        /// [`Tonemap`] as the shaders number it: 0 none, 1 neutral, 2 Reinhard.
        pub tonemap: u32,
        /// SSAO's sampling radius in world units (a fraction of the scene's bounding box
        /// diagonal).
        pub ssao_radius: f32,
        /// How strongly SSAO darkens (0: not at all).
        pub ssao_strength: f32,
        /// First vertex of the cone mesh in the volume vertex buffer (`volume_vertices`; the
        /// sphere starts at 0).
        pub cone_first: u32,
        pad_a: u32,
    }
}

/// `strata::deferred::params`: [`DeferredParams`] for deferred_common.wgsl.
const PARAMS_WGSL: &str = wgsl_module!("strata::deferred::params", DeferredParams);

const HDR_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba16Float;
const DEPTH_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Depth32Float;
const ALBEDO_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba8UnormSrgb;
const NORMAL_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgb10a2Unorm;
/// The unencoded normal's f32 bits: integer targets render on every backend, 32-bit float ones
/// not on GL.
const EXACT_NORMAL_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba32Uint;
const LIGHT_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba16Float;
const AO_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::R16Float;

/// SSAO radius as a fraction of the opaque scene's bounding diagonal.
const SSAO_RADIUS_FRACTION: f32 = 0.05;
const SSAO_STRENGTH: f32 = 1.5;

/// The G-buffer bindings each pass reads (indices in deferred_common.wgsl).
const GBUFFER_SLOTS: [(u32, Slot); 1] = [(0, Slot::Uniform)];
/// The G-buffer's reads: uniforms, albedo, normals, depth; SSAO binds exactly these.
const SSAO_SLOTS: [(u32, Slot); 4] = [
    (0, Slot::Uniform),
    (1, Slot::TextureFloat),
    (2, Slot::TextureFloat),
    (3, Slot::TextureDepth),
];
const SSAO_BLUR_SLOTS: [(u32, Slot); 2] = [(0, Slot::Uniform), (7, Slot::TextureFloat)];
/// Lighting: the G-buffer and the lights and their volumes.
const LIGHTING_EXTRA: [(u32, Slot); 2] = [(8, Slot::Storage), (9, Slot::Storage)];
/// Composite: the G-buffer, the two light sums and the occlusion.
const COMPOSITE_EXTRA: [(u32, Slot); 3] = [
    (4, Slot::TextureFloat),
    (5, Slot::TextureFloat),
    (6, Slot::TextureFloat),
];
/// Debug views: the composite's bindings and the exact normals.
const DEBUG_EXTRA: [(u32, Slot); 4] = [
    (4, Slot::TextureFloat),
    (5, Slot::TextureFloat),
    (6, Slot::TextureFloat),
    (10, Slot::TextureUint),
];

/// The G-buffer's reads followed by a pass's own bindings.
fn reading_gbuffer(extra: &[(u32, Slot)]) -> Vec<(u32, Slot)> {
    SSAO_SLOTS.iter().chain(extra).copied().collect()
}
const TONEMAP_SLOTS: [(u32, Slot); 2] = [(0, Slot::Uniform), (11, Slot::TextureFloat)];

/// The deferred bindings and helpers.
const COMMON_WGSL: &str = include_str!("deferred_common.wgsl");

/// The pipeline's WGSL modules (`strata::deferred::…`): the deferred bindings and helpers, and
/// the stages.
pub const LIBRARY: Library = &[
    PARAMS_WGSL,
    VIEWS_WGSL,
    COMMON_WGSL,
    include_str!("gbuffer.wgsl"),
    include_str!("forward.wgsl"),
    include_str!("lighting.wgsl"),
    include_str!("composite.wgsl"),
    include_str!("ssao.wgsl"),
    include_str!("debug.wgsl"),
    include_str!("tonemap.wgsl"),
];

/// `strata::deferred::views`: the debug views' numbers ([`GbufferView::index`]) for debug.wgsl.
const VIEWS_WGSL: &str = wgsl_constants!(
    "strata::deferred::views",
    VIEW_ALBEDO = GbufferView::Albedo as u32,
    VIEW_NORMAL = GbufferView::Normal as u32,
    VIEW_SPECULAR = GbufferView::Specular as u32,
    VIEW_MATERIAL = GbufferView::Material as u32,
    VIEW_DEPTH = GbufferView::Depth as u32,
    VIEW_LIGHTS = GbufferView::Lights as u32,
    VIEW_NORMAL_ERROR = GbufferView::NormalError as u32,
);

/// The pipeline's stage `index` in [`STAGES`].
pub fn stage(index: usize) -> Stage {
    let (label, source) = STAGES[index];
    Stage::new(label, source).with(LIBRARY)
}

/// The pipeline's stages: (label, WGSL source), in the order [`stage`] indexes them.
pub const STAGES: [(&str, &str); 7] = [
    ("strata.deferred.gbuffer", include_str!("gbuffer.wgsl")),
    ("strata.forward.opaque", include_str!("forward.wgsl")),
    ("strata.deferred.lighting", include_str!("lighting.wgsl")),
    ("strata.deferred.composite", include_str!("composite.wgsl")),
    ("strata.deferred.ssao", include_str!("ssao.wgsl")),
    ("strata.deferred.debug", include_str!("debug.wgsl")),
    ("strata.tonemap", include_str!("tonemap.wgsl")),
];

fn module(gpu: &Gpu, index: usize) -> wgpu::ShaderModule {
    stage(index).module(&gpu.device)
}

/// The pipelines, layouts and bind groups of the lit passes.
struct Passes {
    forward: wgpu::RenderPipeline,
    gbuffer: wgpu::RenderPipeline,
    gbuffer_exact: wgpu::RenderPipeline,
    ssao: wgpu::RenderPipeline,
    ssao_blur: wgpu::RenderPipeline,
    sphere_lights: wgpu::RenderPipeline,
    cone_lights: wgpu::RenderPipeline,
    full_screen_lights: wgpu::RenderPipeline,
    /// Whether the lighting pass tests the volumes against the G-buffer depth as its depth
    /// attachment (else in the shader: `Gpu::reads_bound_depth_attachment`).
    lights_depth_attachment: bool,
    composite: wgpu::RenderPipeline,
    debug: wgpu::RenderPipeline,
    tonemap_module: wgpu::ShaderModule,
    tonemap: HashMap<wgpu::TextureFormat, wgpu::RenderPipeline>,
    /// The background drawn under the HDR image (made on first use).
    background_under: Option<wgpu::RenderPipeline>,
    layouts: Layouts,
}

struct Layouts {
    gbuffer: wgpu::BindGroupLayout,
    ssao: wgpu::BindGroupLayout,
    ssao_blur: wgpu::BindGroupLayout,
    lighting: wgpu::BindGroupLayout,
    composite: wgpu::BindGroupLayout,
    debug: wgpu::BindGroupLayout,
    tonemap: wgpu::BindGroupLayout,
}

fn depth_state(write: bool, compare: wgpu::CompareFunction) -> Option<wgpu::DepthStencilState> {
    Some(wgpu::DepthStencilState {
        format: DEPTH_FORMAT,
        depth_write_enabled: Some(write),
        depth_compare: Some(compare),
        stencil: Default::default(),
        bias: Default::default(),
    })
}

impl Passes {
    fn new(gpu: &Gpu, frame_layout: &wgpu::BindGroupLayout) -> Passes {
        let device = &gpu.device;
        let layouts = Layouts {
            gbuffer: binding::layout_at(device, "strata.deferred.gbuffer", &GBUFFER_SLOTS),
            ssao: binding::layout_at(device, "strata.deferred.ssao", &SSAO_SLOTS),
            ssao_blur: binding::layout_at(device, "strata.deferred.ssao_blur", &SSAO_BLUR_SLOTS),
            lighting: binding::layout_at(
                device,
                "strata.deferred.lighting",
                &reading_gbuffer(&LIGHTING_EXTRA),
            ),
            composite: binding::layout_at(
                device,
                "strata.deferred.composite",
                &reading_gbuffer(&COMPOSITE_EXTRA),
            ),
            debug: binding::layout_at(
                device,
                "strata.deferred.debug",
                &reading_gbuffer(&DEBUG_EXTRA),
            ),
            tonemap: binding::layout_at(device, "strata.tonemap", &TONEMAP_SLOTS),
        };
        let modules: Vec<wgpu::ShaderModule> = (0..STAGES.len()).map(|i| module(gpu, i)).collect();
        let [gbuffer_m, forward_m, lighting_m, composite_m, ssao_m, debug_m, tonemap_m] =
            <[wgpu::ShaderModule; 7]>::try_from(modules).expect("seven stages");
        let write_less = depth_state(true, wgpu::CompareFunction::Less);
        let additive = wgpu::BlendState {
            color: wgpu::BlendComponent {
                src_factor: wgpu::BlendFactor::One,
                dst_factor: wgpu::BlendFactor::One,
                operation: wgpu::BlendOperation::Add,
            },
            alpha: wgpu::BlendComponent::REPLACE,
        };
        let light_targets = [
            color_target(LIGHT_FORMAT, Some(additive)),
            color_target(LIGHT_FORMAT, Some(additive)),
        ];
        let gbuffer_targets = [
            color_target(ALBEDO_FORMAT, None),
            color_target(NORMAL_FORMAT, None),
        ];
        // Where the G-buffer depth cannot be a depth attachment and a bound texture in one pass,
        // the volumes test it in the shader and the lighting pass has no depth attachment.
        let shader_tested = !gpu.reads_bound_depth_attachment();
        let light_entry = if shader_tested {
            "fs_light_tested"
        } else {
            "fs_light"
        };
        let light_depth = |compare| {
            (!shader_tested)
                .then(|| depth_state(false, compare))
                .flatten()
        };
        let volume = |label, entry| {
            screen_pipeline(
                gpu,
                label,
                (&lighting_m, entry),
                (&lighting_m, light_entry),
                &[frame_layout, &layouts.lighting],
                &light_targets,
                Some(wgpu::Face::Front),
                light_depth(wgpu::CompareFunction::GreaterEqual),
            )
        };
        let fullscreen = |label, module, entry, layout, format| {
            screen_pipeline(
                gpu,
                label,
                (gpu.fullscreen_vertex_module(), "vs_fullscreen"),
                (module, entry),
                &[frame_layout, layout],
                &[color_target(format, None)],
                None,
                None,
            )
        };
        let capture = |label, module, entry, layouts: &[&wgpu::BindGroupLayout], targets: &[_]| {
            passes::capture_pipeline(
                gpu,
                label,
                (module, entry),
                layouts,
                targets,
                write_less.clone(),
                1,
            )
        };
        let gbuffer_layouts = [frame_layout, &layouts.gbuffer];
        Passes {
            forward: capture(
                "strata.forward.opaque",
                &forward_m,
                "fs_forward",
                &[frame_layout],
                &[color_target(HDR_FORMAT, None)],
            ),
            gbuffer: capture(
                "strata.deferred.gbuffer",
                &gbuffer_m,
                "fs_gbuffer",
                &gbuffer_layouts,
                &gbuffer_targets,
            ),
            gbuffer_exact: capture(
                "strata.deferred.gbuffer_exact",
                &gbuffer_m,
                "fs_gbuffer_exact",
                &gbuffer_layouts,
                &[
                    gbuffer_targets[0].clone(),
                    gbuffer_targets[1].clone(),
                    color_target(EXACT_NORMAL_FORMAT, None),
                ],
            ),
            ssao: fullscreen(
                "strata.deferred.ssao",
                &ssao_m,
                "fs_ssao",
                &layouts.ssao,
                AO_FORMAT,
            ),
            ssao_blur: fullscreen(
                "strata.deferred.ssao_blur",
                &ssao_m,
                "fs_ssao_blur",
                &layouts.ssao_blur,
                AO_FORMAT,
            ),
            sphere_lights: volume("strata.deferred.lighting.spheres", "vs_sphere_volume"),
            cone_lights: volume("strata.deferred.lighting.cones", "vs_cone_volume"),
            full_screen_lights: screen_pipeline(
                gpu,
                "strata.deferred.lighting.full_screen",
                (&lighting_m, "vs_fullscreen_light"),
                (&lighting_m, "fs_light"),
                &[frame_layout, &layouts.lighting],
                &light_targets,
                None,
                light_depth(wgpu::CompareFunction::Always),
            ),
            lights_depth_attachment: !shader_tested,
            composite: fullscreen(
                "strata.deferred.composite",
                &composite_m,
                "fs_composite",
                &layouts.composite,
                HDR_FORMAT,
            ),
            debug: fullscreen(
                "strata.deferred.debug",
                &debug_m,
                "fs_debug",
                &layouts.debug,
                HDR_FORMAT,
            ),
            tonemap_module: tonemap_m,
            tonemap: HashMap::new(),
            background_under: None,
            layouts,
        }
    }
}

/// Bind groups over the current targets.
struct Groups {
    gbuffer: wgpu::BindGroup,
    ssao: wgpu::BindGroup,
    ssao_blur: wgpu::BindGroup,
    lighting: wgpu::BindGroup,
    composite: wgpu::BindGroup,
    debug: wgpu::BindGroup,
    tonemap: wgpu::BindGroup,
}

/// The lit opaque frame: owns the opaque objects' scene buffers, the targets and the passes.
pub struct LitFrame {
    gpu: Gpu,
    pipeline: Pipeline,
    options: RenderOptions,
    scene: SceneGpu,
    /// False when the scene has no opaque objects: the passes only clear.
    has_opaque: bool,
    lights: Vec<GpuLight>,
    visible: volumes::VisibleLights,
    visible_buffer: wgpu::Buffer,
    volume_buffer: wgpu::Buffer,
    sphere_vertices: u32,
    cone_vertices: u32,
    cone_first: u32,
    params: wgpu::Buffer,
    ssao_radius: f32,
    /// A depth texture for group 0's opaque-depth binding, which these passes do not read.
    unused_depth: wgpu::Texture,
    targets: Targets,
    passes: Passes,
    groups: Groups,
}

impl LitFrame {
    /// `opaque` holds the opaque objects (it may have none) with the frame's camera and lights.
    pub fn new(
        gpu: &Gpu,
        pipeline: Pipeline,
        opaque: &Scene,
        options: &RenderOptions,
    ) -> Result<LitFrame> {
        let has_opaque = !opaque.objects.is_empty();
        if pipeline == Pipeline::Deferred && opaque.materials.len() > 256 {
            return Err(Error::unsupported(format!(
                "--pipeline deferred: the G-buffer's 8-bit material id holds 256 materials; the opaque objects use {}",
                opaque.materials.len()
            )));
        }
        let scene = SceneGpu::new_allow_empty(gpu, opaque, options)?;
        let lights = uniforms::lighting(opaque).lights;
        let meshes = volumes::meshes();
        let storage =
            |label: &str, bytes: u64| gpu.storage_buffer(label, bytes, wgpu::BufferUsages::empty());
        let volume_buffer = storage(
            "strata.deferred.volume_meshes",
            (meshes.vertices.len() * 16) as u64,
        )?;
        gpu.queue
            .write_buffer(&volume_buffer, 0, bytemuck::cast_slice(&meshes.vertices));
        let visible_buffer = storage(
            "strata.deferred.visible_lights",
            (lights.len().max(1) * 4) as u64,
        )?;
        let params = gpu.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("strata.deferred.params"),
            size: std::mem::size_of::<DeferredParams>() as u64,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let (lo, hi) = if has_opaque {
            opaque.bounds()
        } else {
            (glam::Vec3::ZERO, glam::Vec3::ONE)
        };
        let passes = Passes::new(gpu, &scene.frame_layout);
        let targets = Targets::new(gpu, pipeline, options);
        let groups = Self::make_groups(
            gpu,
            &passes.layouts,
            &targets,
            &params,
            &visible_buffer,
            &volume_buffer,
        );
        let unused_depth = gpu.texture_2d(
            "strata.lit.unused_depth",
            (1, 1),
            DEPTH_FORMAT,
            wgpu::TextureUsages::TEXTURE_BINDING,
        );
        let mut lit = LitFrame {
            gpu: gpu.clone(),
            pipeline,
            options: options.clone(),
            has_opaque,
            lights,
            visible: Default::default(),
            visible_buffer,
            volume_buffer,
            sphere_vertices: meshes.sphere_vertices,
            cone_vertices: meshes.cone_vertices,
            cone_first: meshes.cone_first,
            params,
            ssao_radius: SSAO_RADIUS_FRACTION * (hi - lo).length(),
            unused_depth,
            targets,
            passes,
            groups,
            scene,
        };
        let camera = lit.scene.camera;
        lit.set_camera(&camera, options);
        Ok(lit)
    }

    fn make_groups(
        gpu: &Gpu,
        layouts: &Layouts,
        t: &Targets,
        params: &wgpu::Buffer,
        visible: &wgpu::Buffer,
        volumes: &wgpu::Buffer,
    ) -> Groups {
        let views: HashMap<u32, wgpu::TextureView> = [
            (1, &t.albedo),
            (2, &t.normal),
            (3, &t.depth),
            (4, &t.diffuse),
            (5, &t.specular),
            (6, &t.ao),
            (7, &t.ao_raw),
            (10, &t.exact_normal),
            (11, &t.hdr),
        ]
        .into_iter()
        .map(|(i, tex)| (i, view(tex)))
        .collect();
        let group = |label: &str, layout: &wgpu::BindGroupLayout, slots: &[(u32, Slot)]| {
            let entries: Vec<(u32, wgpu::BindingResource<'_>)> = slots
                .iter()
                .map(|&(i, _)| {
                    let resource = match i {
                        0 => params.as_entire_binding(),
                        8 => visible.as_entire_binding(),
                        9 => volumes.as_entire_binding(),
                        _ => wgpu::BindingResource::TextureView(&views[&i]),
                    };
                    (i, resource)
                })
                .collect();
            binding::group_at(&gpu.device, label, layout, &entries)
        };
        Groups {
            gbuffer: group("strata.deferred.gbuffer", &layouts.gbuffer, &GBUFFER_SLOTS),
            ssao: group("strata.deferred.ssao", &layouts.ssao, &SSAO_SLOTS),
            ssao_blur: group(
                "strata.deferred.ssao_blur",
                &layouts.ssao_blur,
                &SSAO_BLUR_SLOTS,
            ),
            lighting: group(
                "strata.deferred.lighting",
                &layouts.lighting,
                &reading_gbuffer(&LIGHTING_EXTRA),
            ),
            composite: group(
                "strata.deferred.composite",
                &layouts.composite,
                &reading_gbuffer(&COMPOSITE_EXTRA),
            ),
            debug: group(
                "strata.deferred.debug",
                &layouts.debug,
                &reading_gbuffer(&DEBUG_EXTRA),
            ),
            tonemap: group("strata.tonemap", &layouts.tonemap, &TONEMAP_SLOTS),
        }
    }

    /// Forward or deferred.
    pub fn pipeline(&self) -> Pipeline {
        self.pipeline
    }

    /// The lit HDR image (Rgba16Float, premultiplied, alpha = coverage): opaque surfaces after
    /// [`LitFrame::record`], the transparent method's result once it presented over it.
    pub fn hdr(&self) -> &wgpu::Texture {
        &self.targets.hdr
    }

    /// The opaque surfaces' depth (Depth32Float), what the transparent method tests against.
    pub fn depth(&self) -> &wgpu::Texture {
        &self.targets.depth
    }

    /// Moves the camera (and takes new options: size, tone map, background); rewrites the
    /// uniforms and the visible-light list.
    pub fn set_camera(&mut self, camera: &Camera, options: &RenderOptions) {
        if (options.frame.width, options.frame.height) != self.targets.size
            || options.build.lighting.ssao != self.options.build.lighting.ssao
            || options.build.lighting.gbuffer_debug != self.options.build.lighting.gbuffer_debug
        {
            self.targets = Targets::new(&self.gpu, self.pipeline, options);
            self.groups = Self::make_groups(
                &self.gpu,
                &self.passes.layouts,
                &self.targets,
                &self.params,
                &self.visible_buffer,
                &self.volume_buffer,
            );
        }
        self.options = options.clone();
        self.scene.update(&self.gpu, camera, options);
        let aspect = options.frame.width as f32 / options.frame.height as f32;
        let view_proj: Mat4 = camera.view_projection(aspect);
        self.visible = volumes::classify(&self.lights, camera, aspect);
        if !self.visible.indices.is_empty() {
            self.gpu.queue.write_buffer(
                &self.visible_buffer,
                0,
                bytemuck::cast_slice(&self.visible.indices),
            );
        }
        let params = DeferredParams {
            inv_view_proj: view_proj.inverse().to_cols_array_2d(),
            normal_encoding: options.build.lighting.normal_encoding as u32,
            ssao: options.build.lighting.ssao as u32,
            debug_view: options
                .build
                .lighting
                .gbuffer_debug
                .map(GbufferView::index)
                .unwrap_or(0),
            tonemap: options.build.lighting.tonemap as u32,
            ssao_radius: self.ssao_radius,
            ssao_strength: SSAO_STRENGTH,
            cone_first: self.cone_first,
            ..Zeroable::zeroed()
        };
        self.gpu
            .queue
            .write_buffer(&self.params, 0, bytemuck::bytes_of(&params));
    }

    /// Replaces the opaque objects' geometry (an animation's next time step).
    pub fn set_geometry(&mut self, opaque: &Scene) -> Result<()> {
        if !self.scene.update_geometry(&self.gpu, opaque)? {
            return Err(Error::input(
                "the opaque objects' triangle count changed between frames",
            ));
        }
        Ok(())
    }

    /// Moves the opaque objects to time `t` (frames) for the next frame, on the GPU.
    pub fn set_time(&mut self, t: f32) {
        self.scene.set_time(t);
    }

    /// What the lit frame reports: lights drawn and culled, G-buffer size, bytes allocated.
    pub fn stats(&self) -> LightingStats {
        let deferred = self.pipeline == Pipeline::Deferred;
        let v = &self.visible;
        LightingStats {
            pipeline: self.pipeline.name().into(),
            lights: self.lights.len() as u32,
            sphere_volumes: deferred.then_some(v.spheres),
            cone_volumes: deferred.then_some(v.cones),
            full_screen_lights: deferred.then_some(v.full_screen),
            culled_lights: deferred.then_some(v.culled),
            gbuffer_bytes_per_pixel: deferred
                .then(|| gbuffer_bytes_per_pixel(GbufferLayout::Compressed)),
            bytes_allocated: self.targets.bytes,
            tonemap: self.options.build.lighting.tonemap,
            ssao: deferred && self.options.build.lighting.ssao,
        }
    }

    /// Records the opaque passes into `encoder`: the HDR image and the depth are cleared, then
    /// drawn (forward, or G-buffer, SSAO, lighting, composite and the debug view).
    pub fn record(&mut self, encoder: &mut wgpu::CommandEncoder, timer: &mut Timer) {
        if let Some(animation) = &mut self.scene.animation {
            animation.record(&self.gpu, encoder, timer);
        }
        let unused = view(&self.unused_depth);
        let frame = self.scene.frame_group(&self.gpu, &unused);
        let hdr = view(&self.targets.hdr);
        let depth = view(&self.targets.depth);
        let clear = wgpu::Color::TRANSPARENT;
        let triangles = if self.has_opaque {
            self.scene.triangle_count * 3
        } else {
            0
        };
        let scene = &self.scene;
        let depth_attachment = |view, clear_depth: bool| {
            Some(wgpu::RenderPassDepthStencilAttachment {
                view,
                depth_ops: clear_depth.then_some(wgpu::Operations {
                    load: wgpu::LoadOp::Clear(1.0),
                    store: wgpu::StoreOp::Store,
                }),
                stencil_ops: None,
            })
        };
        if self.pipeline == Pipeline::Forward {
            let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
                label: Some("strata.forward.opaque"),
                color_attachments: &[passes::attachment(&hdr, clear)],
                depth_stencil_attachment: depth_attachment(&depth, true),
                timestamp_writes: timer.render_pass("forward.opaque"),
                occlusion_query_set: None,
                multiview_mask: None,
            });
            pass.set_pipeline(&self.passes.forward);
            pass.set_bind_group(0, Some(&frame), &[]);
            scene.bind(&mut pass);
            pass.draw(0..triangles, 0..1);
            return;
        }
        let (albedo, normal, exact) = (
            view(&self.targets.albedo),
            view(&self.targets.normal),
            view(&self.targets.exact_normal),
        );
        let exact_normals =
            self.options.build.lighting.gbuffer_debug == Some(GbufferView::NormalError);
        {
            let mut colors = vec![
                passes::attachment(&albedo, clear),
                passes::attachment(&normal, clear),
            ];
            if exact_normals {
                colors.push(passes::attachment(&exact, clear));
            }
            let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
                label: Some("strata.deferred.gbuffer"),
                color_attachments: &colors,
                depth_stencil_attachment: depth_attachment(&depth, true),
                timestamp_writes: timer.render_pass("deferred.gbuffer"),
                occlusion_query_set: None,
                multiview_mask: None,
            });
            pass.set_pipeline(if exact_normals {
                &self.passes.gbuffer_exact
            } else {
                &self.passes.gbuffer
            });
            pass.set_bind_group(0, Some(&frame), &[]);
            pass.set_bind_group(1, Some(&self.groups.gbuffer), &[]);
            scene.bind(&mut pass);
            pass.draw(0..triangles, 0..1);
        }
        if self.options.build.lighting.ssao {
            let (ao_raw, ao) = (view(&self.targets.ao_raw), view(&self.targets.ao));
            self.full_screen(
                encoder,
                timer,
                ("deferred.ssao", &ao_raw),
                &frame,
                Pass::Ssao,
            );
            self.full_screen(
                encoder,
                timer,
                ("deferred.ssao_blur", &ao),
                &frame,
                Pass::SsaoBlur,
            );
        }
        {
            let (diffuse, specular) = (view(&self.targets.diffuse), view(&self.targets.specular));
            let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
                label: Some("strata.deferred.lighting"),
                color_attachments: &[
                    passes::attachment(&diffuse, clear),
                    passes::attachment(&specular, clear),
                ],
                depth_stencil_attachment: if self.passes.lights_depth_attachment {
                    depth_attachment(&depth, false)
                } else {
                    None
                },
                timestamp_writes: timer.render_pass("deferred.lighting"),
                occlusion_query_set: None,
                multiview_mask: None,
            });
            if self.has_opaque {
                pass.set_bind_group(0, Some(&frame), &[]);
                pass.set_bind_group(1, Some(&self.groups.lighting), &[]);
                let v = &self.visible;
                let (s, c, f) = (
                    v.spheres,
                    v.spheres + v.cones,
                    v.spheres + v.cones + v.full_screen,
                );
                pass.set_pipeline(&self.passes.sphere_lights);
                pass.draw(0..self.sphere_vertices, 0..s);
                pass.set_pipeline(&self.passes.cone_lights);
                pass.draw(0..self.cone_vertices, s..c);
                pass.set_pipeline(&self.passes.full_screen_lights);
                pass.draw(0..3, c..f);
            }
        }
        self.full_screen(
            encoder,
            timer,
            ("deferred.composite", &hdr),
            &frame,
            Pass::Composite,
        );
        if self.options.build.lighting.gbuffer_debug.is_some() {
            self.full_screen(
                encoder,
                timer,
                ("deferred.debug", &hdr),
                &frame,
                Pass::Debug,
            );
        }
    }

    fn full_screen(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        timer: &mut Timer,
        (name, target): (&'static str, &wgpu::TextureView),
        frame: &wgpu::BindGroup,
        which: Pass,
    ) {
        let (pipeline, group, clear) = match which {
            Pass::Ssao => (&self.passes.ssao, &self.groups.ssao, wgpu::Color::WHITE),
            Pass::SsaoBlur => (
                &self.passes.ssao_blur,
                &self.groups.ssao_blur,
                wgpu::Color::WHITE,
            ),
            Pass::Composite => (
                &self.passes.composite,
                &self.groups.composite,
                wgpu::Color::TRANSPARENT,
            ),
            Pass::Debug => (&self.passes.debug, &self.groups.debug, wgpu::Color::BLACK),
        };
        passes::fullscreen_pass(
            encoder,
            (&format!("strata.{name}"), timer.render_pass(name)),
            &[passes::attachment(target, clear)],
            pipeline,
            &[frame, group],
        );
    }

    /// Records the picture's background under the HDR image where nothing opaque covers it
    /// (the target becomes image + (1 − coverage)·background, coverage 1), before the
    /// transparent method presents over it: a multiply material's RGB transmittance must
    /// filter the background itself, which the tone map's "over the background" (one alpha)
    /// cannot do.
    pub fn background_under(&mut self, encoder: &mut wgpu::CommandEncoder, timer: &mut Timer) {
        let gpu = &self.gpu;
        let module = &self.passes.tonemap_module;
        let frame_layout = &self.scene.frame_layout;
        let pipeline = self.passes.background_under.get_or_insert_with(|| {
            let under = wgpu::BlendComponent {
                src_factor: wgpu::BlendFactor::OneMinusDstAlpha,
                dst_factor: wgpu::BlendFactor::One,
                operation: wgpu::BlendOperation::Add,
            };
            let blend = wgpu::BlendState {
                color: under,
                alpha: under,
            };
            screen_pipeline(
                gpu,
                "strata.background_under",
                (gpu.fullscreen_vertex_module(), "vs_fullscreen"),
                (module, "fs_background"),
                &[frame_layout],
                &[color_target(HDR_FORMAT, Some(blend))],
                None,
                None,
            )
        });
        let unused = view(&self.unused_depth);
        let frame = self.scene.frame_group(gpu, &unused);
        let hdr = view(&self.targets.hdr);
        passes::fullscreen_pass(
            encoder,
            ("strata.background_under", timer.render_pass("background")),
            &[passes::kept_attachment(&hdr)],
            pipeline,
            &[&frame],
        );
    }

    /// Records the tone map: the HDR image (with the transparent method's result over it) OVER
    /// the picture's background, tone-mapped into `target` (any renderable color format).
    pub fn tonemap(
        &mut self,
        encoder: &mut wgpu::CommandEncoder,
        timer: &mut Timer,
        target: &wgpu::TextureView,
        format: wgpu::TextureFormat,
    ) {
        let gpu = &self.gpu;
        let (module, layouts) = (&self.passes.tonemap_module, &self.passes.layouts);
        let frame_layout = &self.scene.frame_layout;
        let pipeline = self.passes.tonemap.entry(format).or_insert_with(|| {
            screen_pipeline(
                gpu,
                "strata.tonemap",
                (gpu.fullscreen_vertex_module(), "vs_fullscreen"),
                (module, "fs_tonemap"),
                &[frame_layout, &layouts.tonemap],
                &[target_state(format)],
                None,
                None,
            )
        });
        let unused = view(&self.unused_depth);
        let frame = self.scene.frame_group(gpu, &unused);
        passes::fullscreen_pass(
            encoder,
            ("strata.tonemap", timer.render_pass("tonemap")),
            &[passes::attachment(target, wgpu::Color::BLACK)],
            pipeline,
            &[&frame, &self.groups.tonemap],
        );
    }
}

fn target_state(format: wgpu::TextureFormat) -> Option<wgpu::ColorTargetState> {
    color_target(format, None)
}

#[derive(Clone, Copy)]
enum Pass {
    Ssao,
    SsaoBlur,
    Composite,
    Debug,
}

#[cfg(test)]
mod tests;
