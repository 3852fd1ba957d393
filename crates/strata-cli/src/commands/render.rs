//! `strata render`: one picture, or an animation's frames, with one method.

use crate::{check_outputs, prepare_render, with_context, write_outputs, MethodArgs, PictureArgs};
use clap::Args;
use std::path::{Path, PathBuf};
use strata::error::{Error, Result};
use strata::frame::FrameStats;
use strata::gpu::Gpu;
use strata::methods::kbuffer::Tail;
use strata::methods::tiled::TiledStats;
use strata::methods::MethodId;
use strata::output::Outputs;
use strata::render::{save_png, Renderer};
use strata::KBufferOptions;

#[derive(Args)]
pub struct RenderArgs {
    #[command(flatten)]
    pub picture: PictureArgs,
    #[command(flatten)]
    pub method: MethodArgs,
    #[arg(short, long, default_value = "out.png")]
    pub output: PathBuf,
    /// Write the frame's statistics as JSON (with --frames: one JSON line per frame).
    #[arg(long)]
    pub stats: Option<PathBuf>,
    /// Render the animation's frames A..B (B excluded) or A..=B, each to -o with its number in a
    /// %d or %0Nd pattern (e.g. -o frame_%04d.png); one renderer for the whole sequence.
    #[arg(long)]
    pub frames: Option<String>,
}

/// Writes a picture and its statistics (all or nothing), then prints its summary.
pub fn finish_picture(
    image: &strata::LinearImage,
    stats: &FrameStats,
    options: &strata::RenderOptions,
    output: &Path,
    stats_path: Option<&Path>,
) -> Result<()> {
    write_outputs(image, stats, options.frame.effect, output, stats_path)?;
    summary(stats, output, options.frame.family::<KBufferOptions>().tail);
    Ok(())
}

pub fn summary(stats: &FrameStats, output: &Path, tail: Tail) {
    let ms = stats
        .gpu_ms_total
        .map(|t| format!("{t:.2} ms GPU"))
        .unwrap_or_else(|| "untimed".into());
    eprintln!(
        "{}: {}x{} {} — {} geometry pass(es), {} fragments, max depth {}, {ms} → {}",
        stats.method,
        stats.width,
        stats.height,
        stats.effect,
        stats.geometry_passes,
        stats.fragments_generated.unwrap_or(0),
        stats.max_depth_complexity.unwrap_or(0),
        output.display()
    );
    if let (Some(culled), Some(generated)) = (stats.culled_temporal, stats.fragments_generated) {
        eprintln!(
            "temporal culling: {culled} of {generated} fragments culled by last frame's interface ({:.1}%)",
            100.0 * culled as f64 / generated.max(1) as f64
        );
    }
    if let (Some(order), Some(tau)) = (&stats.order, stats.kendall_tau) {
        eprintln!(
            "order: {order}, Kendall distance to front-to-back order {tau:.3} (0 front to back, 1 back to front)"
        );
    }
    if let Some(note) = stats.family.as_ref().and_then(|f| f.stat().note()) {
        eprintln!("note: {note}");
    }
    if let Some(bands) = stats.bands {
        eprintln!(
            "note: rendered in {bands} bands of rows: the whole picture's per-pixel buffers outgrow this device's largest storage binding"
        );
    }
    if let (Some(a), Some(k)) = (&stats.k_auto, stats.k) {
        let percent = |r: Option<f64>| {
            r.map(|r| format!("{:.2}%", 100.0 * r))
                .unwrap_or_else(|| "unknown".into())
        };
        eprintln!(
            "k auto: k={k} (the budget holds k ≤ {}), target {:.2}%, predicted {}, achieved {}",
            a.k_budget,
            100.0 * a.robustness_target,
            percent(a.predicted_robustness),
            percent(a.achieved_robustness)
        );
    }
    let dropped = stats.fragments_dropped.unwrap_or(0);
    if dropped > 0 {
        let past_k = stats
            .method
            .parse::<MethodId>()
            .ok()
            .and_then(|m| m.descriptor().past_k);
        match (stats.k, tail) {
            (Some(k), _) if let Some(what) = past_k => {
                eprintln!("note: {dropped} fragments {what} (k={k})")
            }
            (Some(k), Tail::Blend | Tail::Weighted) => {
                eprintln!("note: {dropped} fragments beyond k={k} were blended into the tail")
            }
            (Some(k), Tail::Drop) => {
                let blends = stats.method.parse::<MethodId>().is_ok_and(|m| {
                    crate::method_options::applies(crate::method_options::Opt::TAIL, m, None)
                });
                let hint = if blends {
                    " (--tail blend keeps them as one term)"
                } else {
                    ""
                };
                eprintln!("note: {dropped} fragments beyond k={k} were dropped{hint}")
            }
            (None, _) => eprintln!("warning: {dropped} fragments dropped"),
        }
    }
    if stats.overflow == Some(true) && stats.geometry_passes > 1 && dropped == 0 {
        // The statistics are the last render's: name what can overflow with this method.
        let what = match (stats.family::<TiledStats>(), &stats.compute_raster) {
            (Some(_), _) => "the compute rasterizer's work items",
            (None, Some(_)) => "the fragment pool or the compute rasterizer's work items",
            (None, None) => "the fragment pool",
        };
        eprintln!("note: {what} overflowed and grew; the frame was re-rendered (output exact)");
    }
    if stats.lock_failures.unwrap_or(0) > 0 {
        eprintln!(
            "warning: {} fragments failed to take their pixel's lock (--max-tries); the picture is not exact",
            stats.lock_failures.unwrap_or(0)
        );
    }
}

/// On a downlevel device the lit pipeline a scene file asks for cannot run (it needs storage
/// buffers and compute): the scene's opaque objects are then peeled with the rest, and a note
/// says so. A `--pipeline` given on the command line stays, and is refused in one line.
fn fit_to_device(gpu: &Gpu, options: &mut strata::RenderOptions, picture: &PictureArgs) {
    let scene_pipeline = options.build.lighting.pipeline;
    if let (None, Some(pipeline)) = (picture.pipeline, scene_pipeline) {
        if strata::methods::downlevel::is_downlevel(gpu) {
            eprintln!(
                "note: the scene's pipeline ({}) does not run on a downlevel device; its opaque objects are peeled with the transparent ones",
                format!("{pipeline:?}").to_lowercase()
            );
            options.build.lighting.pipeline = None;
        }
    }
}

/// A spinner on stderr while long work runs (hidden when stderr is not a terminal).
pub fn spinner(message: String) -> indicatif::ProgressBar {
    let bar = indicatif::ProgressBar::new_spinner();
    bar.set_message(message);
    bar.enable_steady_tick(std::time::Duration::from_millis(120));
    bar
}

pub fn render(mut a: RenderArgs) -> Result<()> {
    if let Some(range) = a.frames.clone() {
        return render_sequence(a, &range);
    }
    let (scene, mut options) = prepare_render(&a.method, &a.picture)?;
    check_outputs(std::iter::once(a.output.as_path()).chain(a.stats.as_deref()))?;
    strata::output::check_png_name(&a.output)?;
    let busy = spinner(format!(
        "rendering {}x{} with {}",
        options.frame.width,
        options.frame.height,
        a.method.id()
    ));
    let rendered = if a.method.id() == MethodId::Reference {
        strata::reference::render(&scene, &options)
    } else {
        Gpu::new().and_then(|gpu| {
            fit_to_device(&gpu, &mut options, &a.picture);
            loop {
                match Renderer::new(&gpu, &scene, &options)?.render_method(a.method.id(), None) {
                    Err(Error::Unsupported(why)) if a.method.fall_back(&why) => continue,
                    done => break done,
                }
            }
        })
    };
    busy.finish_and_clear();
    let (image, mut stats) = rendered?;
    stats.method_choice = a.method.choice();
    finish_picture(&image, &stats, &options, &a.output, a.stats.as_deref())
}

/// The frames of `--frames A..B` or `A..=B`.
pub fn parse_frames(range: &str) -> Result<std::ops::Range<u32>> {
    let bad = || {
        Error::input(format!(
            "--frames '{range}' is not A..B or A..=B with A <= B"
        ))
    };
    let (a, b, inclusive) = match range.split_once("..=") {
        Some((a, b)) => (a, b, true),
        None => range
            .split_once("..")
            .map(|(a, b)| (a, b, false))
            .ok_or_else(bad)?,
    };
    let a: u32 = a.trim().parse().map_err(|_| bad())?;
    let b: u32 = b.trim().parse().map_err(|_| bad())?;
    let end = if inclusive {
        b.checked_add(1).ok_or_else(bad)?
    } else {
        b
    };
    if end <= a {
        return Err(bad());
    }
    if (end - a) as usize > MAX_FRAMES {
        return Err(Error::input(format!(
            "--frames '{range}' is {} frames; one run writes at most {MAX_FRAMES}",
            end - a
        )));
    }
    Ok(a..end)
}

/// `pattern` with its one %d or %0Nd replaced by `n` (%% is a literal %, as is a % that starts
/// no frame number).
pub fn frame_path(pattern: &Path, n: u32) -> Result<PathBuf> {
    let text = pattern.to_string_lossy();
    let bad = |why: &str| {
        Error::input(format!(
            "-o '{text}' {why} with --frames (e.g. frame_%04d.png)"
        ))
    };
    let mut path = String::with_capacity(text.len() + 10);
    let mut numbers = 0;
    let mut rest = text.as_ref();
    while let Some(at) = rest.find('%') {
        path.push_str(&rest[..at]);
        let after = &rest[at + 1..];
        if let Some(tail) = after.strip_prefix('%') {
            path.push('%');
            rest = tail;
            continue;
        }
        // %d, or %0Nd with N of 1 or 2 digits.
        let spec = match after.find('d') {
            Some(d) if d == 0 => Some((0, d)),
            Some(d)
                if d <= 3
                    && after.starts_with('0')
                    && after[1..d].bytes().all(|b| b.is_ascii_digit()) =>
            {
                Some((after[1..d].parse::<usize>().unwrap_or(0), d))
            }
            _ => None,
        };
        match spec {
            Some((digits, d)) => {
                numbers += 1;
                path.push_str(&format!("{n:0digits$}"));
                rest = &after[d + 1..];
            }
            None => {
                path.push('%');
                rest = after;
            }
        }
    }
    path.push_str(rest);
    match numbers {
        0 => Err(bad("needs a %d or %0Nd for the frame number")),
        1 => Ok(PathBuf::from(path)),
        _ => Err(bad(
            "has more than one %d or %0Nd; the frame number goes in one place",
        )),
    }
}

/// The most frames one `render --frames` writes.
pub const MAX_FRAMES: usize = 100_000;

/// `strata render --frames`: each time step of the animation with one renderer — the GPU
/// moves the objects and the camera follows its path, nothing is rebuilt between frames — PNGs
/// by pattern, statistics as JSON lines.
pub fn render_sequence(a: RenderArgs, range: &str) -> Result<()> {
    let frames = parse_frames(range)?;
    if a.picture.frame.is_some() {
        return Err(Error::input("--frame and --frames exclude each other"));
    }
    let paths: Vec<PathBuf> = frames
        .clone()
        .map(|n| frame_path(&a.output, n))
        .collect::<Result<_>>()?;
    // Distinct by their numbers; each checked alone (a check of all together is quadratic).
    for path in &paths {
        strata::output::check_target(path)?;
    }
    strata::output::check_png_name(&paths[0])?;
    if let Some(stats) = &a.stats {
        check_outputs([paths[0].as_path(), stats.as_path()])?;
    }
    let picture = PictureArgs {
        frame: Some(frames.start as f32),
        ..a.picture.clone()
    };
    let (scene, mut options) = prepare_render(&a.method, &picture)?;
    let gpu = if a.method.id() == MethodId::Reference {
        None
    } else {
        let gpu = Gpu::new()?;
        fit_to_device(&gpu, &mut options, &picture);
        Some(gpu)
    };
    let bar = indicatif::ProgressBar::new(frames.len() as u64);
    let mut renderer = match &gpu {
        Some(gpu) => Some(Renderer::new(gpu, &scene, &options)?),
        None => None,
    };
    let mut lines = String::new();
    let mut last = None;
    let mut written = 0;
    let mut frame_by_frame = || -> Result<()> {
        for (n, path) in frames.clone().zip(&paths) {
            let (image, stats) = match renderer.as_mut() {
                None => strata::reference::render(&scene.at_time(n as f32), &options)?,
                Some(r) => {
                    r.set_time(n as f32);
                    r.render_method(a.method.id(), None)?
                }
            };
            save_png(&image.to_rgba8(options.frame.effect), path)?;
            written += 1;
            let mut stats = stats;
            stats.frame = n as u64;
            stats.method_choice = a.method.choice();
            lines += &serde_json::to_string(&stats).map_err(|e| Error::runtime(e.to_string()))?;
            lines.push('\n');
            last = Some((stats, path, options.frame.family::<KBufferOptions>().tail));
            bar.inc(1);
        }
        if let Some(path) = &a.stats {
            let mut outputs = Outputs::new();
            outputs.add(path, std::mem::take(&mut lines).into_bytes())?;
            outputs.commit()?;
        }
        Ok(())
    };
    let done = frame_by_frame();
    bar.finish_and_clear();
    if let Err(e) = done {
        // A sequence is written whole or not at all, like any other output.
        for path in &paths[..written] {
            let _ = std::fs::remove_file(path);
        }
        return Err(match written {
            0 => e,
            _ => with_context(
                e,
                &format!("the {written} frames written before were removed"),
            ),
        });
    }
    if let Some((stats, path, tail)) = last {
        summary(&stats, path, tail);
        eprintln!("{} frames written", frames.len());
    }
    Ok(())
}
