//! Output files and result folders: checked before the work, written whole.

use std::path::Path;
use strata::error::{Error, Result};
use strata::frame::{Effect, FrameStats};
use strata::output::Outputs;
use strata::render::LinearImage;

pub fn write_outputs(
    image: &LinearImage,
    stats: &FrameStats,
    effect: Effect,
    output: &Path,
    stats_path: Option<&Path>,
) -> Result<()> {
    let mut outputs = Outputs::new();
    outputs.add_png(output, &image.to_rgba8(effect))?;
    if let Some(path) = stats_path {
        outputs.add_json(path, stats)?;
    }
    outputs.commit()
}

/// Checks before rendering (after the options, so their errors come first) that the command's
/// output paths can be written (see
/// [`strata::output::check_target`]) and are distinct.
pub fn check_outputs<'a>(paths: impl IntoIterator<Item = &'a Path>) -> Result<()> {
    let mut outputs = Outputs::new();
    for path in paths {
        outputs.add(path, Vec::new())?;
    }
    Ok(())
}

/// Refuses, before any work, a results directory that could not be made (a file in its place
/// or its parent's); it is made when the first results are written, so a run that fails
/// before then leaves nothing behind.
pub fn check_results_dir(dir: &Path) -> Result<()> {
    for ancestor in dir.ancestors().filter(|a| !a.as_os_str().is_empty()) {
        if ancestor.is_dir() {
            return Ok(());
        }
        if ancestor.exists() {
            return Err(Error::input(format!(
                "cannot create '{}': '{}' is not a directory",
                dir.display(),
                ancestor.display()
            )));
        }
    }
    Ok(())
}

/// Writes an experiment's results as `DIR/NAME.json` and `DIR/NAME.csv` and says where.
pub fn write_results(
    dir: &Path,
    name: &str,
    report: &impl serde::Serialize,
    csv: String,
) -> Result<()> {
    write_results_quietly(dir, name, report, csv)?;
    eprintln!("wrote {}.json and .csv", dir.join(name).display());
    Ok(())
}

/// Writes what a run has measured so far, quietly (its progress bar is running); a failure is
/// a warning, not the end of the run.
pub fn write_results_so_far(dir: &Path, name: &str, report: &impl serde::Serialize, csv: String) {
    if let Err(e) = write_results_quietly(dir, name, report, csv) {
        eprintln!("warning: {name}: the results so far were not written: {e}");
    }
}

/// [`write_results`] without the line that says so.
pub fn write_results_quietly(
    dir: &Path,
    name: &str,
    report: &impl serde::Serialize,
    csv: String,
) -> Result<()> {
    std::fs::create_dir_all(dir)
        .map_err(|e| Error::input(format!("cannot create '{}': {e}", dir.display())))?;
    let path = dir.join(name);
    let mut outputs = Outputs::new();
    outputs.add_json(&path.with_extension("json"), report)?;
    outputs.add(&path.with_extension("csv"), csv.into_bytes())?;
    outputs.commit()
}
