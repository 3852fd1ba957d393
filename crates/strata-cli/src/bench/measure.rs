//! The measured frame loop: real-time frames through a `FrameRecorder` (one submit a frame, at
//! most two in flight, statistics read back asynchronously), their medians, and the budget of
//! seconds an experiment may spend.

use super::*;

/// One configuration measured in an experiment.
#[derive(Clone, Debug)]
pub struct Run {
    pub(crate) label: String,
    pub(crate) method: String,
    pub(crate) k: Option<u32>,
    /// Samples per pixel (`--msaa`).
    pub(crate) msaa: u32,
    /// The rasterizer of the storage geometry passes (`--raster`).
    pub(crate) raster: strata::frame::Raster,
    /// The families' options, as the library holds them (a family's new option needs nothing
    /// here).
    pub(crate) families: strata::frame::FamilyOptions,
}

impl Run {
    /// `method` as it comes, at the fewest samples it runs with (stochastic's stipples need 4).
    pub(crate) fn plain(method: &str) -> Run {
        let msaa = method
            .parse::<MethodId>()
            .map_or(1, |m| m.descriptor().min_samples);
        Run {
            label: method.into(),
            method: method.into(),
            k: None,
            msaa,
            raster: strata::frame::Raster::Hw,
            families: Default::default(),
        }
    }

    /// `self` with a family's options set to `options`.
    fn with<T: strata::frame::FamilyOption>(mut self, options: T) -> Run {
        self.families.set(options);
        self
    }

    /// The k-buffer family's options of this run.
    pub(crate) fn kbuffer(&self) -> strata::KBufferOptions {
        self.families.get()
    }

    /// `method` at `k` with the fragments past k blended into a tail (`--tail blend|weighted`:
    /// hybrid transparency when weighted).
    pub(crate) fn with_tail(method: &str, k: u32, tail: strata::Tail) -> Run {
        Run {
            label: format!("{method} k={k} tail={}", tail.name()),
            ..Run::with_k(method, k, true)
        }
        .with(strata::KBufferOptions {
            tail,
            ..Default::default()
        })
    }

    /// stochastic with `msaa` samples per pixel and `passes` passes.
    pub(crate) fn stochastic(msaa: u32, passes: u32) -> Run {
        Run {
            label: format!("stochastic msaa={msaa} passes={passes}"),
            msaa,
            ..Run::plain("stochastic")
        }
        .with(strata::WeightedOptions {
            passes,
            ..Default::default()
        })
    }

    /// wavelet with `coefficients` Haar coefficients.
    pub(crate) fn wavelet(coefficients: u32) -> Run {
        Run {
            label: format!("wavelet coefficients={coefficients}"),
            ..Run::plain("wavelet")
        }
        .with(strata::WeightedOptions {
            coefficients,
            ..Default::default()
        })
    }

    /// `base` with this run's method options.
    pub(crate) fn options(&self, base: &strata::RenderOptions) -> strata::RenderOptions {
        let mut options = base.clone();
        options.frame.k = self.k;
        options.build.msaa = self.msaa;
        options.build.raster = self.raster;
        options.frame.families = self.families.clone();
        options
    }

    /// `self` with its per-pixel arrays laid out by `layout` (`--storage-layout`).
    pub(crate) fn laid_out(self, layout: strata::StorageLayout) -> Run {
        let kbuffer = self.kbuffer();
        Run {
            label: format!("{} layout={}", self.label, layout.name()),
            ..self
        }
        .with(strata::KBufferOptions { layout, ..kbuffer })
    }

    /// `self` on the compute rasterizer (`--raster compute`).
    pub(crate) fn on_compute(self) -> Run {
        Run {
            label: format!("{} raster=compute", self.label),
            raster: strata::frame::Raster::Compute,
            ..self
        }
    }

    /// bucket at `k` with `split`.
    pub(crate) fn bucket(k: u32, split: strata::BucketSplit) -> Run {
        Run {
            label: format!("bucket {} k={k}", split.name()),
            k: Some(k),
            ..Run::plain("bucket")
        }
        .with(strata::PeelingOptions {
            buckets: split,
            ..Default::default()
        })
    }

    pub(crate) fn mboit(moments: strata::Moments) -> Run {
        Run {
            label: format!("mboit moments={moments}"),
            ..Run::plain("mboit")
        }
        .with(strata::WeightedOptions {
            moments,
            ..Default::default()
        })
    }

    /// wavg with its pixels' opacity by `opacity`.
    pub(crate) fn wavg(opacity: strata::methods::weighted::Opacity) -> Run {
        Run {
            label: format!("wavg opacity={}", opacity.name()),
            ..Run::plain("wavg")
        }
        .with(strata::WeightedOptions {
            opacity,
            ..Default::default()
        })
    }

    /// `self` at `msaa` samples per pixel.
    pub(crate) fn multisampled(self, msaa: u32) -> Run {
        Run {
            label: format!("{} msaa={msaa}", self.label),
            msaa,
            ..self
        }
    }

    pub(crate) fn wboit(weight: strata::Weight, depth_scale: f64) -> Run {
        Run {
            label: format!("wboit {} scale={depth_scale}", weight.name()),
            ..Run::plain("wboit")
        }
        .with(strata::WeightedOptions {
            weight,
            depth_scale,
            ..Default::default()
        })
    }

    pub(crate) fn with_k(method: &str, k: u32, culling: bool) -> Run {
        Run {
            label: format!("{method} k={k}{}", if culling { "" } else { " no-culling" }),
            k: Some(k),
            ..Run::plain(method)
        }
        .with(strata::KBufferOptions {
            culling,
            ..Default::default()
        })
    }
}

#[derive(Clone, Serialize)]
pub(crate) struct MethodResult {
    pub(crate) scene: String,
    pub(crate) label: String,
    pub(crate) method: String,
    pub(crate) k: Option<u32>,
    pub(crate) culling: bool,
    /// `--storage-layout` (the k-buffer family's per-pixel arrays).
    pub(crate) storage_layout: &'static str,
    /// Samples per pixel.
    pub(crate) msaa: u32,
    pub(crate) frames: u32,
    /// Median over frames of the sum of all passes' GPU time; null without timestamps.
    pub(crate) median_gpu_ms: Option<f64>,
    /// Median GPU ms per pass name.
    pub(crate) median_gpu_ms_per_pass: Option<BTreeMap<String, f64>>,
    /// Wall-clock ms per frame over the timed loop (for `reference`: the median CPU render).
    pub(crate) median_wall_ms: f64,
    /// Frames per second over the timed loop; null for `reference`.
    pub(crate) fps: Option<f64>,
    /// Timed frames whose statistics arrived (the rest found every readback slot in flight).
    pub(crate) frames_with_stats: Option<u32>,
    /// Blocking readbacks inside the timed loop, summed over frames (0: real-time).
    pub(crate) blocking_readbacks: Option<u32>,
    pub(crate) geometry_passes: Option<u32>,
    pub(crate) fragments: Option<u64>,
    pub(crate) fragments_dropped: Option<u64>,
    pub(crate) max_depth_complexity: Option<u32>,
    pub(crate) bytes_allocated: Option<u64>,
    /// Median GPU ms per MiB allocated (seed 003 Fig. 8's measure).
    pub(crate) gpu_ms_per_mib: Option<f64>,
    pub(crate) lock_failures: Option<u64>,
    /// Quality experiments: error against the exact reference with every fragment.
    pub(crate) error_vs_reference: Option<strata::metrics::Comparison>,
    /// Quality experiments: error against the reference keeping each pixel's k nearest.
    pub(crate) error_vs_reference_k: Option<strata::metrics::Comparison>,
    /// Why the run could not be measured (an unsupported feature, say); null when it was.
    pub(crate) skipped: Option<String>,
    /// `tiled`'s statistics of the last measured frame: its work counters (setups,
    /// evaluations, shadings, items, occupancy) and rounds, for a cost model of the frame.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub(crate) tiled: Option<strata::methods::tiled::TiledStats>,
    /// `tiled`: what its cost model (`strata::methods::tiled::cost`, calibrated on the H100's
    /// 2026-11-27 frame) predicts the frame's passes take on an H100, from these counters — on
    /// an H100 the measured times beside it check the model.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub(crate) tiled_h100_model_ms: Option<strata::methods::tiled::cost::PassTimes>,
}

#[derive(Serialize)]
pub(crate) struct BenchReport {
    pub(crate) experiment: String,
    pub(crate) scene: String,
    pub(crate) width: u32,
    pub(crate) height: u32,
    pub(crate) effect: String,
    pub(crate) alpha: Option<f32>,
    #[serde(flatten)]
    pub(crate) provenance: Provenance,
    pub(crate) warmup: u32,
    pub(crate) results: Vec<MethodResult>,
}

/// The process's `--budget-s` deadline, which the standalone experiments read too.
pub(crate) static DEADLINE: std::sync::OnceLock<(Instant, f64)> = std::sync::OnceLock::new();

/// Why a standalone experiment may start no further run: `--budget-s` was spent.
pub(crate) fn out_of_time() -> Option<String> {
    let (at, limit) = DEADLINE.get()?;
    (Instant::now() >= *at)
        .then(|| format!("not run: the experiment's --budget-s {limit} was spent"))
}

/// `--budget-s`: the wall-clock time an experiment may spend, from its start.
pub(crate) struct Budget {
    pub(crate) start: std::time::Instant,
    pub(crate) seconds: Option<f64>,
}

impl Budget {
    pub(crate) fn new(seconds: Option<f64>) -> Result<Budget> {
        if let Some(s) = seconds {
            if !(s.is_finite() && s > 0.0) {
                return Err(Error::input(format!(
                    "--budget-s {s} is not a positive number of seconds"
                )));
            }
        }
        let start = Instant::now();
        if let Some(s) = seconds {
            let _ = DEADLINE.set((start + std::time::Duration::from_secs_f64(s), s));
        }
        Ok(Budget { start, seconds })
    }

    /// Why no further run may start, once the budget is spent.
    pub(crate) fn spent(&self) -> Option<String> {
        let limit = self.seconds?;
        (self.start.elapsed().as_secs_f64() >= limit)
            .then(|| format!("not run: the experiment's --budget-s {limit} was spent"))
    }
}

/// An experiment's progress bar over `len` frames (or steps), its message naming the current
/// configuration; inside `bench all`, drawn under the suite's bar.
pub(crate) fn frames_bar(len: u64) -> ProgressBar {
    let bar = ProgressBar::new(len).with_style(
        ProgressStyle::with_template("{bar:40} {pos}/{len}  {msg}  (eta {eta})")
            .expect("valid template"),
    );
    crate::bench::suite::attach(bar)
}

/// A scene spec without its parameters, for progress messages.
pub(crate) fn short_scene(spec: &str) -> &str {
    spec.split('?').next().unwrap_or(spec)
}

pub(crate) fn skipped(run: &Run, frames: u32, why: String) -> MethodResult {
    MethodResult {
        skipped: Some(why),
        ..MethodResult::new(run, frames)
    }
}

impl MethodResult {
    /// A run with nothing measured yet.
    pub(crate) fn new(run: &Run, frames: u32) -> MethodResult {
        MethodResult {
            scene: String::new(),
            label: run.label.clone(),
            method: run.method.clone(),
            k: run.k,
            culling: run.kbuffer().culling,
            storage_layout: run.kbuffer().layout.name(),
            msaa: run.msaa,
            frames,
            median_gpu_ms: None,
            median_gpu_ms_per_pass: None,
            median_wall_ms: f64::NAN,
            fps: None,
            frames_with_stats: None,
            blocking_readbacks: None,
            geometry_passes: None,
            fragments: None,
            fragments_dropped: None,
            max_depth_complexity: None,
            bytes_allocated: None,
            gpu_ms_per_mib: None,
            lock_failures: None,
            error_vs_reference: None,
            error_vs_reference_k: None,
            skipped: None,
            tiled: None,
            tiled_h100_model_ms: None,
        }
    }
}

/// Frames in flight in the timed loop, as a swap chain of two would allow.
pub(crate) const FRAMES_IN_FLIGHT: usize = 2;

/// Renders warm-up then timed real-time frames of one run; returns its medians and the last
/// timed frame's statistics.
pub(crate) fn measure(
    gpu: &Gpu,
    scene: &strata::scene::Scene,
    options: &strata::RenderOptions,
    run: &Run,
    warmup: u32,
    frames: u32,
    bar: &ProgressBar,
) -> Result<(MethodResult, Option<FrameStats>)> {
    let (result, timed) = measure_views(gpu, scene, options, run, warmup, frames, bar, &[])?;
    Ok((result, timed.last().cloned()))
}

/// [`measure`] with frame `f` (warm-up frames counted) seen from `cameras[f % len]` when
/// `cameras` is not empty (the scene's own camera otherwise); returns the timed frames'
/// statistics that arrived, in frame order.
#[allow(clippy::too_many_arguments)]
pub(crate) fn measure_views(
    gpu: &Gpu,
    scene: &strata::scene::Scene,
    options: &strata::RenderOptions,
    run: &Run,
    warmup: u32,
    frames: u32,
    bar: &ProgressBar,
    cameras: &[strata::scene::Camera],
) -> Result<(MethodResult, Vec<FrameStats>)> {
    let mut result = MethodResult::new(run, frames);
    let method: MethodId = run.method.parse()?;
    if method == MethodId::Reference {
        let mut walls = Vec::new();
        let mut last = None;
        for f in 0..warmup + frames {
            let viewed;
            let scene = match cameras.get(f as usize % cameras.len().max(1)) {
                Some(camera) => {
                    viewed = strata::scene::Scene {
                        camera: Some(*camera),
                        ..scene.clone()
                    };
                    &viewed
                }
                None => scene,
            };
            let start = Instant::now();
            let (_, stats) = strata::reference::render(scene, options)?;
            if f >= warmup {
                walls.push(start.elapsed().as_secs_f64() * 1e3);
            }
            last = Some(stats);
            bar.inc(1);
        }
        result.median_wall_ms = median(walls);
        let last = last.expect("at least one frame");
        fill_counts(&mut result, &last);
        return Ok((result, vec![last]));
    }
    let mut recorder = FrameRecorder::new(gpu, scene, method, options)?;
    let target = gpu.texture_2d(
        "strata.bench.target",
        (options.frame.width, options.frame.height),
        wgpu::TextureFormat::Rgba8UnormSrgb,
        wgpu::TextureUsages::RENDER_ATTACHMENT,
    );
    let view = target.create_view(&Default::default());
    let targets = FrameTargets {
        color: Some((&view, wgpu::TextureFormat::Rgba8UnormSrgb)),
        opaque_depth: None,
    };
    let mut in_flight = std::collections::VecDeque::new();
    let mut stats: Vec<FrameStats> = Vec::new();
    let mut start = Instant::now();
    for f in 0..warmup + frames {
        if f == warmup {
            // The timed loop starts with the warm-up frames finished.
            gpu.wait()?;
            stats.extend(recorder.poll_stats());
            in_flight.clear();
            start = Instant::now();
        }
        if in_flight.len() >= FRAMES_IN_FLIGHT {
            let oldest = in_flight.pop_front().expect("non-empty");
            gpu.device
                .poll(wgpu::PollType::Wait {
                    submission_index: Some(oldest),
                    timeout: None,
                })
                .map_err(|e| Error::runtime(format!("GPU wait failed: {e}")))?;
        }
        if !cameras.is_empty() {
            recorder.set_camera(&cameras[f as usize % cameras.len()]);
        }
        let mut encoder = gpu.device.create_command_encoder(&Default::default());
        recorder.record(&mut encoder, &targets, None)?;
        in_flight.push_back(gpu.queue.submit([encoder.finish()]));
        stats.extend(recorder.poll_stats());
        bar.inc(1);
    }
    gpu.wait()?;
    let elapsed = start.elapsed().as_secs_f64();
    stats.extend(recorder.poll_stats());
    let timed: Vec<&FrameStats> = stats.iter().filter(|s| s.frame >= warmup as u64).collect();
    result.median_wall_ms = elapsed * 1e3 / frames as f64;
    result.fps = Some(frames as f64 / elapsed);
    result.frames_with_stats = Some(timed.len() as u32);
    result.blocking_readbacks = Some(timed.iter().map(|s| s.blocking_readbacks).sum());
    let totals: Vec<f64> = timed.iter().filter_map(|s| s.gpu_ms_total).collect();
    result.median_gpu_ms = (!totals.is_empty()).then(|| median(totals));
    let mut per_pass: BTreeMap<String, Vec<f64>> = BTreeMap::new();
    for s in &timed {
        for (k, v) in s.gpu_ms.iter().flatten() {
            per_pass.entry(k.clone()).or_default().push(*v);
        }
    }
    result.median_gpu_ms_per_pass =
        (!per_pass.is_empty()).then(|| per_pass.into_iter().map(|(k, v)| (k, median(v))).collect());
    if let Some(last) = timed.last() {
        fill_counts(&mut result, last);
    }
    result.gpu_ms_per_mib = match (result.median_gpu_ms, result.bytes_allocated) {
        (Some(ms), Some(bytes)) if bytes > 0 => Some(ms / (bytes as f64 / 1048576.0)),
        _ => None,
    };
    Ok((result, timed.into_iter().cloned().collect()))
}

pub(crate) fn fill_counts(result: &mut MethodResult, stats: &FrameStats) {
    result.geometry_passes = Some(stats.geometry_passes);
    result.fragments = stats.fragments_generated;
    result.fragments_dropped = stats.fragments_dropped;
    result.max_depth_complexity = stats.max_depth_complexity;
    result.bytes_allocated = Some(stats.bytes_allocated);
    result.lock_failures = stats.lock_failures;
    result.tiled = stats
        .family::<strata::methods::tiled::TiledStats>()
        .cloned();
    result.tiled_h100_model_ms = match (
        stats.family::<strata::methods::tiled::TiledStats>(),
        &stats.compute_raster,
    ) {
        (Some(tiled), Some(raster)) => {
            let pixels = stats.width as u64 * stats.height as u64;
            let work = strata::methods::tiled::cost::Work::of_frame(tiled, raster, pixels);
            Some(strata::methods::tiled::cost::Costs::h100().predict(&work))
        }
        _ => None,
    };
}
