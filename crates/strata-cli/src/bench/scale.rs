//! `strata bench scale`: scenes of 1M to 12M triangles (the seeds' largest scenes are 7.6M, 10M
//! and 11.9M) through an exact method, each measured from the scene description to steady
//! frames: load (building the meshes), flatten and upload (the scene's vertex buffer and
//! per-triangle materials, waited for), then real-time frames as every experiment measures them
//! (`bench::measure`). Memory: the scene's bytes on the GPU, the method's own allocation, and the
//! process's resident and peak host memory after each size (Linux; sizes run in ascending order,
//! so the peak belongs to the size on its row or a smaller one).
//!
//! The scenes are `builtin:nvpro` with 120-triangle spheres (`subdiv=12`) and as many objects as
//! the size needs; the generator keeps the spheres' density, so depth complexity stays about the
//! same while the triangle count grows.

use crate::bench::{csv_of, fixed, opt, print_rows, Column};
use std::path::Path;
use std::time::Instant;

use serde::Serialize;
use strata::error::Result;
use strata::frame::SceneGpu;
use strata::gpu::Gpu;
use strata::scene::{loaders, GPU_TRIANGLE_BYTES};
use strata::RenderOptions;

use crate::bench::{measure, standalone_setup, Run};

/// The experiment `bench scale` runs.
pub const EXPERIMENT: super::Standalone = super::Standalone {
    name: "scale",
    description: "scenes of 1M..12M triangles (nvpro, 120-triangle spheres) with abuffer-ll: load, flatten+upload and frame time, GPU bytes and host memory",
    run,
};

const MILLIONS: [u64; 5] = [1, 2, 4, 8, 12];
const TRIANGLES_PER_SPHERE: u64 = 120;
const METHOD: &str = "abuffer-ll";

#[derive(Serialize)]
struct Row {
    scene: String,
    triangles: u64,
    /// Building the scene from its description (CPU).
    load_ms: f64,
    /// Flattening to three vertices per triangle and uploading, until the GPU has it.
    upload_ms: f64,
    /// The scene on the GPU: vertices and per-triangle materials.
    scene_gpu_bytes: u64,
    median_gpu_ms: Option<f64>,
    median_wall_ms: f64,
    fps: Option<f64>,
    /// The method's per-frame allocation (lists, heads, output).
    method_bytes: Option<u64>,
    fragments: Option<u64>,
    max_depth_complexity: Option<u32>,
    /// Resident host memory after the size's frames, and the process's peak so far (MiB).
    host_rss_mib: Option<f64>,
    host_peak_mib: Option<f64>,
}

#[derive(Serialize)]
struct Report {
    #[serde(flatten)]
    header: crate::bench::Header,
    method: &'static str,
    frames: u32,
    rows: Vec<Row>,
}

/// The scene of about `millions` million triangles.
fn scene_of(millions: u64) -> String {
    let objects = (millions * 1_000_000).div_ceil(TRIANGLES_PER_SPHERE);
    format!("builtin:nvpro?objects={objects}&subdiv=12&seed=0")
}

/// VmRSS and VmHWM of this process in MiB (Linux's /proc; `None` elsewhere).
/// The process's resident and peak resident memory in MiB (Linux's /proc/self/status).
pub(crate) fn host_memory() -> (Option<f64>, Option<f64>) {
    let Ok(status) = std::fs::read_to_string("/proc/self/status") else {
        return (None, None);
    };
    let field = |name: &str| {
        status
            .lines()
            .find_map(|l| l.strip_prefix(name))
            .and_then(|rest| {
                rest.trim()
                    .trim_end_matches("kB")
                    .trim()
                    .parse::<f64>()
                    .ok()
            })
            .map(|kib| kib / 1024.0)
    };
    (field("VmRSS:"), field("VmHWM:"))
}

pub fn run(gpu: &Gpu, size: Option<crate::Size>, frames: Option<u32>, dir: &Path) -> Result<()> {
    let (cpu_figures, (width, height), frames) =
        standalone_setup(gpu, size, frames, ((256, 256), (1920, 1080)), (3, 10))?;
    let warmup = 2;
    let options = RenderOptions::sized(width, height);
    options.validate()?;
    let bar = crate::bench::frames_bar(MILLIONS.len() as u64 * (2 + warmup + frames) as u64);
    let mut rows = Vec::new();
    for millions in MILLIONS {
        let spec = scene_of(millions);
        bar.set_message(format!("{millions}M triangles: loading"));
        let start = Instant::now();
        let scene = loaders::load_scene(&spec)?;
        let load_ms = start.elapsed().as_secs_f64() * 1e3;
        bar.inc(1);
        bar.set_message(format!("{millions}M triangles: uploading"));
        let start = Instant::now();
        let uploaded = SceneGpu::new(gpu, &scene, &options)?;
        gpu.wait()?;
        let upload_ms = start.elapsed().as_secs_f64() * 1e3;
        drop(uploaded);
        bar.inc(1);
        bar.set_message(format!("{millions}M triangles: {METHOD} frames"));
        let (result, last) = measure(
            gpu,
            &scene,
            &options,
            &Run::plain(METHOD),
            warmup,
            frames,
            &bar,
        )?;
        let triangles = scene.triangle_count() as u64;
        drop(scene);
        let (host_rss_mib, host_peak_mib) = host_memory();
        rows.push(Row {
            scene: spec,
            triangles,
            load_ms,
            upload_ms,
            scene_gpu_bytes: triangles * GPU_TRIANGLE_BYTES,
            median_gpu_ms: result.median_gpu_ms,
            median_wall_ms: result.median_wall_ms,
            fps: result.fps,
            method_bytes: result.bytes_allocated,
            fragments: last.as_ref().and_then(|s| s.fragments_generated),
            max_depth_complexity: last.as_ref().and_then(|s| s.max_depth_complexity),
            host_rss_mib,
            host_peak_mib,
        });
    }
    bar.finish_and_clear();
    let report = Report {
        header: crate::bench::Header::new("scale", gpu, cpu_figures, (width, height)),
        method: METHOD,
        frames,
        rows,
    };
    print(&report);
    crate::write_results(dir, "scale", &report, csv(&report))
}

fn columns() -> Vec<Column<'static, Row>> {
    type C = Column<'static, Row>;
    let mib = |bytes: u64| bytes as f64 / 1048576.0;
    vec![
        C::csv("triangles", |r| r.triangles.to_string()).shown("triangles", 10),
        C::csv("load_ms", |r| format!("{:.1}", r.load_ms))
            .shown_as("load ms", 9, |r| format!("{:.0}", r.load_ms)),
        C::csv("upload_ms", |r| format!("{:.1}", r.upload_ms))
            .shown_as("upload ms", 10, |r| format!("{:.0}", r.upload_ms)),
        C::csv("scene_gpu_mib", move |r| {
            format!("{:.1}", mib(r.scene_gpu_bytes))
        })
        .shown_as("scene MiB", 9, move |r| {
            format!("{:.0}", mib(r.scene_gpu_bytes))
        }),
        C::csv("median_gpu_ms", |r| fixed(r.median_gpu_ms, 3))
            .shown_as("GPU ms", 10, |r| fixed(r.median_gpu_ms, 2)),
        C::csv("median_wall_ms", |r| format!("{:.3}", r.median_wall_ms)).shown_as(
            "wall ms",
            10,
            |r| format!("{:.1}", r.median_wall_ms),
        ),
        C::csv("method_mib", move |r| fixed(r.method_bytes.map(mib), 1)).shown("method MiB", 10),
        C::csv("fragments", |r| opt(r.fragments)),
        C::csv("max_depth_complexity", |r| opt(r.max_depth_complexity)),
        C::csv("host_rss_mib", |r| fixed(r.host_rss_mib, 0)).shown("RSS MiB", 9),
        C::csv("host_peak_mib", |r| fixed(r.host_peak_mib, 0)).shown("peak MiB", 9),
    ]
}

fn csv(r: &Report) -> String {
    csv_of(&columns(), &r.rows)
}

fn print(r: &Report) {
    r.header.print_heading(format_args!(
        "{} at {}, median of {} frames",
        r.method,
        r.header.size(),
        r.frames
    ));
    print_rows(&columns(), &r.rows, |_| None);
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_scenes_have_the_sizes_they_are_named_for() {
        for millions in MILLIONS {
            let spec = scene_of(millions);
            let objects: u64 = spec
                .split("objects=")
                .nth(1)
                .and_then(|s| s.split('&').next())
                .and_then(|s| s.parse().ok())
                .unwrap();
            let triangles = objects * strata::scene::builtin::uv_sphere_triangles(12);
            assert!(
                triangles >= millions * 1_000_000 && triangles < millions * 1_000_000 + 120,
                "{spec}: {triangles}"
            );
        }
        assert!(*MILLIONS.last().unwrap() >= 10, "the issue asks for 10M+");
    }
}
