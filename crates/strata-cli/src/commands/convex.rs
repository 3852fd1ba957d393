//! `strata convex`: the convex decomposition `convex` orders.

use crate::{cache_dir, check_outputs, prepare, PictureArgs};
use clap::Args;
use std::path::PathBuf;
use strata::error::{Error, Result};
use strata::frame::Effect;
use strata::gpu::Gpu;
use strata::output::Outputs;
use strata::render::Renderer;

#[derive(Args)]
pub struct ConvexArgs {
    /// The model or scene to decompose.
    #[arg(default_value = "builtin:teapot")]
    pub scene: String,
    /// The view's size, WxH, for its passes and --out (default: the scene's, else 512x512).
    #[arg(long, allow_hyphen_values = true)]
    pub size: Option<crate::Size>,
    /// Render the decomposition to this PNG: one opaque color per group (paired groups
    /// darker), from the scene's camera.
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Print the statistics as JSON.
    #[arg(long)]
    pub json: bool,
    /// Keep the decomposition in DIR: read when there, written when made.
    #[arg(long)]
    pub cache_dir: Option<PathBuf>,
}

/// What `strata convex` reports: the preprocess, and the order of the scene's view.
#[derive(serde::Serialize)]
pub struct ConvexReport {
    pub decomposition: strata::methods::convex::decompose::DecompositionStats,
    pub width: u32,
    pub height: u32,
    pub passes: usize,
    pub culled: u32,
    pub overlapping_pairs: u64,
    pub unseparated_pairs: u64,
    pub cycles_broken: u32,
    pub order_ms: f64,
}

pub fn convex(a: ConvexArgs) -> Result<()> {
    use strata::methods::convex::{self, order};
    let picture = PictureArgs {
        size: a.size,
        ..PictureArgs::for_scene(a.scene)
    };
    let (scene, options) = prepare(&picture)?;
    if let Some(out) = &a.out {
        check_outputs([out.as_path()])?;
        strata::output::check_png_name(out)?;
    }
    let triangles = convex::triangles_of(&scene);
    let bar = indicatif::ProgressBar::new(100).with_message("decomposing");
    bar.set_style(
        indicatif::ProgressStyle::with_template("{msg} [{bar:40}] {percent}% ({elapsed})")
            .map_err(|e| Error::runtime(e.to_string()))?,
    );
    if triangles.len() < 50_000 || a.json {
        bar.set_draw_target(indicatif::ProgressDrawTarget::hidden());
    }
    let cache = a.cache_dir.as_deref().map(cache_dir).transpose()?;
    let d = convex::decomposition_of(&triangles, cache.as_deref(), &|f| {
        bar.set_position((f * 100.0) as u64)
    });
    bar.finish_and_clear();
    let camera = scene.camera_or_framing();
    let view_proj = strata::frame::uniforms::band_projection(&camera, &options);
    let plan = order::plan(
        &d,
        &camera,
        view_proj,
        options.frame.width,
        options.frame.height,
        1,
    );
    let report = ConvexReport {
        decomposition: d.stats.clone(),
        width: options.frame.width,
        height: options.frame.height,
        passes: plan.passes.len(),
        culled: plan.culled,
        overlapping_pairs: plan.overlapping,
        unseparated_pairs: plan.unseparated,
        cycles_broken: plan.cycles_broken,
        order_ms: plan.order_ms,
    };
    if let Some(out) = &a.out {
        let pieces = convex::pieces_scene(&scene, &triangles, &d);
        let gpu = Gpu::new()?;
        let (image, _) = Renderer::new(&gpu, &pieces, &options)?.render("abuffer-ll")?;
        let mut outputs = Outputs::new();
        outputs.add_png(out, &image.to_rgba8(Effect::Transparency))?;
        outputs.commit()?;
    }
    if a.json {
        println!(
            "{}",
            serde_json::to_string_pretty(&report).map_err(|e| Error::runtime(e.to_string()))?
        );
        return Ok(());
    }
    let s = &report.decomposition;
    println!(
        "{} triangles -> {} convex parts -> {} groups ({} inseparable pairs joined; up to {} layers per pixel and group), preprocess {:.0} ms",
        s.triangles, s.parts, s.groups, s.paired, s.layers_per_group, s.preprocess_ms
    );
    if let Some(ms) = s.read_from_cache_ms {
        println!(
            "read from the cache in {ms:.0} ms (the preprocess above is the run that made it)"
        );
    }
    println!(
        "pairs with overlapping boxes: {} ({} nested, {} without a separating plane: ordered by centroid)",
        s.overlapping_pairs, s.nested, s.unseparated
    );
    println!(
        "this view at {}x{}: {} passes, {} groups culled, {} overlapping pairs on screen ({} without a plane), {} cycles broken, order {:.2} ms",
        report.width,
        report.height,
        report.passes,
        report.culled,
        report.overlapping_pairs,
        report.unseparated_pairs,
        report.cycles_broken,
        report.order_ms
    );
    if let Some(out) = &a.out {
        println!("-> {}", out.display());
    }
    Ok(())
}
