//! `strata compare`: two PNG images side by side in numbers.

use crate::check_outputs;
use clap::Args;
use std::path::PathBuf;
use strata::error::{Error, Result};
use strata::render::save_png;

#[derive(Args)]
pub struct CompareArgs {
    pub a: PathBuf,
    pub b: PathBuf,
    /// Write a heatmap of per-pixel differences.
    #[arg(long)]
    pub diff: Option<PathBuf>,
    /// Print the metrics as JSON.
    #[arg(long)]
    pub json: bool,
}

pub fn compare(a: CompareArgs) -> Result<()> {
    if let Some(d) = &a.diff {
        check_outputs([d.as_path()])?;
        strata::output::check_png_name(d)?;
    }
    let ia = strata::metrics::load_png(&a.a)?;
    let ib = strata::metrics::load_png(&a.b)?;
    let c = strata::metrics::compare(&ia, &ib)?;
    if let Some(d) = &a.diff {
        save_png(&strata::metrics::diff_heatmap(&ia, &ib), d)?;
    }
    if a.json {
        println!(
            "{}",
            serde_json::to_string_pretty(&c).map_err(|e| Error::runtime(e.to_string()))?
        );
    } else {
        println!("RMSE            {:.6}", c.rmse);
        println!(
            "PSNR            {}",
            if c.psnr.is_finite() {
                format!("{:.2} dB", c.psnr)
            } else {
                "inf (identical)".into()
            }
        );
        println!("max abs diff    {}/255", c.max_abs_diff);
        println!("FLIP mean       {:.6}", c.flip_mean);
        println!("pixels > 2/255  {:.4}%", c.pct_over_2);
    }
    Ok(())
}
