//! Animation on the GPU: a scene's moving objects ([`crate::scene::ObjectMotion`]) move every
//! frame without any mesh rebuilt or uploaded — the CPU writes one 32-byte uniform (the time).
//!
//! Passes, recorded at the start of a frame into the caller's encoder (timed as `animate`):
//! 1. **objects** (one thread per object): each object's transform at the frame's time from
//!    its orbit, and the transform back to where it was at the previous frame's time, which
//!    temporal culling reprojects moving fragments with ([`crate::methods::kbuffer::temporal`]);
//! 2. **vertices** (one thread per triangle, only when the time changed): the rest vertices
//!    (object space for moving objects, world space for the others) through their object's
//!    transform into the scene's vertex buffer that every method draws, and with `--order`
//!    the triangles' centroids its sort keys read. The pass runs in chunks, each bound at an
//!    offset, so that a vertex buffer larger than one storage binding still moves.
//!
//! Both evaluate the orbit with the expression the CPU uses ([`crate::scene::Orbit::position`]),
//! so the reference at the same time sees the same triangles, up to the GPU's own sin and cos.
//!
//! Memory: rest vertices 72 bytes and object index 4 bytes per triangle; 64 bytes of motion and
//! 128 of transforms per object.

use bytemuck::Zeroable;

use crate::gpu::twin::{gpu_struct, wgsl_module};

use crate::error::{Error, Result};
use crate::gpu::binding::{self, Slot};
use crate::gpu::shader::{Library, Stage};
use crate::gpu::timing::Timer;
use crate::gpu::Gpu;
use crate::scene::{ObjectMotion, Scene};

const OBJECTS: &str = include_str!("animate_objects.wgsl");
const VERTICES: &str = include_str!("animate_vertices.wgsl");
/// The animation's WGSL modules (`strata::animation::…`).
pub const LIBRARY: Library = &[
    PARAMS,
    include_str!("animate_common.wgsl"),
    OBJECTS,
    VERTICES,
];

/// Threads per workgroup of both passes.
const WORKGROUP: u32 = 64;
/// Bytes of one triangle's three vertices.
const VERTEX_BYTES: u64 = 3 * std::mem::size_of::<crate::scene::GpuVertex>() as u64;

gpu_struct! {
    /// The animation's uniforms (`strata::animation::params`), bound as `params` by
    /// animate_common.wgsl.
    pub struct AnimationParams {
        /// The time (frames) this frame shows.
        pub time: f32,
        /// The time the previous frame showed (for the motion since).
        pub previous_time: f32,
        /// Objects in the scene.
        pub objects: u32,
        /// Workgroups per row of the two-dimensional dispatch (one dimension holds 65535).
        pub grid_x: u32,
        /// 1 when the moved triangles' centroids are written too (for `--order`).
        pub write_centroids: u32,
        pad_a: u32,
        pad_b: u32,
        pad_c: u32,
    }
}

gpu_struct! {
    /// One object's motion (`strata::animation::params`, read by animate_objects.wgsl): its
    /// object-space mesh scaled by `scale` and carried along the orbit
    /// centre + radius·(cos a·u + sin a·v), a = angular_speed·t + phase.
    pub struct GpuMotion {
        /// The orbit's centre.
        pub centre: [f32; 3],
        /// The orbit's radius.
        pub radius: f32,
        /// First unit vector of the orbit's plane.
        pub u: [f32; 3],
        /// Radians per frame.
        pub angular_speed: f32,
        /// Second unit vector of the orbit's plane.
        pub v: [f32; 3],
        /// Angle at time 0, in radians.
        pub phase: f32,
        /// Uniform scale of the object-space mesh.
        pub scale: f32,
        /// 0: the object stays where its rest vertices are (world space).
        pub moving: u32,
        pad_a: u32,
        pad_b: u32,
    }
}

/// `strata::animation::params`: [`AnimationParams`] and [`GpuMotion`] for the animation's
/// stages.
const PARAMS: &str = wgsl_module!("strata::animation::params", AnimationParams, GpuMotion);

impl GpuMotion {
    fn new(motion: Option<&ObjectMotion>) -> GpuMotion {
        match motion {
            None => Zeroable::zeroed(),
            Some(m) => GpuMotion {
                centre: m.orbit.centre.to_array(),
                radius: m.orbit.radius,
                u: m.orbit.u.to_array(),
                angular_speed: m.orbit.angular_speed,
                v: m.orbit.v.to_array(),
                phase: m.orbit.phase,
                scale: m.scale,
                moving: 1,
                ..Zeroable::zeroed()
            },
        }
    }
}

/// `workgroups` laid out in two dimensions with rows of at most 65535.
fn grid(workgroups: u32) -> (u32, u32) {
    crate::order::radix::grid(workgroups)
}

/// `count` elements of `stride` bytes of `buffer` from element `first`.
fn range(buffer: &wgpu::Buffer, stride: u64, first: u32, count: u32) -> wgpu::BindingResource<'_> {
    wgpu::BindingResource::Buffer(wgpu::BufferBinding {
        buffer,
        offset: first as u64 * stride,
        size: std::num::NonZeroU64::new(count as u64 * stride),
    })
}

/// The buffer bound in place of `triangles` centroids while no order reads them.
fn centroid_stub(gpu: &Gpu, triangles: u32) -> wgpu::Buffer {
    gpu.device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("strata.animation.centroid_stub"),
        size: 12 * triangles as u64,
        usage: wgpu::BufferUsages::STORAGE,
        mapped_at_creation: false,
    })
}

/// A scene's moving objects on the GPU.
pub struct SceneAnimation {
    objects: u32,
    triangles: u32,
    params: wgpu::Buffer,
    triangle_objects: wgpu::Buffer,
    rest: wgpu::Buffer,
    models: wgpu::Buffer,
    to_previous: wgpu::Buffer,
    objects_pass: (wgpu::ComputePipeline, wgpu::BindGroup),
    vertices_pipeline: wgpu::ComputePipeline,
    vertices_layout: wgpu::BindGroupLayout,
    /// Triangles per chunk of the vertices pass (a multiple of 64, so every binding offset is
    /// 256-byte aligned).
    chunk: u32,
    /// Each chunk's first triangle, count and group.
    chunks: Vec<(u32, u32, wgpu::BindGroup)>,
    /// Stands in for the centroids while no order reads them.
    centroid_stub: wgpu::Buffer,
    writes_centroids: bool,
    /// The time the next frame shows.
    time: f32,
    /// The time the vertex buffer holds.
    shown: f32,
    /// The time the last recorded frame showed.
    previous: f32,
}

impl SceneAnimation {
    /// The animation of `scene` (which must be [`Scene::animated`]), moving `vertices` — the
    /// scene's vertex buffer, which holds it at `scene.time`.
    pub fn new(gpu: &Gpu, scene: &Scene, vertices: &wgpu::Buffer) -> Result<SceneAnimation> {
        let (rest, objects) = scene.rest_triangles();
        let triangles = objects.len() as u32;
        if triangles == 0 {
            return Err(Error::input("an animated scene needs triangles"));
        }
        let object_count = scene.objects.len() as u32;
        let motions: Vec<GpuMotion> = (0..scene.objects.len())
            .map(|i| GpuMotion::new(scene.motions.get(i).and_then(Option::as_ref)))
            .collect();
        let init = |name: &str, contents: &[u8], usage| {
            gpu.buffer_with(&format!("strata.animation.{name}"), contents, usage)
        };
        let storage = wgpu::BufferUsages::STORAGE;
        let per_object = object_count as u64 * 64;
        if per_object > gpu.max_storage_binding() {
            return Err(Error::unsupported(format!(
                "an animation of {object_count} objects needs {:.1} MiB of transforms in one storage binding, beyond this device's {:.1} MiB",
                per_object as f64 / 1048576.0,
                gpu.max_storage_binding() as f64 / 1048576.0
            )));
        }
        let params = gpu.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("strata.animation.params"),
            size: std::mem::size_of::<AnimationParams>() as u64,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let motion_buffer = init("motions", bytemuck::cast_slice(&motions), storage);
        let triangle_objects = init("triangle_objects", bytemuck::cast_slice(&objects), storage);
        let rest = init("rest", bytemuck::cast_slice(&rest.vertices), storage);
        let transforms = |name: &str| {
            gpu.device.create_buffer(&wgpu::BufferDescriptor {
                label: Some(&format!("strata.animation.{name}")),
                size: per_object.max(64),
                usage: storage,
                mapped_at_creation: false,
            })
        };
        let models = transforms("models");
        let to_previous = transforms("to_previous");
        let module = |name: &str, stage: &'static str| {
            Stage::new(format!("strata.animation.{name}"), stage)
                .with(LIBRARY)
                .module(&gpu.device)
        };
        let objects_layout = binding::layout(
            &gpu.device,
            "strata.animation.objects",
            &[
                Slot::Uniform,
                Slot::Storage,
                Slot::StorageRw,
                Slot::StorageRw,
            ],
        );
        let objects_pipeline = crate::gpu::passes::compute_pipeline(
            gpu,
            "strata.animation.objects",
            (&module("objects", OBJECTS), "object_transforms"),
            &[&objects_layout],
        );
        let objects_group = binding::group(
            &gpu.device,
            "strata.animation.objects",
            &objects_layout,
            &[
                params.as_entire_binding(),
                motion_buffer.as_entire_binding(),
                models.as_entire_binding(),
                to_previous.as_entire_binding(),
            ],
        );
        let vertices_layout = binding::layout(
            &gpu.device,
            "strata.animation.vertices",
            &[
                Slot::Uniform,
                Slot::Storage,
                Slot::Storage,
                Slot::Storage,
                Slot::StorageRw,
                Slot::StorageRw,
            ],
        );
        let vertices_pipeline = crate::gpu::passes::compute_pipeline(
            gpu,
            "strata.animation.vertices",
            (&module("vertices", VERTICES), "move_vertices"),
            &[&vertices_layout],
        );
        // The widest binding of a chunk is its vertices (72 bytes per triangle).
        let per_binding = gpu.max_storage_binding() / VERTEX_BYTES;
        let chunk = ((per_binding / WORKGROUP as u64) * WORKGROUP as u64)
            .clamp(WORKGROUP as u64, u32::MAX as u64) as u32;
        let mut animation = SceneAnimation {
            objects: object_count,
            triangles,
            params,
            triangle_objects,
            rest,
            models,
            to_previous,
            objects_pass: (objects_pipeline, objects_group),
            vertices_pipeline,
            vertices_layout,
            chunk,
            chunks: Vec::new(),
            centroid_stub: centroid_stub(gpu, chunk.min(triangles)),
            writes_centroids: false,
            time: scene.time,
            shown: scene.time,
            previous: scene.time,
        };
        animation.bind(gpu, vertices, None);
        Ok(animation)
    }

    /// Binds the chunks of the vertices pass to `vertices` and, with an order, to the
    /// centroids its keys read (12 bytes per triangle).
    pub fn bind(&mut self, gpu: &Gpu, vertices: &wgpu::Buffer, centroids: Option<&wgpu::Buffer>) {
        self.writes_centroids = centroids.is_some();
        self.chunks = (0..self.triangles.div_ceil(self.chunk))
            .map(|c| {
                let first = c * self.chunk;
                let count = self.chunk.min(self.triangles - first);
                let centroid_range = match centroids {
                    Some(b) => range(b, 12, first, count),
                    None => range(&self.centroid_stub, 12, 0, count),
                };
                let group = binding::group(
                    &gpu.device,
                    "strata.animation.vertices",
                    &self.vertices_layout,
                    &[
                        self.params.as_entire_binding(),
                        self.models.as_entire_binding(),
                        range(&self.triangle_objects, 4, first, count),
                        range(&self.rest, VERTEX_BYTES, first, count),
                        range(vertices, VERTEX_BYTES, first, count),
                        centroid_range,
                    ],
                );
                (first, count, group)
            })
            .collect();
        // Centroids newly bound are written by the next frame's vertices pass.
        if self.writes_centroids {
            self.shown = f32::NAN;
        }
    }

    /// Splits the vertices pass into chunks of `triangles` (a multiple of 64), as a device
    /// with a smaller storage binding would.
    #[cfg(test)]
    pub(crate) fn set_chunk(&mut self, gpu: &Gpu, vertices: &wgpu::Buffer, triangles: u32) {
        assert!(triangles > 0 && triangles.is_multiple_of(WORKGROUP));
        self.chunk = triangles;
        self.centroid_stub = centroid_stub(gpu, triangles);
        self.bind(gpu, vertices, None);
        self.shown = f32::NAN;
    }

    /// The time the next recorded frame shows.
    pub fn set_time(&mut self, t: f32) {
        self.time = t;
    }

    /// The time the next recorded frame shows.
    pub fn time(&self) -> f32 {
        self.time
    }

    /// Each triangle's object (temporal culling looks its motion up by primitive).
    pub fn triangle_objects(&self) -> &wgpu::Buffer {
        &self.triangle_objects
    }

    /// Per object, the transform from this frame's position to the previous frame's.
    pub fn to_previous(&self) -> &wgpu::Buffer {
        &self.to_previous
    }

    /// Bytes the animation keeps on the GPU.
    pub fn bytes(&self) -> u64 {
        self.triangles as u64 * (VERTEX_BYTES + 4) + self.objects as u64 * (64 + 128)
    }

    /// Records the frame's passes: the objects always (the motion since the previous frame
    /// changes even when the time does not), the vertices when the time moved.
    pub fn record(&mut self, gpu: &Gpu, encoder: &mut wgpu::CommandEncoder, timer: &mut Timer) {
        let (grid_x, _) = grid(self.chunk.div_ceil(WORKGROUP));
        let params = AnimationParams {
            time: self.time,
            previous_time: self.previous,
            objects: self.objects,
            grid_x,
            write_centroids: self.writes_centroids as u32,
            ..Zeroable::zeroed()
        };
        gpu.queue
            .write_buffer(&self.params, 0, bytemuck::bytes_of(&params));
        let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some("strata.animation"),
            timestamp_writes: timer.compute_pass("animate"),
        });
        // Both passes index threads with the same row width.
        let object_groups = self.objects.div_ceil(WORKGROUP);
        pass.set_pipeline(&self.objects_pass.0);
        pass.set_bind_group(0, Some(&self.objects_pass.1), &[]);
        pass.dispatch_workgroups(object_groups.min(grid_x), object_groups.div_ceil(grid_x), 1);
        if self.time.to_bits() != self.shown.to_bits() {
            pass.set_pipeline(&self.vertices_pipeline);
            for (_, count, group) in &self.chunks {
                let groups = count.div_ceil(WORKGROUP);
                pass.set_bind_group(0, Some(group), &[]);
                pass.dispatch_workgroups(groups.min(grid_x), groups.div_ceil(grid_x), 1);
            }
            self.shown = self.time;
        }
        self.previous = self.time;
    }
}

#[cfg(test)]
mod tests;
