//! `strata bench`: named experiments and ad-hoc runs. Each method renders warm-up frames, then
//! N timed frames; the median of each pass's GPU time (timestamp queries) and of the wall-clock
//! frame time are reported, and written as JSON and CSV with the device, driver, size and commit.
//! Figures from a CPU adapter (lavapipe) are CPU figures and are labelled so.

use std::collections::BTreeMap;
use std::path::PathBuf;
use std::time::Instant;

use clap::Args;
use indicatif::{ProgressBar, ProgressStyle};
use serde::Serialize;
use strata::error::{Error, Result};
use strata::gpu::Gpu;
use strata::render::Renderer;

use crate::{prepare, write_json, PictureArgs};

#[derive(Args)]
pub struct BenchArgs {
    /// A named experiment (see --list), or none with --scene/--methods.
    experiment: Option<String>,
    /// List the named experiments.
    #[arg(long)]
    list: bool,
    #[arg(long)]
    scene: Option<String>,
    /// Comma-separated method ids.
    #[arg(long)]
    methods: Option<String>,
    /// Timed frames per method.
    #[arg(long)]
    frames: Option<u32>,
    /// Untimed frames before them.
    #[arg(long, default_value_t = 2)]
    warmup: u32,
    #[arg(long)]
    size: Option<String>,
    #[arg(long)]
    alpha: Option<f32>,
    #[arg(long, default_value = "transparency")]
    effect: String,
    /// Output folder (default: bench/results/<device>/).
    #[arg(long)]
    out: Option<PathBuf>,
}

struct Experiment {
    name: &'static str,
    description: &'static str,
    scene: &'static str,
    methods: &'static [&'static str],
    size: &'static str,
    alpha: Option<f32>,
    frames: u32,
}

const EXPERIMENTS: &[Experiment] = &[Experiment {
    name: "foundation",
    description: "exact baselines on the dragon (opacity 0.5) at 512x512: f2b, dual, abuffer-ll, sorted and the CPU reference",
    scene: "builtin:dragon",
    methods: &["f2b", "dual", "abuffer-ll", "sorted", "reference"],
    size: "512x512",
    alpha: Some(0.5),
    frames: 5,
}];

#[derive(Serialize)]
struct MethodResult {
    method: String,
    frames: u32,
    /// Median over frames of the sum of all passes' GPU time; null without timestamps.
    median_gpu_ms: Option<f64>,
    /// Median GPU ms per pass name.
    median_gpu_ms_per_pass: Option<BTreeMap<String, f64>>,
    /// Median wall-clock ms per frame, readback included (for `reference`: the CPU render).
    median_wall_ms: f64,
    geometry_passes: Option<u32>,
    fragments: Option<u64>,
    max_depth_complexity: Option<u32>,
    bytes_allocated: Option<u64>,
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

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    let n = v.len();
    if n == 0 {
        return f64::NAN;
    }
    if n % 2 == 1 {
        v[n / 2]
    } else {
        (v[n / 2 - 1] + v[n / 2]) * 0.5
    }
}

fn commit() -> Option<String> {
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

pub fn run(a: BenchArgs) -> Result<()> {
    if a.list {
        for e in EXPERIMENTS {
            println!("{:<12} {}", e.name, e.description);
        }
        return Ok(());
    }
    let (name, scene, methods, size, alpha, frames) = match &a.experiment {
        Some(n) => {
            let e = EXPERIMENTS.iter().find(|e| e.name == n).ok_or_else(|| {
                let names: Vec<_> = EXPERIMENTS.iter().map(|e| e.name).collect();
                Error::input(format!(
                    "unknown experiment '{n}' (available: {})",
                    names.join(", ")
                ))
            })?;
            (
                e.name.to_string(),
                a.scene.clone().unwrap_or(e.scene.into()),
                a.methods.clone().unwrap_or(e.methods.join(",")),
                a.size.clone().unwrap_or(e.size.into()),
                a.alpha.or(e.alpha),
                a.frames.unwrap_or(e.frames),
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
            (
                "adhoc".to_string(),
                scene,
                methods,
                a.size.clone().unwrap_or("512x512".into()),
                a.alpha,
                a.frames.unwrap_or(10),
            )
        }
    };
    if frames == 0 {
        return Err(Error::input("--frames must be at least 1"));
    }
    let method_ids: Vec<String> = methods
        .split(',')
        .map(|s| s.trim().to_string())
        .filter(|s| !s.is_empty())
        .collect();
    for m in &method_ids {
        if strata::methods::info(m).is_none() {
            return Err(strata::methods::unknown_method(m));
        }
    }
    let picture = PictureArgs {
        scene: scene.clone(),
        size: Some(size),
        effect: a.effect.clone(),
        shading: None,
        background: None,
        alpha,
        k: None,
        frame: None,
    };
    let (scene_data, options) = prepare(&picture)?;
    let gpu = Gpu::new()?;
    let cpu_figures = gpu.info.device_type == wgpu::DeviceType::Cpu;
    let bar = ProgressBar::new(method_ids.len() as u64 * (a.warmup + frames) as u64);
    bar.set_style(
        ProgressStyle::with_template("{bar:40} {pos}/{len} frames  {msg}").expect("valid template"),
    );
    let mut results = Vec::new();
    for id in &method_ids {
        bar.set_message(id.clone());
        let mut renderer = if id == "reference" {
            None
        } else {
            Some(Renderer::new(&gpu, &scene_data, &options)?)
        };
        let mut totals = Vec::new();
        let mut per_pass: BTreeMap<String, Vec<f64>> = BTreeMap::new();
        let mut walls = Vec::new();
        let mut last = None;
        for f in 0..a.warmup + frames {
            let start = Instant::now();
            let (_, stats) = match renderer.as_mut() {
                Some(r) => r.render(id)?,
                None => strata::reference::render(&scene_data, &options)?,
            };
            let wall = start.elapsed().as_secs_f64() * 1e3;
            if f >= a.warmup {
                walls.push(wall);
                if let Some(t) = stats.gpu_ms_total {
                    totals.push(t);
                }
                for (k, v) in stats.gpu_ms.iter().flatten() {
                    per_pass.entry(k.clone()).or_default().push(*v);
                }
            }
            last = Some(stats);
            bar.inc(1);
        }
        let stats = last.expect("at least one frame");
        results.push(MethodResult {
            method: id.clone(),
            frames,
            median_gpu_ms: (!totals.is_empty()).then(|| median(totals)),
            median_gpu_ms_per_pass: (!per_pass.is_empty())
                .then(|| per_pass.into_iter().map(|(k, v)| (k, median(v))).collect()),
            median_wall_ms: median(walls),
            geometry_passes: stats.geometry_passes,
            fragments: stats.fragments_generated,
            max_depth_complexity: stats.max_depth_complexity,
            bytes_allocated: stats.bytes_allocated,
        });
    }
    bar.finish_and_clear();
    let report = BenchReport {
        experiment: name.clone(),
        scene,
        width: options.width,
        height: options.height,
        effect: options.effect.name().into(),
        alpha,
        adapter: gpu.info.name.clone(),
        backend: gpu.backend_name(),
        device_type: format!("{:?}", gpu.info.device_type),
        driver: format!("{} {}", gpu.info.driver, gpu.info.driver_info)
            .trim()
            .to_string(),
        cpu_figures,
        commit: commit(),
        unix_time: std::time::SystemTime::now()
            .duration_since(std::time::UNIX_EPOCH)
            .map(|d| d.as_secs())
            .unwrap_or(0),
        warmup: a.warmup,
        results,
    };
    print_table(&report);
    let dir = a
        .out
        .clone()
        .unwrap_or_else(|| PathBuf::from("bench/results").join(device_slug(&gpu)));
    std::fs::create_dir_all(&dir)
        .map_err(|e| Error::runtime(format!("cannot create '{}': {e}", dir.display())))?;
    let base = dir.join(&name);
    write_json(&base.with_extension("json"), &report)?;
    std::fs::write(base.with_extension("csv"), csv(&report))
        .map_err(|e| Error::runtime(format!("cannot write CSV: {e}")))?;
    eprintln!("wrote {}.json and .csv", base.display());
    Ok(())
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
    println!(
        "{:<12} {:>12} {:>12} {:>8} {:>12} {:>10} {:>12}",
        "method", "gpu ms", "wall ms", "passes", "fragments", "max depth", "MiB"
    );
    for m in &r.results {
        println!(
            "{:<12} {:>12} {:>12.2} {:>8} {:>12} {:>10} {:>12.1}",
            m.method,
            fmt_ms(m.median_gpu_ms),
            m.median_wall_ms,
            m.geometry_passes.map(|p| p.to_string()).unwrap_or_default(),
            m.fragments.map(|p| p.to_string()).unwrap_or_default(),
            m.max_depth_complexity
                .map(|p| p.to_string())
                .unwrap_or_default(),
            m.bytes_allocated.unwrap_or(0) as f64 / 1048576.0
        );
    }
}

fn csv(r: &BenchReport) -> String {
    let mut s = String::from("experiment,scene,width,height,adapter,cpu_figures,commit,method,median_gpu_ms,median_wall_ms,geometry_passes,fragments,max_depth_complexity,bytes_allocated\n");
    for m in &r.results {
        s += &format!(
            "{},{},{},{},{},{},{},{},{},{:.3},{},{},{},{}\n",
            r.experiment,
            r.scene,
            r.width,
            r.height,
            r.adapter.replace(',', " "),
            r.cpu_figures,
            r.commit.clone().unwrap_or_default(),
            m.method,
            m.median_gpu_ms
                .map(|v| format!("{v:.3}"))
                .unwrap_or_default(),
            m.median_wall_ms,
            m.geometry_passes.map(|v| v.to_string()).unwrap_or_default(),
            m.fragments.map(|v| v.to_string()).unwrap_or_default(),
            m.max_depth_complexity
                .map(|v| v.to_string())
                .unwrap_or_default(),
            m.bytes_allocated.map(|v| v.to_string()).unwrap_or_default()
        );
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
