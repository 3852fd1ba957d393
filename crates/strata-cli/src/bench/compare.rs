//! `strata bench compare OLD.json NEW.json [--repeat OLD2.json]...`: which figures of an
//! experiment moved between two runs (before and after a change) by more than the run-to-run
//! noise.
//!
//! Any experiment's results file works: each array of objects in it is a table whose rows are
//! matched by their configuration (every text and true/false field, and the numbers that name a
//! configuration: k, step, seed, lights, views, …); every other number in a row (nested ones
//! too, e.g. `error_vs_reference.rmse`) is a figure. The noise of a figure is measured from
//! repeat runs of the old code (`--repeat`, the same experiment run again before the change):
//! the spread of its values across them. A figure moved when the new value lies outside the old
//! runs' range widened by that spread. Timing figures (ms, fps, seconds, rates) never count as
//! moved under `--min-change` (2%), and without repeats their noise is taken as `--threshold`
//! (10%) of the old value, as stated in the output. Counters, memory and image error have no
//! noise on a deterministic method: any change is reported.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use serde::Serialize;
use serde_json::Value;
use strata::error::{Error, Result};

use crate::bench::median;

/// Numbers that name a row's configuration rather than measure it.
const CONFIGURATION: &[&str] = &[
    "k",
    "msaa",
    "step",
    "seed",
    "lights",
    "views",
    "refresh",
    "budget_mb",
    "triangles",
    "frames",
    "layers",
    "width",
    "height",
];

/// A row's figures by path, under its table and configuration.
type Figures = BTreeMap<(String, String), BTreeMap<String, f64>>;

/// Whether a figure is a time or a rate, so noisy even on a deterministic method.
fn is_timing(path: &str) -> bool {
    let leaf = path.rsplit('.').next().unwrap_or(path);
    path.contains("_ms")
        || leaf.ends_with("ms")
        || leaf == "fps"
        || leaf.contains("seconds")
        || leaf.contains("per_s")
        || leaf.contains("_over_")
        || path.contains("gpu_ms_per_pass")
}

/// Every table row of `report`, keyed by (table, configuration), with its numeric figures.
fn figures(report: &Value) -> Figures {
    let mut out = Figures::new();
    let Value::Object(top) = report else {
        return out;
    };
    for (table, rows) in top {
        let Value::Array(rows) = rows else { continue };
        for row in rows {
            let Value::Object(fields) = row else { continue };
            let mut id = Vec::new();
            let mut numbers = BTreeMap::new();
            for (name, v) in fields {
                match v {
                    Value::String(s) => id.push(format!("{name}={s}")),
                    Value::Bool(b) => id.push(format!("{name}={b}")),
                    Value::Number(n) if CONFIGURATION.contains(&name.as_str()) => {
                        id.push(format!("{name}={n}"))
                    }
                    _ => leaves(name, v, &mut numbers),
                }
            }
            out.insert((table.clone(), id.join(" ")), numbers);
        }
    }
    out
}

fn leaves(path: &str, v: &Value, out: &mut BTreeMap<String, f64>) {
    match v {
        Value::Number(n) => {
            if let Some(x) = n.as_f64().filter(|x| x.is_finite()) {
                out.insert(path.to_string(), x);
            }
        }
        Value::Object(m) => {
            for (k, x) in m {
                leaves(&format!("{path}.{k}"), x, out);
            }
        }
        _ => {}
    }
}

/// One figure that moved beyond the noise.
#[derive(Debug, Serialize, PartialEq)]
pub struct Moved {
    pub table: String,
    pub row: String,
    pub figure: String,
    /// The old runs' median.
    pub old: f64,
    pub new: f64,
    /// (new − old) / |old|, in percent; null when old is 0.
    pub change_pct: Option<f64>,
    /// How far from the old runs' range a value may lie and still be noise.
    pub noise: f64,
    /// Whether the noise was measured from repeats (else assumed: --threshold, or 0 for
    /// counters).
    pub noise_measured: bool,
}

#[derive(Debug, Serialize)]
pub struct Comparison {
    pub experiment: Option<String>,
    pub figures_compared: usize,
    pub moved: Vec<Moved>,
    /// Rows found on one side only ("table: configuration").
    pub only_old: Vec<String>,
    pub only_new: Vec<String>,
    pub repeats: usize,
}

pub struct Settings {
    /// Percent: the timing noise assumed without repeats.
    pub threshold_pct: f64,
    /// Percent: timing figures closer than this never count as moved.
    pub min_change_pct: f64,
}

/// Compares `new` with `old` and its repeats.
pub fn compare(old: &[Value], new: &Value, settings: &Settings) -> Result<Comparison> {
    let experiment = |v: &Value| {
        v.get("experiment")
            .and_then(Value::as_str)
            .map(String::from)
    };
    let name = experiment(new);
    for o in old {
        if experiment(o) != name {
            return Err(Error::input(format!(
                "these are results of different experiments ({} and {})",
                experiment(o).as_deref().unwrap_or("unnamed"),
                name.as_deref().unwrap_or("unnamed")
            )));
        }
    }
    let runs: Vec<Figures> = old.iter().map(figures).collect();
    let new_figures = figures(new);
    let mut result = Comparison {
        experiment: name,
        figures_compared: 0,
        moved: Vec::new(),
        only_old: Vec::new(),
        only_new: Vec::new(),
        repeats: old.len() - 1,
    };
    // What every row of a table shares (one scene, one frame count) says nothing about a row.
    let mut shared: BTreeMap<&str, Vec<&str>> = BTreeMap::new();
    for (table, row) in runs[0].keys().chain(new_figures.keys()) {
        let tokens: Vec<&str> = row.split(' ').collect();
        shared
            .entry(table)
            .and_modify(|s| s.retain(|t| tokens.contains(t)))
            .or_insert(tokens);
    }
    let row_name = |(table, row): &(String, String)| {
        let own: Vec<&str> = row
            .split(' ')
            .filter(|t| !shared[table.as_str()].contains(t))
            .collect();
        if own.is_empty() {
            row.clone()
        } else {
            own.join(" ")
        }
    };
    let describe = |key: &(String, String)| format!("{}: {}", key.0, row_name(key));
    for key in runs[0].keys() {
        if !new_figures.contains_key(key) {
            result.only_old.push(describe(key));
        }
    }
    for (key, now) in &new_figures {
        let Some(first) = runs[0].get(key) else {
            result.only_new.push(describe(key));
            continue;
        };
        for (figure, &new_value) in now {
            if !first.contains_key(figure) {
                continue;
            }
            let values: Vec<f64> = runs
                .iter()
                .filter_map(|r| r.get(key)?.get(figure).copied())
                .collect();
            result.figures_compared += 1;
            let (lo, hi) = values
                .iter()
                .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &v| {
                    (a.min(v), b.max(v))
                });
            let centre = median(values.clone());
            let timing = is_timing(figure);
            let measured = values.len() > 1;
            let noise = if measured {
                hi - lo
            } else if timing {
                centre.abs() * settings.threshold_pct / 100.0
            } else {
                0.0
            };
            let outside = new_value < lo - noise || new_value > hi + noise;
            let change_pct = (centre != 0.0).then(|| (new_value - centre) / centre.abs() * 100.0);
            let small = timing && change_pct.is_some_and(|c| c.abs() < settings.min_change_pct);
            if outside && !small {
                result.moved.push(Moved {
                    table: key.0.clone(),
                    row: row_name(key),
                    figure: figure.clone(),
                    old: centre,
                    new: new_value,
                    change_pct,
                    noise,
                    noise_measured: measured,
                });
            }
        }
    }
    Ok(result)
}

fn load(path: &Path) -> Result<Value> {
    let bytes = std::fs::read(path)
        .map_err(|e| Error::input(format!("cannot read '{}': {e}", path.display())))?;
    let v: Value = serde_json::from_slice(&bytes).map_err(|e| {
        Error::input(format!(
            "'{}' is not a results file (JSON: {e})",
            path.display()
        ))
    })?;
    if !v.is_object() {
        return Err(Error::input(format!(
            "'{}' is not a results file (no JSON object)",
            path.display()
        )));
    }
    Ok(v)
}

/// The command: `old` then its repeats, `new`.
pub fn run(
    old: &Path,
    repeats: &[PathBuf],
    new: &Path,
    settings: &Settings,
    json: bool,
) -> Result<()> {
    let mut olds = vec![load(old)?];
    for r in repeats {
        olds.push(load(r)?);
    }
    let new_value = load(new)?;
    let adapter = |v: &Value| v.get("adapter").and_then(Value::as_str).map(String::from);
    if olds.iter().any(|o| adapter(o) != adapter(&new_value)) {
        eprintln!(
            "note: the runs come from different adapters ({} and {}): differences include the device",
            adapter(&olds[0]).as_deref().unwrap_or("unknown"),
            adapter(&new_value).as_deref().unwrap_or("unknown")
        );
    }
    let c = compare(&olds, &new_value, settings)?;
    if json {
        println!(
            "{}",
            serde_json::to_string_pretty(&c).map_err(|e| Error::runtime(e.to_string()))?
        );
        return Ok(());
    }
    let noise = if c.repeats > 0 {
        format!("noise measured over {} old runs", c.repeats + 1)
    } else {
        format!(
            "no repeats: timing noise assumed {}%, counters and errors exact (give --repeat OLD2.json to measure it)",
            settings.threshold_pct
        )
    };
    println!(
        "{}: {} figures compared, {} moved beyond the noise ({noise})",
        c.experiment.as_deref().unwrap_or("results"),
        c.figures_compared,
        c.moved.len()
    );
    for m in &c.moved {
        let change = m
            .change_pct
            .map(|p| format!("{p:+.1}%"))
            .unwrap_or_else(|| "from 0".into());
        println!(
            "  {} [{}] {}: {} -> {} ({change}; noise ±{}{})",
            m.table,
            m.row,
            m.figure,
            short(m.old),
            short(m.new),
            short(m.noise),
            if m.noise_measured { "" } else { " assumed" }
        );
    }
    for (side, rows) in [("old", &c.only_old), ("new", &c.only_new)] {
        if !rows.is_empty() {
            println!(
                "  {} rows only in the {side} run: {}",
                rows.len(),
                rows.join("; ")
            );
        }
    }
    Ok(())
}

fn short(v: f64) -> String {
    if v == v.trunc() && v.abs() < 1e12 {
        format!("{v:.0}")
    } else {
        format!("{v:.4}")
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde_json::json;

    fn settings() -> Settings {
        Settings {
            threshold_pct: 10.0,
            min_change_pct: 2.0,
        }
    }

    fn report(ms: f64, fragments: u64, rmse: f64) -> Value {
        json!({
            "experiment": "e",
            "adapter": "a",
            "width": 64,
            "results": [
                {"method": "f2b", "k": null, "median_gpu_ms": 5.0, "fragments": 10,
                 "error_vs_reference": {"rmse": 0.0}},
                {"method": "kb", "k": 8, "median_gpu_ms": ms, "fragments": fragments,
                 "error_vs_reference": {"rmse": rmse}},
            ]
        })
    }

    fn moved(c: &Comparison) -> Vec<(&str, &str)> {
        c.moved
            .iter()
            .map(|m| (m.row.as_str(), m.figure.as_str()))
            .collect()
    }

    #[test]
    fn a_run_compared_with_itself_moves_nothing() {
        let r = report(8.0, 100, 0.01);
        let c = compare(std::slice::from_ref(&r), &r, &settings()).unwrap();
        assert_eq!(c.figures_compared, 6);
        assert!(c.moved.is_empty());
        assert!(c.only_old.is_empty() && c.only_new.is_empty());
    }

    #[test]
    fn counters_and_errors_move_on_any_change_times_beyond_the_noise() {
        let old = report(8.0, 100, 0.01);
        // 5% slower: within the assumed 10% without repeats; one fragment more is a change.
        let c = compare(
            std::slice::from_ref(&old),
            &report(8.4, 101, 0.01),
            &settings(),
        )
        .unwrap();
        assert_eq!(moved(&c), [("k=8 method=kb", "fragments")]);
        // Repeats measure the timing noise: 8.0 and 8.1 → anything past [7.9, 8.2] moved.
        let olds = [old.clone(), report(8.1, 100, 0.01)];
        let c = compare(&olds, &report(8.15, 100, 0.01), &settings()).unwrap();
        assert!(c.moved.is_empty());
        let c = compare(&olds, &report(8.4, 100, 0.02), &settings()).unwrap();
        assert_eq!(
            moved(&c),
            [
                ("k=8 method=kb", "error_vs_reference.rmse"),
                ("k=8 method=kb", "median_gpu_ms")
            ]
        );
        assert!((c.moved[1].change_pct.unwrap() - 4.347).abs() < 0.01);
        assert!(c.moved[1].noise_measured);
        // Repeats that agree exactly do not make a 1% timing change a move.
        let same = [old.clone(), old.clone()];
        assert!(compare(&same, &report(8.08, 100, 0.01), &settings())
            .unwrap()
            .moved
            .is_empty());
    }

    #[test]
    fn rows_are_matched_by_configuration_and_experiments_must_agree() {
        let old = report(8.0, 100, 0.01);
        let mut new = report(8.0, 100, 0.01);
        new["results"][1]["k"] = json!(16);
        let c = compare(std::slice::from_ref(&old), &new, &settings()).unwrap();
        assert!(c.moved.is_empty());
        assert_eq!(c.only_old, ["results: k=8 method=kb"]);
        assert_eq!(c.only_new, ["results: k=16 method=kb"]);
        let mut other = old.clone();
        other["experiment"] = json!("f");
        assert!(compare(&[old], &other, &settings()).is_err());
    }
}
