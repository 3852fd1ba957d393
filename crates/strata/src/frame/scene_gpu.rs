//! The scene on the GPU: the flattened triangles, materials, lights, the frame uniforms and the
//! frame totals, with the group-0 layout every method's pipelines start with.

use wgpu::util::DeviceExt;

use super::uniforms::{self, LightingSetup};
use super::{RenderOptions, TOTAL_WORDS};
use crate::error::{Error, Result};
use crate::gpu::binding::{self, Slot};
use crate::gpu::Gpu;
use crate::scene::{Camera, GpuVertex, Scene};

/// Group 0: frame uniforms, vertices, materials, lights, draw order, opaque depth, totals.
pub const FRAME_SLOTS: [Slot; 7] = [
    Slot::Uniform,
    Slot::Storage,
    Slot::Storage,
    Slot::Storage,
    Slot::Storage,
    Slot::TextureDepth,
    Slot::StorageRw,
];

/// Scenes with more triangles are refused: a pixel then never sees 2³² fragments in one
/// geometry pass, so per-pixel u32 counters cannot wrap.
pub const MAX_TRIANGLES: u64 = 1 << 31;

pub struct SceneGpu {
    pub triangle_count: u32,
    pub vertices: wgpu::Buffer,
    pub materials: wgpu::Buffer,
    pub lights: wgpu::Buffer,
    pub identity_order: wgpu::Buffer,
    pub uniforms: wgpu::Buffer,
    /// Frame totals (see [`super::Totals`]), cleared at the start of every frame.
    pub totals: wgpu::Buffer,
    pub frame_layout: wgpu::BindGroupLayout,
    pub camera: Camera,
    lighting: LightingSetup,
    /// Positions of every triangle's vertices, for methods that order triangles on the CPU.
    pub cpu_positions: Vec<[f32; 3]>,
    /// With `--raster compute`: the layout of the compute rasterizer's group, which the methods'
    /// compute captures place after their own (`None`: the GPU's rasterizer).
    pub raster_layout: Option<wgpu::BindGroupLayout>,
}

impl SceneGpu {
    pub fn new(gpu: &Gpu, scene: &Scene, options: &RenderOptions) -> Result<SceneGpu> {
        scene.validate()?;
        Self::new_allow_empty(gpu, scene, options)
    }

    /// Like [`SceneGpu::new`], for a scene that may have no objects (one side of a scene split
    /// by opacity): it then draws nothing.
    pub fn new_allow_empty(gpu: &Gpu, scene: &Scene, options: &RenderOptions) -> Result<SceneGpu> {
        if !scene.objects.is_empty() {
            scene.validate()?;
        }
        let triangles = scene.triangle_count() as u64;
        let vertex_bytes = triangles * 3 * std::mem::size_of::<GpuVertex>() as u64;
        if triangles >= MAX_TRIANGLES || vertex_bytes > gpu.max_storage_binding() {
            return Err(Error::unsupported(format!(
                "scene has {triangles} triangles ({:.0} MiB), more than the device binds in one buffer",
                vertex_bytes as f64 / 1048576.0
            )));
        }
        let mut tris = scene.triangles();
        let triangle_count = (tris.len() / 3) as u32;
        if tris.is_empty() {
            tris.push(GpuVertex::default()); // bindings cannot be empty
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
        let order: Vec<u32> = (0..triangle_count.max(1)).collect();
        let u = uniforms::frame_uniforms(&camera, options, &lighting);
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
            totals: gpu.storage_buffer(
                "strata.frame.totals",
                TOTAL_WORDS * 4,
                wgpu::BufferUsages::COPY_SRC,
            )?,
            frame_layout: binding::layout(&gpu.device, "strata.frame.layout", &FRAME_SLOTS),
            camera,
            lighting,
            cpu_positions: tris[..triangle_count as usize * 3]
                .iter()
                .map(|v| v.position)
                .collect(),
            raster_layout: (options.raster == crate::raster::Raster::Compute)
                .then(|| crate::raster::raster_layout(gpu)),
        })
    }

    /// Writes the frame uniforms for `camera` and `options` (size, effect, background); takes
    /// effect with the next submission.
    pub fn update(&mut self, gpu: &Gpu, camera: &Camera, options: &RenderOptions) {
        self.camera = *camera;
        let u = uniforms::frame_uniforms(camera, options, &self.lighting);
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
        gpu.queue
            .write_buffer(&self.vertices, 0, bytemuck::cast_slice(&tris));
        self.cpu_positions = tris.iter().map(|v| v.position).collect();
        Ok(true)
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
                self.totals.as_entire_binding(),
            ],
        )
    }
}
