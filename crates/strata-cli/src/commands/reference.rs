//! `strata reference`: the exact CPU picture.

use crate::commands::render::finish_picture;
use crate::{check_outputs, prepare, spinner, PictureArgs};
use clap::Args;
use std::path::PathBuf;
use strata::error::Result;

#[derive(Args)]
pub struct ReferenceArgs {
    #[command(flatten)]
    pub picture: PictureArgs,
    #[arg(short, long, default_value = "reference.png")]
    pub output: PathBuf,
    #[arg(long)]
    pub stats: Option<PathBuf>,
}

pub fn reference(a: ReferenceArgs) -> Result<()> {
    let (scene, options) = prepare(&a.picture)?;
    check_outputs(std::iter::once(a.output.as_path()).chain(a.stats.as_deref()))?;
    strata::output::check_png_name(&a.output)?;
    let busy = spinner(format!(
        "rendering {}x{} with the CPU reference",
        options.frame.width, options.frame.height
    ));
    let rendered = strata::reference::render(&scene, &options);
    busy.finish_and_clear();
    let (image, stats) = rendered?;
    finish_picture(&image, &stats, &options, &a.output, a.stats.as_deref())
}
