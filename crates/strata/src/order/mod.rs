//! Triangle submission order (`--order scene|front|back|random --seed S`): seed 000's
//! experiments measure how the order in which triangles reach a one-pass k-buffer changes its
//! cost (in-frame culling and lock contention depend on it), so strata can resubmit the scene
//! sorted by centroid depth, front to back or back to front, or randomly permuted every frame,
//! and reports how far each frame's submission is from depth order.
//!
//! Passes, recorded at the start of a frame into the caller's encoder (timed as `order`):
//! 1. **keys** (one thread per triangle): the centroid's view depth as an orderable integer,
//!    and the sort key — the depth, its complement, or a hash of the triangle and the frame's
//!    seed (a permutation of u32, so a random order has no ties);
//! 2. **sort**: the stable GPU radix sort of [`radix`] (the paper's future work: it sorted on
//!    the CPU), eight passes of 4-bit digits;
//! 3. **indices**: the sorted triangles become an index buffer of their vertex numbers, which
//!    every geometry pass of every method draws through ([`crate::frame::SceneGpu::draw`]);
//! 4. **Kendall** (65536 threads): sampled pairs of submission positions, counting pairs of
//!    distinct depth and those submitted far before near. Their ratio is the normalized Kendall
//!    tau distance to front-to-back order (0 front to back, 1 back to front, ~0.5 random;
//!    standard error under 0.002), reported as `FrameStats::kendall_tau`.
//!
//! `--order scene` runs only keys and Kendall (the scene's own order, measured). Ties in depth
//! keep the scene's order (the sort is stable); exact methods order equal depths by primitive,
//! so their pictures do not change with the order.
//!
//! Memory: 44 bytes per triangle (centroids 12, depth keys 4, sort pairs 16, index buffer 12)
//! plus 64 bytes per 1024 triangles; `scene` order 16 bytes per triangle. The centroids and
//! index buffer are bound as storage, so a scene over the device's largest storage binding / 12
//! triangles (11.1M at 128 MiB) is refused with `--order`. Limits: an application's draw
//! callback or capture pass, `--raster compute` (which has no submission order), `sorted`
//! (which has its own) and `f2b` (whose depth test keeps the first drawn of equal depths, so it
//! peels in primitive order; `--order scene` it takes) refuse it.

pub mod radix;

use crate::gpu::twin::{gpu_struct, wgsl_module};

use crate::error::{Error, Result};
use crate::gpu::binding::{self, Slot};
use crate::gpu::readback::ReadbackList;
use crate::gpu::shader::{Library, Stage};
use crate::gpu::timing::Timer;
use crate::gpu::Gpu;
use crate::keyword::keyword_enum;
use crate::scene::Camera;
use radix::RadixSort;

const COMMON: &str = include_str!("order_common.wgsl");
const KEYS: &str = include_str!("order_keys.wgsl");
const INDICES: &str = include_str!("order_indices.wgsl");
const KENDALL: &str = include_str!("order_kendall.wgsl");

/// Pairs the Kendall pass samples per frame.
pub const KENDALL_SAMPLES: u32 = 65536;

keyword_enum! {
    /// The order triangles are submitted in.
    pub enum Order ("--order") {
        /// The scene's own order (measured, not changed).
        Scene = "scene",
        /// Sorted by centroid view depth, nearest first.
        Front = "front",
        /// Sorted by centroid view depth, farthest first.
        Back = "back",
        /// A random permutation, a new one every frame (from `--seed` and the frame number).
        Random = "random",
    }
}

gpu_struct! {
    /// The order passes' uniforms (`strata::order::params`).
    pub struct OrderParams {
        /// A point p lies at view depth dot(depth_row.xyz, p) + depth_row.w (larger is farther).
        pub depth_row: [f32; 4],
        /// Triangles to order.
        pub count: u32,
        /// Which key the keys pass writes (the [`Order`]'s index, MODE_ in order_common.wgsl).
        pub mode: u32,
        /// Random permutations and the Kendall samples draw from it; it changes every frame.
        pub seed: u32,
        /// Workgroups per row of a two-dimensional dispatch (one dimension holds 65535).
        pub grid_x: u32,
        /// Pairs sampled for the Kendall distance.
        pub samples: u32,
        pad_a: u32,
        pad_b: u32,
        pad_c: u32,
    }
}

/// `strata::order::params`: [`OrderParams`] for the order stages.
const PARAMS: &str = wgsl_module!("strata::order::params", OrderParams);

/// Bytes the order keeps on the GPU for `triangles`.
pub fn bytes(order: Order, triangles: u32) -> u64 {
    let n = triangles.max(1) as u64;
    match order {
        Order::Scene => 16 * n,
        _ => 28 * n + radix::bytes(triangles),
    }
}

/// Refuses an order whose storage the device cannot bind.
pub fn check_fits(gpu: &Gpu, order: Order, triangles: u32) -> Result<()> {
    let widest = if order == Order::Scene { 12 } else { 16 };
    let needed = widest * triangles as u64;
    if needed > gpu.max_storage_binding() {
        return Err(Error::unsupported(format!(
            "--order {}: {triangles} triangles need {:.1} MiB in one storage buffer, beyond this device's largest binding ({:.1} MiB); leave out --order",
            order.name(),
            needed as f64 / 1048576.0,
            gpu.max_storage_binding() as f64 / 1048576.0
        )));
    }
    Ok(())
}

/// A seed for one frame: `seed` and `frame` mixed (splitmix64), folded to 32 bits.
pub fn frame_seed(seed: u64, frame: u64) -> u32 {
    let mix = |mut z: u64| {
        z = z.wrapping_add(0x9e37_79b9_7f4a_7c15);
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^ (z >> 31)
    };
    let z = mix(seed ^ mix(frame));
    (z ^ (z >> 32)) as u32
}

/// The view-depth row for `camera`: depth = row · (p, 1), larger is farther.
pub fn depth_row(camera: &Camera) -> [f32; 4] {
    let v = camera.view();
    [-v.x_axis.z, -v.y_axis.z, -v.z_axis.z, -v.w_axis.z]
}

/// A frame's submission order on the GPU.
pub struct TriangleOrder {
    order: Order,
    seed: u64,
    count: u32,
    params: wgpu::Buffer,
    centroids: wgpu::Buffer,
    sort: Option<RadixSort>,
    indices: Option<wgpu::Buffer>,
    pair_counts: wgpu::Buffer,
    keys_pipeline: wgpu::ComputePipeline,
    keys_group: wgpu::BindGroup,
    indices_pass: Option<(wgpu::ComputePipeline, wgpu::BindGroup)>,
    kendall_pipeline: wgpu::ComputePipeline,
    kendall_group: wgpu::BindGroup,
}

/// The stages' WGSL modules.
pub const LIBRARY: Library = &[PARAMS, COMMON, KEYS, INDICES, KENDALL];

fn module(gpu: &Gpu, label: &str, stage: &'static str) -> wgpu::ShaderModule {
    Stage::new(label, stage).with(LIBRARY).module(&gpu.device)
}

impl TriangleOrder {
    /// The order of the triangles whose centroids are `centroids`.
    pub fn new(
        gpu: &Gpu,
        order: Order,
        seed: u64,
        centroids: &[glam::Vec3],
    ) -> Result<TriangleOrder> {
        let count = centroids.len() as u32;
        check_fits(gpu, order, count)?;
        let n = count.max(1) as u64;
        let storage = |name: &str, bytes: u64, extra| {
            gpu.storage_buffer(&format!("strata.order.{name}"), bytes, extra)
        };
        let centroid_buffer = storage("centroids", 12 * n, wgpu::BufferUsages::empty())?;
        let depth_keys = storage("depth_keys", 4 * n, wgpu::BufferUsages::empty())?;
        let pair_counts = storage("pair_counts", 8, wgpu::BufferUsages::COPY_SRC)?;
        // Scene order binds this in place of the sort's buffers, which it never touches.
        let unused = storage("unused", 16, wgpu::BufferUsages::empty())?;
        let sort = match order {
            Order::Scene => None,
            _ => Some(RadixSort::new(gpu, "order.sort", count)?),
        };
        let indices = match order {
            Order::Scene => None,
            _ => Some(storage(
                "indices",
                12 * n,
                wgpu::BufferUsages::INDEX | wgpu::BufferUsages::COPY_SRC,
            )?),
        };
        let params = gpu.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("strata.order.params"),
            size: std::mem::size_of::<OrderParams>() as u64,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let sorted = sort.as_ref().map_or(&unused, |s| &s.values[0]);
        let sort_keys = sort.as_ref().map_or(&unused, |s| &s.keys[0]);
        let pipeline = |name: &str,
                        stage: &'static str,
                        entry: &str,
                        slots: &[Slot],
                        resources: &[wgpu::BindingResource<'_>]| {
            let label = format!("strata.order.{name}");
            let layout = binding::layout(&gpu.device, &label, slots);
            let module = module(gpu, &label, stage);
            let pipeline =
                crate::gpu::passes::compute_pipeline(gpu, &label, (&module, entry), &[&layout]);
            let group = binding::group(&gpu.device, &label, &layout, resources);
            (pipeline, group)
        };
        let (keys_pipeline, keys_group) = pipeline(
            "keys",
            KEYS,
            "triangle_keys",
            &[
                Slot::Uniform,
                Slot::Storage,
                Slot::StorageRw,
                Slot::StorageRw,
                Slot::StorageRw,
            ],
            &[
                params.as_entire_binding(),
                centroid_buffer.as_entire_binding(),
                depth_keys.as_entire_binding(),
                sort_keys.as_entire_binding(),
                sorted.as_entire_binding(),
            ],
        );
        let indices_pass = indices.as_ref().map(|indices| {
            pipeline(
                "indices",
                INDICES,
                "draw_indices",
                &[Slot::Uniform, Slot::Storage, Slot::StorageRw],
                &[
                    params.as_entire_binding(),
                    sorted.as_entire_binding(),
                    indices.as_entire_binding(),
                ],
            )
        });
        let (kendall_pipeline, kendall_group) = pipeline(
            "kendall",
            KENDALL,
            "sample_pairs",
            &[Slot::Uniform, Slot::Storage, Slot::Storage, Slot::StorageRw],
            &[
                params.as_entire_binding(),
                sorted.as_entire_binding(),
                depth_keys.as_entire_binding(),
                pair_counts.as_entire_binding(),
            ],
        );
        let order = TriangleOrder {
            order,
            seed,
            count,
            params,
            centroids: centroid_buffer,
            sort,
            indices,
            pair_counts,
            keys_pipeline,
            keys_group,
            indices_pass,
            kendall_pipeline,
            kendall_group,
        };
        order.set_centroids(gpu, centroids);
        Ok(order)
    }

    /// The order this sorter makes.
    pub fn order(&self) -> Order {
        self.order
    }

    /// The seed of this frame's random draws.
    pub fn seed(&self) -> u64 {
        self.seed
    }

    /// Triangles ordered.
    pub fn count(&self) -> u32 {
        self.count
    }

    /// The index buffer geometry passes draw through (`None` for the scene's own order).
    pub fn indices(&self) -> Option<&wgpu::Buffer> {
        self.indices.as_ref()
    }

    /// Bytes of the order's buffers.
    pub fn bytes(&self) -> u64 {
        bytes(self.order, self.count)
    }

    /// The triangles' centroids the keys pass reads (three floats each; the animation's
    /// vertices pass writes them when the scene moves on the GPU).
    pub fn centroids(&self) -> &wgpu::Buffer {
        &self.centroids
    }

    /// New centroids for the same triangle count (an animation's next frame).
    pub fn set_centroids(&self, gpu: &Gpu, centroids: &[glam::Vec3]) {
        debug_assert_eq!(centroids.len(), self.count as usize);
        if !centroids.is_empty() {
            gpu.queue
                .write_buffer(&self.centroids, 0, bytemuck::cast_slice(centroids));
        }
    }

    /// Records frame `frame`'s order for `camera` into `encoder`. The parameters are written
    /// with `queue.write_buffer`, like the frame uniforms.
    pub fn record(
        &self,
        gpu: &Gpu,
        encoder: &mut wgpu::CommandEncoder,
        timer: &mut Timer,
        camera: &Camera,
        frame: u64,
    ) {
        let threads = radix::grid(self.count.div_ceil(256));
        let params = OrderParams {
            depth_row: depth_row(camera),
            count: self.count,
            mode: self.order.index(),
            seed: frame_seed(self.seed, frame),
            grid_x: threads.0,
            samples: KENDALL_SAMPLES,
            pad_a: 0,
            pad_b: 0,
            pad_c: 0,
        };
        gpu.queue
            .write_buffer(&self.params, 0, bytemuck::bytes_of(&params));
        encoder.clear_buffer(&self.pair_counts, 0, None);
        if self.count == 0 {
            return;
        }
        // Every pass indexes threads with the same `grid_x`, so the Kendall pass's 256
        // workgroups are laid out in rows of that width.
        let kendall_groups = KENDALL_SAMPLES / 256;
        let kendall_grid = (
            kendall_groups.min(threads.0),
            kendall_groups.div_ceil(threads.0),
        );
        dispatch(
            encoder,
            timer,
            "keys",
            &self.keys_pipeline,
            &self.keys_group,
            threads,
        );
        if let (Some(sort), Some((pipeline, group))) = (&self.sort, &self.indices_pass) {
            sort.record(encoder, timer, "order.sort", "order");
            dispatch(encoder, timer, "indices", pipeline, group, threads);
        }
        dispatch(
            encoder,
            timer,
            "kendall",
            &self.kendall_pipeline,
            &self.kendall_group,
            kendall_grid,
        );
    }

    /// Asks for the Kendall pair counts (two words) with the frame's statistics.
    pub fn read_counters(&self, list: &mut ReadbackList) {
        list.words(&self.pair_counts, 0, 2);
    }
}

/// The normalized Kendall tau distance from the pass's counts: discordant / distinct pairs (0
/// when every sampled pair had equal depths: any order is then depth order).
pub fn kendall_tau(words: &[u32]) -> f64 {
    match words {
        [_, 0] => 0.0,
        [discordant, distinct] => *discordant as f64 / *distinct as f64,
        _ => 0.0,
    }
}

fn dispatch(
    encoder: &mut wgpu::CommandEncoder,
    timer: &mut Timer,
    stage: &str,
    pipeline: &wgpu::ComputePipeline,
    group: &wgpu::BindGroup,
    (x, y): (u32, u32),
) {
    let label = format!("strata.order.{stage}");
    let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
        label: Some(&label),
        timestamp_writes: timer.compute_pass("order"),
    });
    pass.set_pipeline(pipeline);
    pass.set_bind_group(0, Some(group), &[]);
    pass.dispatch_workgroups(x, y, 1);
}

#[cfg(test)]
mod tests;
