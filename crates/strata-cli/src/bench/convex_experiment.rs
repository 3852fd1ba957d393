//! `strata bench convex` (seed 001 Tables 1–3): `convex` — each triangle drawn once per frame,
//! in visibility order — against depth peeling (`f2b`, `dual`) and the single-pass arrays the
//! paper compares with (MDTS as `kb-mdt32`, ABS as `abuffer-fixed`, both with enough slots to
//! keep every layer): frame time, geometry passes and memory.
//!
//! - Models (Table 1): teapot, bunny, spot, the dragon, and the dragon Loop-subdivided twice
//!   (1.6M triangles; the paper's largest model has 655K), opacity 0.5, each seen from views
//!   spread around it (azimuths evenly spaced, elevations alternating ±30°) at 512² (lavapipe:
//!   128²). Each timed frame shows the next view, so the medians are over views, and `convex`
//!   makes its order again every frame (its CPU time is `order_ms`, in the wall time, not in the
//!   GPU time).
//! - Depth (Table 2): the layered spheres of the paper's Fig. 6 (`builtin:stack`: 4 columns of
//!   spheres, 16…96 layers, 1.27M…7.6M triangles, seen along the columns) at 1024² (lavapipe:
//!   smaller spheres, 256²).
//! - Memory (Table 3): every row's `bytes_allocated` and bytes per pixel.
//!
//! Runs as the other experiments do (`bench::measure_views`: a steady loop of real-time frames,
//! two in flight, medians of the frames' own GPU timestamps). A configuration the device cannot
//! hold is recorded with its error, not fatal.

use crate::bench::{csv_of, fixed, opt, print_rows, Column};
use std::path::Path;
use strata::frame::FrameOptions;

use glam::Vec3;
use serde::Serialize;
use strata::error::Result;
use strata::frame::FrameStats;
use strata::gpu::Gpu;
use strata::scene::{loaders, Camera, Scene};
use strata::RenderOptions;

use crate::bench::{measure_views, standalone_setup, Run};

/// The experiment `bench convex` runs.
pub const EXPERIMENT: super::Standalone = super::Standalone {
    name: "convex",
    description: "seed 001 Tables 1-3: convex vs f2b, dual, kb-mdt32 and abuffer-fixed on teapot, bunny, spot, the dragon and the dragon subdivided to 1.6M triangles over views around each (512², lavapipe 128²), and on the layered spheres at 16..96 layers (1024², lavapipe 256² with smaller spheres): frame time, passes, memory",
    run,
};

const MODELS: [&str; 5] = [
    "builtin:teapot",
    "builtin:bunny",
    "builtin:spot",
    "builtin:dragon",
    "builtin:dragon?subdivide=2",
];
const MODEL_ALPHA: f32 = 0.5;
/// Slots per pixel for the arrays on the models: above their depth complexity from any view
/// (dropped fragments are reported if not).
const MODEL_K: u32 = 32;
const STACK_LAYERS: [u32; 6] = [16, 32, 48, 64, 80, 96];
/// Sphere segments: the paper's 39,600-triangle spheres on a GPU, 528 on lavapipe.
const STACK_SEGMENTS_GPU: u32 = 200;
const STACK_SEGMENTS_CPU: u32 = 24;
const METHODS: [&str; 5] = ["convex", "f2b", "dual", "kb-mdt32", "abuffer-fixed"];

#[derive(Serialize)]
struct Row {
    table: &'static str,
    scene: String,
    triangles: usize,
    method: &'static str,
    k: Option<u32>,
    views: u32,
    /// Timed frames whose statistics arrived (the medians are over these).
    frames_with_stats: usize,
    median_gpu_ms: Option<f64>,
    median_wall_ms: f64,
    /// Mean geometry passes per frame over the timed frames.
    mean_passes: Option<f64>,
    bytes_allocated: Option<u64>,
    bytes_per_pixel: Option<f64>,
    max_depth_complexity: Option<u32>,
    fragments_dropped: Option<u64>,
    convex: Option<ConvexFigures>,
    error: Option<String>,
}

#[derive(Serialize)]
struct ConvexFigures {
    parts: u32,
    groups: u32,
    preprocess_ms: f64,
    /// Mean CPU milliseconds of a frame's order (made again for every view).
    mean_order_ms: f64,
    mean_cycles_broken: f64,
    /// Summed over the timed frames: pixel-passes where the order failed.
    order_violations: u64,
    overflowing_pixels: u64,
}

#[derive(Serialize)]
struct Speedup {
    scene: String,
    /// Each method's median GPU ms over convex's (> 1: convex is faster).
    f2b_over_convex: Option<f64>,
    dual_over_convex: Option<f64>,
    mdt32_over_convex: Option<f64>,
    abuffer_fixed_over_convex: Option<f64>,
}

#[derive(Serialize)]
struct Report {
    #[serde(flatten)]
    header: crate::bench::Header,
    stack_size: (u32, u32),
    frames: u32,
    /// False while the run is under way: the results are written after every scene, so a run
    /// stopped early (a time limit) leaves what it measured.
    complete: bool,
    rows: Vec<Row>,
    speedups: Vec<Speedup>,
}

/// `views` cameras around `scene`'s framing: the same distance from its target, azimuths
/// evenly spaced, elevations alternating +30° and −30°.
fn views_around(scene: &Scene, views: u32) -> Vec<Camera> {
    let base = scene.camera_or_framing();
    let distance = (base.eye - base.target).length();
    (0..views)
        .map(|v| {
            let azimuth = (v as f32 / views as f32) * std::f32::consts::TAU;
            let elevation = if v % 2 == 0 { 30f32 } else { -30f32 }.to_radians();
            let direction = Vec3::new(
                elevation.cos() * azimuth.sin(),
                elevation.sin(),
                elevation.cos() * azimuth.cos(),
            );
            Camera {
                eye: base.target + distance * direction,
                up: Vec3::Y,
                ..base
            }
        })
        .collect()
}

fn mean(values: impl Iterator<Item = f64>) -> Option<f64> {
    let (sum, n) = values.fold((0.0, 0u32), |(s, n), v| (s + v, n + 1));
    (n > 0).then(|| sum / n as f64)
}

fn convex_figures(timed: &[FrameStats]) -> Option<ConvexFigures> {
    let stats: Vec<_> = timed
        .iter()
        .filter_map(|s| s.family::<strata::methods::convex::ConvexStats>())
        .collect();
    let first = stats.first()?;
    Some(ConvexFigures {
        parts: first.parts,
        groups: first.groups,
        preprocess_ms: first.preprocess_ms,
        mean_order_ms: mean(stats.iter().map(|c| c.order_ms)).unwrap_or(0.0),
        mean_cycles_broken: mean(stats.iter().map(|c| c.cycles_broken as f64)).unwrap_or(0.0),
        order_violations: stats.iter().filter_map(|c| c.order_violations).sum(),
        overflowing_pixels: stats.iter().filter_map(|c| c.overflowing_pixels).sum(),
    })
}

/// One table's configurations on `scene`.
struct Case<'a> {
    table: &'static str,
    spec: String,
    scene: &'a Scene,
    size: (u32, u32),
    k: u32,
    cameras: &'a [Camera],
    warmup: u32,
    frames: u32,
}

fn run_case(gpu: &Gpu, case: &Case<'_>, bar: &indicatif::ProgressBar, rows: &mut Vec<Row>) {
    for method in METHODS {
        bar.set_message(format!("{method} on {}", case.spec));
        let k = matches!(method, "kb-mdt32" | "abuffer-fixed").then_some(case.k);
        let options = RenderOptions {
            frame: FrameOptions {
                width: case.size.0,
                height: case.size.1,
                k,
                ..Default::default()
            },
            ..Default::default()
        };
        let mut row = Row {
            table: case.table,
            scene: case.spec.clone(),
            triangles: case.scene.triangle_count(),
            method,
            k,
            views: case.cameras.len().max(1) as u32,
            frames_with_stats: 0,
            median_gpu_ms: None,
            median_wall_ms: 0.0,
            mean_passes: None,
            bytes_allocated: None,
            bytes_per_pixel: None,
            max_depth_complexity: None,
            fragments_dropped: None,
            convex: None,
            error: None,
        };
        let measured = measure_views(
            gpu,
            case.scene,
            &options,
            &Run::plain(method),
            case.warmup,
            case.frames,
            bar,
            case.cameras,
        );
        match measured {
            Ok((result, timed)) => {
                row.frames_with_stats = timed.len();
                row.median_gpu_ms = result.median_gpu_ms;
                row.median_wall_ms = result.median_wall_ms;
                row.mean_passes = mean(timed.iter().map(|s| f64::from(s.geometry_passes)));
                row.bytes_allocated = result.bytes_allocated;
                row.bytes_per_pixel = result
                    .bytes_allocated
                    .map(|b| b as f64 / (case.size.0 as f64 * case.size.1 as f64));
                row.max_depth_complexity =
                    timed.iter().filter_map(|s| s.max_depth_complexity).max();
                row.fragments_dropped =
                    Some(timed.iter().filter_map(|s| s.fragments_dropped).sum());
                row.convex = convex_figures(&timed);
            }
            Err(e) => {
                bar.inc((case.warmup + case.frames) as u64);
                row.error = Some(e.to_string());
            }
        }
        rows.push(row);
    }
}

pub fn run(gpu: &Gpu, size: Option<crate::Size>, frames: Option<u32>, dir: &Path) -> Result<()> {
    let (cpu_figures, model_size, frames) =
        standalone_setup(gpu, size, frames, ((128, 128), (512, 512)), (4, 16))?;
    let (views, stack_size, segments) = if cpu_figures {
        (4, (256, 256), STACK_SEGMENTS_CPU)
    } else {
        (8, (1024, 1024), STACK_SEGMENTS_GPU)
    };
    // `--size` sets both tables' size.
    let stack_size = if size.is_some() {
        model_size
    } else {
        stack_size
    };
    let cases = MODELS.len() + STACK_LAYERS.len();
    let per_case = (views + frames) as u64 * METHODS.len() as u64;
    let bar = crate::bench::frames_bar(cases as u64 * per_case);
    let partial = Partial {
        header: crate::bench::Header::new("convex", gpu, cpu_figures, model_size),
        stack_size,
        frames,
    };
    let mut rows = Vec::new();
    for spec in MODELS {
        if crate::bench::out_of_time().is_some() {
            break;
        }
        bar.set_message(format!("loading {spec}"));
        let mut scene = loaders::load_scene(spec)?;
        scene.override_alpha(MODEL_ALPHA);
        let cameras = views_around(&scene, views);
        let case = Case {
            table: "models",
            spec: spec.to_string(),
            scene: &scene,
            size: model_size,
            k: MODEL_K,
            cameras: &cameras,
            warmup: views,
            frames,
        };
        run_case(gpu, &case, &bar, &mut rows);
        rows = partial.write(dir, rows);
    }
    for layers in STACK_LAYERS {
        if crate::bench::out_of_time().is_some() {
            break;
        }
        let spec = format!("builtin:stack?layers={layers}&columns=2&segments={segments}");
        bar.set_message(format!("loading {spec}"));
        let scene = loaders::load_scene(&spec)?;
        let case = Case {
            table: "depth",
            spec,
            scene: &scene,
            size: stack_size,
            k: layers,
            cameras: &[],
            warmup: views,
            frames,
        };
        run_case(gpu, &case, &bar, &mut rows);
        rows = partial.write(dir, rows);
    }
    bar.finish_and_clear();
    // Not complete when --budget-s cut it short.
    let report = partial.report(rows, crate::bench::out_of_time().is_none());
    print(&report);
    crate::write_results(dir, "convex", &report, csv(&report))
}

/// What a report holds besides its rows.
struct Partial {
    header: crate::bench::Header,
    stack_size: (u32, u32),
    frames: u32,
}

impl Partial {
    fn report(&self, rows: Vec<Row>, complete: bool) -> Report {
        let mut scenes: Vec<&str> = Vec::new();
        for r in &rows {
            if !scenes.contains(&r.scene.as_str()) {
                scenes.push(&r.scene);
            }
        }
        let speedups = scenes
            .iter()
            .map(|&scene| {
                let time = |method: &str| {
                    rows.iter()
                        .find(|r| r.scene == scene && r.method == method)
                        .and_then(|r| r.median_gpu_ms)
                };
                let over = |method: &str| match (time(method), time("convex")) {
                    (Some(m), Some(c)) if c > 0.0 => Some(m / c),
                    _ => None,
                };
                Speedup {
                    scene: scene.to_string(),
                    f2b_over_convex: over("f2b"),
                    dual_over_convex: over("dual"),
                    mdt32_over_convex: over("kb-mdt32"),
                    abuffer_fixed_over_convex: over("abuffer-fixed"),
                }
            })
            .collect();
        Report {
            header: self.header.clone(),
            stack_size: self.stack_size,
            frames: self.frames,
            complete,
            rows,
            speedups,
        }
    }

    /// Writes what is measured so far; gives the rows back.
    fn write(&self, dir: &Path, rows: Vec<Row>) -> Vec<Row> {
        let report = self.report(rows, false);
        crate::write_results_so_far(dir, "convex", &report, csv(&report));
        report.rows
    }
}

fn columns() -> Vec<Column<'static, Row>> {
    type C = Column<'static, Row>;
    let mib = |r: &Row| fixed(r.bytes_allocated.map(|b| b as f64 / 1048576.0), 2);
    vec![
        C::csv("table", |r| r.table.to_string()),
        C::csv("scene", |r| format!("\"{}\"", r.scene))
            .shown_as("scene", 44, |r| {
                r.scene.trim_start_matches("builtin:").to_string()
            })
            .left(),
        C::csv("triangles", |r| r.triangles.to_string()).shown("triangles", 9),
        C::csv("method", |r| r.method.to_string())
            .shown("method", 14)
            .left(),
        C::csv("k", |r| opt(r.k)),
        C::csv("views", |r| r.views.to_string()),
        C::csv("median_gpu_ms", |r| fixed(r.median_gpu_ms, 3)).shown_as("GPU ms", 11, |r| match &r
            .error
        {
            Some(_) => "error".to_string(),
            None => fixed(r.median_gpu_ms, 3),
        }),
        C::csv("median_wall_ms", |r| format!("{:.3}", r.median_wall_ms)),
        C::csv("mean_passes", |r| fixed(r.mean_passes, 1)).shown("passes", 8),
        C::csv("bytes_allocated", |r| opt(r.bytes_allocated)).shown_as("MiB", 9, mib),
        C::csv("max_depth_complexity", |r| opt(r.max_depth_complexity)),
        C::csv("fragments_dropped", |r| opt(r.fragments_dropped)),
        C::csv("convex_groups", |r| {
            opt(r.convex.as_ref().map(|c| c.groups))
        }),
        C::csv("convex_mean_order_ms", |r| {
            fixed(r.convex.as_ref().map(|c| c.mean_order_ms), 3)
        }),
        C::csv("convex_order_violations", |r| {
            opt(r.convex.as_ref().map(|c| c.order_violations))
        })
        .shown("violations", 10),
        C::csv("error", |r| {
            format!(
                "\"{}\"",
                r.error.as_deref().unwrap_or_default().replace('"', "'")
            )
        }),
    ]
}

fn csv(r: &Report) -> String {
    csv_of(&columns(), &r.rows)
}

fn print(r: &Report) {
    r.header.print_heading(format_args!(
        "models at {} (median over views), layered spheres at {}x{}",
        r.header.size(),
        r.stack_size.0,
        r.stack_size.1
    ));
    print_rows(&columns(), &r.rows, |_| None);
    println!(
        "{:<44} {:>8} {:>8} {:>8} {:>8}",
        "speedup of convex over", "f2b", "dual", "mdt32", "abuf-fix"
    );
    let x = |v: Option<f64>| v.map(|v| format!("{v:.2}x")).unwrap_or_default();
    for s in &r.speedups {
        println!(
            "{:<44} {:>8} {:>8} {:>8} {:>8}",
            s.scene.trim_start_matches("builtin:"),
            x(s.f2b_over_convex),
            x(s.dual_over_convex),
            x(s.mdt32_over_convex),
            x(s.abuffer_fixed_over_convex)
        );
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn row(scene: &str, method: &'static str, gpu_ms: f64) -> Row {
        Row {
            table: "models",
            scene: scene.to_string(),
            triangles: 12,
            method,
            k: None,
            views: 2,
            frames_with_stats: 4,
            median_gpu_ms: Some(gpu_ms),
            median_wall_ms: gpu_ms,
            mean_passes: Some(3.0),
            bytes_allocated: Some(1024),
            bytes_per_pixel: Some(1.0),
            max_depth_complexity: Some(2),
            fragments_dropped: Some(0),
            convex: None,
            error: None,
        }
    }

    #[test]
    fn results_so_far_are_written_and_marked_incomplete() {
        let dir =
            std::env::temp_dir().join(format!("strata-convex-partial-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        let partial = Partial {
            header: crate::bench::Header {
                experiment: "convex",
                provenance: crate::bench::Provenance {
                    adapter: "test".into(),
                    backend: "none".into(),
                    device_type: "Cpu".into(),
                    driver: "test".into(),
                    cpu_figures: true,
                    commit: None,
                    unix_time: 0,
                },
                width: 8,
                height: 8,
            },
            stack_size: (8, 8),
            frames: 4,
        };
        let rows = partial.write(&dir, vec![row("a", "convex", 2.0), row("a", "f2b", 5.0)]);
        assert_eq!(rows.len(), 2, "the rows come back for the next scene");
        let text = std::fs::read_to_string(dir.join("convex.json")).expect("written");
        let json: serde_json::Value = serde_json::from_str(&text).expect("JSON");
        assert_eq!(json["complete"], false);
        assert_eq!(json["rows"].as_array().map(Vec::len), Some(2));
        assert_eq!(json["speedups"][0]["f2b_over_convex"], 2.5);
        assert!(dir.join("convex.csv").exists());
        let done = partial.report(rows, true);
        assert!(done.complete);
        let _ = std::fs::remove_dir_all(&dir);
    }
}
