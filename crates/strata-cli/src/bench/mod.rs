//! `strata bench`: named experiments and ad-hoc runs, measured as an application runs strata:
//! a steady-state loop of real-time frames (one submit per frame, each frame resolved OVER an
//! offscreen color target, statistics read asynchronously, at most two frames in flight as a
//! swap chain would allow), after warm-up frames. Reported: the median GPU time per frame and
//! per pass (timestamp queries, from the frames' own statistics), wall-clock frames per second
//! over the timed loop, and the frames' counters; `blocking_readbacks` stays 0 inside the loop.
//! Written as JSON and CSV with the device, driver, size and commit. Figures from a CPU adapter
//! (lavapipe) are CPU figures and are labelled so.

pub(crate) mod auto_k;
pub(crate) mod bandwidth;
pub(crate) mod compare;
pub(crate) mod convex_experiment;
pub(crate) mod cuda_renderer;
pub(crate) mod deferred_lights;
mod header;
mod measure;
pub(crate) mod online_culling;
pub(crate) mod peers;
pub(crate) mod scale;
pub(crate) mod soak;
mod soak_app;
pub(crate) mod suite;
mod table;

pub(crate) use header::*;
pub(crate) use measure::*;
pub(crate) use table::*;

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

use crate::Size;

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
    pub(crate) size: Option<Size>,
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

struct Experiment {
    name: &'static str,
    description: &'static str,
    /// The scenes, each run with every configuration.
    scenes: &'static [&'static str],
    /// Size on a GPU, and on a CPU adapter (lavapipe), where the full size would take hours.
    size_gpu: Size,
    size_cpu: Size,
    alpha: Option<f32>,
    frames: u32,
    runs: fn() -> Vec<Run>,
    /// Also measure each run's image error against the reference (full and --k).
    quality: bool,
}

/// Every k-buffer method of the k+-buffer paper's comparison (the table's `in_k_comparison`;
/// kb-mdt64 where the adapter has 64-bit atomics), in catalogue order.
fn k_methods() -> impl Iterator<Item = &'static str> {
    strata::methods::TABLE
        .iter()
        .filter(|d| d.in_k_comparison)
        .map(|d| d.name)
}

/// Seed 003's Figs. 6 and 7 measure on one stack: 128 layers over 75% of the screen, in random
/// order, at 1024x1024 (128x128 on a CPU adapter), five frames, timing only.
const fn on_128_layers(
    name: &'static str,
    description: &'static str,
    runs: fn() -> Vec<Run>,
) -> Experiment {
    Experiment {
        name,
        description,
        scenes: &["builtin:layers?n=128&coverage=0.75&order=random&seed=1"],
        size_gpu: Size::new(1024, 1024),
        size_cpu: Size::new(128, 128),
        alpha: None,
        frames: 5,
        runs,
        quality: false,
    }
}

const EXPERIMENTS: &[Experiment] = &[
    Experiment {
        name: "approx-quality",
        description: "what engines ship against exact: wboit (eqs. 7-10, depth scales 1 and 50), mboit (4, 6, 8 power and 2, 3, 4 trigonometric moments), wavelet (4, 8 Haar coefficients), wavg (average and product opacity), mlab (k = 2, 4, 8), stochastic (4 samples, 1, 4 and 16 passes; against the reference at 4 samples), unsorted, sorted, kplus-heap k=8 and k=4 with its tail dropped, blended or weighted (hybrid transparency), bucket k=16 (uniform, adaptive) and the exact abuffer-ll and kpeel, on nvpro, the dragon, the demo and balls: error against the reference (RMSE, FLIP, % over 2/255, heatmaps), time, memory",
        scenes: &[
            "builtin:nvpro?objects=1024&subdiv=16&seed=0",
            "builtin:dragon",
            "builtin:demo",
            "builtin:balls",
        ],
        size_gpu: Size::new(1024, 1024),
        size_cpu: Size::new(192, 192),
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
                Run::mboit(strata::Moments::Power(6)),
                Run::mboit(strata::Moments::Power(8)),
                Run::mboit(strata::Moments::Trigonometric(2)),
                Run::mboit(strata::Moments::Trigonometric(3)),
                Run::mboit(strata::Moments::Trigonometric(4)),
                Run::wavelet(4),
                Run::wavelet(8),
                Run::wavg(strata::methods::weighted::Opacity::Average),
                Run::wavg(strata::methods::weighted::Opacity::Product),
                Run::with_k("mlab", 2, true),
                Run::with_k("mlab", 4, true),
                Run::with_k("mlab", 8, true),
                Run::stochastic(4, 1),
                Run::stochastic(4, 4),
                Run::stochastic(4, 16),
                Run::plain("unsorted"),
                Run::plain("sorted"),
                Run::with_k("kplus-heap", 8, true),
                Run::with_k("kplus-heap", 4, true),
                Run::with_tail("kplus-heap", 4, strata::Tail::Blend),
                Run::with_tail("kplus-heap", 4, strata::Tail::Weighted),
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
        description: "issue 13: every family that takes --msaa at 1, 4 and 8 samples per pixel (8 where the device rasterizes it): time, memory, fragments stored (a pixel on a mesh edge stores one per primitive touching it), abuffer-fixed's drops at k = 16 (edges overflowing per-pixel arrays), kplus-heap's and kb-mdt32's per-sample storage (each sample its own k: S times the memory, nothing lost at edges), peeling and convex per sample (f2b, kpeel: one more geometry pass, the account), and tiled's samples found in compute (8 on any device)",
        scenes: &["builtin:dragon", "builtin:spheres", "builtin:nvpro?objects=1024&subdiv=16&seed=0"],
        size_gpu: Size::new(1024, 1024),
        size_cpu: Size::new(160, 160),
        alpha: Some(0.5),
        frames: 5,
        runs: || {
            let base = [
                Run::plain("abuffer-ll"),
                Run::plain("tiled"),
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
        size_gpu: Size::new(1024, 1024),
        size_cpu: Size::new(192, 192),
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
        size_gpu: Size::new(1024, 1024),
        size_cpu: Size::new(192, 192),
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
        name: "tiled",
        description: "issue 42: tiled (exact, in compute, 8×8 tiles sorted inside a workgroup) against abuffer-ll and kb-ab-ll k=16 on both rasterizers, kb-mdt-pack k=16, f2b and dual, on the dragon, nvpro and the layered-spheres stack (opacity 0.5): GPU ms, bytes, fragments",
        scenes: &[
            "builtin:dragon",
            "builtin:nvpro?objects=1024&subdiv=16&seed=0",
            "builtin:spheres?layers=12",
        ],
        size_gpu: Size::new(1024, 1024),
        size_cpu: Size::new(192, 192),
        alpha: Some(0.5),
        frames: 5,
        runs: || {
            vec![
                Run::plain("tiled"),
                Run::plain("abuffer-ll"),
                Run::plain("abuffer-ll").on_compute(),
                Run::with_k("kb-ab-ll", 16, true),
                Run::with_k("kb-ab-ll", 16, true).on_compute(),
                Run::with_k("kb-mdt-pack", 16, true),
                Run::plain("f2b"),
                Run::plain("dual"),
            ]
        },
        quality: false,
    },
    Experiment {
        name: "foundation",
        description: "exact baselines on the dragon (opacity 0.5): f2b, dual, abuffer-ll, sorted and the CPU reference",
        scenes: &["builtin:dragon"],
        size_gpu: Size::new(512, 512),
        size_cpu: Size::new(512, 512),
        alpha: Some(0.5),
        frames: 5,
        runs: || ["f2b", "dual", "abuffer-ll", "sorted", "reference"].iter().map(|m| Run::plain(m)).collect(),
        quality: false,
    },
    on_128_layers(
        "kbuffer-k",
        "seed 003 Fig. 6: 128 layers over 75% of the screen, k = 4..64, every k-buffer method; the paper's claims (k = 64: kplus-heap, kb-ps, kb-mdt32) and kb-keys first, so that a GPU run cut short by its budget has them",
        || {
            let first = ["kplus-heap", "kb-ps", "kb-mdt32"]
                .iter()
                .map(|m| (*m, 64))
                .chain([4, 8, 16, 32, 64].iter().map(|&k| ("kb-keys", k)));
            let rest = [4, 8, 16, 32, 64]
                .iter()
                .flat_map(|&k| k_methods().map(move |m| (m, k)));
            let mut runs: Vec<(&str, u32)> = Vec::new();
            for run in first.chain(rest) {
                if !runs.contains(&run) {
                    runs.push(run);
                }
            }
            runs.into_iter().map(|(m, k)| Run::with_k(m, k, true)).collect()
        },
    ),
    on_128_layers(
        "kbuffer-culling",
        "seed 003 Fig. 7: culling on and off for kplus-array, kplus-heap, kb-ps, kb-mdt32 and kb-keys (its slot search) at k = 4, 16, 64",
        || {
            let mut runs = Vec::new();
            for k in [4, 16, 64] {
                for m in ["kplus-array", "kplus-heap", "kb-ps", "kb-mdt32", "kb-keys"] {
                    runs.push(Run::with_k(m, k, true));
                    runs.push(Run::with_k(m, k, false));
                }
            }
            runs
        },
    ),
    on_128_layers(
        "kbuffer-layout",
        "the k-buffer family's per-pixel arrays pixel-major (the default: each pixel's items together, as the papers draw them) against slot-major (item i of every pixel together, so that a warp's neighbouring pixels share memory transactions): kb-keys, kplus-array, kb-mdt64 and abuffer-fixed at k = 16, 4, 64",
        || {
            let mut runs = Vec::new();
            for k in [16, 4, 64] {
                for m in ["kb-keys", "kplus-array", "kb-mdt64", "abuffer-fixed"] {
                    for layout in [strata::StorageLayout::Pixel, strata::StorageLayout::Slot] {
                        runs.push(Run::with_k(m, k, true).laid_out(layout));
                    }
                }
            }
            runs
        },
    ),
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
        size_gpu: Size::new(1024, 1024),
        size_cpu: Size::new(128, 128),
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
        size_gpu: Size::new(1024, 1024),
        size_cpu: Size::new(96, 96),
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
        size_gpu: Size::new(1024, 1024),
        size_cpu: Size::new(256, 256),
        alpha: None,
        frames: 3,
        runs: || k_methods().map(|m| Run::with_k(m, 16, true)).collect(),
        quality: true,
    },
];

/// An experiment with its own runner: (GPU, `--size`, `--frames`, output folder).
type StandaloneRun = fn(&Gpu, Option<Size>, Option<u32>, &Path) -> Result<()>;

/// An experiment that reports its own table: its name, what `bench --list` says of it, and its
/// runner.
pub(crate) struct Standalone {
    pub name: &'static str,
    pub description: &'static str,
    pub run: StandaloneRun,
}

/// The experiments that report their own tables, in the order `bench all` runs them.
const STANDALONE: [Standalone; 9] = [
    crate::bench::auto_k::EXPERIMENT,
    crate::bench::deferred_lights::EXPERIMENT,
    crate::bench::cuda_renderer::EXPERIMENT,
    crate::bench::scale::EXPERIMENT,
    crate::bench::online_culling::EXPERIMENT,
    crate::bench::convex_experiment::EXPERIMENT,
    crate::bench::peers::EXPERIMENT,
    crate::bench::bandwidth::EXPERIMENT,
    crate::bench::soak::EXPERIMENT,
];

/// Size, frame count and whether figures are CPU figures for a standalone experiment: `--size`
/// or the default for the adapter's kind (`cpu` on lavapipe, `gpu` otherwise), likewise frames.
pub(crate) fn standalone_setup(
    gpu: &Gpu,
    size: Option<Size>,
    frames: Option<u32>,
    (cpu_size, gpu_size): ((u32, u32), (u32, u32)),
    (cpu_frames, gpu_frames): (u32, u32),
) -> Result<(bool, (u32, u32), u32)> {
    let cpu_figures = gpu.info.device_type == wgpu::DeviceType::Cpu;
    let size = match size {
        Some(s) => (s.width, s.height),
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
        for e in STANDALONE {
            println!("{:<16} {}", e.name, e.description);
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
        let settings = crate::bench::compare::Settings {
            threshold_pct: a.threshold,
            min_change_pct: a.min_change,
        };
        return crate::bench::compare::run(old, &a.repeat, new, &settings, a.json);
    }
    if !a.files.is_empty() || !a.repeat.is_empty() || a.json {
        return Err(Error::input(
            "files, --repeat and --json apply to `bench compare OLD.json NEW.json`",
        ));
    }
    let gpu = Gpu::new()?;
    if a.experiment.as_deref() == Some("all") {
        return crate::bench::suite::run(&gpu, &a);
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
        .chain(STANDALONE.iter().map(|e| e.name))
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
    if let Some(e) = STANDALONE.iter().find(|e| experiment == Some(e.name)) {
        // Sets the deadline the standalone experiment reads (`out_of_time`).
        Budget::new(a.budget_s)?;
        return (e.run)(gpu, a.size, a.frames, &results_dir(gpu, a));
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
                a.size.unwrap_or(default_size),
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
                a.size.unwrap_or(Size::new(512, 512)),
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
        width: options.frame.width,
        height: options.frame.height,
        effect: options.frame.effect.name().into(),
        alpha,
        provenance: Provenance::new(gpu, cpu_figures),
        warmup: a.warmup,
        results: results.to_vec(),
    };
    for scene in &scenes {
        let picture = PictureArgs {
            size: Some(size),
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
            let options = run.options(&options);
            match measure(gpu, &scene_data, &options, run, a.warmup, frames, &bar).map(|(r, _)| r) {
                Ok(mut result) => {
                    result.scene = scene.clone();
                    if let Some(full) = &full_reference {
                        let effect = options.frame.effect;
                        let (image, _) =
                            Renderer::new(gpu, &scene_data, &options)?.render(&run.method)?;
                        let picture = image.to_rgba8(effect);
                        // A multisampled run against the reference at its sample count.
                        let truth = if options.build.msaa > 1 {
                            let exact = {
                                let mut options = options.clone();
                                options.frame.k = None;
                                options
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

#[cfg(test)]
mod tests {
    /// The k-buffer experiments run the thirteen methods of the k+-buffer paper's comparison
    /// (seed 003, Table 1, with strata's A-buffer selections and kb-keys), whatever else the
    /// k-buffer family gains.
    #[test]
    fn the_k_comparison_is_the_papers() {
        let mut methods: Vec<_> = super::k_methods().collect();
        methods.sort_unstable();
        assert_eq!(
            methods,
            [
                "abuffer-fixed",
                "kb",
                "kb-ab-fixed",
                "kb-ab-ll",
                "kb-keys",
                "kb-ll",
                "kb-mdt-pack",
                "kb-mdt32",
                "kb-mdt64",
                "kb-ps",
                "kplus-array",
                "kplus-array-r",
                "kplus-heap",
            ]
        );
    }
}
