//! `strata bench deferred-lights` (seed 004 Figs. 13–14): frame time against the number of
//! lights for the forward and the deferred pipeline on an opaque ~100K-triangle scene, where the
//! curves cross, and the G-buffer's bytes per pixel and traffic at 60 fps for the traditional
//! layout against the compressed one.
//!
//! Each configuration runs as the other experiments do (`bench::measure`: a steady loop of
//! real-time frames, two in flight, medians of the frames' own GPU timestamps). The lights are
//! `--lights N`'s field; the scene is opaque, so the transparent method draws nothing and the
//! frame is the pipeline's.

use std::path::Path;
use strata::frame::{BuildOptions, FrameOptions, Lighting};

use serde::Serialize;
use strata::deferred::{gbuffer_bytes_per_pixel, GbufferLayout, Pipeline};
use strata::error::Result;
use strata::gpu::Gpu;
use strata::scene::loaders;
use strata::RenderOptions;

use crate::bench::{csv_of, measure, opt, standalone_setup, Column, Run};

/// The experiment `bench deferred-lights` runs.
pub const EXPERIMENT: super::Standalone = super::Standalone {
    name: "deferred-lights",
    description: "seed 004 Figs. 13-14: forward vs deferred frame time over 1..4096 lights (lavapipe: 1..1024) on ~100K opaque triangles, and G-buffer bytes per pixel and traffic at 60 fps, traditional vs compressed",
    run,
};

/// About 100K triangles: 196 UV spheres of 528 triangles (the G-buffer holds 256 materials).
const SCENE: &str = "builtin:nvpro?objects=196&subdiv=24&seed=0";
const LIGHTS_GPU: [u32; 7] = [1, 4, 16, 64, 256, 1024, 4096];
const LIGHTS_CPU: [u32; 6] = [1, 4, 16, 64, 256, 1024];
const METHOD: &str = "abuffer-ll";

#[derive(Serialize)]
struct Row {
    pipeline: &'static str,
    lights: u32,
    /// Deferred: lights left after frustum culling.
    lights_drawn: Option<u32>,
    median_gpu_ms: Option<f64>,
    median_wall_ms: f64,
    median_gpu_ms_per_pass: Option<std::collections::BTreeMap<String, f64>>,
    bytes_allocated: Option<u64>,
}

#[derive(Serialize)]
struct Layout {
    layout: &'static str,
    bytes_per_pixel: u64,
    /// At 1024×768, as seed 004 reports it.
    mib_at_1024x768: f64,
    /// One write and one read of every byte per frame, 60 frames per second.
    traffic_gib_per_s_at_60fps: f64,
}

#[derive(Serialize)]
struct Report {
    #[serde(flatten)]
    header: crate::bench::Header,
    scene: &'static str,
    triangles: usize,
    frames: u32,
    rows: Vec<Row>,
    /// The smallest light count at which deferred is faster than forward, if any measured.
    crossing_lights: Option<u32>,
    layouts: Vec<Layout>,
}

pub fn run(gpu: &Gpu, size: Option<crate::Size>, frames: Option<u32>, dir: &Path) -> Result<()> {
    let (cpu_figures, (width, height), frames) =
        standalone_setup(gpu, size, frames, ((256, 192), (1024, 768)), (7, 20))?;
    let counts: &[u32] = if cpu_figures {
        &LIGHTS_CPU
    } else {
        &LIGHTS_GPU
    };
    let mut base = loaders::load_scene(SCENE)?;
    base.override_alpha(1.0);
    let triangles = base.triangle_count();
    let warmup = 2;
    let bar = crate::bench::frames_bar((counts.len() * 2) as u64 * (warmup + frames) as u64);
    let mut rows = Vec::new();
    for &lights in counts {
        let mut scene = base.clone();
        scene.add_light_field(lights, 1);
        for pipeline in [Pipeline::Forward, Pipeline::Deferred] {
            let name = match pipeline {
                Pipeline::Forward => "forward",
                Pipeline::Deferred => "deferred",
            };
            bar.set_message(format!("{name}, {lights} lights"));
            let options = RenderOptions {
                build: BuildOptions {
                    lighting: Lighting {
                        pipeline: Some(pipeline),
                        ..Default::default()
                    },
                    ..Default::default()
                },
                frame: FrameOptions {
                    width,
                    height,
                    ..Default::default()
                },
            };
            let run = Run::plain(METHOD);
            let (result, last) = measure(gpu, &scene, &options, &run, warmup, frames, &bar)?;
            let lighting = last.and_then(|s| s.lighting);
            rows.push(Row {
                pipeline: name,
                lights,
                lights_drawn: lighting.as_ref().and_then(|l| {
                    Some(l.sphere_volumes? + l.cone_volumes? + l.full_screen_lights?)
                }),
                median_gpu_ms: result.median_gpu_ms,
                median_wall_ms: result.median_wall_ms,
                median_gpu_ms_per_pass: result.median_gpu_ms_per_pass,
                bytes_allocated: lighting.map(|l| l.bytes_allocated),
            });
        }
    }
    bar.finish_and_clear();
    let time = |pipeline: &str, lights: u32| {
        rows.iter()
            .find(|r| r.pipeline == pipeline && r.lights == lights)
            .and_then(|r| r.median_gpu_ms)
    };
    let crossing_lights = counts.iter().copied().find(
        |&n| matches!((time("deferred", n), time("forward", n)), (Some(d), Some(f)) if d < f),
    );
    let layouts = [
        ("traditional (3×RGBA16 + depth)", GbufferLayout::Traditional),
        (
            "compressed (RGBA8 + RGB10A2 + depth)",
            GbufferLayout::Compressed,
        ),
    ]
    .map(|(name, layout)| {
        let bytes = gbuffer_bytes_per_pixel(layout);
        let frame = bytes as f64 * 1024.0 * 768.0;
        Layout {
            layout: name,
            bytes_per_pixel: bytes,
            mib_at_1024x768: frame / 1048576.0,
            traffic_gib_per_s_at_60fps: 2.0 * frame * 60.0 / (1u64 << 30) as f64,
        }
    })
    .into_iter()
    .collect();
    let report = Report {
        header: crate::bench::Header::new("deferred-lights", gpu, cpu_figures, (width, height)),
        scene: SCENE,
        triangles,
        frames,
        rows,
        crossing_lights,
        layouts,
    };
    print(&report);
    crate::write_results(dir, "deferred-lights", &report, csv(&report))
}

fn ms(v: Option<f64>) -> String {
    v.map(|v| format!("{v:.3}")).unwrap_or_default()
}

fn csv(r: &Report) -> String {
    type C = Column<'static, Row>;
    let columns = [
        C::csv("pipeline", |r| r.pipeline.to_string()),
        C::csv("lights", |r| r.lights.to_string()),
        C::csv("lights_drawn", |r| opt(r.lights_drawn)),
        C::csv("median_gpu_ms", |r| ms(r.median_gpu_ms)),
        C::csv("median_wall_ms", |r| format!("{:.3}", r.median_wall_ms)),
    ];
    csv_of(&columns, &r.rows)
}

fn print(r: &Report) {
    r.header.print_heading(format_args!(
        "{} triangles at {}, median of {} frames",
        r.triangles,
        r.header.size(),
        r.frames
    ));
    println!(
        "{:>7} {:>12} {:>12} {:>8}",
        "lights", "forward ms", "deferred ms", "drawn"
    );
    for pair in r.rows.chunks(2) {
        if let [f, d] = pair {
            println!(
                "{:>7} {:>12} {:>12} {:>8}",
                f.lights,
                ms(f.median_gpu_ms),
                ms(d.median_gpu_ms),
                opt(d.lights_drawn)
            );
        }
    }
    match r.crossing_lights {
        Some(n) => println!("deferred is faster from {n} lights"),
        None => println!("deferred was not faster at any measured light count"),
    }
    for l in &r.layouts {
        println!(
            "{:<38} {:>3} B/px  {:>6.2} MiB at 1024x768  {:>5.2} GiB/s at 60 fps",
            l.layout, l.bytes_per_pixel, l.mib_at_1024x768, l.traffic_gib_per_s_at_60fps
        );
    }
}
