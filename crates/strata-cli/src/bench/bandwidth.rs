//! `strata bench bandwidth`: the device's copy bandwidth and atomic rates
//! ([`strata::gpu::bandwidth`]), then every GPU method's real-time frames with each frame's
//! memory-traffic floor ([`strata::methods::traffic`]): the least time its bytes and atomics
//! take at those rates, and measured / floor — how far each method is from its memory bound.
//!
//! On a GPU: the dragon (opacity 0.5) and nvpro at 1024²; on lavapipe the dragon at 192² (CPU
//! figures: a CPU's memory system and a software rasterizer, so the ratios are large).

use crate::bench::{csv_of, fixed, opt, print_rows, scene_column, Column};
use std::path::Path;

use serde::Serialize;
use strata::error::Result;
use strata::gpu::bandwidth::{self, DeviceRates, ProbeSizes};
use strata::gpu::Gpu;
use strata::methods::traffic::{self, FrameCounts, Traffic};
use strata::MethodId;

use crate::bench::{measure, standalone_setup, Run};
use crate::PictureArgs;

/// The experiment `bench bandwidth` runs.
pub const EXPERIMENT: super::Standalone = super::Standalone {
    name: "bandwidth",
    description: "memory-traffic floors: the device's copy bandwidth and atomic rates, then every GPU method's frame time against the floor its bytes and atomics set (measured / floor)",
    run,
};

/// The scenes on a GPU; lavapipe runs the first only.
const SCENES: [&str; 2] = [
    "builtin:dragon",
    "builtin:nvpro?objects=1024&subdiv=16&seed=0",
];
const ALPHA: f32 = 0.5;

#[derive(Serialize)]
struct Row {
    scene: String,
    method: String,
    median_gpu_ms: Option<f64>,
    fragments: Option<u64>,
    fragments_stored: Option<u64>,
    geometry_passes: Option<u32>,
    bytes_allocated: Option<u64>,
    /// The frame's traffic under the model.
    traffic: Option<Traffic>,
    floor_ms: Option<f64>,
    /// What sets the floor: bandwidth, pixel atomics or global atomics.
    bound: Option<&'static str>,
    /// median_gpu_ms / floor_ms.
    measured_over_floor: Option<f64>,
    skipped: Option<String>,
}

#[derive(Serialize)]
struct Report {
    #[serde(flatten)]
    header: crate::bench::Header,
    frames: u32,
    alpha: f32,
    device: DeviceRates,
    rows: Vec<Row>,
}

pub fn run(gpu: &Gpu, size: Option<crate::Size>, frames: Option<u32>, dir: &Path) -> Result<()> {
    let (cpu_figures, (width, height), frames) =
        standalone_setup(gpu, size, frames, ((192, 192), (1024, 1024)), (3, 10))?;
    eprintln!("bandwidth: probing the device's copy bandwidth and atomic rates");
    let device = bandwidth::measure(gpu, ProbeSizes::for_device(gpu))?;
    let scenes = if cpu_figures {
        &SCENES[..1]
    } else {
        &SCENES[..]
    };
    let methods: Vec<MethodId> = MethodId::gpu_methods().collect();
    let warmup = 2;
    let bar =
        crate::bench::frames_bar((scenes.len() * methods.len()) as u64 * (warmup + frames) as u64);
    let mut rows = Vec::new();
    for spec in scenes {
        let picture = PictureArgs {
            size: Some(crate::Size::new(width, height)),
            alpha: Some(ALPHA),
            ..PictureArgs::for_scene(spec.to_string())
        };
        let (scene, options) = crate::prepare(&picture)?;
        for &method in &methods {
            bar.set_message(format!("{} {method}", crate::bench::short_scene(spec)));
            let run = Run::plain(method.as_str());
            let mut row = Row {
                scene: spec.to_string(),
                method: method.as_str().into(),
                median_gpu_ms: None,
                fragments: None,
                fragments_stored: None,
                geometry_passes: None,
                bytes_allocated: None,
                traffic: None,
                floor_ms: None,
                bound: None,
                measured_over_floor: None,
                skipped: None,
            };
            match measure(
                gpu,
                &scene,
                &run.options(&options),
                &run,
                warmup,
                frames,
                &bar,
            ) {
                Ok((result, last)) => {
                    row.median_gpu_ms = result.median_gpu_ms;
                    if let Some(s) = last {
                        row.fragments = s.fragments_generated;
                        row.fragments_stored = s.fragments_stored;
                        row.geometry_passes = Some(s.geometry_passes);
                        row.bytes_allocated = Some(s.bytes_allocated);
                        let counts = FrameCounts {
                            pixels: width as u64 * height as u64,
                            generated: s.fragments_generated.unwrap_or(0),
                            stored: s.fragments_stored.unwrap_or(0),
                            geometry_passes: s.geometry_passes.max(1) as u64,
                            bytes_allocated: s.bytes_allocated,
                        };
                        row.traffic = traffic::traffic(method, &counts);
                        if let Some(t) = &row.traffic {
                            let floor = traffic::floor(t, &device);
                            row.floor_ms = Some(floor.ms);
                            row.bound = Some(floor.bound);
                            row.measured_over_floor = row.median_gpu_ms.map(|ms| ms / floor.ms);
                        }
                    }
                }
                Err(strata::error::Error::Unsupported(why)) => {
                    bar.inc((warmup + frames) as u64);
                    row.skipped = Some(why);
                }
                Err(e) => return Err(e),
            }
            rows.push(row);
        }
    }
    bar.finish_and_clear();
    let report = Report {
        header: crate::bench::Header::new("bandwidth", gpu, cpu_figures, (width, height)),
        frames,
        alpha: ALPHA,
        device,
        rows,
    };
    print(&report);
    crate::write_results(dir, "bandwidth", &report, csv(&report))
}

fn columns() -> Vec<Column<'static, Row>> {
    type C = Column<'static, Row>;
    let mib = |r: &Row, digits| fixed(r.traffic.map(|t| t.bytes as f64 / 1048576.0), digits);
    vec![
        scene_column(|r: &Row| &r.scene),
        C::csv("method", |r| r.method.clone())
            .shown("method", 16)
            .left(),
        C::csv("median_gpu_ms", |r| fixed(r.median_gpu_ms, 3))
            .shown_as("GPU ms", 10, |r| fixed(r.median_gpu_ms, 2)),
        C::csv("traffic_mib", move |r| mib(r, 2)).shown_as("traffic MiB", 12, move |r| mib(r, 1)),
        C::csv("pixel_atomics", |r| opt(r.traffic.map(|t| t.pixel_atomics))),
        C::csv("global_atomics", |r| {
            opt(r.traffic.map(|t| t.global_atomics))
        }),
        C::csv("floor_ms", |r| fixed(r.floor_ms, 4))
            .shown_as("floor ms", 10, |r| fixed(r.floor_ms, 3)),
        C::csv("bound", |r| opt(r.bound)).shown("bound", 15),
        C::csv("measured_over_floor", |r| fixed(r.measured_over_floor, 1)).shown("ms/floor", 10),
        C::csv("skipped", |r| opt(r.skipped.as_deref()).replace(',', ";")),
    ]
}

fn csv(r: &Report) -> String {
    csv_of(&columns(), &r.rows)
}

fn print(r: &Report) {
    let d = &r.device;
    r.header.print_heading(format_args!(
        "copy {:.1} GB/s, stream {:.1} GB/s; atomics (G/s) distinct {:.3}, {} per word {:.3}, one word {:.4}",
        d.copy_gb_per_s,
        d.stream_gb_per_s,
        d.atomics_distinct_g_per_s,
        bandwidth::FRAGMENTS_PER_PIXEL,
        d.atomics_per_pixel_g_per_s,
        d.atomics_one_word_g_per_s
    ));
    print_rows(&columns(), &r.rows, |row| row.skipped.clone());
}
