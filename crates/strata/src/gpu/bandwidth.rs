//! Device probes for memory-traffic floors (`strata bench bandwidth`): how fast this device
//! moves bytes and makes atomic increments, the two resources a multi-fragment method spends.
//!
//! Probes:
//! - `copy`: `copy_buffer_to_buffer` of one buffer into another (the driver's copy engine or
//!   shader path), counted as bytes read plus bytes written;
//! - `stream`: the same copy by a compute shader (`vec4<u32>` loads and stores in a grid-stride
//!   loop), which is how a method's passes move memory;
//! - `atomics`: `atomicAdd` of 1 over one word per invocation (`distinct`), over words each hit
//!   by [`FRAGMENTS_PER_PIXEL`] invocations spread across the grid, as a pixel's fragments hit
//!   its head pointer or lock (`per_pixel`), and over a single word, as every fragment of a pool
//!   method hits its allocation counter (`one_word`).
//!
//! Each probe is timed on the wall clock as the difference between a submission of `2n`
//! repetitions and one of `n` (after a warm-up, `n` doubled until a submission lasts
//! `MIN_SECONDS`), so submission and wait overheads cancel; the median of [`TRIALS`]
//! differences is kept. That works without timestamp queries and times the
//! copies, which no pass encloses. Every probe checks its result (the copy's bytes, the
//! counters' sum), so a probe that did not run cannot report a rate.

#[cfg(feature = "serde")]
use serde::Serialize;

use crate::error::{Error, Result};
use crate::gpu::shader::{Library, Stage};
use crate::gpu::twin::{gpu_struct, wgsl_module};
use crate::gpu::Gpu;

const SHADER: &str = include_str!("bandwidth.wgsl");

/// Invocations per word in the per-pixel atomic probe: a pixel of depth complexity 16.
pub const FRAGMENTS_PER_PIXEL: u32 = 16;
/// Timed differences per probe; the median is kept.
pub const TRIALS: usize = 3;
/// The shorter timed submission runs at least this long (repetitions double until it does).
const MIN_SECONDS: f64 = 0.02;
/// Repetitions never double past this.
const MAX_REPEATS: u32 = 4096;
/// Invocations of the probes' grids (grid-stride loops cover the rest).
const GRID_WORKGROUPS: u32 = 4096;
const WORKGROUP: u32 = 256;

gpu_struct! {
    /// The probes' uniforms (`strata::gpu::probe_params`).
    #[derive(Default, PartialEq)]
    pub struct ProbeParams {
        /// Elements the probe moves: 16-byte vectors to stream, or increments.
        pub count: u32,
        /// Words the increments are spread over: increment i goes to word i % words.
        pub words: u32,
        /// Invocations in the whole grid (the stride of the grid-stride loops).
        pub invocations: u32,
        pad_a: u32,
    }
}

/// The WGSL declaration of [`ProbeParams`].
const PROBE_PARAMS: Library = &[wgsl_module!("strata::gpu::probe_params", ProbeParams)];

/// The probes' stage.
fn stage(label: &str) -> Stage {
    Stage::new(label, SHADER).with(PROBE_PARAMS)
}

/// How much each probe moves.
#[derive(Clone, Copy, Debug)]
#[cfg_attr(feature = "serde", derive(Serialize))]
pub struct ProbeSizes {
    /// Bytes of the buffer copied (and of its destination).
    pub copy_bytes: u64,
    /// Increments per atomic probe.
    pub increments: u32,
    /// Repetitions in the shorter of the two timed submissions to start from (doubled until
    /// it lasts `MIN_SECONDS`).
    pub repeats: u32,
}

impl ProbeSizes {
    /// Sizes for `gpu`: a copy of 256 MiB and 2^26 increments on a GPU (well past its caches),
    /// 32 MiB and 2^22 on a CPU adapter (lavapipe), both within the device's binding limit.
    pub fn for_device(gpu: &Gpu) -> ProbeSizes {
        let cpu = gpu.info.device_type == wgpu::DeviceType::Cpu;
        let wanted: u64 = if cpu { 32 << 20 } else { 256 << 20 };
        ProbeSizes {
            copy_bytes: (wanted.min(gpu.max_storage_binding()) / 16) * 16,
            increments: if cpu { 1 << 22 } else { 1 << 26 },
            repeats: if cpu { 2 } else { 10 },
        }
    }
}

/// The device's measured rates.
#[derive(Clone, Copy, Debug)]
#[cfg_attr(feature = "serde", derive(Serialize))]
pub struct DeviceRates {
    /// Bytes read plus written per second by `copy_buffer_to_buffer`, in GB/s (10^9 bytes).
    pub copy_gb_per_s: f64,
    /// The same by a compute shader's loads and stores, in GB/s.
    pub stream_gb_per_s: f64,
    /// Atomic increments per second, in billions (one word per invocation).
    pub atomics_distinct_g_per_s: f64,
    /// ... with [`FRAGMENTS_PER_PIXEL`] invocations per word.
    pub atomics_per_pixel_g_per_s: f64,
    /// ... all on one word.
    pub atomics_one_word_g_per_s: f64,
    /// How much each probe moved.
    pub sizes: ProbeSizes,
}

impl DeviceRates {
    /// The memory bandwidth a floor divides bytes by: the faster of the two copies (a floor
    /// assumes the best the device showed).
    pub fn bandwidth_bytes_per_s(&self) -> f64 {
        self.copy_gb_per_s.max(self.stream_gb_per_s) * 1e9
    }
}

/// Runs every probe on `gpu`.
pub fn measure(gpu: &Gpu, sizes: ProbeSizes) -> Result<DeviceRates> {
    let probes = Probes::new(gpu, sizes)?;
    let copy = probes.time(|enc| probes.copy(enc))?;
    probes.check_copy()?;
    let group = probes.stream_group();
    let stream = probes.time(|enc| probes.dispatch(enc, &probes.stream, &group))?;
    probes.check_copy()?;
    let n = sizes.increments;
    let mut atomics = [0.0; 3];
    for (rate, words) in atomics
        .iter_mut()
        .zip([n, (n / FRAGMENTS_PER_PIXEL).max(1), 1])
    {
        let group = probes.increment_group(words);
        let seconds = probes.time(|enc| probes.dispatch(enc, &probes.increment, &group))?;
        probes.check_increments(words)?;
        *rate = n as f64 / seconds / 1e9;
    }
    let moved = 2.0 * sizes.copy_bytes as f64;
    Ok(DeviceRates {
        copy_gb_per_s: moved / copy / 1e9,
        stream_gb_per_s: moved / stream / 1e9,
        atomics_distinct_g_per_s: atomics[0],
        atomics_per_pixel_g_per_s: atomics[1],
        atomics_one_word_g_per_s: atomics[2],
        sizes,
    })
}

struct Probes<'g> {
    gpu: &'g Gpu,
    sizes: ProbeSizes,
    source: wgpu::Buffer,
    destination: wgpu::Buffer,
    counters: wgpu::Buffer,
    layout: wgpu::BindGroupLayout,
    stream: wgpu::ComputePipeline,
    increment: wgpu::ComputePipeline,
    /// Repetitions in the submission being recorded (the counters' expected sum needs it).
    repetitions: std::cell::Cell<u32>,
}

/// The copy's source pattern: word i holds a hash of i, so a copy that moved nothing, or moved
/// the wrong range, shows.
fn pattern(i: u32) -> u32 {
    i.wrapping_mul(0x9E37_79B1) ^ 0x5bd1_e995
}

impl<'g> Probes<'g> {
    fn new(gpu: &'g Gpu, sizes: ProbeSizes) -> Result<Probes<'g>> {
        use crate::gpu::binding::{self, Slot};
        let elements = sizes.copy_bytes / 16;
        if elements == 0 || elements + (GRID_WORKGROUPS * WORKGROUP) as u64 >= u32::MAX as u64 {
            return Err(Error::input(format!(
                "bandwidth probe: a copy of {} bytes is out of range",
                sizes.copy_bytes
            )));
        }
        if sizes.increments == 0 || sizes.repeats == 0 {
            return Err(Error::input(
                "bandwidth probe: increments and repeats must be at least 1",
            ));
        }
        let words: Vec<u32> = (0..(sizes.copy_bytes / 4) as u32).map(pattern).collect();
        let source = gpu.buffer_with(
            "strata.bandwidth.source",
            &words,
            wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
        );
        let destination = gpu.storage_buffer(
            "strata.bandwidth.destination",
            sizes.copy_bytes,
            wgpu::BufferUsages::COPY_SRC,
        )?;
        let counters = gpu.storage_buffer(
            "strata.bandwidth.counters",
            sizes.increments as u64 * 4,
            wgpu::BufferUsages::COPY_SRC,
        )?;
        let layout = binding::layout(
            &gpu.device,
            "strata.bandwidth",
            &[
                Slot::Uniform,
                Slot::Storage,
                Slot::StorageRw,
                Slot::StorageRw,
            ],
        );
        let module = stage("strata.bandwidth").module(&gpu.device);
        let pipeline = |entry: &str| {
            let layout = binding::pipeline_layout(&gpu.device, "strata.bandwidth", &[&layout]);
            gpu.device
                .create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
                    label: Some(&format!("strata.bandwidth.{entry}")),
                    layout: Some(&layout),
                    module: &module,
                    entry_point: Some(entry),
                    compilation_options: Default::default(),
                    cache: None,
                })
        };
        Ok(Probes {
            gpu,
            sizes,
            stream: pipeline("stream"),
            increment: pipeline("increment"),
            source,
            destination,
            counters,
            layout,
            repetitions: std::cell::Cell::new(0),
        })
    }

    /// Seconds per repetition of `record`: the median over [`TRIALS`] of the wall-clock
    /// difference between `2n` and `n` repetitions (each starting from a cleared state).
    fn time(&self, record: impl Fn(&mut wgpu::CommandEncoder)) -> Result<f64> {
        let run = |n: u32| -> Result<f64> {
            let mut enc = self.gpu.device.create_command_encoder(&Default::default());
            enc.clear_buffer(&self.destination, 0, None);
            enc.clear_buffer(&self.counters, 0, None);
            self.gpu.queue.submit([enc.finish()]);
            self.gpu.wait()?;
            let mut enc = self.gpu.device.create_command_encoder(&Default::default());
            for _ in 0..n {
                record(&mut enc);
            }
            self.repetitions.set(n);
            let start = std::time::Instant::now();
            self.gpu.queue.submit([enc.finish()]);
            self.gpu.wait()?;
            Ok(start.elapsed().as_secs_f64())
        };
        // Enough repetitions that the shorter submission runs for MIN_SECONDS: the difference
        // then stands well above the clock's and the scheduler's noise.
        run(1)?;
        let mut n = self.sizes.repeats;
        while n < MAX_REPEATS && run(n)? < MIN_SECONDS {
            n = (n * 2).min(MAX_REPEATS);
        }
        let mut differences = Vec::with_capacity(TRIALS);
        let mut longest = 0.0f64;
        for _ in 0..TRIALS {
            let short = run(n)?;
            let long = run(2 * n)?;
            longest = longest.max(long);
            differences.push((long - short) / n as f64);
        }
        // The last submission (2n repetitions) is what the checks read.
        let seconds = crate::gpu::timing::median(differences);
        if seconds.is_finite() && seconds > 0.0 {
            Ok(seconds)
        } else {
            // Noise beat the difference: the longest submission per repetition, overheads
            // included, bounds the time from above (the rate reported is then a lower bound).
            Ok(longest / (2 * n) as f64)
        }
    }

    fn bind(&self, params: ProbeParams) -> wgpu::BindGroup {
        let uniform = self.gpu.buffer_with(
            "strata.bandwidth.params",
            std::slice::from_ref(&params),
            wgpu::BufferUsages::UNIFORM,
        );
        crate::gpu::binding::group(
            &self.gpu.device,
            "strata.bandwidth",
            &self.layout,
            &[
                uniform.as_entire_binding(),
                self.source.as_entire_binding(),
                self.destination.as_entire_binding(),
                self.counters.as_entire_binding(),
            ],
        )
    }

    fn copy(&self, enc: &mut wgpu::CommandEncoder) {
        enc.copy_buffer_to_buffer(&self.source, 0, &self.destination, 0, self.sizes.copy_bytes);
    }

    /// Records one grid of `pipeline` with `group` (made once per probe, not per repetition).
    fn dispatch(
        &self,
        enc: &mut wgpu::CommandEncoder,
        pipeline: &wgpu::ComputePipeline,
        group: &wgpu::BindGroup,
    ) {
        let mut pass = enc.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some("strata.bandwidth"),
            timestamp_writes: None,
        });
        pass.set_pipeline(pipeline);
        pass.set_bind_group(0, Some(group), &[]);
        pass.dispatch_workgroups(GRID_WORKGROUPS, 1, 1);
    }

    /// The stream probe's bindings.
    fn stream_group(&self) -> wgpu::BindGroup {
        self.bind(ProbeParams {
            count: (self.sizes.copy_bytes / 16) as u32,
            words: 1,
            invocations: GRID_WORKGROUPS * WORKGROUP,
            ..Default::default()
        })
    }

    /// The bindings of the atomic probe spreading its increments over `words` words.
    fn increment_group(&self, words: u32) -> wgpu::BindGroup {
        self.bind(ProbeParams {
            count: self.sizes.increments,
            words,
            invocations: GRID_WORKGROUPS * WORKGROUP,
            ..Default::default()
        })
    }

    fn check_copy(&self) -> Result<()> {
        let got = crate::gpu::readback::read_u32s(
            self.gpu,
            &self.destination,
            self.sizes.copy_bytes / 4,
        )?;
        match got
            .iter()
            .enumerate()
            .find(|(i, w)| **w != pattern(*i as u32))
        {
            None => Ok(()),
            Some((i, w)) => Err(Error::runtime(format!(
                "bandwidth probe: the copy's word {i} is {w:#x}, not {:#x}",
                pattern(i as u32)
            ))),
        }
    }

    /// Each counter holds the increments that fell on it (mod 2^32, as a counter wraps).
    fn check_increments(&self, words: u32) -> Result<()> {
        let got = crate::gpu::readback::read_u32s(self.gpu, &self.counters, words as u64)?;
        let repetitions = self.repetitions.get();
        let (each, extra) = (self.sizes.increments / words, self.sizes.increments % words);
        let expected = |w: u32| (each + (w < extra) as u32).wrapping_mul(repetitions);
        match (0..words).find(|&w| got[w as usize] != expected(w)) {
            None => Ok(()),
            Some(w) => Err(Error::runtime(format!(
                "bandwidth probe: counter {w} of {words} holds {} after {repetitions} rounds of {} atomic increments, not {}",
                got[w as usize],
                self.sizes.increments,
                expected(w)
            ))),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn probe_params_layout_matches_wgsl() {
        crate::gpu::twin::assert_twin::<ProbeParams>();
        crate::gpu::shader::validate(&stage("bandwidth"));
    }

    /// Probes of `copy_bytes` and `increments`, run once.
    fn small(copy_bytes: u64, increments: u32) -> ProbeSizes {
        ProbeSizes {
            copy_bytes,
            increments,
            repeats: 1,
        }
    }

    /// Small probes on the test adapter: each checks its own result, so a copy that moved the
    /// wrong bytes or an increment that was lost fails here; rates are only required positive
    /// (speed is the benchmark's business).
    #[test]
    fn probes_move_the_right_bytes_and_count_every_increment() {
        let rates = measure(crate::testing::gpu(), small(1 << 20, 1 << 16)).expect("probes run");
        for r in [
            rates.copy_gb_per_s,
            rates.stream_gb_per_s,
            rates.atomics_distinct_g_per_s,
            rates.atomics_per_pixel_g_per_s,
            rates.atomics_one_word_g_per_s,
        ] {
            assert!(r.is_finite() && r > 0.0, "{rates:?}");
        }
    }

    #[test]
    fn a_probe_that_lost_increments_is_an_error() {
        let gpu = crate::testing::gpu();
        let probes = Probes::new(gpu, small(1 << 16, 1 << 12)).unwrap();
        let group = probes.increment_group(64);
        probes
            .time(|enc| probes.dispatch(enc, &probes.increment, &group))
            .unwrap();
        // Claim one more repetition than ran: the sum no longer matches.
        probes.repetitions.set(probes.repetitions.get() + 1);
        let err = probes.check_increments(64).unwrap_err().to_string();
        assert!(err.contains("atomic increments, not"), "{err}");
        // A destination that was cleared after the copy no longer holds the pattern.
        probes.time(|enc| probes.copy(enc)).unwrap();
        probes.check_copy().unwrap();
        let mut enc = gpu.device.create_command_encoder(&Default::default());
        enc.clear_buffer(&probes.destination, 0, None);
        gpu.queue.submit([enc.finish()]);
        assert!(probes.check_copy().is_err());
    }
}
