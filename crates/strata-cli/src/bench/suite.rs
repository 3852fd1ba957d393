//! `strata bench all`: every named experiment in turn at the sizes chosen for the device (the
//! papers' on a GPU, smaller on lavapipe; each result file records its own), under one progress
//! bar with an estimate of the time left. The estimate comes from the durations the last suite
//! on this device recorded (`suite.json` beside the results), scaled by how this run compares
//! so far; experiments without a record are estimated by the mean of those done. An experiment
//! that fails is reported and the suite goes on; the command fails at the end if any did.

use std::sync::Mutex;
use std::time::Instant;

use indicatif::{MultiProgress, ProgressBar, ProgressStyle};
use serde::{Deserialize, Serialize};
use strata::error::{Error, Result};
use strata::gpu::Gpu;

use crate::bench::{self, BenchArgs};

/// The suite's bars while `bench all` runs: experiments' own bars are drawn under its bar.
static PROGRESS: Mutex<Option<MultiProgress>> = Mutex::new(None);

/// `bar`, drawn under the suite's bar when a suite is running.
pub fn attach(bar: ProgressBar) -> ProgressBar {
    match &*PROGRESS.lock().unwrap_or_else(|e| e.into_inner()) {
        Some(multi) => multi.add(bar),
        None => bar,
    }
}

/// What `suite.json` records of one experiment's last run on the device.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct Entry {
    pub name: String,
    pub seconds: f64,
    /// Why it failed; `None` when it completed.
    pub error: Option<String>,
    pub commit: Option<String>,
    pub unix_time: u64,
    /// `--size` and `--frames` given to the suite (`None`: each experiment's own settings);
    /// only runs with the same settings inform the estimate.
    #[serde(default)]
    pub overrides: Option<String>,
}

#[derive(Debug, Default, Serialize, Deserialize)]
pub struct SuiteRecord {
    pub adapter: String,
    pub cpu_figures: bool,
    /// Each experiment's latest run, in suite order.
    pub experiments: Vec<Entry>,
}

const RECORD: &str = "suite.json";

/// The experiments `--only` and `--skip` leave, in suite order.
fn selection(a: &BenchArgs) -> Result<Vec<&'static str>> {
    let names = bench::experiment_names();
    let list = |flag: &str, v: &Option<String>| -> Result<Vec<String>> {
        let Some(v) = v else { return Ok(Vec::new()) };
        let picked: Vec<String> = v
            .split(',')
            .map(str::trim)
            .filter(|n| !n.is_empty())
            .map(String::from)
            .collect();
        if let Some(bad) = picked.iter().find(|n| !names.contains(&n.as_str())) {
            return Err(Error::input(format!(
                "--{flag}: unknown experiment '{bad}' (available: {})",
                names.join(", ")
            )));
        }
        Ok(picked)
    };
    let (only, skip) = (list("only", &a.only)?, list("skip", &a.skip)?);
    let chosen: Vec<_> = names
        .into_iter()
        .filter(|n| only.is_empty() || only.iter().any(|o| o == n))
        .filter(|n| !skip.iter().any(|s| s == n))
        .collect();
    if chosen.is_empty() {
        return Err(Error::input("--only and --skip leave no experiment to run"));
    }
    Ok(chosen)
}

/// Seconds the experiments in `left` should take: their last recorded durations scaled by this
/// run's pace on the ones done that have a record; without a record, the mean of those done.
/// `None` until something can be said.
pub fn estimate_left(
    previous: &SuiteRecord,
    overrides: &Option<String>,
    done: &[Entry],
    left: &[&str],
) -> Option<f64> {
    let last = |name: &str| {
        previous
            .experiments
            .iter()
            .find(|e| e.name == name && e.error.is_none() && e.overrides == *overrides)
            .map(|e| e.seconds)
    };
    let (mut now, mut then) = (0.0, 0.0);
    for d in done.iter().filter(|d| d.error.is_none()) {
        if let Some(s) = last(&d.name) {
            now += d.seconds;
            then += s;
        }
    }
    let pace = if then > 0.0 { now / then } else { 1.0 };
    let finished: Vec<f64> = done.iter().map(|d| d.seconds).collect();
    let mean = (!finished.is_empty()).then(|| finished.iter().sum::<f64>() / finished.len() as f64);
    left.iter()
        .map(|n| last(n).map(|s| s * pace).or(mean))
        .sum()
}

fn human(seconds: f64) -> String {
    if seconds < 90.0 {
        format!("{seconds:.0} s")
    } else if seconds < 5400.0 {
        format!("{:.0} min", seconds / 60.0)
    } else {
        format!("{:.1} h", seconds / 3600.0)
    }
}

pub fn run(gpu: &Gpu, a: &BenchArgs) -> Result<()> {
    if a.has_single_run_options() {
        return Err(Error::input(
            "bench all runs the named experiments at their own settings: --scene, --methods, --k and --alpha apply to single runs",
        ));
    }
    let names = selection(a)?;
    let dir = bench::results_dir(gpu, a);
    std::fs::create_dir_all(&dir)
        .map_err(|e| Error::input(format!("cannot create '{}': {e}", dir.display())))?;
    let record_path = dir.join(RECORD);
    let previous: SuiteRecord = std::fs::read(&record_path)
        .ok()
        .and_then(|b| serde_json::from_slice(&b).ok())
        .unwrap_or_default();
    let cpu_figures = gpu.info.device_type == wgpu::DeviceType::Cpu;
    eprintln!(
        "bench all: {} experiments on {}{} into {}",
        names.len(),
        gpu.info.name,
        bench::cpu_label(cpu_figures),
        dir.display()
    );

    let multi = MultiProgress::new();
    let suite_bar = multi.add(
        ProgressBar::new(names.len() as u64).with_style(
            ProgressStyle::with_template(
                "suite {bar:30} {pos}/{len} experiments, {elapsed} elapsed  {msg}",
            )
            .expect("valid template"),
        ),
    );
    suite_bar.enable_steady_tick(std::time::Duration::from_secs(1));
    *PROGRESS.lock().unwrap_or_else(|e| e.into_inner()) = Some(multi.clone());

    let overrides = match (&a.size, a.frames) {
        (None, None) => None,
        (size, frames) => Some(
            [
                size.as_ref().map(|s| format!("--size {s}")),
                frames.map(|f| format!("--frames {f}")),
            ]
            .into_iter()
            .flatten()
            .collect::<Vec<_>>()
            .join(" "),
        ),
    };
    let mut done: Vec<Entry> = Vec::new();
    for (i, name) in names.iter().enumerate() {
        let left = match estimate_left(&previous, &overrides, &done, &names[i..]) {
            Some(s) => format!("~{} left", human(s)),
            None => "time left known after the first experiment".into(),
        };
        suite_bar.set_message(format!("now {name}; {left}"));
        let start = Instant::now();
        let outcome = bench::run_experiment(gpu, a, Some(name));
        let seconds = start.elapsed().as_secs_f64();
        let error = outcome.err().map(|e| e.to_string());
        let _ = multi.println(match &error {
            None => format!("{name}: done in {}", human(seconds)),
            Some(e) => format!("{name}: FAILED after {}: {e}", human(seconds)),
        });
        done.push(Entry {
            name: name.to_string(),
            seconds,
            error,
            commit: bench::commit(),
            unix_time: bench::unix_time(),
            overrides: overrides.clone(),
        });
        suite_bar.inc(1);
    }
    suite_bar.finish_and_clear();
    *PROGRESS.lock().unwrap_or_else(|e| e.into_inner()) = None;

    // The record keeps every experiment's latest run, those left out this time too.
    let mut record = SuiteRecord {
        adapter: gpu.info.name.clone(),
        cpu_figures,
        experiments: Vec::new(),
    };
    for name in bench::experiment_names() {
        let latest = done
            .iter()
            .chain(&previous.experiments)
            .find(|e| e.name == name);
        record.experiments.extend(latest.cloned());
    }
    let mut outputs = strata::output::Outputs::new();
    outputs.add_json(&record_path, &record)?;
    outputs.commit()?;

    let total: f64 = done.iter().map(|d| d.seconds).sum();
    let failed: Vec<&str> = done
        .iter()
        .filter(|d| d.error.is_some())
        .map(|d| d.name.as_str())
        .collect();
    eprintln!(
        "bench all: {} of {} experiments done in {}; durations in {}",
        done.len() - failed.len(),
        done.len(),
        human(total),
        record_path.display()
    );
    if failed.is_empty() {
        Ok(())
    } else {
        Err(Error::runtime(format!(
            "{} of {} experiments failed: {}",
            failed.len(),
            done.len(),
            failed.join(", ")
        )))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn entry(name: &str, seconds: f64) -> Entry {
        Entry {
            name: name.into(),
            seconds,
            error: None,
            commit: None,
            unix_time: 0,
            overrides: None,
        }
    }

    #[test]
    fn the_time_left_follows_the_last_suite_at_this_runs_pace() {
        let previous = SuiteRecord {
            experiments: vec![entry("a", 10.0), entry("b", 20.0), entry("c", 40.0)],
            ..Default::default()
        };
        // Nothing done: the last run's durations.
        assert_eq!(
            estimate_left(&previous, &None, &[], &["a", "b", "c"]),
            Some(70.0)
        );
        // `a` took twice as long as last time: so will the rest.
        assert_eq!(
            estimate_left(&previous, &None, &[entry("a", 20.0)], &["b", "c"]),
            Some(120.0)
        );
        // No record: unknown until one is done, then the mean of those done.
        let none = SuiteRecord::default();
        assert_eq!(estimate_left(&none, &None, &[], &["a"]), None);
        assert_eq!(
            estimate_left(
                &none,
                &None,
                &[entry("a", 6.0), entry("b", 2.0)],
                &["c", "d"]
            ),
            Some(8.0)
        );
        // A failed run tells nothing of the pace.
        let mut failed = entry("a", 1.0);
        failed.error = Some("lost".into());
        assert_eq!(
            estimate_left(&previous, &None, &[failed], &["b"]),
            Some(20.0)
        );
        // Runs at other sizes do not count.
        let small = Some("--size 32x32".to_string());
        assert_eq!(estimate_left(&previous, &small, &[], &["a"]), None);
    }
}
