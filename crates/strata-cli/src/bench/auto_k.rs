//! `strata bench auto-k` (seed 003 Figs. 3–4): the k that `--k auto` chooses, frame after frame,
//! as the view orbits a model and as an animation runs, under two memory budgets.
//!
//! Each sequence runs as an application would: one recorder, frame t's depth-complexity
//! histogram choosing frame t + 1's k. The experiment waits for each frame's statistics before
//! recording the next, since it measures the choice (k, predicted and achieved robustness),
//! not speed; its GPU times are those of single frames, not of a steady loop.

use crate::bench::{csv_of, fixed, opt, print_rows, Column};
use std::path::Path;
use strata::frame::FrameOptions;

use serde::Serialize;
use strata::error::Result;
use strata::frame::FrameStats;
use strata::gpu::Gpu;
use strata::scene::{loaders, Camera};
use strata::{FrameRecorder, MethodId, RenderOptions};

use crate::bench::standalone_setup;

/// The experiment `bench auto-k` runs.
pub const EXPERIMENT: super::Standalone = super::Standalone {
    name: "auto-k",
    description: "seed 003 Figs. 3-4: the k --k auto picks (R = 0.95) per view of a dragon orbit and per frame of balls, kplus-heap and kplus-sbuffer, budgets of 64 and 256 bytes per pixel",
    run,
};

const ROBUSTNESS: f64 = 0.95;
const BUDGET_BYTES_PER_PIXEL: [f64; 2] = [64.0, 256.0];
const METHODS: [MethodId; 2] = [MethodId::KplusHeap, MethodId::KplusSbuffer];
const DEFAULT_STEPS: u32 = 12;

#[derive(Serialize)]
struct Row {
    sequence: &'static str,
    step: u32,
    method: MethodId,
    budget_mb: f64,
    k: Option<u32>,
    k_budget: Option<u32>,
    histogram_frame: Option<u64>,
    predicted_robustness: Option<f64>,
    achieved_robustness: Option<f64>,
    max_depth_complexity: Option<u32>,
    fragments: Option<u64>,
    bytes_allocated: Option<u64>,
    /// The fragment pool (kplus-sbuffer) was smaller than the frame's regions.
    overflow: Option<bool>,
    gpu_ms: Option<f64>,
}

#[derive(Serialize)]
struct Report {
    #[serde(flatten)]
    header: crate::bench::Header,
    robustness: f64,
    rows: Vec<Row>,
}

/// The camera `step` of `steps` around the model's vertical axis.
fn orbit(base: &Camera, step: u32, steps: u32) -> Camera {
    let angle = std::f32::consts::TAU * step as f32 / steps as f32;
    let turn = glam::Quat::from_axis_angle(base.up.normalize(), angle);
    Camera {
        eye: base.target + turn * (base.eye - base.target),
        ..*base
    }
}

fn row(sequence: &'static str, step: u32, method: MethodId, budget_mb: f64, s: FrameStats) -> Row {
    let auto = s.k_auto.as_ref();
    Row {
        sequence,
        step,
        method,
        budget_mb,
        k: s.k,
        k_budget: auto.map(|a| a.k_budget),
        histogram_frame: auto.and_then(|a| a.histogram_frame),
        predicted_robustness: auto.and_then(|a| a.predicted_robustness),
        achieved_robustness: auto.and_then(|a| a.achieved_robustness),
        max_depth_complexity: s.max_depth_complexity,
        fragments: s.fragments_generated,
        bytes_allocated: Some(s.bytes_allocated),
        overflow: s.overflow,
        gpu_ms: s.gpu_ms_total,
    }
}

/// Records one frame and waits for its statistics.
fn frame(gpu: &Gpu, recorder: &mut FrameRecorder) -> Result<FrameStats> {
    let mut encoder = gpu.device.create_command_encoder(&Default::default());
    recorder.record(&mut encoder, &Default::default(), None)?;
    gpu.queue.submit([encoder.finish()]);
    Ok(recorder.wait_stats()?.stats)
}

pub fn run(gpu: &Gpu, size: Option<crate::Size>, steps: Option<u32>, dir: &Path) -> Result<()> {
    let (cpu_figures, (width, height), steps) = standalone_setup(
        gpu,
        size,
        steps,
        ((256, 256), (1024, 1024)),
        (DEFAULT_STEPS, DEFAULT_STEPS),
    )?;
    let mut dragon = loaders::load_scene("builtin:dragon")?;
    dragon.override_alpha(0.5);
    let base_camera = dragon.camera_or_framing();
    let pixels = width as f64 * height as f64;
    let bar = crate::bench::frames_bar(
        (2 * METHODS.len() * BUDGET_BYTES_PER_PIXEL.len()) as u64 * steps as u64,
    );
    let mut rows = Vec::new();
    for method in METHODS {
        for bytes_per_pixel in BUDGET_BYTES_PER_PIXEL {
            let budget_mb = bytes_per_pixel * pixels / 1048576.0;
            let options = RenderOptions {
                frame: FrameOptions {
                    width,
                    height,
                    k_auto: Some(ROBUSTNESS),
                    budget_mb: Some(budget_mb),
                    ..Default::default()
                },
                ..Default::default()
            };
            bar.set_message(format!("{method} {budget_mb:.1} MiB orbit"));
            let mut recorder = FrameRecorder::new(gpu, &dragon, method, &options)?;
            for step in 0..steps {
                recorder.set_camera(&orbit(&base_camera, step, steps));
                rows.push(row(
                    "dragon-orbit",
                    step,
                    method,
                    budget_mb,
                    frame(gpu, &mut recorder)?,
                ));
                bar.inc(1);
            }
            bar.set_message(format!("{method} {budget_mb:.1} MiB balls"));
            let balls = loaders::load_scene("builtin:balls")?;
            let mut recorder = FrameRecorder::new(gpu, &balls, method, &options)?;
            for step in 0..steps {
                recorder.set_time(step as f32);
                rows.push(row(
                    "balls",
                    step,
                    method,
                    budget_mb,
                    frame(gpu, &mut recorder)?,
                ));
                bar.inc(1);
            }
        }
    }
    bar.finish_and_clear();
    let report = Report {
        header: crate::bench::Header::new("auto-k", gpu, cpu_figures, (width, height)),
        robustness: ROBUSTNESS,
        rows,
    };
    print(&report);
    crate::write_results(dir, "auto-k", &report, csv(&report))
}

fn columns() -> Vec<Column<'static, Row>> {
    type C = Column<'static, Row>;
    let pct = |v: Option<f64>| {
        v.map(|v| format!("{:.1}%", 100.0 * v))
            .unwrap_or("-".into())
    };
    vec![
        C::csv("sequence", |r| r.sequence.to_string())
            .shown("sequence", 13)
            .left(),
        C::csv("step", |r| r.step.to_string()).shown("step", 4),
        C::csv("method", |r| r.method.to_string())
            .shown("method", 14)
            .left(),
        C::csv("budget_mb", |r| format!("{:.3}", r.budget_mb))
            .shown_as("budget MiB", 9, |r| format!("{:.2}", r.budget_mb)),
        C::csv("k", |r| opt(r.k)).shown("k", 4),
        C::csv("k_budget", |r| opt(r.k_budget)).shown("k_budget", 8),
        C::csv("histogram_frame", |r| opt(r.histogram_frame)),
        C::csv("predicted_robustness", |r| fixed(r.predicted_robustness, 4)).shown_as(
            "predicted",
            9,
            move |r| pct(r.predicted_robustness),
        ),
        C::csv("achieved_robustness", |r| fixed(r.achieved_robustness, 4)).shown_as(
            "achieved",
            9,
            move |r| pct(r.achieved_robustness),
        ),
        C::csv("max_depth_complexity", |r| opt(r.max_depth_complexity)).shown("depth", 6),
        C::csv("fragments", |r| opt(r.fragments)),
        C::csv("bytes_allocated", |r| opt(r.bytes_allocated)),
        C::csv("overflow", |r| opt(r.overflow)).shown("overflow", 8),
        C::csv("gpu_ms", |r| fixed(r.gpu_ms, 3)),
    ]
}

fn csv(r: &Report) -> String {
    csv_of(&columns(), &r.rows)
}

fn print(r: &Report) {
    println!(
        "auto-k — {}x{} R = {} on {}",
        r.header.width,
        r.header.height,
        r.robustness,
        r.header.device()
    );
    print_rows(&columns(), &r.rows, |_| None);
}
