//! `strata histogram`: a scene's depth-complexity histogram, counted on the GPU or by the reference.

use crate::{check_outputs, prepare, PictureArgs};
use clap::Args;
use std::path::PathBuf;
use strata::error::{Error, Result};
use strata::frame::{Effect, RenderOptions};
use strata::gpu::Gpu;
use strata::methods::MethodId;
use strata::render::save_png;
use strata::scene::Scene;

#[derive(Args)]
pub struct HistogramArgs {
    #[arg(default_value = "builtin:demo")]
    pub scene: String,
    /// Image size, WxH (default: the scene's, else 512x512).
    #[arg(long, allow_hyphen_values = true)]
    pub size: Option<crate::Size>,
    /// Write the histogram as a bar chart PNG (log scale).
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Print the histogram as JSON.
    #[arg(long)]
    pub json: bool,
    /// Count with the CPU reference instead of the GPU (the GPU's check).
    #[arg(long)]
    pub cpu: bool,
}

/// One frame with the GPU histogram on (a count pass and a binning pass, read back with the
/// frame's statistics).
pub fn gpu_histogram(scene: &Scene, options: &RenderOptions) -> Result<Vec<u64>> {
    let gpu = Gpu::new()?;
    let mut recorder = strata::FrameRecorder::new(&gpu, scene, MethodId::Unsorted, options)?;
    recorder.set_histogram(true);
    let mut encoder = gpu.device.create_command_encoder(&Default::default());
    recorder.record(&mut encoder, &Default::default(), None)?;
    gpu.queue.submit([encoder.finish()]);
    let stats = recorder.wait_stats()?.stats;
    let clipped = stats.depth_histogram_clipped.unwrap_or(0);
    if clipped > 0 {
        eprintln!(
            "note: {clipped} pixels have {} or more fragments; the last bin counts them together (--cpu counts them exactly)",
            strata::metrics::gpu_histogram::HISTOGRAM_BINS - 1
        );
    }
    stats
        .depth_histogram
        .ok_or_else(|| Error::runtime("the GPU histogram did not arrive"))
}

pub fn histogram(a: HistogramArgs) -> Result<()> {
    let picture = PictureArgs {
        size: a.size,
        effect: Effect::Complexity,
        ..PictureArgs::for_scene(a.scene)
    };
    let (scene, options) = prepare(&picture)?;
    if let Some(out) = &a.out {
        check_outputs([out.as_path()])?;
        strata::output::check_png_name(out)?;
    }
    let hist = if a.cpu {
        let (image, _) = strata::reference::render(&scene, &options)?;
        strata::metrics::depth_complexity_histogram(&image.counts())
    } else {
        gpu_histogram(&scene, &options)?
    };
    if let Some(out) = &a.out {
        save_png(&crate::bench::histogram_chart(&hist), out)?;
    }
    if a.json {
        println!(
            "{}",
            serde_json::to_string(&hist).map_err(|e| Error::runtime(e.to_string()))?
        );
    } else {
        for (count, pixels) in hist.iter().enumerate().filter(|(_, &p)| p > 0) {
            println!("{count:>5} fragments: {pixels} pixels");
        }
    }
    Ok(())
}
