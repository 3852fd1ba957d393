//! `strata report`'s charts: sweeps as lines, configurations as bars, approximate methods'
//! errors, each an SVG and a PNG beside it (plotters, with the crate's font).

use std::collections::BTreeMap;
use std::path::Path;

use plotters::coord::Shift;
use plotters::prelude::*;
use strata::error::{Error, Result};

use super::{DeviceResults, Point};

/// Size of a sweep chart in pixels.
const SWEEP_SIZE: (u32, u32) = (900, 520);

/// The kinds of chart, each drawn on any plotters backend.
#[derive(Clone, Copy)]
pub(super) enum Kind<'a> {
    /// A line chart of time over the sweep whose x axis is `axis` (one line per series and
    /// device).
    Sweep { axis: &'a str },
    /// A bar per row (devices side by side), the figure on a log axis titled by the unit.
    Bars,
    /// Error against time: one panel per scene (a row's name before " · "), each run a labelled
    /// point at its figure (x, log) and its RMSE against the reference (y, log), a color per
    /// device. Runs without an error or a positive RMSE are left out.
    Errors,
}

/// Draws a chart of `kind` titled `title`, its figure's axis `unit`, as an SVG at `path` and a
/// PNG beside it.
pub(super) fn chart(
    kind: Kind<'_>,
    path: &Path,
    (title, unit): (&str, &str),
    data: &[(&DeviceResults, Vec<Point>)],
) -> Result<()> {
    let size = match kind {
        Kind::Sweep { .. } => SWEEP_SIZE,
        Kind::Bars => bar_chart_size(title, data)?,
        Kind::Errors => ERROR_CHART_SIZE,
    };
    svg_and_png(kind, path, size, (title, unit), data)
}

fn draw_on<DB: DrawingBackend>(
    kind: Kind<'_>,
    root: DrawingArea<DB, Shift>,
    path: &Path,
    (title, unit): (&str, &str),
    data: &[(&DeviceResults, Vec<Point>)],
) -> Result<()> {
    match kind {
        Kind::Sweep { axis } => sweep_chart_on(root, path, title, (axis, unit), data),
        Kind::Bars => bar_chart_on(root, path, title, unit, data),
        Kind::Errors => error_chart_on(root, path, (title, unit), data),
    }
}

/// Draws a chart of `kind` as an SVG at `path` and a PNG of the same size beside it.
fn svg_and_png(
    kind: Kind<'_>,
    path: &Path,
    size: (u32, u32),
    labels: (&str, &str),
    data: &[(&DeviceResults, Vec<Point>)],
) -> Result<()> {
    draw_on(
        kind,
        SVGBackend::new(path, size).into_drawing_area(),
        path,
        labels,
        data,
    )?;
    let png = path.with_extension("png");
    let mut pixels = vec![0u8; (size.0 * size.1 * 3) as usize];
    draw_on(
        kind,
        BitMapBackend::with_buffer(&mut pixels, size).into_drawing_area(),
        &png,
        labels,
        data,
    )?;
    save_png(&png, size, pixels)
}

pub(super) fn sweep_chart_on<DB: DrawingBackend>(
    root: DrawingArea<DB, Shift>,
    path: &Path,
    title: &str,
    (axis, unit): (&str, &str),
    data: &[(&DeviceResults, Vec<Point>)],
) -> Result<()> {
    let mut lines: BTreeMap<String, Vec<(f64, f64)>> = BTreeMap::new();
    let several = data.len() > 1;
    for (device, points) in data {
        for p in points {
            let Some(x) = p.x else { continue };
            let name = if several {
                format!("{} ({})", p.series, device.device)
            } else {
                p.series.clone()
            };
            lines.entry(name).or_default().push((x, p.ms));
        }
    }
    for line in lines.values_mut() {
        line.sort_by(|a, b| a.0.total_cmp(&b.0));
        // Several rows at one x (other scenes or settings): their median.
        let mut merged: Vec<(f64, f64)> = Vec::new();
        let mut i = 0;
        while i < line.len() {
            let same: Vec<f64> = line[i..]
                .iter()
                .take_while(|p| p.0 == line[i].0)
                .map(|p| p.1)
                .collect();
            let n = same.len();
            merged.push((line[i].0, crate::bench::median(same)));
            i += n;
        }
        *line = merged;
    }
    let all: Vec<(f64, f64)> = lines.values().flatten().copied().collect();
    if all.is_empty() {
        return Err(Error::input(format!("{title}: nothing to chart")));
    }
    let (x_lo, x_hi) = bounds(all.iter().map(|p| p.0));
    let (y_lo, y_hi) = bounds(all.iter().map(|p| p.1));
    let draw = |e: &dyn std::fmt::Display| Error::runtime(format!("{}: {e}", path.display()));
    root.fill(&WHITE).map_err(|e| draw(&e))?;
    let log_x = x_hi / x_lo.max(f64::MIN_POSITIVE) > 20.0;
    let mut builder = ChartBuilder::on(&root);
    builder
        .caption(title, ("sans-serif", 18))
        .margin(12)
        .x_label_area_size(40)
        .y_label_area_size(70);
    let style = |i: usize| Palette99::pick(i).stroke_width(2);
    macro_rules! plot {
        ($chart:expr) => {{
            let mut chart = $chart;
            chart
                .configure_mesh()
                .x_desc(axis)
                .y_desc(unit)
                .x_labels(10)
                .y_labels(10)
                .x_label_formatter(&|v| format!("{v:.0}"))
                .y_label_formatter(&|v| format!("{v:.0}"))
                .draw()
                .map_err(|e| draw(&e))?;
            for (i, (name, line)) in lines.iter().enumerate() {
                chart
                    .draw_series(LineSeries::new(line.iter().copied(), style(i)))
                    .map_err(|e| draw(&e))?
                    .label(name.as_str())
                    .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 16, y)], style(i)));
            }
            chart
                .configure_series_labels()
                .background_style(WHITE.mix(0.85))
                .border_style(BLACK)
                .position(SeriesLabelPosition::UpperLeft)
                .draw()
                .map_err(|e| draw(&e))?;
        }};
    }
    let y = (y_lo * 0.8)..(y_hi * 1.25);
    if log_x {
        plot!(builder
            .build_cartesian_2d((x_lo..x_hi).log_scale(), y.log_scale())
            .map_err(|e| draw(&e))?);
    } else {
        plot!(builder
            .build_cartesian_2d(x_lo..x_hi, y.log_scale())
            .map_err(|e| draw(&e))?);
    }
    root.present().map_err(|e| draw(&e))
}

/// Pixels of one device's bar.
const BAR_PX: u32 = 12;

/// Size of a bar chart in pixels: a bar per row and device (no rows: an error).
fn bar_chart_size(title: &str, data: &[(&DeviceResults, Vec<Point>)]) -> Result<(u32, u32)> {
    let names = row_names(data);
    if names.is_empty() {
        return Err(Error::input(format!("{title}: nothing to chart")));
    }
    Ok((
        1000,
        100 + names.len() as u32 * (8 + BAR_PX * data.len() as u32),
    ))
}

/// Every row's name over the devices, in the results' order.
pub(super) fn row_names(data: &[(&DeviceResults, Vec<Point>)]) -> Vec<String> {
    let mut names: Vec<String> = Vec::new();
    for (_, points) in data {
        for p in points {
            if !names.contains(&p.name) {
                names.push(p.name.clone());
            }
        }
    }
    names
}

pub(super) fn bar_chart_on<DB: DrawingBackend>(
    root: DrawingArea<DB, Shift>,
    path: &Path,
    title: &str,
    unit: &str,
    data: &[(&DeviceResults, Vec<Point>)],
) -> Result<()> {
    let names = row_names(data);
    let (y_lo, y_hi) = bounds(data.iter().flat_map(|(_, p)| p.iter().map(|p| p.ms)));
    let devices = data.len();
    let draw = |e: &dyn std::fmt::Display| Error::runtime(format!("{}: {e}", path.display()));
    root.fill(&WHITE).map_err(|e| draw(&e))?;
    let mut chart = ChartBuilder::on(&root)
        .caption(title, ("sans-serif", 18))
        .margin(12)
        .x_label_area_size(36)
        .y_label_area_size(340)
        .build_cartesian_2d(
            ((y_lo * 0.8)..(y_hi * 1.25)).log_scale(),
            (0..names.len()).into_segmented(),
        )
        .map_err(|e| draw(&e))?;
    // Top to bottom in the results' order.
    let name_at = |segment: &SegmentValue<usize>| match segment {
        SegmentValue::CenterOf(i) if *i < names.len() => names[names.len() - 1 - i].clone(),
        _ => String::new(),
    };
    chart
        .configure_mesh()
        .disable_y_mesh()
        .x_desc(unit)
        .x_labels(8)
        .x_label_formatter(&|v| format!("{v:.0}"))
        .y_labels(names.len())
        .y_label_formatter(&name_at)
        .draw()
        .map_err(|e| draw(&e))?;
    for (d, (device, points)) in data.iter().enumerate() {
        let color = Palette99::pick(d).filled();
        let bars = points.iter().filter_map(|p| {
            let i = names.len() - 1 - names.iter().position(|n| *n == p.name)?;
            let mut bar = Rectangle::new(
                [
                    (y_lo * 0.8, SegmentValue::Exact(i)),
                    (p.ms, SegmentValue::Exact(i + 1)),
                ],
                color,
            );
            // Each name's band (BAR_PX per device and a gap) split between the devices.
            let (d, n) = (d as u32, devices as u32);
            bar.set_margin(4 + d * BAR_PX, 4 + (n - 1 - d) * BAR_PX, 0, 0);
            Some(bar)
        });
        chart
            .draw_series(bars)
            .map_err(|e| draw(&e))?
            .label(device.device.as_str())
            .legend(move |(x, y)| Rectangle::new([(x, y - 5), (x + 12, y + 5)], color));
    }
    if devices > 1 {
        chart
            .configure_series_labels()
            .background_style(WHITE.mix(0.85))
            .border_style(BLACK)
            .draw()
            .map_err(|e| draw(&e))?;
    }
    root.present().map_err(|e| draw(&e))
}

/// Size of an error chart in pixels.
const ERROR_CHART_SIZE: (u32, u32) = (1400, 1100);

/// A point's scene and run: its name split at the first " · " (no scene: "").
pub(super) fn scene_and_run(name: &str) -> (&str, &str) {
    name.split_once(" · ").unwrap_or(("", name))
}

pub(super) fn error_chart_on<DB: DrawingBackend>(
    root: DrawingArea<DB, Shift>,
    path: &Path,
    (title, unit): (&str, &str),
    data: &[(&DeviceResults, Vec<Point>)],
) -> Result<()> {
    let draw = |e: &dyn std::fmt::Display| Error::runtime(format!("{}: {e}", path.display()));
    let charted = |p: &Point| p.error.filter(|e| e[0] > 0.0).map(|e| (p.ms, e[0]));
    let mut scenes: Vec<&str> = Vec::new();
    for (_, points) in data {
        for p in points.iter().filter(|p| charted(p).is_some()) {
            let scene = scene_and_run(&p.name).0;
            if !scenes.contains(&scene) {
                scenes.push(scene);
            }
        }
    }
    root.fill(&WHITE).map_err(|e| draw(&e))?;
    let root = root
        .titled(&format!("{title}: error against time"), ("sans-serif", 20))
        .map_err(|e| draw(&e))?;
    let columns = if scenes.len() > 1 { 2 } else { 1 };
    let rows = scenes.len().div_ceil(columns).max(1);
    let panels = root.split_evenly((rows, columns));
    for (scene, panel) in scenes.iter().zip(panels.iter()) {
        let in_scene = || {
            data.iter().flat_map(|(_, points)| {
                points
                    .iter()
                    .filter(|p| scene_and_run(&p.name).0 == *scene)
                    .filter_map(charted)
            })
        };
        let (x_lo, x_hi) = bounds(in_scene().map(|p| p.0));
        let (y_lo, y_hi) = bounds(in_scene().map(|p| p.1));
        let mut chart = ChartBuilder::on(panel)
            .caption(*scene, ("sans-serif", 16))
            .margin(10)
            .x_label_area_size(32)
            .y_label_area_size(56)
            .build_cartesian_2d(
                ((x_lo * 0.8)..(x_hi * 1.6)).log_scale(),
                // Whole decades, so that a narrow range still gets labels.
                (10f64.powf((y_lo * 0.9).log10().floor())..10f64.powf((y_hi * 1.1).log10().ceil()))
                    .log_scale(),
            )
            .map_err(|e| draw(&e))?;
        chart
            .configure_mesh()
            .x_desc(unit)
            .y_desc("RMSE against the reference (log)")
            .x_label_formatter(&|v| format!("{v:.0}"))
            .y_label_formatter(&|v| format!("{v:.4}"))
            .draw()
            .map_err(|e| draw(&e))?;
        for (d, (_, points)) in data.iter().enumerate() {
            let color = Palette99::pick(d);
            let marks = points
                .iter()
                .filter(|p| scene_and_run(&p.name).0 == *scene)
                .filter_map(|p| Some((charted(p)?, scene_and_run(&p.name).1.to_string())));
            chart
                .draw_series(marks.map(|((x, y), run)| {
                    EmptyElement::at((x, y))
                        + Circle::new((0, 0), 3, color.filled())
                        + Text::new(run, (5, -5), ("sans-serif", 10))
                }))
                .map_err(|e| draw(&e))?;
        }
    }
    root.present().map_err(|e| draw(&e))
}

/// Writes an RGB chart's pixels as a PNG.
pub(super) fn save_png(path: &Path, (width, height): (u32, u32), pixels: Vec<u8>) -> Result<()> {
    let image = image::RgbImage::from_raw(width, height, pixels).ok_or_else(|| {
        Error::runtime(format!(
            "{}: chart buffer of the wrong size",
            path.display()
        ))
    })?;
    image
        .save(path)
        .map_err(|e| Error::runtime(format!("cannot write '{}': {e}", path.display())))
}

/// Makes the PNG charts' text drawable: plotters' bitmap backend draws text with fonts
/// registered by name, and strata depends on no system font, so it registers egui's bundled
/// Ubuntu Light as "sans-serif".
pub(super) fn register_chart_font() -> Result<()> {
    static REGISTERED: std::sync::OnceLock<bool> = std::sync::OnceLock::new();
    let registered = *REGISTERED.get_or_init(|| {
        plotters::style::register_font(
            "sans-serif",
            FontStyle::Normal,
            epaint_default_fonts::UBUNTU_LIGHT,
        )
        .is_ok()
    });
    if registered {
        Ok(())
    } else {
        Err(Error::runtime(
            "the charts' bundled font (Ubuntu Light) did not parse",
        ))
    }
}

pub(super) fn bounds(values: impl Iterator<Item = f64>) -> (f64, f64) {
    let (lo, hi) = values.fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| {
        (a.min(v), b.max(v))
    });
    if lo < hi {
        (lo, hi)
    } else {
        (lo * 0.5, hi * 2.0)
    }
}
