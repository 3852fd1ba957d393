//! `strata bench`: named experiments and ad-hoc runs, measured as an application runs strata:
//! a steady-state loop of real-time frames (one submit per frame, each frame resolved OVER an
//! offscreen color target, statistics read asynchronously, at most two frames in flight as a
//! swap chain would allow), after warm-up frames. Reported: the median GPU time per frame and
//! per pass (timestamp queries, from the frames' own statistics), wall-clock frames per second
//! over the timed loop, and the frames' counters; `blocking_readbacks` stays 0 inside the loop.
//! Written as JSON and CSV with the device, driver, size and commit. Figures from a CPU adapter
//! (lavapipe) are CPU figures and are labelled so.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::time::Instant;

use clap::Args;
use indicatif::{ProgressBar, ProgressStyle};
use serde::Serialize;
use strata::error::{Error, Result};
use strata::frame::{FrameStats, FrameTargets};
use strata::gpu::Gpu;
use strata::render::Renderer;
use strata::FrameRecorder;
use strata::MethodId;

use crate::{prepare, PictureArgs};

#[derive(Args)]
pub struct BenchArgs {
    /// A named experiment (see --list), `all` for every one in turn, `compare` (OLD.json
    /// NEW.json: which figures moved beyond the noise), or none with --scene/--methods.
    experiment: Option<String>,
    /// `compare`: the old results file, then the new one.
    files: Vec<PathBuf>,
    /// `compare`: another run of the old code (repeatable): the spread across runs is the noise.
    #[arg(long)]
    repeat: Vec<PathBuf>,
    /// `compare`: timing noise in percent assumed without --repeat.
    #[arg(long, default_value_t = 10.0)]
    threshold: f64,
    /// `compare`: timing figures that changed less than this percentage never count as moved.
    #[arg(long, default_value_t = 2.0)]
    min_change: f64,
    /// `compare`: write the comparison as JSON.
    #[arg(long)]
    json: bool,
    /// List the named experiments.
    #[arg(long)]
    list: bool,
    /// An ad-hoc run's scene (with --methods), or the one scene a named experiment runs on.
    #[arg(long)]
    scene: Option<String>,
    /// Comma-separated method ids.
    #[arg(long)]
    methods: Option<String>,
    /// Timed frames per method.
    #[arg(long)]
    pub(crate) frames: Option<u32>,
    /// Untimed frames before them.
    #[arg(long, default_value_t = 2)]
    warmup: u32,
    /// k for the methods of an ad-hoc run.
    #[arg(long)]
    k: Option<u32>,
    /// Frame size, WxH (default: the experiment's, which is smaller on a CPU adapter; 512x512
    /// for an ad-hoc run).
    #[arg(long)]
    pub(crate) size: Option<String>,
    /// Sets every material's opacity.
    #[arg(long)]
    alpha: Option<f32>,
    #[arg(long, value_enum, default_value = "transparency")]
    effect: strata::Effect,
    /// Output folder (default: bench/results/<device>/).
    #[arg(long)]
    out: Option<PathBuf>,
    /// With `all`: only these experiments (comma-separated names).
    #[arg(long)]
    pub(crate) only: Option<String>,
    /// With `all`: every experiment but these (comma-separated names).
    #[arg(long)]
    pub(crate) skip: Option<String>,
    /// Wall-clock seconds the experiment may spend: once spent, the runs not yet started are
    /// recorded as skipped (results are written after every run either way).
    #[arg(long)]
    pub(crate) budget_s: Option<f64>,
}

impl BenchArgs {
    /// Options that configure one ad-hoc run or override one experiment's scene.
    pub(crate) fn has_single_run_options(&self) -> bool {
        self.scene.is_some() || self.methods.is_some() || self.k.is_some() || self.alpha.is_some()
    }
}

/// One configuration measured in an experiment.
#[derive(Clone, Debug)]
pub struct Run {
    label: String,
    method: String,
    k: Option<u32>,
    culling: bool,
    /// wboit's weight function and depth scale.
    weight: strata::Weight,
    depth_scale: f64,
    /// Samples per pixel (`--msaa`).
    msaa: u32,
    /// mboit's power moments.
    moments: u32,
    /// bucket's split of the depth range.
    buckets: strata::BucketSplit,
}

impl Run {
    pub(crate) fn plain(method: &str) -> Run {
        Run {
            label: method.into(),
            method: method.into(),
            k: None,
            culling: true,
            weight: strata::Weight::default(),
            depth_scale: 1.0,
            msaa: 1,
            moments: 4,
            buckets: strata::BucketSplit::Uniform,
        }
    }

    /// bucket at `k` with `split`.
    fn bucket(k: u32, split: strata::BucketSplit) -> Run {
        Run {
            label: format!("bucket {} k={k}", split.name()),
            k: Some(k),
            buckets: split,
            ..Run::plain("bucket")
        }
    }

    fn mboit(moments: u32) -> Run {
        Run {
            label: format!("mboit moments={moments}"),
            moments,
            ..Run::plain("mboit")
        }
    }

    /// `self` at `msaa` samples per pixel.
    fn multisampled(self, msaa: u32) -> Run {
        Run {
            label: format!("{} msaa={msaa}", self.label),
            msaa,
            ..self
        }
    }

    fn wboit(weight: strata::Weight, depth_scale: f64) -> Run {
        Run {
            label: format!("wboit {} scale={depth_scale}", weight.name()),
            weight,
            depth_scale,
            ..Run::plain("wboit")
        }
    }

    pub(crate) fn with_k(method: &str, k: u32, culling: bool) -> Run {
        Run {
            label: format!("{method} k={k}{}", if culling { "" } else { " no-culling" }),
            k: Some(k),
            culling,
            ..Run::plain(method)
        }
    }
}

struct Experiment {
    name: &'static str,
    description: &'static str,
    /// The scenes, each run with every configuration.
    scenes: &'static [&'static str],
    /// Size on a GPU, and on a CPU adapter (lavapipe), where the full size would take hours.
    size_gpu: &'static str,
    size_cpu: &'static str,
    alpha: Option<f32>,
    frames: u32,
    runs: fn() -> Vec<Run>,
    /// Also measure each run's image error against the reference (full and --k).
    quality: bool,
}

/// Every k-buffer method of the k+-buffer paper's comparison (kb-mdt64 where the adapter has
/// 64-bit atomics).
const K_METHODS: &[&str] = &[
    "kb-keys",
    "kplus-array",
    "kplus-array-r",
    "kplus-heap",
    "kb",
    "kb-ps",
    "kb-mdt32",
    "kb-mdt64",
    "kb-mdt-pack",
    "kb-ab-fixed",
    "kb-ab-ll",
    "kb-ll",
    "abuffer-fixed",
];

const EXPERIMENTS: &[Experiment] = &[
    Experiment {
        name: "approx-quality",
        description: "what engines ship against exact: wboit (eqs. 7-10, depth scales 1 and 50), mboit (4, 6, 8 moments), unsorted, sorted, kplus-heap k=8, bucket k=16 (uniform, adaptive) and the exact abuffer-ll and kpeel, on nvpro, the dragon, the demo and balls: error against the reference (RMSE, FLIP, % over 2/255, heatmaps), time, memory",
        scenes: &[
            "builtin:nvpro?objects=1024&subdiv=16&seed=0",
            "builtin:dragon",
            "builtin:demo",
            "builtin:balls",
        ],
        size_gpu: "1024x1024",
        size_cpu: "192x192",
        alpha: None,
        frames: 5,
        runs: || {
            use strata::Weight;
            let mut runs: Vec<Run> = [Weight::Eq7, Weight::Eq8, Weight::Eq9, Weight::Eq10]
                .into_iter()
                .flat_map(|w| [Run::wboit(w, 1.0), Run::wboit(w, 50.0)])
                .collect();
            runs.extend([
                Run::plain("mboit"),
                Run::mboit(6),
                Run::mboit(8),
                Run::plain("unsorted"),
                Run::plain("sorted"),
                Run::with_k("kplus-heap", 8, true),
                Run::bucket(16, strata::BucketSplit::Uniform),
                Run::bucket(16, strata::BucketSplit::Adaptive),
                Run::plain("abuffer-ll"),
                Run::with_k("kpeel", 8, true),
            ]);
            runs
        },
        quality: true,
    },
    Experiment {
        name: "msaa",
        description: "issue 13: every family that takes --msaa at 1, 4 and 8 samples per pixel (8 where the device rasterizes it): time, memory, fragments stored (a pixel on a mesh edge stores one per primitive touching it), abuffer-fixed's drops at k = 16 (edges overflowing per-pixel arrays), kplus-heap's and kb-mdt32's per-sample storage (each sample its own k: S times the memory, nothing lost at edges), and peeling and convex per sample (f2b, kpeel: one more geometry pass, the account)",
        scenes: &["builtin:dragon", "builtin:spheres", "builtin:nvpro?objects=1024&subdiv=16&seed=0"],
        size_gpu: "1024x1024",
        size_cpu: "160x160",
        alpha: Some(0.5),
        frames: 5,
        runs: || {
            let base = [
                Run::plain("abuffer-ll"),
                Run::plain("sbuffer"),
                Run::with_k("kb-ab-ll", 8, true),
                Run::with_k("kb-ab-fixed", 8, true),
                Run::with_k("abuffer-fixed", 16, true),
                Run::with_k("kplus-heap", 8, true),
                Run::with_k("kb-mdt32", 8, true),
                Run::plain("f2b"),
                Run::with_k("kpeel", 8, true),
                Run::plain("convex"),
                Run::plain("wboit"),
                Run::plain("mboit"),
                Run::plain("unsorted"),
            ];
            base.iter()
                .flat_map(|r| [1, 4, 8].map(|n| r.clone().multisampled(n)))
                .collect()
        },
        quality: false,
    },
    Experiment {
        name: "bucket",
        description: "bucket depth peeling (Liu et al. 2009), uniform and adaptive buckets, at k = 8, 16 and 32 (where the device blends 8 RGBA32F targets) and at k = 16 with --msaa 4, against exact peeling (f2b, dual) and abuffer-ll: time, geometry passes, memory, fragments lost to bucket collisions and the error they cost against the reference",
        scenes: &[
            "builtin:dragon",
            "builtin:spheres",
            "builtin:nvpro?objects=1024&subdiv=16&seed=0",
            "builtin:layers?n=32&coverage=0.75&order=random&seed=1",
        ],
        size_gpu: "1024x1024",
        size_cpu: "192x192",
        alpha: Some(0.5),
        frames: 5,
        runs: || {
            use strata::BucketSplit;
            let mut runs: Vec<Run> = [BucketSplit::Uniform, BucketSplit::Adaptive]
                .into_iter()
                .flat_map(|split| [8, 16, 32].map(|k| Run::bucket(k, split)))
                .collect();
            runs.extend(
                [BucketSplit::Uniform, BucketSplit::Adaptive]
                    .map(|split| Run::bucket(16, split).multisampled(4)),
            );
            runs.extend(["f2b", "dual", "abuffer-ll"].map(Run::plain));
            runs
        },
        quality: true,
    },
    Experiment {
        name: "realtime",
        description: "real-time frames of every GPU method on the dragon (opacity 0.5) and nvpro: GPU ms and frames per second, no blocking readback",
        scenes: &["builtin:dragon", "builtin:nvpro?objects=1024&subdiv=16&seed=0"],
        size_gpu: "1024x1024",
        size_cpu: "192x192",
        alpha: Some(0.5),
        frames: 10,
        runs: || {
            MethodId::gpu_methods()
                .map(|m| Run::plain(m.as_str()))
                .chain(std::iter::once(Run::plain("reference")))
                .collect()
        },
        quality: false,
    },
    Experiment {
        name: "foundation",
        description: "exact baselines on the dragon (opacity 0.5): f2b, dual, abuffer-ll, sorted and the CPU reference",
        scenes: &["builtin:dragon"],
        size_gpu: "512x512",
        size_cpu: "512x512",
        alpha: Some(0.5),
        frames: 5,
        runs: || ["f2b", "dual", "abuffer-ll", "sorted", "reference"].iter().map(|m| Run::plain(m)).collect(),
        quality: false,
    },
    Experiment {
        name: "kbuffer-k",
        description: "seed 003 Fig. 6: 128 layers over 75% of the screen, k = 4..64, every k-buffer method",
        scenes: &["builtin:layers?n=128&coverage=0.75&order=random&seed=1"],
        size_gpu: "1024x1024",
        size_cpu: "128x128",
        alpha: None,
        frames: 5,
        runs: || {
            [4, 8, 16, 32, 64]
                .iter()
                .flat_map(|&k| K_METHODS.iter().map(move |m| Run::with_k(m, k, true)))
                .collect()
        },
        quality: false,
    },
    Experiment {
        name: "kbuffer-culling",
        description: "seed 003 Fig. 7: culling on and off for kplus-array, kplus-heap, kb-ps, kb-mdt32 at k = 4, 16, 64",
        scenes: &["builtin:layers?n=128&coverage=0.75&order=random&seed=1"],
        size_gpu: "1024x1024",
        size_cpu: "128x128",
        alpha: None,
        frames: 5,
        runs: || {
            let mut runs = Vec::new();
            for k in [4, 16, 64] {
                for m in ["kplus-array", "kplus-heap", "kb-ps", "kb-mdt32"] {
                    runs.push(Run::with_k(m, k, true));
                    runs.push(Run::with_k(m, k, false));
                }
            }
            runs
        },
        quality: false,
    },
    Experiment {
        name: "memory-density",
        description: "seed 003 Fig. 8: GPU ms per MiB of the bounded methods at k = 16 as coverage (25, 50, 100%) and fragments per pixel (16, 64) grow",
        scenes: &[
            "builtin:layers?n=16&coverage=0.25&order=random&seed=1",
            "builtin:layers?n=16&coverage=0.5&order=random&seed=1",
            "builtin:layers?n=16&coverage=1&order=random&seed=1",
            "builtin:layers?n=64&coverage=0.25&order=random&seed=1",
            "builtin:layers?n=64&coverage=0.5&order=random&seed=1",
            "builtin:layers?n=64&coverage=1&order=random&seed=1",
        ],
        size_gpu: "1024x1024",
        size_cpu: "128x128",
        alpha: None,
        frames: 5,
        runs: || {
            ["kplus-array", "kplus-heap", "kplus-sbuffer", "kb-sbuffer", "kb-mdt32", "abuffer-fixed"]
                .iter()
                .map(|m| Run::with_k(m, 16, true))
                .collect()
        },
        quality: false,
    },
    Experiment {
        name: "peel-vs-abuffer",
        description: "seed 003 Fig. 9 right: kpeel (k = 8, 32), f2b, dual, abuffer-ll, abuffer-fixed, sbuffer, kplus-sbuffer (k = 128: every fragment) over depth complexity 8..128",
        scenes: &[
            "builtin:layers?n=8&coverage=1&order=random&seed=1",
            "builtin:layers?n=16&coverage=1&order=random&seed=1",
            "builtin:layers?n=32&coverage=1&order=random&seed=1",
            "builtin:layers?n=64&coverage=1&order=random&seed=1",
            "builtin:layers?n=128&coverage=1&order=random&seed=1",
        ],
        size_gpu: "1024x1024",
        size_cpu: "96x96",
        alpha: None,
        frames: 5,
        runs: || {
            vec![
                Run::with_k("kpeel", 8, true),
                Run::with_k("kpeel", 32, true),
                Run::plain("f2b"),
                Run::plain("dual"),
                Run::plain("abuffer-ll"),
                Run::with_k("abuffer-fixed", 128, true),
                Run::plain("sbuffer"),
                Run::with_k("kplus-sbuffer", 128, true),
            ]
        },
        quality: false,
    },
    Experiment {
        name: "kbuffer-quality",
        description: "seed 003 Fig. 10: image error of every k-buffer method at k = 16 against the exact reference, with heatmaps",
        scenes: &["builtin:nvpro?objects=1024&subdiv=16&seed=0"],
        size_gpu: "1024x1024",
        size_cpu: "256x256",
        alpha: None,
        frames: 3,
        runs: || K_METHODS.iter().map(|m| Run::with_k(m, 16, true)).collect(),
        quality: true,
    },
];

#[derive(Clone, Serialize)]
pub(crate) struct MethodResult {
    scene: String,
    label: String,
    method: String,
    k: Option<u32>,
    culling: bool,
    /// Samples per pixel.
    msaa: u32,
    frames: u32,
    /// Median over frames of the sum of all passes' GPU time; null without timestamps.
    pub(crate) median_gpu_ms: Option<f64>,
    /// Median GPU ms per pass name.
    pub(crate) median_gpu_ms_per_pass: Option<BTreeMap<String, f64>>,
    /// Wall-clock ms per frame over the timed loop (for `reference`: the median CPU render).
    pub(crate) median_wall_ms: f64,
    /// Frames per second over the timed loop; null for `reference`.
    pub(crate) fps: Option<f64>,
    /// Timed frames whose statistics arrived (the rest found every readback slot in flight).
    frames_with_stats: Option<u32>,
    /// Blocking readbacks inside the timed loop, summed over frames (0: real-time).
    blocking_readbacks: Option<u32>,
    pub(crate) geometry_passes: Option<u32>,
    pub(crate) fragments: Option<u64>,
    pub(crate) fragments_dropped: Option<u64>,
    pub(crate) max_depth_complexity: Option<u32>,
    pub(crate) bytes_allocated: Option<u64>,
    /// Median GPU ms per MiB allocated (seed 003 Fig. 8's measure).
    gpu_ms_per_mib: Option<f64>,
    lock_failures: Option<u64>,
    /// Quality experiments: error against the exact reference with every fragment.
    error_vs_reference: Option<strata::metrics::Comparison>,
    /// Quality experiments: error against the reference keeping each pixel's k nearest.
    error_vs_reference_k: Option<strata::metrics::Comparison>,
    /// Why the run could not be measured (an unsupported feature, say); null when it was.
    skipped: Option<String>,
}

#[derive(Serialize)]
struct BenchReport {
    experiment: String,
    scene: String,
    width: u32,
    height: u32,
    effect: String,
    alpha: Option<f32>,
    adapter: String,
    backend: String,
    device_type: String,
    driver: String,
    /// True when the adapter is a CPU (lavapipe): the figures measure a CPU, not a GPU.
    cpu_figures: bool,
    commit: Option<String>,
    unix_time: u64,
    warmup: u32,
    results: Vec<MethodResult>,
}

pub(crate) use strata::metrics::median;

pub(crate) fn commit() -> Option<String> {
    let out = std::process::Command::new("git")
        .args(["rev-parse", "--short", "HEAD"])
        .output()
        .ok()?;
    out.status
        .success()
        .then(|| String::from_utf8_lossy(&out.stdout).trim().to_string())
}

pub fn device_slug(gpu: &Gpu) -> String {
    let name = gpu.info.name.to_lowercase();
    if name.contains("llvmpipe") {
        return "lavapipe".into();
    }
    let slug: String = name
        .chars()
        .map(|c| if c.is_ascii_alphanumeric() { c } else { '-' })
        .collect();
    slug.split('-')
        .filter(|s| !s.is_empty())
        .collect::<Vec<_>>()
        .join("-")
}

/// What every standalone experiment's results file starts with (flattened into it): the same
/// provenance as a frame-loop experiment's.
#[derive(Clone, Serialize)]
pub(crate) struct Header {
    pub(crate) experiment: &'static str,
    pub(crate) adapter: String,
    pub(crate) backend: String,
    pub(crate) device_type: String,
    pub(crate) driver: String,
    /// True when the adapter is a CPU (lavapipe): the figures measure a CPU, not a GPU.
    pub(crate) cpu_figures: bool,
    pub(crate) commit: Option<String>,
    pub(crate) unix_time: u64,
}

impl Header {
    pub(crate) fn new(experiment: &'static str, gpu: &Gpu, cpu_figures: bool) -> Header {
        Header {
            experiment,
            adapter: gpu.info.name.clone(),
            backend: gpu.backend_name(),
            device_type: device_type(gpu),
            driver: driver(gpu),
            cpu_figures,
            commit: commit(),
            unix_time: unix_time(),
        }
    }
}

fn device_type(gpu: &Gpu) -> String {
    format!("{:?}", gpu.info.device_type)
}

fn driver(gpu: &Gpu) -> String {
    format!("{} {}", gpu.info.driver, gpu.info.driver_info)
        .trim()
        .to_string()
}

pub(crate) fn unix_time() -> u64 {
    std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map(|d| d.as_secs())
        .unwrap_or(0)
}

/// A number with `digits` decimals, or nothing (a table's empty cell).
pub(crate) fn fixed(v: Option<f64>, digits: usize) -> String {
    v.map(|v| format!("{v:.digits$}")).unwrap_or_default()
}

/// A value, or nothing (a table's empty cell).
pub(crate) fn opt<T: std::fmt::Display>(v: Option<T>) -> String {
    v.map(|v| v.to_string()).unwrap_or_default()
}

/// The suffix of a report's heading whose figures come from a CPU adapter.
pub(crate) fn cpu_label(cpu_figures: bool) -> &'static str {
    if cpu_figures {
        " (CPU figures: lavapipe)"
    } else {
        ""
    }
}

/// An experiment with its own runner: (GPU, `--size`, `--frames`, output folder).
type StandaloneRun = fn(&Gpu, Option<&str>, Option<u32>, &Path) -> Result<()>;

/// The experiments that report their own tables: name, description, runner.
const STANDALONE: [(&str, &str, StandaloneRun); 8] = [
    ("auto-k", crate::auto_k::DESCRIPTION, crate::auto_k::run),
    (
        "deferred-lights",
        crate::deferred_lights::DESCRIPTION,
        crate::deferred_lights::run,
    ),
    (
        "cuda-renderer",
        crate::cuda_renderer::DESCRIPTION,
        crate::cuda_renderer::run,
    ),
    ("scale", crate::scale::DESCRIPTION, crate::scale::run),
    (
        "online-culling",
        crate::online_culling::DESCRIPTION,
        crate::online_culling::run,
    ),
    (
        "convex",
        crate::convex_experiment::DESCRIPTION,
        crate::convex_experiment::run,
    ),
    ("peers", crate::peers::DESCRIPTION, crate::peers::run),
    (
        "bandwidth",
        crate::bandwidth::DESCRIPTION,
        crate::bandwidth::run,
    ),
];

/// Size, frame count and whether figures are CPU figures for a standalone experiment: `--size`
/// or the default for the adapter's kind (`cpu` on lavapipe, `gpu` otherwise), likewise frames.
pub(crate) fn standalone_setup(
    gpu: &Gpu,
    size: Option<&str>,
    frames: Option<u32>,
    (cpu_size, gpu_size): ((u32, u32), (u32, u32)),
    (cpu_frames, gpu_frames): (u32, u32),
) -> Result<(bool, (u32, u32), u32)> {
    let cpu_figures = gpu.info.device_type == wgpu::DeviceType::Cpu;
    let size = match size {
        Some(s) => crate::parse_size(s)?,
        None if cpu_figures => cpu_size,
        None => gpu_size,
    };
    let frames = frames.unwrap_or(if cpu_figures { cpu_frames } else { gpu_frames });
    if frames == 0 {
        return Err(Error::input("--frames must be at least 1"));
    }
    Ok((cpu_figures, size, frames))
}

pub fn run(a: BenchArgs) -> Result<()> {
    if a.list {
        for e in EXPERIMENTS {
            println!("{:<16} {}", e.name, e.description);
        }
        for (name, description, _) in STANDALONE {
            println!("{name:<16} {description}");
        }
        return Ok(());
    }
    if a.experiment.as_deref() == Some("compare") {
        let [old, new] = &a.files[..] else {
            return Err(Error::input(
                "bench compare needs two results files: OLD.json NEW.json",
            ));
        };
        if !(a.threshold >= 0.0 && a.min_change >= 0.0) {
            return Err(Error::input(
                "--threshold and --min-change are percentages, at least 0",
            ));
        }
        let settings = crate::compare::Settings {
            threshold_pct: a.threshold,
            min_change_pct: a.min_change,
        };
        return crate::compare::run(old, &a.repeat, new, &settings, a.json);
    }
    if !a.files.is_empty() || !a.repeat.is_empty() || a.json {
        return Err(Error::input(
            "files, --repeat and --json apply to `bench compare OLD.json NEW.json`",
        ));
    }
    let gpu = Gpu::new()?;
    if a.experiment.as_deref() == Some("all") {
        return crate::suite::run(&gpu, &a);
    }
    if a.only.is_some() || a.skip.is_some() {
        return Err(Error::input("--only and --skip apply to `bench all`"));
    }
    run_experiment(&gpu, &a, a.experiment.as_deref())
}

/// Every named experiment, in the order `bench all` runs them.
pub(crate) fn experiment_names() -> Vec<&'static str> {
    EXPERIMENTS
        .iter()
        .map(|e| e.name)
        .chain(STANDALONE.iter().map(|e| e.0))
        .collect()
}

/// The output folder: `--out`, else `bench/results/<device>/`.
pub(crate) fn results_dir(gpu: &Gpu, a: &BenchArgs) -> PathBuf {
    a.out
        .clone()
        .unwrap_or_else(|| PathBuf::from("bench/results").join(device_slug(gpu)))
}

/// Runs the named experiment `experiment`, or the ad-hoc run of `--scene` and `--methods`.
pub(crate) fn run_experiment(gpu: &Gpu, a: &BenchArgs, experiment: Option<&str>) -> Result<()> {
    let cpu_figures = gpu.info.device_type == wgpu::DeviceType::Cpu;
    if let Some((_, _, run)) = STANDALONE.iter().find(|e| experiment == Some(e.0)) {
        // Sets the deadline the standalone experiment reads (`out_of_time`).
        Budget::new(a.budget_s)?;
        return run(gpu, a.size.as_deref(), a.frames, &results_dir(gpu, a));
    }
    let k_flag = a.k;
    let (name, scenes, runs, size, alpha, frames, quality) = match experiment {
        Some(n) => {
            let e = EXPERIMENTS.iter().find(|e| e.name == n).ok_or_else(|| {
                Error::input(format!(
                    "unknown experiment '{n}' (available: all, {})",
                    experiment_names().join(", ")
                ))
            })?;
            if a.methods.is_some() {
                return Err(Error::input(
                    "--methods applies to ad-hoc runs (--scene), not to named experiments",
                ));
            }
            let default_size = if cpu_figures { e.size_cpu } else { e.size_gpu };
            (
                e.name.to_string(),
                match &a.scene {
                    Some(s) => vec![s.clone()],
                    None => e.scenes.iter().map(|s| s.to_string()).collect(),
                },
                (e.runs)(),
                a.size.clone().unwrap_or(default_size.into()),
                a.alpha.or(e.alpha),
                a.frames.unwrap_or(e.frames),
                e.quality,
            )
        }
        None => {
            let scene = a.scene.clone().ok_or_else(|| {
                Error::input("bench needs an experiment name or --scene and --methods")
            })?;
            let methods = a
                .methods
                .clone()
                .ok_or_else(|| Error::input("bench --scene needs --methods a,b,c"))?;
            let runs = methods
                .split(',')
                .map(str::trim)
                .filter(|m| !m.is_empty())
                .map(|m| match k_flag {
                    Some(k) => Run::with_k(m, k, true),
                    None => Run::plain(m),
                })
                .collect();
            (
                "adhoc".to_string(),
                vec![scene],
                runs,
                a.size.clone().unwrap_or("512x512".into()),
                a.alpha,
                a.frames.unwrap_or(10),
                false,
            )
        }
    };
    if frames == 0 {
        return Err(Error::input("--frames must be at least 1"));
    }
    for r in &runs {
        r.method.parse::<strata::MethodId>()?;
    }
    let dir = results_dir(gpu, a);
    crate::check_results_dir(&dir)?;
    let budget = Budget::new(a.budget_s)?;
    let bar = frames_bar((scenes.len() * runs.len()) as u64 * (a.warmup + frames) as u64);
    let mut results = Vec::new();
    let mut base_options = None;
    let report = |results: &[MethodResult], options: &strata::RenderOptions| BenchReport {
        experiment: name.clone(),
        scene: scenes.join(", "),
        width: options.width,
        height: options.height,
        effect: options.effect.name().into(),
        alpha,
        adapter: gpu.info.name.clone(),
        backend: gpu.backend_name(),
        device_type: device_type(gpu),
        driver: driver(gpu),
        cpu_figures,
        commit: commit(),
        unix_time: unix_time(),
        warmup: a.warmup,
        results: results.to_vec(),
    };
    for scene in &scenes {
        let picture = PictureArgs {
            size: Some(size.clone()),
            effect: a.effect,
            alpha,
            ..PictureArgs::for_scene(scene.clone())
        };
        let (scene_data, options) = prepare(&picture)?;
        if let Some(why) = budget.spent() {
            for run in &runs {
                bar.inc((a.warmup + frames) as u64);
                let mut r = skipped(run, frames, why.clone());
                r.scene = scene.clone();
                results.push(r);
            }
            {
                let so_far = report(&results, &options);
                crate::write_results_so_far(&dir, &name, &so_far, csv(&so_far));
            }
            base_options = Some(options);
            continue;
        }
        let full_reference = if quality {
            Some(strata::reference::render(&scene_data, &options)?.0)
        } else {
            None
        };
        for run in &runs {
            if let Some(why) = budget.spent() {
                bar.inc((a.warmup + frames) as u64);
                let mut r = skipped(run, frames, why);
                r.scene = scene.clone();
                results.push(r);
                continue;
            }
            bar.set_message(format!("{} {}", short_scene(scene), run.label));
            let mut options = options.clone();
            options.k = run.k;
            options.culling = run.culling;
            options.weight = run.weight;
            options.depth_scale = run.depth_scale;
            options.msaa = run.msaa;
            options.moments = run.moments;
            options.buckets = run.buckets;
            match measure(gpu, &scene_data, &options, run, a.warmup, frames, &bar).map(|(r, _)| r) {
                Ok(mut result) => {
                    result.scene = scene.clone();
                    if let Some(full) = &full_reference {
                        let effect = options.effect;
                        let (image, _) =
                            Renderer::new(gpu, &scene_data, &options)?.render(&run.method)?;
                        let picture = image.to_rgba8(effect);
                        // A multisampled run against the reference at its sample count.
                        let truth = if options.msaa > 1 {
                            let exact = strata::RenderOptions {
                                k: None,
                                ..options.clone()
                            };
                            strata::reference::render(&scene_data, &exact)?
                                .0
                                .to_rgba8(effect)
                        } else {
                            full.to_rgba8(effect)
                        };
                        let with_k = strata::reference::render(&scene_data, &options)?
                            .0
                            .to_rgba8(effect);
                        result.error_vs_reference =
                            Some(strata::metrics::compare(&truth, &picture)?);
                        result.error_vs_reference_k =
                            Some(strata::metrics::compare(&with_k, &picture)?);
                        let stem = format!(
                            "{name}-{}-{}",
                            short_scene(scene).trim_start_matches("builtin:"),
                            run.label.replace([' ', '='], "-")
                        );
                        std::fs::create_dir_all(&dir).map_err(|e| {
                            Error::input(format!("cannot create '{}': {e}", dir.display()))
                        })?;
                        strata::render::save_png(&picture, &dir.join(format!("{stem}.png")))?;
                        strata::render::save_png(
                            &strata::metrics::diff_heatmap(&truth, &picture),
                            &dir.join(format!("{stem}-diff.png")),
                        )?;
                    }
                    results.push(result);
                }
                // A method the adapter cannot run is recorded as skipped, with the reason.
                Err(Error::Unsupported(why)) => {
                    bar.inc((a.warmup + frames) as u64);
                    let mut r = skipped(run, frames, why);
                    r.scene = scene.clone();
                    results.push(r);
                }
                Err(e) => return Err(e),
            }
            {
                let so_far = report(&results, &options);
                crate::write_results_so_far(&dir, &name, &so_far, csv(&so_far));
            }
        }
        base_options = Some(options);
    }
    let base_options = base_options.expect("at least one scene");
    bar.finish_and_clear();
    let report = report(&results, &base_options);
    print_table(&report);
    crate::write_results(&dir, &name, &report, csv(&report))
}

/// The process's `--budget-s` deadline, which the standalone experiments read too.
static DEADLINE: std::sync::OnceLock<(Instant, f64)> = std::sync::OnceLock::new();

/// Why a standalone experiment may start no further run: `--budget-s` was spent.
pub(crate) fn out_of_time() -> Option<String> {
    let (at, limit) = DEADLINE.get()?;
    (Instant::now() >= *at)
        .then(|| format!("not run: the experiment's --budget-s {limit} was spent"))
}

/// `--budget-s`: the wall-clock time an experiment may spend, from its start.
pub(crate) struct Budget {
    start: std::time::Instant,
    seconds: Option<f64>,
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
    crate::suite::attach(bar)
}

/// A scene spec without its parameters, for progress messages.
pub(crate) fn short_scene(spec: &str) -> &str {
    spec.split('?').next().unwrap_or(spec)
}

fn skipped(run: &Run, frames: u32, why: String) -> MethodResult {
    MethodResult {
        skipped: Some(why),
        ..MethodResult::new(run, frames)
    }
}

impl MethodResult {
    /// A run with nothing measured yet.
    fn new(run: &Run, frames: u32) -> MethodResult {
        MethodResult {
            scene: String::new(),
            label: run.label.clone(),
            method: run.method.clone(),
            k: run.k,
            culling: run.culling,
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
        }
    }
}

/// Frames in flight in the timed loop, as a swap chain of two would allow.
const FRAMES_IN_FLIGHT: usize = 2;

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
        (options.width, options.height),
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

fn fill_counts(result: &mut MethodResult, stats: &FrameStats) {
    result.geometry_passes = stats.geometry_passes;
    result.fragments = stats.fragments_generated;
    result.fragments_dropped = stats.fragments_dropped;
    result.max_depth_complexity = stats.max_depth_complexity;
    result.bytes_allocated = stats.bytes_allocated;
    result.lock_failures = stats.lock_failures;
}

fn fmt_ms(v: Option<f64>) -> String {
    v.map(|v| format!("{v:.2}"))
        .unwrap_or_else(|| "null".into())
}

fn print_table(r: &BenchReport) {
    println!(
        "{} — {} {}x{} {} on {} ({}){}",
        r.experiment,
        r.scene,
        r.width,
        r.height,
        r.effect,
        r.adapter,
        r.backend,
        if r.cpu_figures {
            " — CPU FIGURES (software rasterizer), not GPU performance"
        } else {
            ""
        }
    );
    let multi_scene = r.results.iter().any(|m| m.scene != r.results[0].scene);
    println!(
        "{:<28} {:>10} {:>10} {:>8} {:>7} {:>10} {:>8} {:>9} {:>8} {:>9} {:>8}",
        "run",
        "gpu ms",
        "wall ms",
        "fps",
        "passes",
        "fragments",
        "dropped",
        "max depth",
        "MiB",
        "locks",
        "RMSE"
    );
    for m in &r.results {
        let label = if multi_scene {
            format!(
                "{} {}",
                short_scene(&m.scene).trim_start_matches("builtin:"),
                m.label
            )
        } else {
            m.label.clone()
        };
        if let Some(why) = &m.skipped {
            println!("{label:<28} skipped: {why}");
            continue;
        }
        let opt = |v: Option<u64>| v.map(|p| p.to_string()).unwrap_or_default();
        println!(
            "{:<28} {:>10} {:>10.2} {:>8} {:>7} {:>10} {:>8} {:>9} {:>8.1} {:>9} {:>8}",
            label,
            fmt_ms(m.median_gpu_ms),
            m.median_wall_ms,
            m.fps.map(|f| format!("{f:.1}")).unwrap_or_default(),
            opt(m.geometry_passes.map(u64::from)),
            opt(m.fragments),
            opt(m.fragments_dropped),
            opt(m.max_depth_complexity.map(u64::from)),
            m.bytes_allocated.unwrap_or(0) as f64 / 1048576.0,
            opt(m.lock_failures),
            m.error_vs_reference
                .map(|c| format!("{:.4}", c.rmse))
                .unwrap_or_default(),
        );
    }
}

fn csv(r: &BenchReport) -> String {
    let mut s = String::from(
        "experiment,scene,width,height,adapter,cpu_figures,commit,label,method,k,culling,msaa,median_gpu_ms,median_wall_ms,fps,blocking_readbacks,geometry_passes,fragments,fragments_dropped,max_depth_complexity,bytes_allocated,gpu_ms_per_mib,lock_failures,rmse,flip_mean,pct_over_2,rmse_vs_k,flip_vs_k,pct_over_2_vs_k,skipped\n",
    );
    let opt = |v: Option<String>| v.unwrap_or_default();
    for m in &r.results {
        let err = |c: Option<strata::metrics::Comparison>| match c {
            Some(c) => format!("{:.6},{:.6},{:.4}", c.rmse, c.flip_mean, c.pct_over_2),
            None => ",,".into(),
        };
        s += &[
            r.experiment.clone(),
            m.scene.clone(),
            r.width.to_string(),
            r.height.to_string(),
            r.adapter.replace(',', " "),
            r.cpu_figures.to_string(),
            opt(r.commit.clone()),
            m.label.clone(),
            m.method.clone(),
            opt(m.k.map(|k| k.to_string())),
            m.culling.to_string(),
            m.msaa.to_string(),
            opt(m.median_gpu_ms.map(|v| format!("{v:.3}"))),
            if m.median_wall_ms.is_finite() {
                format!("{:.3}", m.median_wall_ms)
            } else {
                String::new()
            },
            opt(m.fps.map(|v| format!("{v:.2}"))),
            opt(m.blocking_readbacks.map(|v| v.to_string())),
            opt(m.geometry_passes.map(|v| v.to_string())),
            opt(m.fragments.map(|v| v.to_string())),
            opt(m.fragments_dropped.map(|v| v.to_string())),
            opt(m.max_depth_complexity.map(|v| v.to_string())),
            opt(m.bytes_allocated.map(|v| v.to_string())),
            opt(m.gpu_ms_per_mib.map(|v| format!("{v:.4}"))),
            opt(m.lock_failures.map(|v| v.to_string())),
            err(m.error_vs_reference),
            err(m.error_vs_reference_k),
            opt(m.skipped.clone().map(|w| w.replace(',', ";"))),
        ]
        .join(",");
        s.push('\n');
    }
    s
}

/// A bar chart of a depth-complexity histogram (pixels per fragment count, log scale).
pub fn histogram_chart(hist: &[u64]) -> image::RgbaImage {
    let (w, h) = (640u32, 320u32);
    let mut img = image::RgbaImage::from_pixel(w, h, image::Rgba([24, 24, 28, 255]));
    let bins = hist.len().max(1) as u32;
    let top = hist.iter().copied().max().unwrap_or(1).max(1) as f64;
    for (i, &count) in hist.iter().enumerate() {
        if count == 0 {
            continue;
        }
        let x0 = 8 + i as u32 * (w - 16) / bins;
        let x1 = (8 + (i as u32 + 1) * (w - 16) / bins).max(x0 + 1);
        let bar = ((1.0 + count as f64).ln() / (1.0 + top).ln() * (h - 16) as f64) as u32;
        let [r, g, b] = strata::metrics::colormap::colormap(i as f32 / bins as f32);
        for x in x0..x1.min(w - 8) {
            for y in (h - 8 - bar)..(h - 8) {
                img.put_pixel(x, y, image::Rgba([r, g, b, 255]));
            }
        }
    }
    img
}
