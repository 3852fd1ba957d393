//! `strata bench cuda-renderer` (seed 002 Table 1): the compute rasterizer's single-pass
//! captures — MDTS (`kb-mdt32`, `kb-mdt-pack`) and FABS (`abuffer-fixed`) — against the GPU
//! rasterizer's `abuffer-fixed`, depth peeling (`f2b`, `dual`), the linked-list A-buffer and
//! the k+-buffer (on both rasterizers), on models from small to large: frame time, geometry passes and the compute
//! pipeline's time by stage (bin, capture, resolve).
//!
//! Each configuration runs as the other experiments do (`bench::measure`: a steady loop of
//! real-time frames, two in flight, medians of the frames' own GPU timestamps).

use std::collections::BTreeMap;
use std::path::Path;
use strata::frame::{BuildOptions, FrameOptions};

use serde::Serialize;
use strata::error::Result;
use strata::frame::Raster;
use strata::gpu::Gpu;
use strata::scene::loaders;
use strata::RenderOptions;

use crate::bench::{csv_of, fixed, measure, opt, print_rows, standalone_setup, Column, Run};

/// The experiment `bench cuda-renderer` runs.
pub const EXPERIMENT: super::Standalone = super::Standalone {
    name: "cuda-renderer",
    description: "seed 002 Table 1: compute-rasterizer MDTS and FABS vs the hardware abuffer-fixed, f2b, dual, abuffer-ll and kplus-array (and kplus-array on the compute rasterizer) on bunny, dragon and procedural scenes up to 10M triangles (lavapipe: up to ~1M): frame time, passes, compute time by stage",
    run,
};

/// Scenes from small to large; the last ones only on a GPU.
const SCENES_CPU: [&str; 3] = [
    "builtin:bunny",
    "builtin:dragon",
    "builtin:nvpro?objects=512&subdiv=32&seed=0",
];
const SCENES_GPU: [&str; 5] = [
    "builtin:bunny",
    "builtin:dragon",
    "builtin:nvpro?objects=512&subdiv=32&seed=0",
    "builtin:nvpro?objects=2048&subdiv=48&seed=0",
    "builtin:nvpro?objects=4096&subdiv=52&seed=0",
];
/// Slots per pixel of the fixed arrays and cascades: above the scenes' depth complexity, so
/// FABS and MDTS keep every fragment (dropped fragments are reported if not).
const K_FIXED: u32 = 32;
const K_PLUS: u32 = 16;

/// (label, method, rasterizer, k).
const RUNS: [(&str, &str, Raster, Option<u32>); 9] = [
    (
        "compute MDTS (kb-mdt32)",
        "kb-mdt32",
        Raster::Compute,
        Some(K_FIXED),
    ),
    (
        "compute MDTS packed (kb-mdt-pack)",
        "kb-mdt-pack",
        Raster::Compute,
        Some(K_FIXED),
    ),
    (
        "compute FABS (abuffer-fixed)",
        "abuffer-fixed",
        Raster::Compute,
        Some(K_FIXED),
    ),
    (
        "hw FABS (abuffer-fixed)",
        "abuffer-fixed",
        Raster::Hw,
        Some(K_FIXED),
    ),
    ("hw f2b", "f2b", Raster::Hw, None),
    ("hw dual", "dual", Raster::Hw, None),
    ("hw abuffer-ll", "abuffer-ll", Raster::Hw, None),
    ("hw kplus-array", "kplus-array", Raster::Hw, Some(K_PLUS)),
    // The spin lock on the compute rasterizer, with the same ordered atomics.
    (
        "compute kplus-array",
        "kplus-array",
        Raster::Compute,
        Some(K_PLUS),
    ),
];

#[derive(Serialize)]
struct Row {
    scene: String,
    triangles: usize,
    label: &'static str,
    method: &'static str,
    raster: &'static str,
    k: Option<u32>,
    geometry_passes: Option<u32>,
    median_gpu_ms: Option<f64>,
    median_wall_ms: f64,
    median_gpu_ms_per_pass: Option<BTreeMap<String, f64>>,
    fragments: Option<u64>,
    fragments_dropped: Option<u64>,
    max_depth_complexity: Option<u32>,
    bytes_allocated: Option<u64>,
    /// The compute rasterizer's work items (triangle × 8×8 tile).
    tile_items: Option<u64>,
    error: Option<String>,
}

#[derive(Serialize)]
struct Ratio {
    scene: String,
    /// Compute FABS over hardware FABS frame time (goal: ≤ 1.5 on large meshes).
    compute_over_hw_fabs: Option<f64>,
    /// f2b over compute FABS (seed 002: ≈ N).
    f2b_over_compute_fabs: Option<f64>,
    /// dual over compute FABS (seed 002: ≈ N/2).
    dual_over_compute_fabs: Option<f64>,
    /// kb-mdt32 over compute FABS (seed 002: MDTS ≈ 3/2 of FABS's time).
    mdts_over_fabs: Option<f64>,
}

#[derive(Serialize)]
struct Report {
    #[serde(flatten)]
    header: crate::bench::Header,
    frames: u32,
    rows: Vec<Row>,
    ratios: Vec<Ratio>,
}

pub fn run(gpu: &Gpu, size: Option<crate::Size>, frames: Option<u32>, dir: &Path) -> Result<()> {
    let (cpu_figures, (width, height), frames) =
        standalone_setup(gpu, size, frames, ((256, 256), (1024, 1024)), (5, 20))?;
    let scenes: &[&str] = if cpu_figures {
        &SCENES_CPU
    } else {
        &SCENES_GPU
    };
    let warmup = 2;
    let bar =
        crate::bench::frames_bar((scenes.len() * RUNS.len()) as u64 * (warmup + frames) as u64);
    let report = |rows| report_of(gpu, cpu_figures, (width, height, frames), scenes, rows);
    let mut rows = Vec::new();
    for spec in scenes {
        bar.set_message(format!("loading {spec}"));
        let scene = loaders::load_scene(spec)?;
        let triangles = scene.triangle_count();
        for (label, method, raster, k) in RUNS {
            bar.set_message(format!("{label} on {spec}"));
            let options = RenderOptions {
                build: BuildOptions {
                    raster,
                    ..Default::default()
                },
                frame: FrameOptions {
                    width,
                    height,
                    k,
                    ..Default::default()
                },
            };
            let mut row = Row {
                scene: spec.to_string(),
                triangles,
                label,
                method,
                raster: raster.name(),
                k,
                geometry_passes: None,
                median_gpu_ms: None,
                median_wall_ms: 0.0,
                median_gpu_ms_per_pass: None,
                fragments: None,
                fragments_dropped: None,
                max_depth_complexity: None,
                bytes_allocated: None,
                tile_items: None,
                error: None,
            };
            if let Some(why) = crate::bench::out_of_time() {
                row.error = Some(why);
                rows.push(row);
                continue;
            }
            // A configuration the device cannot hold (memory) is recorded, not fatal.
            match measure(
                gpu,
                &scene,
                &options,
                &Run::plain(method),
                warmup,
                frames,
                &bar,
            ) {
                Ok((result, last)) => {
                    row.geometry_passes = result.geometry_passes;
                    row.median_gpu_ms = result.median_gpu_ms;
                    row.median_wall_ms = result.median_wall_ms;
                    row.median_gpu_ms_per_pass = result.median_gpu_ms_per_pass;
                    row.fragments = result.fragments;
                    row.fragments_dropped = result.fragments_dropped;
                    row.max_depth_complexity = result.max_depth_complexity;
                    row.bytes_allocated = result.bytes_allocated;
                    row.tile_items = last.and_then(|s| s.compute_raster).map(|r| r.tile_items);
                }
                Err(e) => row.error = Some(e.to_string()),
            }
            rows.push(row);
            let so_far = report(rows);
            crate::write_results_so_far(dir, "cuda-renderer", &so_far, csv(&so_far));
            rows = so_far.rows;
        }
    }
    bar.finish_and_clear();
    let report = report(rows);
    print(&report);
    crate::write_results(dir, "cuda-renderer", &report, csv(&report))
}

/// The report of the rows measured so far, with each scene's ratios.
fn report_of(
    gpu: &Gpu,
    cpu_figures: bool,
    (width, height, frames): (u32, u32, u32),
    scenes: &[&str],
    rows: Vec<Row>,
) -> Report {
    let ratios = scenes
        .iter()
        .map(|spec| {
            let time = |label: &str| {
                rows.iter()
                    .find(|r| r.scene == *spec && r.label == label)
                    .and_then(|r| r.median_gpu_ms)
            };
            let ratio = |a: Option<f64>, b: Option<f64>| match (a, b) {
                (Some(a), Some(b)) if b > 0.0 => Some(a / b),
                _ => None,
            };
            let fabs = time(RUNS[2].0);
            Ratio {
                scene: spec.to_string(),
                compute_over_hw_fabs: ratio(fabs, time(RUNS[3].0)),
                f2b_over_compute_fabs: ratio(time(RUNS[4].0), fabs),
                dual_over_compute_fabs: ratio(time(RUNS[5].0), fabs),
                mdts_over_fabs: ratio(time(RUNS[0].0), fabs),
            }
        })
        .collect();
    Report {
        header: crate::bench::Header::new("cuda-renderer", gpu, cpu_figures, (width, height)),
        frames,
        rows,
        ratios,
    }
}

fn stage(row: &Row, name: &str) -> Option<f64> {
    row.median_gpu_ms_per_pass.as_ref()?.get(name).copied()
}

fn columns() -> Vec<Column<'static, Row>> {
    type C = Column<'static, Row>;
    let capture = |r: &Row| fixed(stage(r, "capture").or(stage(r, "capture_depth")), 3);
    vec![
        C::csv("scene", |r| r.scene.clone()),
        C::csv("triangles", |r| r.triangles.to_string()),
        C::csv("run", |r| r.label.to_string())
            .shown("run", 36)
            .left(),
        C::csv("raster", |r| r.raster.to_string()),
        C::csv("geometry_passes", |r| opt(r.geometry_passes)).shown("passes", 6),
        C::csv("median_gpu_ms", |r| fixed(r.median_gpu_ms, 3)).shown("gpu ms", 10),
        C::csv("bin_ms", |r| fixed(stage(r, "raster.bin"), 3)).shown("bin ms", 9),
        C::csv("capture_ms", capture).shown("capture ms", 10),
        C::csv("resolve_ms", |r| fixed(stage(r, "resolve"), 3)),
        C::csv("fragments", |r| opt(r.fragments)),
        C::csv("dropped", |r| opt(r.fragments_dropped)).shown("dropped", 9),
        C::csv("bytes", |r| opt(r.bytes_allocated)),
        C::csv("error", |r| opt(r.error.as_deref()).replace(',', ";")),
    ]
}

fn csv(r: &Report) -> String {
    csv_of(&columns(), &r.rows)
}

fn print(r: &Report) {
    r.header.print_heading(format_args!(
        "{}, median of {} frames",
        r.header.size(),
        r.frames
    ));
    for rows in r.rows.chunk_by(|a, b| a.scene == b.scene) {
        println!("{} ({} triangles)", rows[0].scene, rows[0].triangles);
        print_rows(&columns(), rows, |row| row.error.clone());
    }
    for ratio in &r.ratios {
        let f = |v: Option<f64>| v.map(|v| format!("{v:.2}")).unwrap_or("-".into());
        println!(
            "{}: compute/hw FABS {}, f2b/FABS {}, dual/FABS {}, MDTS/FABS {}",
            ratio.scene,
            f(ratio.compute_over_hw_fabs),
            f(ratio.f2b_over_compute_fabs),
            f(ratio.dual_over_compute_fabs),
            f(ratio.mdts_over_fabs)
        );
    }
}
