//! A stable GPU radix sort of (u32 key, u32 value) pairs in compute: eight passes of 4-bit
//! digits, each three dispatches — count (per block of 1024 keys, each digit's keys), scan
//! (one workgroup turns the digit-major counts into exclusive offsets) and scatter (each key to
//! its digit's next place; ranks within a round of 256 from a workgroup scan of packed one-hot
//! counters, so equal keys keep their order).
//!
//! Memory: two key and two value buffers (16 bytes per pair, ping-ponged; eight passes end in
//! the first pair), 64 bytes of digit counts per block of 1024, eight 16-byte uniforms. Every
//! buffer is fixed for a count, so a frame's sort allocates and writes nothing on the CPU.

use crate::gpu::twin::{gpu_struct, wgsl_module};

use crate::error::Result;
use crate::gpu::binding::{self, Slot};
use crate::gpu::shader::{Library, Stage};
use crate::gpu::timing::Timer;
use crate::gpu::Gpu;

const COMMON: &str = include_str!("radix_common.wgsl");
const COUNT: &str = include_str!("radix_count.wgsl");
const SCAN: &str = include_str!("radix_scan.wgsl");
const SCATTER: &str = include_str!("radix_scatter.wgsl");

/// Keys per workgroup (256 threads × 4).
pub const BLOCK: u32 = 1024;
const DIGIT_BITS: u32 = 4;
const DIGITS: u64 = 1 << DIGIT_BITS;
const PASSES: u32 = 32 / DIGIT_BITS;
/// Workgroups in one dimension of a dispatch (WebGPU's default limit).
pub const MAX_GRID: u32 = 65535;

gpu_struct! {
    /// One pass's uniforms (`strata::order::radix_pass`).
    pub struct RadixPass {
        /// The digit this pass sorts by is (key >> shift) & 15.
        pub shift: u32,
        /// Pairs to sort.
        pub count: u32,
        /// Blocks of 1024 keys.
        pub blocks: u32,
        /// Workgroups per row of the two-dimensional dispatch.
        pub grid_x: u32,
    }
}

/// `strata::order::radix_pass`: [`RadixPass`] for the sort's stages.
const PASS: &str = wgsl_module!("strata::order::radix_pass", RadixPass);

/// `workgroups` laid out in two dimensions: (x, y) with x ≤ [`MAX_GRID`].
pub fn grid(workgroups: u32) -> (u32, u32) {
    let x = workgroups.clamp(1, MAX_GRID);
    (x, workgroups.div_ceil(x))
}

/// Bytes a sort of `count` pairs keeps on the GPU.
pub fn bytes(count: u32) -> u64 {
    let blocks = count.div_ceil(BLOCK).max(1) as u64;
    16 * count.max(1) as u64 + 4 * DIGITS * blocks + PASSES as u64 * 16
}

/// A stable GPU radix sort of (u32 key, u32 value) pairs, 4 bits per pass.
pub struct RadixSort {
    count: u32,
    blocks: u32,
    /// Keys and values: the caller writes pair 0, which holds the sorted pairs afterwards.
    pub keys: [wgpu::Buffer; 2],
    /// Values, moved with their keys.
    pub values: [wgpu::Buffer; 2],
    count_pipeline: wgpu::ComputePipeline,
    scan_pipeline: wgpu::ComputePipeline,
    scatter_pipeline: wgpu::ComputePipeline,
    /// Per pass: the count, scan and scatter groups.
    groups: Vec<[wgpu::BindGroup; 3]>,
}

/// The stages' WGSL modules.
pub const LIBRARY: Library = &[PASS, COMMON, COUNT, SCAN, SCATTER];

fn module(gpu: &Gpu, label: &str, stage: &'static str) -> wgpu::ShaderModule {
    Stage::new(label, stage).with(LIBRARY).module(&gpu.device)
}

impl RadixSort {
    /// A sort of `count` pairs; `label` prefixes its buffers (`strata.<label>.keys0`, ...).
    pub fn new(gpu: &Gpu, label: &str, count: u32) -> Result<RadixSort> {
        let blocks = count.div_ceil(BLOCK).max(1);
        let buffer = |name: &str, words: u64| {
            gpu.storage_buffer(
                &format!("strata.{label}.{name}"),
                words * 4,
                wgpu::BufferUsages::COPY_SRC,
            )
        };
        let n = count.max(1) as u64;
        let keys = [buffer("keys0", n)?, buffer("keys1", n)?];
        let values = [buffer("values0", n)?, buffer("values1", n)?];
        let digits = buffer("block_digits", DIGITS * blocks as u64)?;
        let layout = |name: &str, slots: &[Slot]| {
            binding::layout(&gpu.device, &format!("strata.{label}.{name}"), slots)
        };
        let count_layout = layout("count", &[Slot::Uniform, Slot::Storage, Slot::StorageRw]);
        let scan_layout = layout("scan", &[Slot::Uniform, Slot::StorageRw]);
        let scatter_layout = layout(
            "scatter",
            &[
                Slot::Uniform,
                Slot::Storage,
                Slot::Storage,
                Slot::Storage,
                Slot::StorageRw,
                Slot::StorageRw,
            ],
        );
        let pipeline =
            |name: &str, stage: &'static str, entry: &str, layout: &wgpu::BindGroupLayout| {
                let label = format!("strata.{label}.{name}");
                let module = module(gpu, &label, stage);
                crate::gpu::passes::compute_pipeline(gpu, &label, (&module, entry), &[layout])
            };
        let count_pipeline = pipeline("count", COUNT, "count_digits", &count_layout);
        let scan_pipeline = pipeline("scan", SCAN, "scan_digits", &scan_layout);
        let scatter_pipeline = pipeline("scatter", SCATTER, "scatter_keys", &scatter_layout);
        let (grid_x, _) = grid(blocks);
        let groups = (0..PASSES as usize)
            .map(|p| {
                let pass = RadixPass {
                    shift: p as u32 * DIGIT_BITS,
                    count,
                    blocks,
                    grid_x,
                };
                let uniform = gpu.buffer_with(
                    &format!("strata.{label}.pass{p}"),
                    std::slice::from_ref(&pass),
                    wgpu::BufferUsages::UNIFORM,
                );
                let (from, to) = (p % 2, 1 - p % 2);
                let group = |name: &str, layout, resources: &[wgpu::BindingResource<'_>]| {
                    binding::group(
                        &gpu.device,
                        &format!("strata.{label}.{name}{p}"),
                        layout,
                        resources,
                    )
                };
                [
                    group(
                        "count",
                        &count_layout,
                        &[
                            uniform.as_entire_binding(),
                            keys[from].as_entire_binding(),
                            digits.as_entire_binding(),
                        ],
                    ),
                    group(
                        "scan",
                        &scan_layout,
                        &[uniform.as_entire_binding(), digits.as_entire_binding()],
                    ),
                    group(
                        "scatter",
                        &scatter_layout,
                        &[
                            uniform.as_entire_binding(),
                            keys[from].as_entire_binding(),
                            values[from].as_entire_binding(),
                            digits.as_entire_binding(),
                            keys[to].as_entire_binding(),
                            values[to].as_entire_binding(),
                        ],
                    ),
                ]
            })
            .collect();
        Ok(RadixSort {
            count,
            blocks,
            keys,
            values,
            count_pipeline,
            scan_pipeline,
            scatter_pipeline,
            groups,
        })
    }

    /// Pairs the sort holds.
    pub fn count(&self) -> u32 {
        self.count
    }

    /// Records the sort of pair 0 (`keys[0]`, `values[0]`) into `encoder`, each dispatch its own
    /// compute pass labelled `strata.<label>.<stage>`, timed under `timer_name`.
    pub fn record(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        timer: &mut Timer,
        label: &str,
        timer_name: &'static str,
    ) {
        if self.count < 2 {
            return;
        }
        let blocks = grid(self.blocks);
        for groups in &self.groups {
            let stages = [
                ("count", &self.count_pipeline, blocks),
                ("scan", &self.scan_pipeline, (1, 1)),
                ("scatter", &self.scatter_pipeline, blocks),
            ];
            for ((stage, pipeline, (x, y)), group) in stages.into_iter().zip(groups) {
                let label = format!("strata.{label}.{stage}");
                let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                    label: Some(&label),
                    timestamp_writes: timer.compute_pass(timer_name),
                });
                pass.set_pipeline(pipeline);
                pass.set_bind_group(0, Some(group), &[]);
                pass.dispatch_workgroups(x, y, 1);
            }
        }
    }
}

/// The CPU twin: pairs stably sorted by key.
pub fn sort_pairs(keys: &[u32], values: &[u32]) -> (Vec<u32>, Vec<u32>) {
    let mut pairs: Vec<(u32, u32)> = keys.iter().copied().zip(values.iter().copied()).collect();
    pairs.sort_by_key(|p| p.0);
    pairs.into_iter().unzip()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::gpu::readback;
    use crate::testing::gpu;
    use proptest::prelude::*;

    #[test]
    fn radix_stages_and_their_pass_uniforms_validate() {
        crate::gpu::twin::assert_twin::<RadixPass>();
        for (label, stage) in [("count", COUNT), ("scan", SCAN), ("scatter", SCATTER)] {
            crate::gpu::shader::validate(
                &crate::gpu::shader::Stage::new(label, stage).with(LIBRARY),
            );
        }
    }

    #[test]
    fn grids_stay_within_one_dimension_limit() {
        assert_eq!(grid(0), (1, 0));
        assert_eq!(grid(10), (10, 1));
        assert_eq!(grid(MAX_GRID + 1), (MAX_GRID, 2));
        let (x, y) = grid(3 * MAX_GRID);
        assert!(x <= MAX_GRID && x as u64 * y as u64 >= 3 * MAX_GRID as u64);
    }

    /// Sorts on the GPU, starting from poisoned scratch buffers.
    fn gpu_sort(keys: &[u32], values: &[u32]) -> (Vec<u32>, Vec<u32>) {
        let g = gpu();
        let sort = RadixSort::new(g, "test_sort", keys.len() as u32).unwrap();
        for b in [&sort.keys[1], &sort.values[1]] {
            g.queue.write_buffer(b, 0, &crate::gpu::garbage(b.size()));
        }
        g.queue
            .write_buffer(&sort.keys[0], 0, bytemuck::cast_slice(keys));
        g.queue
            .write_buffer(&sort.values[0], 0, bytemuck::cast_slice(values));
        let mut encoder = g.device.create_command_encoder(&Default::default());
        let mut timer = Timer::new(g);
        sort.record(&mut encoder, &mut timer, "test_sort", "sort");
        g.queue.submit([encoder.finish()]);
        let n = keys.len() as u64;
        (
            readback::read_u32s(g, &sort.keys[0], n).unwrap(),
            readback::read_u32s(g, &sort.values[0], n).unwrap(),
        )
    }

    #[test]
    fn sorts_several_blocks_stably_like_the_cpu_twin() {
        // 5000 keys: five blocks, the last partial; few distinct keys, so stability shows.
        let keys: Vec<u32> = (0..5000u32)
            .map(|i| (i.wrapping_mul(2654435761) >> 7) % 37 * 0x0101_0101)
            .collect();
        let values: Vec<u32> = (0..5000).collect();
        assert_eq!(gpu_sort(&keys, &values), sort_pairs(&keys, &values));
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(12))]
        #[test]
        fn gpu_sort_equals_the_stable_cpu_sort(
            keys in proptest::collection::vec(any::<u32>(), 1..3000),
            narrow in any::<bool>(),
        ) {
            // Half the cases draw keys from a few values, so equal keys are common.
            let keys: Vec<u32> = if narrow { keys.iter().map(|k| ((k % 5) << 30) | (k % 3)).collect() } else { keys };
            let values: Vec<u32> = (0..keys.len() as u32).map(|i| i ^ 0xa5a5).collect();
            prop_assert_eq!(gpu_sort(&keys, &values), sort_pairs(&keys, &values));
        }
    }
}
