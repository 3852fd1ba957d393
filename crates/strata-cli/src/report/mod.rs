//! `strata report`: refreshes the generated parts of `bench/REPORT.md` from the results in
//! `bench/results/<device>/*.json`, leaving every hand-written line as it is.
//!
//! Each experiment with results gets one generated block, between
//! `<!-- strata report: NAME -->` and `<!-- end strata report: NAME -->`: a chart (SVG, drawn
//! with plotters, in `bench/charts/`) and, folded, the table of every configuration's time with
//! the devices side by side. A block already in the file is replaced where it stands; a new one
//! goes at the end of the experiment's section (the `## NAME` heading), or in a new section at
//! the end. Everything outside the markers is prose and survives regeneration.
//!
//! Charts take the papers' shapes where a results file has a sweep: time over k (seed 003
//! Fig. 6), over the light count (seed 004 Fig. 13), over the triangle count, one line per
//! method (or pipeline) and device; otherwise a bar per configuration, devices side by side.
//! Times are on a log axis: methods differ by orders of magnitude.

mod charts;

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use charts::{chart, register_chart_font, Kind};
use clap::Args;
use serde_json::Value;
use strata::error::{Error, Result};

#[derive(Args)]
pub struct ReportArgs {
    /// The results folder: one subfolder per device.
    #[arg(long, default_value = "bench/results")]
    results: PathBuf,
    /// The report to refresh (made if missing).
    #[arg(long, default_value = "bench/REPORT.md")]
    out: PathBuf,
    /// Where the charts go (default: `charts/` beside the report).
    #[arg(long)]
    charts: Option<PathBuf>,
}

/// The figure a chart and table show, the first a row has: GPU time, else wall time.
const TIME_FIELDS: &[&str] = &["median_gpu_ms", "gpu_ms", "median_wall_ms"];
/// Experiments compared on wall-clock time for every row: some renderers have no GPU timer
/// (peers), and lavapipe's timestamps miss `tiled`'s rounds.
const WALL_CLOCK_EXPERIMENTS: &[&str] = &["peers", "tiled"];

/// What `experiment`'s chart and table show: the row fields it is read from, in order of
/// preference, and what the figure is.
fn figure(experiment: &str) -> (&'static [&'static str], &'static str) {
    if WALL_CLOCK_EXPERIMENTS.contains(&experiment) {
        (&["median_wall_ms"], "wall-clock ms per frame")
    } else if experiment == "memory-density" {
        (&["gpu_ms_per_mib"], "GPU ms per MiB allocated")
    } else if experiment == "bandwidth" {
        (
            &["measured_over_floor"],
            "measured GPU time / memory-traffic floor",
        )
    } else {
        (TIME_FIELDS, "ms per frame")
    }
}

/// The fields `experiment`'s rows are charted by, in order of preference.
fn time_fields(experiment: &str) -> &'static [&'static str] {
    figure(experiment).0
}
/// The experiments whose figure is a sweep: the field it runs over and the axis's name.
const SWEEPS: &[(&str, &str, &str)] = &[
    ("kbuffer-k", "k", "k (seed 003 Fig. 6)"),
    ("kbuffer-culling", "k", "k (seed 003 Fig. 7)"),
    ("kbuffer-layout", "k", "k"),
    ("deferred-lights", "lights", "lights (seed 004 Fig. 13)"),
    ("scale", "triangles", "triangles"),
    (
        "peel-vs-abuffer",
        "scene:n",
        "fragments per pixel (seed 003 Fig. 9 right)",
    ),
    (
        "memory-density",
        "scene:n*coverage",
        "fragments per pixel over the screen (seed 003 Fig. 8)",
    ),
    (
        "convex",
        "scene:layers",
        "layers of the stacked spheres (seed 001 Table 3)",
    ),
];

/// A row's value of a sweep field: a number of the row, or with `scene:NAME` the parameter
/// NAME of its scene (`builtin:layers?n=64` gives 64 for `scene:n`), with `scene:A*B` the
/// product of two.
fn sweep_value(row: &Value, field: &str) -> Option<f64> {
    let Some(params) = field.strip_prefix("scene:") else {
        return row.get(field)?.as_f64();
    };
    let scene = text(row, "scene")?;
    let query = scene.split_once('?')?.1;
    // `scene:a*b`: the product of the scene's parameters a and b.
    params.split('*').try_fold(1.0, |product, param| {
        let value: f64 = query
            .split('&')
            .find_map(|p| p.strip_prefix(param)?.strip_prefix('=')?.parse().ok())?;
        Some(product * value)
    })
}
/// Fields naming a line of a sweep.
const SERIES_FIELDS: &[&str] = &["method", "pipeline", "config"];

/// One device's results of one experiment.
struct DeviceResults {
    device: String,
    cpu_figures: bool,
    rows: Vec<Value>,
    /// `bandwidth`: the device's measured rates (its results' `device` object).
    rates: Option<Value>,
}

/// A measured row: its name, sweep value and series where it has them, and its time.
struct Point {
    name: String,
    series: String,
    x: Option<f64>,
    ms: f64,
    /// Error against the reference: RMSE, FLIP mean, % of pixels over 2/255.
    error: Option<[f64; 3]>,
}

fn rows_of(report: &Value) -> Vec<Value> {
    for table in ["results", "rows"] {
        if let Some(Value::Array(rows)) = report.get(table) {
            return rows.clone();
        }
    }
    Vec::new()
}

fn text(row: &Value, field: &str) -> Option<String> {
    match row.get(field)? {
        Value::String(s) => Some(s.clone()),
        Value::Number(n) => Some(n.to_string()),
        _ => None,
    }
}

fn short_scene(scene: &str) -> &str {
    scene
        .split('?')
        .next()
        .unwrap_or(scene)
        .trim_start_matches("builtin:")
}

/// What tells `scenes` apart: each one's name, with the parameters whose values differ between
/// scenes of the same name (`layers n=16 coverage=0.25`); empty names for a single scene.
fn scene_names(scenes: &std::collections::BTreeSet<String>) -> BTreeMap<String, String> {
    let params = |s: &str| -> Vec<(String, String)> {
        s.split_once('?')
            .map(|(_, q)| q)
            .unwrap_or("")
            .split('&')
            .filter(|p| !p.is_empty())
            .map(|p| {
                let (k, v) = p.split_once('=').unwrap_or((p, ""));
                (k.to_string(), v.to_string())
            })
            .collect()
    };
    scenes
        .iter()
        .map(|scene| {
            if scenes.len() < 2 {
                return (scene.clone(), String::new());
            }
            let name = short_scene(scene);
            let siblings: Vec<&String> = scenes.iter().filter(|s| short_scene(s) == name).collect();
            let differing: Vec<String> = params(scene)
                .into_iter()
                .filter(|(k, v)| {
                    siblings
                        .iter()
                        .any(|s| params(s).iter().all(|(k2, v2)| k2 != k || v2 != v))
                })
                .map(|(k, v)| format!("{k}={v}"))
                .collect();
            let shown = if differing.is_empty() {
                name.to_string()
            } else {
                format!("{name} {}", differing.join(" "))
            };
            (scene.clone(), shown)
        })
        .collect()
}

/// A row's name: its label (or its configuration), after its scene's name in `scenes`.
fn row_name(row: &Value, scenes: &BTreeMap<String, String>) -> String {
    let name = text(row, "label")
        .or_else(|| {
            let mut parts: Vec<String> = ["sequence", "method", "pipeline", "config", "order"]
                .iter()
                .filter_map(|f| text(row, f))
                .collect();
            for f in ["k", "lights", "budget_mb", "refresh", "step", "seed"] {
                if let Some(v) = text(row, f) {
                    parts.push(format!("{f}={v}"));
                }
            }
            (!parts.is_empty()).then(|| parts.join(" "))
        })
        .unwrap_or_else(|| "run".into());
    match text(row, "scene").and_then(|s| scenes.get(&s)) {
        Some(scene) if !scene.is_empty() => format!("{scene} · {name}"),
        _ => name,
    }
}

/// `experiment`'s sweep (field, axis) when its rows run over at least three of its values.
fn sweep_of(experiment: &str, rows: &[Value]) -> Option<(&'static str, &'static str)> {
    let &(_, field, axis) = SWEEPS.iter().find(|s| s.0 == experiment)?;
    let mut values: Vec<f64> = rows.iter().filter_map(|r| sweep_value(r, field)).collect();
    values.sort_by(f64::total_cmp);
    values.dedup();
    (values.len() >= 3).then_some((field, axis))
}

fn points(rows: &[Value], sweep: Option<&str>, fields: &[&str]) -> Vec<Point> {
    let scenes: std::collections::BTreeSet<String> =
        rows.iter().filter_map(|r| text(r, "scene")).collect();
    let scene_names = scene_names(&scenes);
    let base_series = |row: &Value| {
        let mut series = SERIES_FIELDS
            .iter()
            .find_map(|f| text(row, f))
            .unwrap_or_default();
        if row.get("culling") == Some(&Value::Bool(false)) {
            series += " no-culling";
        }
        if let Some(layout) = text(row, "storage_layout").filter(|l| l != "pixel") {
            series += &format!(" {layout}-major");
        }
        series
    };
    // A series run at several k for one sweep value (kpeel k=8 and k=32 over depth) splits
    // into a line per k; one whose k follows the axis (k = the layer count) stays one line.
    let mut ks: BTreeMap<(String, String), std::collections::BTreeSet<String>> = BTreeMap::new();
    if let Some(field) = sweep.filter(|f| *f != "k") {
        for row in rows {
            if let (Some(x), Some(k)) = (sweep_value(row, field), text(row, "k")) {
                ks.entry((base_series(row), x.to_string()))
                    .or_default()
                    .insert(k);
            }
        }
    }
    let split: std::collections::BTreeSet<String> = ks
        .into_iter()
        .filter(|(_, k)| k.len() > 1)
        .map(|((series, _), _)| series)
        .collect();
    let mut seen: BTreeMap<String, usize> = BTreeMap::new();
    rows.iter()
        .filter_map(|row| {
            let ms = fields
                .iter()
                .find_map(|f| row.get(*f)?.as_f64())
                .filter(|v| v.is_finite() && *v > 0.0)?;
            let mut series = base_series(row);
            if split.contains(&series) {
                if let Some(k) = text(row, "k") {
                    series += &format!(" k={k}");
                }
            }
            // Rows the fields above cannot tell apart are numbered, never merged.
            let mut name = row_name(row, &scene_names);
            let count = seen.entry(name.clone()).or_insert(0);
            *count += 1;
            if *count > 1 {
                name = format!("{name} #{count}");
            }
            Some(Point {
                name,
                series,
                x: sweep.and_then(|f| sweep_value(row, f)),
                ms,
                error: row.get("error_vs_reference").and_then(|e| {
                    Some(["rmse", "flip_mean", "pct_over_2"].map(|f| e.get(f)?.as_f64()))
                        .and_then(|[a, b, c]| Some([a?, b?, c?]))
                }),
            })
        })
        .collect()
}

/// A Markdown table's header: the configuration, then one column per device.
fn table_head(data: &[(&DeviceResults, Vec<Point>)]) -> String {
    let mut s = String::from("| configuration |");
    for (d, _) in data {
        s += &format!(" {} |", d.device);
    }
    s += "\n|---|";
    s += &"---|".repeat(data.len());
    s + "\n"
}

/// The generated block of one experiment: its chart and tables.
fn block(
    name: &str,
    (chart, error_chart): (&str, Option<&str>),
    data: &[(&DeviceResults, Vec<Point>)],
) -> String {
    let what = figure(name).1;
    let mut s = format!("<!-- strata report: {name} -->\n");
    s += &format!(
        "*Generated by `strata report` from `bench/results/*/{name}.json`; edits between these markers are replaced.*\n\n"
    );
    s += &format!("![{name}]({chart})\n\n");
    if let Some(errors) = error_chart {
        s += &format!("![{name}: error against time]({errors})\n\n");
    }
    let cpu: Vec<&str> = data
        .iter()
        .filter(|(d, _)| d.cpu_figures)
        .map(|(d, _)| d.device.as_str())
        .collect();
    if !cpu.is_empty() {
        s += &format!(
            "Figures from {} are CPU figures (a software rasterizer), not GPU performance.\n\n",
            cpu.join(", ")
        );
    }
    let mut names: Vec<String> = Vec::new();
    for (_, points) in data {
        for p in points {
            if !names.contains(&p.name) {
                names.push(p.name.clone());
            }
        }
    }
    s += &format!("<details><summary>every configuration's {what}, by device</summary>\n\n");
    s += &table_head(data);
    for n in &names {
        s += &format!("| {} |", n.replace('|', "\\|"));
        for (_, points) in data {
            match points.iter().find(|p| p.name == *n) {
                Some(p) => s += &format!(" {:.2} |", p.ms),
                None => s += " |",
            }
        }
        s += "\n";
    }
    s += "\n</details>\n";
    if data
        .iter()
        .any(|(_, points)| points.iter().any(|p| p.error.is_some()))
    {
        s += "\n<details><summary>error against the reference: RMSE · FLIP · % of pixels over 2/255, by device</summary>\n\n";
        s += &table_head(data);
        for n in &names {
            s += &format!("| {} |", n.replace('|', "\\|"));
            for (_, points) in data {
                match points.iter().find(|p| p.name == *n).and_then(|p| p.error) {
                    Some([rmse, flip, pct]) => {
                        s += &format!(" {rmse:.4} · {flip:.4} · {pct:.1}% |")
                    }
                    None => s += " |",
                }
            }
            s += "\n";
        }
        s += "\n</details>\n";
    }
    if name == "bandwidth" {
        s += &floor_tables(data);
    }
    s += &format!("<!-- end strata report: {name} -->\n");
    s
}

/// `bandwidth`'s own tables: each device's measured rates, and each method's time, floor and
/// what sets it.
fn floor_tables(data: &[(&DeviceResults, Vec<Point>)]) -> String {
    let rate = |d: &DeviceResults, f: &str| {
        d.rates
            .as_ref()
            .and_then(|r| r.get(f)?.as_f64())
            .map_or(String::new(), |v| format!("{v:.3}"))
    };
    let mut s = String::from(
        "\n| device | copy GB/s | stream GB/s | atomics G/s: distinct | per pixel (16 per word) | one word |\n|---|---|---|---|---|---|\n",
    );
    for (d, _) in data {
        s += &format!(
            "| {} | {} | {} | {} | {} | {} |\n",
            d.device,
            rate(d, "copy_gb_per_s"),
            rate(d, "stream_gb_per_s"),
            rate(d, "atomics_distinct_g_per_s"),
            rate(d, "atomics_per_pixel_g_per_s"),
            rate(d, "atomics_one_word_g_per_s"),
        );
    }
    s += "\n<details><summary>GPU ms · floor ms (what sets the floor), by device</summary>\n\n";
    s += &table_head(data);
    let scenes: std::collections::BTreeSet<String> = data
        .iter()
        .flat_map(|(d, _)| d.rows.iter().filter_map(|r| text(r, "scene")))
        .collect();
    let scene_names = scene_names(&scenes);
    let mut names: Vec<String> = Vec::new();
    for (d, _) in data {
        for row in &d.rows {
            let n = row_name(row, &scene_names);
            if !names.contains(&n) {
                names.push(n);
            }
        }
    }
    for n in &names {
        s += &format!("| {} |", n.replace('|', "\\|"));
        for (d, _) in data {
            let row = d.rows.iter().find(|r| row_name(r, &scene_names) == *n);
            let cell = row.and_then(|r| {
                let ms = r.get("median_gpu_ms")?.as_f64()?;
                let floor = r.get("floor_ms")?.as_f64()?;
                Some(format!(
                    " {ms:.2} · {floor:.4} ({})",
                    text(r, "bound").unwrap_or_default()
                ))
            });
            match (cell, row.and_then(|r| text(r, "skipped"))) {
                (Some(c), _) => s += &format!("{c} |"),
                (None, Some(why)) => s += &format!(" skipped: {} |", why.replace('|', "\\|")),
                (None, None) => s += " |",
            }
        }
        s += "\n";
    }
    s + "\n</details>\n"
}

/// `report` with `name`'s generated block replaced by `new`, or inserted at the end of its
/// section, or in a new section at the end.
pub fn place_block(report: &str, name: &str, new: &str) -> String {
    let begin = format!("<!-- strata report: {name} -->");
    let end = format!("<!-- end strata report: {name} -->");
    if let (Some(b), Some(e)) = (report.find(&begin), report.find(&end)) {
        if b < e {
            let after = e + end.len();
            let after = after + report[after..].starts_with('\n') as usize;
            return format!("{}{new}{}", &report[..b], &report[after..]);
        }
    }
    let heading = format!("## {name}");
    let lines: Vec<&str> = report.split_inclusive('\n').collect();
    let start = lines
        .iter()
        .position(|l| l.trim_end() == heading || l.starts_with(&format!("{heading} ")));
    match start {
        Some(i) => {
            let next = lines[i + 1..]
                .iter()
                .position(|l| l.starts_with("## "))
                .map_or(lines.len(), |j| i + 1 + j);
            let mut head: String = lines[..next].concat();
            if !head.ends_with('\n') {
                head.push('\n');
            }
            if !head.ends_with("\n\n") {
                head.push('\n');
            }
            let tail: String = lines[next..].concat();
            let gap = if tail.is_empty() { "" } else { "\n" };
            format!("{head}{new}{gap}{tail}")
        }
        None => {
            let mut s = report.to_string();
            if !s.is_empty() && !s.ends_with('\n') {
                s.push('\n');
            }
            if !s.is_empty() {
                s.push('\n');
            }
            format!("{s}{heading}\n\n{new}")
        }
    }
}

pub fn run(a: ReportArgs) -> Result<()> {
    let devices = std::fs::read_dir(&a.results).map_err(|e| {
        Error::input(format!(
            "cannot read the results folder '{}': {e}",
            a.results.display()
        ))
    })?;
    let mut device_dirs: Vec<PathBuf> = devices
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.is_dir())
        .collect();
    device_dirs.sort();
    let charts = a
        .charts
        .clone()
        .unwrap_or_else(|| a.out.parent().unwrap_or(Path::new(".")).join("charts"));
    std::fs::create_dir_all(&charts)
        .map_err(|e| Error::input(format!("cannot create '{}': {e}", charts.display())))?;
    let mut report = match std::fs::read_to_string(&a.out) {
        Ok(s) => s,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => "# Benchmark report\n".into(),
        Err(e) => {
            return Err(Error::input(format!(
                "cannot read '{}': {e}",
                a.out.display()
            )))
        }
    };
    register_chart_font()?;
    let mut claim_files: Vec<(String, bool, crate::claims::DeviceFiles)> = Vec::new();
    let mut written = 0;
    for name in crate::bench::experiment_names() {
        let mut found = Vec::new();
        for dir in &device_dirs {
            let path = dir.join(format!("{name}.json"));
            let Ok(bytes) = std::fs::read(&path) else {
                continue;
            };
            let v: Value = serde_json::from_slice(&bytes).map_err(|e| {
                Error::input(format!("'{}' is not a results file: {e}", path.display()))
            })?;
            let device = dir
                .file_name()
                .map(|n| n.to_string_lossy().into_owned())
                .unwrap_or_default();
            let cpu = v
                .get("cpu_figures")
                .and_then(Value::as_bool)
                .unwrap_or(false);
            match claim_files.iter_mut().find(|(d, _, _)| *d == device) {
                Some((_, any_cpu, files)) => {
                    *any_cpu |= cpu;
                    files.insert(name.to_string(), v.clone());
                }
                None => claim_files.push((
                    device.clone(),
                    cpu,
                    [(name.to_string(), v.clone())].into_iter().collect(),
                )),
            }
            found.push(DeviceResults {
                device,
                cpu_figures: v
                    .get("cpu_figures")
                    .and_then(Value::as_bool)
                    .unwrap_or(false),
                rows: rows_of(&v),
                rates: v.get("device").filter(|d| d.is_object()).cloned(),
            });
        }
        if found.is_empty() {
            continue;
        }
        let all_rows: Vec<Value> = found.iter().flat_map(|d| d.rows.clone()).collect();
        let sweep = sweep_of(name, &all_rows);
        let data: Vec<(&DeviceResults, Vec<Point>)> = found
            .iter()
            .map(|d| (d, points(&d.rows, sweep.map(|s| s.0), time_fields(name))))
            .collect();
        if data.iter().all(|(_, p)| p.is_empty()) {
            continue;
        }
        let svg = charts.join(format!("{name}.svg"));
        let unit = format!("{} (log)", figure(name).1);
        let kind = match sweep {
            Some((_, axis)) => Kind::Sweep { axis },
            None => Kind::Bars,
        };
        chart(kind, &svg, (name, &unit), &data)?;
        let base = a.out.parent().unwrap_or(Path::new("."));
        let relative = pathdiff(&svg, base);
        let errors = if data
            .iter()
            .any(|(_, points)| points.iter().any(|p| p.error.is_some_and(|e| e[0] > 0.0)))
        {
            let path = charts.join(format!("{name}-error.svg"));
            chart(Kind::Errors, &path, (name, &unit), &data)?;
            Some(pathdiff(&path, base))
        } else {
            None
        };
        report = place_block(
            &report,
            name,
            &block(name, (&relative, errors.as_deref()), &data),
        );
        written += 1;
    }
    if !claim_files.is_empty() {
        let block = format!(
            "<!-- strata report: claims -->\n*Generated by `strata report` from `bench/results/*/`; edits between these markers are replaced.*\n\n{}<!-- end strata report: claims -->\n",
            crate::claims::table(&claim_files)
        );
        report = place_block(&report, "claims", &block);
    }
    let mut outputs = strata::output::Outputs::new();
    outputs.add(&a.out, report.into_bytes())?;
    outputs.commit()?;
    eprintln!(
        "{}: {written} experiments' charts and tables refreshed (charts in {})",
        a.out.display(),
        charts.display()
    );
    Ok(())
}

/// `path` relative to `base` when it lies below it (the report links its charts relatively).
fn pathdiff(path: &Path, base: &Path) -> String {
    path.strip_prefix(base)
        .unwrap_or(path)
        .to_string_lossy()
        .replace('\\', "/")
}

#[cfg(test)]
mod tests {
    use super::charts::scene_and_run;
    use super::*;

    #[test]
    fn blocks_replace_themselves_and_leave_the_prose() {
        let prose =
            "# Report\n\nintro\n\n## kbuffer-k — seed 003 Fig. 6\nhand-written\n\n## other\ntext\n";
        let first = place_block(
            prose,
            "kbuffer-k",
            "<!-- strata report: kbuffer-k -->\nA\n<!-- end strata report: kbuffer-k -->\n",
        );
        assert_eq!(
            first,
            "# Report\n\nintro\n\n## kbuffer-k — seed 003 Fig. 6\nhand-written\n\n<!-- strata report: kbuffer-k -->\nA\n<!-- end strata report: kbuffer-k -->\n\n## other\ntext\n"
        );
        let again = place_block(
            &first,
            "kbuffer-k",
            "<!-- strata report: kbuffer-k -->\nB\n<!-- end strata report: kbuffer-k -->\n",
        );
        assert_eq!(again, first.replace("\nA\n", "\nB\n"));
        let new = place_block(
            &again,
            "scale",
            "<!-- strata report: scale -->\nC\n<!-- end strata report: scale -->\n",
        );
        assert!(new.starts_with(&again));
        assert!(new.ends_with("text\n\n## scale\n\n<!-- strata report: scale -->\nC\n<!-- end strata report: scale -->\n"));
    }

    #[test]
    fn a_sweep_needs_three_values_and_rows_are_named_by_their_configuration() {
        let rows: Vec<Value> = [4, 8, 16]
            .iter()
            .map(|k| serde_json::json!({"method": "kb", "k": k, "median_gpu_ms": *k as f64, "scene": "builtin:layers?n=8"}))
            .collect();
        assert_eq!(sweep_of("kbuffer-k", &rows).map(|s| s.0), Some("k"));
        assert_eq!(sweep_of("kbuffer-k", &rows[..2]), None);
        assert_eq!(sweep_of("auto-k", &rows), None);
        let layered: Vec<Value> = [8, 16, 32]
            .iter()
            .map(|n| serde_json::json!({"method": "f2b", "scene": format!("builtin:layers?n={n}&coverage=1"), "median_gpu_ms": 1.0}))
            .collect();
        assert_eq!(
            sweep_of("peel-vs-abuffer", &layered).map(|s| s.0),
            Some("scene:n")
        );
        let p = points(&layered, Some("scene:n"), TIME_FIELDS);
        assert_eq!(
            p.iter().map(|p| p.x).collect::<Vec<_>>(),
            [Some(8.0), Some(16.0), Some(32.0)]
        );
        assert_eq!(
            sweep_value(
                &serde_json::json!({"scene": "builtin:nvpro?objects=5"}),
                "scene:n"
            ),
            None
        );
        let p = points(&rows, Some("k"), TIME_FIELDS);
        assert_eq!(p.len(), 3);
        assert_eq!(
            (p[1].name.as_str(), p[1].series.as_str(), p[1].x, p[1].ms),
            ("kb k=8", "kb", Some(8.0), 8.0)
        );
    }

    #[test]
    fn peers_are_charted_by_wall_clock_and_errors_get_their_own_table() {
        let rows = vec![
            serde_json::json!({"label": "abuffer-ll", "median_gpu_ms": 1.0, "median_wall_ms": 3.0,
                "error_vs_reference": {"rmse": 0.0, "flip_mean": 0.0, "pct_over_2": 0.0}}),
            serde_json::json!({"label": "pygfx blend", "median_gpu_ms": null, "median_wall_ms": 5.0,
                "error_vs_reference": {"rmse": 0.0125, "flip_mean": 0.25, "pct_over_2": 12.5}}),
            serde_json::json!({"label": "pygfx dither", "median_wall_ms": 6.0, "skipped": null}),
        ];
        let p = points(&rows, None, time_fields("peers"));
        assert_eq!(p.iter().map(|p| p.ms).collect::<Vec<_>>(), [3.0, 5.0, 6.0]);
        assert_eq!(points(&rows, None, time_fields("realtime"))[0].ms, 1.0);
        let device = DeviceResults {
            device: "lavapipe".into(),
            cpu_figures: true,
            rows: rows.clone(),
            rates: None,
        };
        let text = block("peers", ("charts/peers.svg", None), &[(&device, p)]);
        assert!(
            text.contains("every configuration's wall-clock ms per frame"),
            "{text}"
        );
        assert!(
            text.contains("| pygfx blend | 0.0125 · 0.2500 · 12.5% |"),
            "{text}"
        );
        assert!(text.contains("| pygfx dither | |"), "{text}");
        let text = block(
            "peers",
            ("charts/peers.svg", Some("charts/peers-error.svg")),
            &[(&device, points(&rows, None, time_fields("peers")))],
        );
        assert!(
            text.contains("![peers: error against time](charts/peers-error.svg)"),
            "{text}"
        );
    }

    #[test]
    fn error_charts_split_names_into_scene_and_run() {
        assert_eq!(scene_and_run("nvpro · mlab k=4"), ("nvpro", "mlab k=4"));
        assert_eq!(scene_and_run("pygfx blend"), ("", "pygfx blend"));
        let dir = std::env::temp_dir().join(format!("strata-error-chart-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let device = DeviceResults {
            device: "lavapipe".into(),
            cpu_figures: true,
            rows: Vec::new(),
            rates: None,
        };
        let point = |name: &str, ms: f64, rmse: f64| Point {
            name: name.into(),
            series: String::new(),
            x: None,
            ms,
            error: Some([rmse, 0.0, 0.0]),
        };
        let data = [(
            &device,
            vec![point("a · one", 10.0, 0.01), point("b · two", 20.0, 0.002)],
        )];
        let svg = dir.join("e.svg");
        register_chart_font().unwrap();
        chart(Kind::Errors, &svg, ("test", "ms (log)"), &data).unwrap();
        assert!(std::fs::read_to_string(&svg).unwrap().contains("two"));
        assert!(svg.with_extension("png").exists());
        let _ = std::fs::remove_dir_all(&dir);
    }
}
