//! The scene on the GPU: the flattened triangles, materials, lights, the frame uniforms and the
//! frame totals, with the group-0 layout every method's pipelines start with.
//!
//! The triangles live in a vertex buffer (three [`GpuVertex`] per triangle, 72 bytes), which
//! the adapter's largest buffer bounds, not its largest storage binding: on lavapipe that is
//! 2 GiB (29.8M triangles) against 128 MiB (1.9M). Storage holds only each triangle's material
//! (4 bytes), which resolves look up by the fragment's primitive. The compute rasterizer reads
//! the vertex buffer as storage, and so refuses a scene beyond one storage binding.

use super::uniforms::{self, LightingSetup};
use super::{DrawCallback, RenderOptions, TOTAL_WORDS};
use crate::animation::SceneAnimation;
use crate::error::{Error, Result};
use crate::gpu::binding::{self, Slot};
use crate::gpu::Gpu;
use crate::scene::{Camera, GpuVertex, Scene, TriangleList, GPU_TRIANGLE_BYTES};

/// Group 0: frame uniforms, triangle materials, materials, lights, opaque depth, totals.
pub const FRAME_SLOTS: [Slot; 6] = [
    Slot::Uniform,
    Slot::Storage,
    Slot::Storage,
    Slot::Storage,
    Slot::TextureDepth,
    Slot::StorageRw,
];

/// Refuses a device strata's frames cannot run on at all, in one line naming what it lacks:
/// every frame keeps its scene's materials, lights and totals and its resolved pixels in storage
/// buffers and resolves in compute, which downlevel (WebGL2-class) devices do not have.
pub fn check_device(gpu: &Gpu) -> Result<()> {
    let needed = FRAME_SLOTS
        .iter()
        .filter(|s| matches!(s, Slot::Storage | Slot::StorageRw))
        .count() as u32;
    let limits = &gpu.limits;
    let mut missing = Vec::new();
    if limits.max_storage_buffers_per_shader_stage < needed {
        missing.push(format!(
            "{needed} storage buffers per shader stage (it has {})",
            limits.max_storage_buffers_per_shader_stage
        ));
    }
    if limits.max_compute_invocations_per_workgroup < 64 {
        missing.push(format!(
            "compute workgroups of 64 invocations (it has {})",
            limits.max_compute_invocations_per_workgroup
        ));
    }
    if missing.is_empty() {
        return Ok(());
    }
    Err(Error::unsupported(format!(
        "'{}' is a downlevel device: strata's frames need {}, for the scene's materials, lights and totals, the resolved pixels and the compute resolves",
        gpu.info.name,
        missing.join(" and ")
    )))
}

/// Scenes with more triangles are refused: vertex indices (3 per triangle) fit in u32, and a
/// pixel never sees 2³² fragments in one geometry pass, so per-pixel u32 counters cannot wrap.
pub const MAX_TRIANGLES: u64 = (u32::MAX / 3) as u64;

/// The scene on the device: its vertices, materials, lights, the frame's uniforms and totals, and group 0's layout, which every capture stage binds.
pub struct SceneGpu {
    /// Triangles of the scene (three vertices each).
    pub triangle_count: u32,
    /// Three [`GpuVertex`] per triangle; bound at vertex-buffer slot 0 by [`SceneGpu::bind`].
    pub vertices: wgpu::Buffer,
    /// Each triangle's material index.
    pub triangle_materials: wgpu::Buffer,
    /// [`crate::frame::uniforms::GpuMaterial`]s, indexed by `triangle_materials`.
    pub materials: wgpu::Buffer,
    /// [`crate::frame::uniforms::GpuLight`]s.
    pub lights: wgpu::Buffer,
    /// The frame's [`crate::frame::uniforms::FrameUniforms`].
    pub uniforms: wgpu::Buffer,
    /// Frame totals (see [`super::Totals`]), cleared at the start of every frame.
    pub totals: wgpu::Buffer,
    /// Group 0's layout: uniforms, materials, lights, opaque depth, totals.
    pub frame_layout: wgpu::BindGroupLayout,
    /// The camera the uniforms were last written for.
    pub camera: Camera,
    lighting: LightingSetup,
    /// The blend modes other than over that the scene uses ([`Scene::blend_modes`]): methods
    /// that honour only over refuse the scene, and the present multiplies by an RGB
    /// transmittance when multiply is among them.
    pub blend_modes: Vec<crate::scene::Blend>,
    /// Every triangle's centroid, for methods that order triangles on the CPU.
    pub centroids: Vec<glam::Vec3>,
    /// With `--order` (other than `scene`): the index buffer of the frame's submission order,
    /// which [`SceneGpu::draw`] draws through.
    pub draw_indices: Option<wgpu::Buffer>,
    /// With `--raster compute`: the layout of the compute rasterizer's group, which the methods'
    /// compute captures place after their own (`None`: the GPU's rasterizer). The recorder sets
    /// it (`crate::raster::raster_layout`) before it creates a method.
    pub raster_layout: Option<wgpu::BindGroupLayout>,
    /// Samples per pixel of the storage geometry passes (`--msaa`).
    pub samples: u32,
    /// An application's recorder ([`crate::FrameRecorder::for_application`]): the geometry
    /// passes draw the application's geometry with pipelines made from its shader, and the
    /// scene holds no triangles.
    pub application: Option<std::sync::Arc<super::application::AppShader>>,
    /// A scene whose objects move: the passes that move them on the GPU.
    pub animation: Option<SceneAnimation>,
    /// What the CPU needs to follow the animation's centroids (for `sorted`), and whether
    /// `centroids` lag its time.
    motion: Option<CpuMotion>,
    /// The most triangles one draw call of [`SceneGpu::draw`] holds ([`MAX_TRIANGLES_PER_DRAW`];
    /// smaller in tests).
    triangles_per_draw: u32,
    /// The bands of rows [`SceneGpu::draw`] draws the geometry in, each under a scissor of its
    /// rows ([`SceneGpu::set_draw_bands`]): the frame's width and height, and the bands.
    draw_bands: (u32, u32, u32),
    /// The fragments the latest frame that came back generated ([`SceneGpu::note_fragments`]).
    last_fragments: u64,
    /// Bands whatever the frames generate (tests).
    forced_bands: Option<u32>,
    /// A CPU device: no display watchdog, so no bands (and lavapipe's multisampled scissor
    /// lets the row above the rectangle through: the geometry would be drawn twice there).
    cpu_device: bool,
}

/// The most triangles in one draw call strata issues (docs/watchdog.md, S1): about 40 ms of
/// an H100's vertex work, so that a driver which preempts or times jobs at draw boundaries sees
/// no draw near a display watchdog's limit even at [`crate::scene::MAX_SCENE_TRIANGLES`] (four
/// draws).
/// The ranges go in order, so a method that depends on the draw order sees the same order.
pub const MAX_TRIANGLES_PER_DRAW: u32 = 1 << 23;

/// The most fragments one draw is meant to hold (docs/watchdog.md, S2): about 64 ms of the
/// costliest capture measured on an H100 (kb-keys at k = 16, 3.8 ns a fragment), 35 ms of a
/// lock k-buffer's. A frame whose last frame generated more draws its geometry once per band of
/// rows, each band under a scissor, so that each draw rasterizes all triangles but shades only
/// its rows' fragments. The bands partition the pixels and each draws in the same order, so every
/// pixel sees the same fragments in the same order: pictures do not change.
pub const MAX_FRAGMENTS_PER_DRAW: u64 = 1 << 24;

/// The bands of rows a frame of `height` rows draws in when its last frame generated
/// `fragments`: at least one, at most one per row.
pub fn draw_bands_for(fragments: u64, height: u32) -> u32 {
    fragments
        .div_ceil(MAX_FRAGMENTS_PER_DRAW)
        .clamp(1, height.max(1) as u64) as u32
}

/// Row `band` of `bands` bands' top edge over `height` rows, on a multiple of 8 rows but the
/// last (GPUs shade the pixels of a tile together).
fn band_edge(height: u32, band: u32, bands: u32) -> u32 {
    match band >= bands {
        true => height,
        false => (height * band / bands) & !7,
    }
}

/// The vertex (or index) ranges of `triangles` triangles in draws of at most `per_draw`.
pub fn draw_ranges(triangles: u32, per_draw: u32) -> impl Iterator<Item = std::ops::Range<u32>> {
    let per_draw = per_draw.max(1);
    (0..triangles.div_ceil(per_draw)).map(move |i| {
        let first = i * per_draw;
        first * 3..(first + per_draw).min(triangles) * 3
    })
}

/// The CPU's view of an animated scene: enough to place every triangle's centroid at a time.
struct CpuMotion {
    motions: Vec<Option<crate::scene::ObjectMotion>>,
    /// Each triangle's object and rest centroid (object space for moving objects).
    triangle_objects: Vec<u32>,
    rest_centroids: Vec<glam::Vec3>,
    stale: bool,
}

impl SceneGpu {
    /// Uploads `scene`, refusing one over [`MAX_TRIANGLES`] or larger than the device's buffers.
    pub fn new(gpu: &Gpu, scene: &Scene, options: &RenderOptions) -> Result<SceneGpu> {
        scene.validate()?;
        Self::new_allow_empty(gpu, scene, options)
    }

    /// Like [`SceneGpu::new`], for a scene that may have no objects (one side of a scene split
    /// by opacity): it then draws nothing.
    pub fn new_allow_empty(gpu: &Gpu, scene: &Scene, options: &RenderOptions) -> Result<SceneGpu> {
        check_device(gpu)?;
        if !scene.objects.is_empty() {
            scene.validate()?;
        }
        let triangles = scene.triangle_count() as u64;
        check_fits(&gpu.limits, triangles, options.build.raster)?;
        let TriangleList {
            mut vertices,
            materials: mut triangle_materials,
        } = scene.triangles();
        let triangle_count = triangle_materials.len() as u32;
        if vertices.is_empty() {
            // Buffers and bindings cannot be empty.
            vertices.push(GpuVertex::default());
            triangle_materials.push(0);
        }
        let storage = wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST;
        let mut materials: Vec<_> = scene.materials.iter().map(uniforms::gpu_material).collect();
        if materials.is_empty() {
            materials.push(bytemuck::Zeroable::zeroed());
        }
        let lighting = uniforms::lighting(scene);
        let mut lights = lighting.lights.clone();
        if lights.is_empty() {
            lights.push(bytemuck::Zeroable::zeroed()); // bindings cannot be empty
        }
        let camera = scene.camera_or_framing();
        let blend_modes = scene.blend_modes();
        let u = uniforms::frame_uniforms(&camera, options, &lighting, !blend_modes.is_empty());
        let mut scene_gpu = SceneGpu {
            triangle_count,
            // STORAGE for the compute rasterizer, which reads it as floats, and the animation,
            // which writes it.
            vertices: gpu.buffer_with(
                "strata.scene.vertices",
                &vertices,
                wgpu::BufferUsages::VERTEX | wgpu::BufferUsages::COPY_SRC | storage,
            ),
            triangle_materials: gpu.buffer_with(
                "strata.scene.triangle_materials",
                &triangle_materials,
                storage,
            ),
            materials: gpu.buffer_with("strata.scene.materials", &materials, storage),
            lights: gpu.buffer_with("strata.scene.lights", &lights, storage),
            uniforms: gpu.buffer_with(
                "strata.frame.uniforms",
                std::slice::from_ref(&u),
                wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            ),
            totals: gpu.storage_buffer(
                "strata.frame.totals",
                TOTAL_WORDS * 4,
                wgpu::BufferUsages::COPY_SRC,
            )?,
            frame_layout: binding::layout(&gpu.device, "strata.frame.layout", &FRAME_SLOTS),
            camera,
            lighting,
            blend_modes,
            centroids: centroids(&vertices[..triangle_count as usize * 3]),
            draw_indices: None,
            raster_layout: None,
            samples: options.build.msaa,
            application: None,
            animation: None,
            motion: None,
            triangles_per_draw: MAX_TRIANGLES_PER_DRAW,
            draw_bands: (1, 1, 1),
            last_fragments: 0,
            forced_bands: None,
            cpu_device: gpu.info.device_type == wgpu::DeviceType::Cpu,
        };
        scene_gpu.animate(gpu, scene)?;
        Ok(scene_gpu)
    }

    /// Makes the GPU animation of `scene` when it moves (none otherwise).
    fn animate(&mut self, gpu: &Gpu, scene: &Scene) -> Result<()> {
        if !scene.animated() || self.triangle_count == 0 {
            self.animation = None;
            self.motion = None;
            return Ok(());
        }
        self.animation = Some(SceneAnimation::new(gpu, scene, &self.vertices)?);
        let (rest, triangle_objects) = scene.rest_triangles();
        self.motion = Some(CpuMotion {
            motions: scene.motions.clone(),
            triangle_objects,
            rest_centroids: centroids(&rest.vertices),
            stale: false,
        });
        Ok(())
    }

    /// Moves an animated scene to time `t` (frames) for the next frame; the vertices move on
    /// the GPU when it is recorded. Nothing happens to a scene that does not move.
    pub fn set_time(&mut self, t: f32) {
        if let Some(animation) = &mut self.animation {
            if animation.time().to_bits() != t.to_bits() {
                animation.set_time(t);
                if let Some(m) = &mut self.motion {
                    m.stale = true;
                }
            }
        }
    }

    /// Brings `centroids` to the animation's time on the CPU (for methods that order triangles
    /// there); free when nothing moved since.
    pub fn refresh_centroids(&mut self) {
        let (Some(m), Some(animation)) = (&mut self.motion, &self.animation) else {
            return;
        };
        if !m.stale {
            return;
        }
        let t = animation.time();
        let transforms: Vec<Option<glam::Mat4>> = m
            .motions
            .iter()
            .map(|motion| motion.as_ref().map(|mo| mo.transform(t)))
            .collect();
        for ((c, &o), &rest) in self
            .centroids
            .iter_mut()
            .zip(&m.triangle_objects)
            .zip(&m.rest_centroids)
        {
            *c = match transforms[o as usize] {
                Some(transform) => transform.transform_point3(rest),
                None => rest,
            };
        }
        m.stale = false;
    }

    /// Writes the frame uniforms for `camera` and `options` (size, effect, background); takes
    /// effect with the next submission.
    pub fn update(&mut self, gpu: &Gpu, camera: &Camera, options: &RenderOptions) {
        self.camera = *camera;
        let u = uniforms::frame_uniforms(
            camera,
            options,
            &self.lighting,
            !self.blend_modes.is_empty(),
        );
        gpu.queue
            .write_buffer(&self.uniforms, 0, bytemuck::bytes_of(&u));
    }

    /// Replaces the triangles with those of `scene` (an animation's next frame) when it has as
    /// many; returns false, changing nothing, when the count differs.
    pub fn update_geometry(&mut self, gpu: &Gpu, scene: &Scene) -> Result<bool> {
        if scene.triangle_count() as u64 != self.triangle_count as u64 {
            return Ok(false);
        }
        scene.validate()?;
        let tris = scene.triangles();
        if tris.vertices.is_empty() {
            return Ok(true);
        }
        gpu.queue
            .write_buffer(&self.vertices, 0, bytemuck::cast_slice(&tris.vertices));
        gpu.queue.write_buffer(
            &self.triangle_materials,
            0,
            bytemuck::cast_slice(&tris.materials),
        );
        self.centroids = centroids(&tris.vertices);
        self.animate(gpu, scene)?;
        Ok(true)
    }

    /// Binds the scene's vertex buffer at slot 0 of `pass`, as every scene pipeline reads it.
    pub fn bind(&self, pass: &mut wgpu::RenderPass<'_>) {
        pass.set_vertex_buffer(0, self.vertices.slice(..));
    }

    /// The fragments a frame generated (its statistics, when they come back): the next frames'
    /// draws are split by them ([`SceneGpu::set_draw_bands`]).
    pub fn note_fragments(&mut self, generated: u64) {
        self.last_fragments = generated;
    }

    /// Splits the frame about to be recorded, `width` × `height`, into bands of rows by what the
    /// latest frame generated ([`MAX_FRAGMENTS_PER_DRAW`]).
    pub fn set_draw_bands(&mut self, width: u32, height: u32) {
        let bands = match (self.forced_bands, self.cpu_device) {
            (Some(bands), _) => bands,
            (None, true) => 1,
            (None, false) => draw_bands_for(self.last_fragments, height),
        };
        self.draw_bands = (width, height, bands);
    }

    /// Draws the geometry once per band of rows ([`SceneGpu::set_draw_bands`]; one band: no
    /// scissor), each drawing every triangle (or calling the application's `draw`), and leaves the
    /// scissor on the whole frame.
    pub fn draw(&self, pass: &mut wgpu::RenderPass<'_>, draw: Option<&DrawCallback<'_>>) {
        let (width, height, bands) = self.draw_bands;
        if bands <= 1 {
            self.draw_once(pass, draw);
            return;
        }
        for band in 0..bands {
            let (top, bottom) = (
                band_edge(height, band, bands),
                band_edge(height, band + 1, bands),
            );
            if bottom > top {
                pass.set_scissor_rect(0, top, width, bottom - top);
                self.draw_once(pass, draw);
            }
        }
        pass.set_scissor_rect(0, 0, width, height);
    }

    /// Binds the vertex buffer and draws the geometry: through `draw` (an application's
    /// callback), or every triangle — in the frame's `--order` when one is set.
    fn draw_once(&self, pass: &mut wgpu::RenderPass<'_>, draw: Option<&DrawCallback<'_>>) {
        if self.application.is_some() {
            // The application binds its own vertex buffers; the recorder refuses a frame of
            // an application's recorder without its draw callback.
            if let Some(draw) = draw {
                draw(pass);
            }
            return;
        }
        self.bind(pass);
        let ranges = draw_ranges(self.triangle_count, self.triangles_per_draw);
        match (draw, &self.draw_indices) {
            (Some(draw), _) => draw(pass),
            (None, Some(indices)) => {
                pass.set_index_buffer(indices.slice(..), wgpu::IndexFormat::Uint32);
                ranges.for_each(|range| pass.draw_indexed(range, 0, 0..1));
            }
            (None, None) => ranges.for_each(|range| pass.draw(range, 0..1)),
        }
    }

    /// Splits [`SceneGpu::draw`] into draws of at most `triangles` (tests show that the split
    /// leaves every picture as it was).
    #[cfg(test)]
    pub(crate) fn set_triangles_per_draw(&mut self, triangles: u32) {
        self.triangles_per_draw = triangles;
    }

    /// Draws in `bands` bands of rows whatever the last frame generated (tests).
    #[cfg(test)]
    pub(crate) fn force_draw_bands(&mut self, bands: u32) {
        self.forced_bands = Some(bands);
    }

    /// The bind group index of strata's first group in a geometry pass: 0, or after an
    /// application's own groups.
    pub fn first_group(&self) -> u32 {
        self.application
            .as_ref()
            .map_or(0, |app| app.first_strata_group())
    }

    /// Group 0 for a frame.
    pub fn frame_group(&self, gpu: &Gpu, opaque_depth: &wgpu::TextureView) -> wgpu::BindGroup {
        binding::group(
            &gpu.device,
            "strata.frame.group",
            &self.frame_layout,
            &[
                self.uniforms.as_entire_binding(),
                self.triangle_materials.as_entire_binding(),
                self.materials.as_entire_binding(),
                self.lights.as_entire_binding(),
                wgpu::BindingResource::TextureView(opaque_depth),
                self.totals.as_entire_binding(),
            ],
        )
    }
}

fn centroids(vertices: &[GpuVertex]) -> Vec<glam::Vec3> {
    vertices
        .chunks_exact(3)
        .map(|t| {
            t.iter()
                .map(|v| glam::Vec3::from(v.position))
                .sum::<glam::Vec3>()
                / 3.0
        })
        .collect()
}

/// Refuses, before anything is built, a scene of `triangles` the device cannot hold: its
/// vertex buffer over the largest buffer, its materials (or, for the compute rasterizer, its
/// vertices) over the largest storage binding.
pub fn check_fits(
    limits: &wgpu::Limits,
    triangles: u64,
    raster: crate::frame::Raster,
) -> Result<()> {
    let mib = |bytes: u64| bytes as f64 / 1048576.0;
    let vertex_bytes = triangles * 3 * std::mem::size_of::<GpuVertex>() as u64;
    let binding = limits
        .max_storage_buffer_binding_size
        .min(limits.max_buffer_size);
    let total = triangles * GPU_TRIANGLE_BYTES;
    if triangles > MAX_TRIANGLES {
        return Err(Error::unsupported(format!(
            "scene has {triangles} triangles, more than strata draws in one frame ({MAX_TRIANGLES})"
        )));
    }
    if vertex_bytes > limits.max_buffer_size || triangles * 4 > binding {
        return Err(Error::unsupported(format!(
            "scene has {triangles} triangles ({:.0} MiB on the GPU), more than the device holds: its largest buffer is {:.0} MiB (vertices take 72 bytes per triangle) and its largest storage binding {:.0} MiB (materials take 4)",
            mib(total),
            mib(limits.max_buffer_size),
            mib(binding)
        )));
    }
    if raster == crate::frame::Raster::Compute && vertex_bytes > binding {
        return Err(Error::unsupported(format!(
            "--raster compute reads the scene's vertices from one storage binding: {triangles} triangles take {:.0} MiB, more than the device's {:.0} MiB; use --raster hw",
            mib(vertex_bytes),
            mib(binding)
        )));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::frame::Raster;

    /// Default limits but for the largest storage binding and buffer.
    fn limits(binding: u64, buffer: u64) -> wgpu::Limits {
        wgpu::Limits {
            max_storage_buffer_binding_size: binding,
            max_buffer_size: buffer,
            ..Default::default()
        }
    }

    /// Lavapipe's limits: 128 MiB storage bindings, 2 GiB buffers.
    fn lavapipe() -> wgpu::Limits {
        limits(128 << 20, (2 << 30) - 1)
    }

    #[test]
    fn vertices_are_bounded_by_the_largest_buffer_not_the_largest_binding() {
        let limits = lavapipe();
        // 12M triangles: 824 MiB of vertices, 46 MiB of materials.
        check_fits(&limits, 12_000_000, Raster::Hw).unwrap();
        let over = ((2u64 << 30) / 72) + 1;
        let message = check_fits(&limits, over, Raster::Hw)
            .unwrap_err()
            .to_string();
        assert!(
            message.contains("largest buffer is 2048 MiB") && message.contains(&over.to_string()),
            "{message}"
        );
    }

    #[test]
    fn the_compute_rasterizer_refuses_vertices_beyond_one_binding() {
        let limits = lavapipe();
        let fits = (128u64 << 20) / 72;
        check_fits(&limits, fits, Raster::Compute).unwrap();
        let message = check_fits(&limits, fits + 1, Raster::Compute)
            .unwrap_err()
            .to_string();
        assert!(
            message.contains("--raster compute") && message.contains("--raster hw"),
            "{message}"
        );
        check_fits(&limits, fits + 1, Raster::Hw).unwrap();
    }

    #[test]
    fn materials_are_bounded_by_the_largest_binding() {
        let limits = limits(1 << 20, 1 << 40);
        check_fits(&limits, 1 << 18, Raster::Hw).unwrap();
        assert!(check_fits(&limits, (1 << 18) + 1, Raster::Hw).is_err());
    }

    #[test]
    fn vertex_numbers_fit_in_u32() {
        let unbounded = limits(1 << 40, 1 << 40);
        check_fits(&unbounded, MAX_TRIANGLES, Raster::Hw).unwrap();
        let message = check_fits(&unbounded, MAX_TRIANGLES + 1, Raster::Hw)
            .unwrap_err()
            .to_string();
        assert!(message.contains("strata draws in one frame"), "{message}");
        assert!(MAX_TRIANGLES * 3 <= u32::MAX as u64);
    }
}
