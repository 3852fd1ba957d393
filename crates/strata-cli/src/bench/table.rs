//! The table writer every experiment uses (`Column`: one list of columns gives the CSV and the
//! printed table), the run of methods' columns, and the histogram chart.

use super::*;

pub(crate) fn fmt_ms(v: Option<f64>) -> String {
    v.map(|v| format!("{v:.2}"))
        .unwrap_or_else(|| "null".into())
}

/// One column of an experiment's rows: its CSV header and cell, and, when the printed table
/// shows it, its heading, width, alignment and printed cell. An experiment lists its columns
/// once; its CSV and its printed table both come from that list and its row type (whose serde
/// form is the JSON's).
pub(crate) struct Column<'a, R> {
    name: &'static str,
    cell: Cell<'a, R>,
    printed: Option<Printed<'a, R>>,
}

type Cell<'a, R> = Box<dyn Fn(&R) -> String + 'a>;

struct Printed<'a, R> {
    heading: &'static str,
    width: usize,
    left: bool,
    /// `None`: the CSV's cell.
    cell: Option<Cell<'a, R>>,
}

impl<'a, R> Column<'a, R> {
    /// A column of the CSV only.
    pub(crate) fn csv(name: &'static str, cell: impl Fn(&R) -> String + 'a) -> Self {
        Column {
            name,
            cell: Box::new(cell),
            printed: None,
        }
    }

    /// Printed too, right-aligned in `width` characters, with the CSV's cell.
    pub(crate) fn shown(self, heading: &'static str, width: usize) -> Self {
        self.printed(heading, width, None)
    }

    /// Printed too, right-aligned in `width` characters, as `cell` writes it.
    pub(crate) fn shown_as(
        self,
        heading: &'static str,
        width: usize,
        cell: impl Fn(&R) -> String + 'a,
    ) -> Self {
        self.printed(heading, width, Some(Box::new(cell)))
    }

    /// Left-aligned where printed (after [`Column::shown`] or [`Column::shown_as`]).
    pub(crate) fn left(mut self) -> Self {
        self.printed.as_mut().expect("a printed column").left = true;
        self
    }

    fn printed(mut self, heading: &'static str, width: usize, cell: Option<Cell<'a, R>>) -> Self {
        self.printed = Some(Printed {
            heading,
            width,
            left: false,
            cell,
        });
        self
    }
}

/// The scene a row measured: its spec in the CSV (commas as semicolons), its short name printed.
pub(crate) fn scene_column<'a, R: 'a>(scene: fn(&R) -> &String) -> Column<'a, R> {
    Column::csv("scene", move |r| scene(r).replace(',', ";"))
        .shown_as("scene", 10, move |r| {
            short_scene(scene(r))
                .trim_start_matches("builtin:")
                .to_string()
        })
        .left()
}

/// The CSV of `rows`: a header line, then a line per row.
pub(crate) fn csv_of<R>(columns: &[Column<'_, R>], rows: &[R]) -> String {
    let mut out = columns.iter().map(|c| c.name).collect::<Vec<_>>().join(",");
    out.push('\n');
    for row in rows {
        out += &columns
            .iter()
            .map(|c| (c.cell)(row))
            .collect::<Vec<_>>()
            .join(",");
        out.push('\n');
    }
    out
}

/// Prints the headings and a line per row; a row `skipped` names a reason for shows its leading
/// left-aligned cells (what it is) and the reason.
pub(crate) fn print_rows<R>(
    columns: &[Column<'_, R>],
    rows: &[R],
    skipped: impl Fn(&R) -> Option<String>,
) {
    let shown: Vec<&Printed<'_, R>> = columns.iter().filter_map(|c| c.printed.as_ref()).collect();
    let pad = |p: &Printed<'_, R>, text: &str| {
        if p.left {
            format!("{text:<w$}", w = p.width)
        } else {
            format!("{text:>w$}", w = p.width)
        }
    };
    let line: Vec<String> = shown.iter().map(|p| pad(p, p.heading)).collect();
    println!("{}", line.join(" "));
    for row in rows {
        let cell = |c: &Column<'_, R>| {
            let p = c.printed.as_ref().expect("shown columns only");
            pad(p, &p.cell.as_ref().unwrap_or(&c.cell)(row))
        };
        let printed = columns.iter().filter(|c| c.printed.is_some());
        let line: Vec<String> = match skipped(row) {
            Some(why) => printed
                .take_while(|c| c.printed.as_ref().is_some_and(|p| p.left))
                .map(cell)
                .chain([format!("skipped: {why}")])
                .collect(),
            None => printed.map(cell).collect(),
        };
        println!("{}", line.join(" "));
    }
}

pub(crate) fn print_table(r: &BenchReport) {
    println!(
        "{} — {} {}x{} {} on {}",
        r.experiment,
        r.scene,
        r.width,
        r.height,
        r.effect,
        r.provenance.device()
    );
    print_rows(&columns(r), &r.results, |m| m.skipped.clone());
}

pub(crate) fn csv(r: &BenchReport) -> String {
    csv_of(&columns(r), &r.results)
}

/// The columns of a run of methods.
fn columns(r: &BenchReport) -> Vec<Column<'_, MethodResult>> {
    type C<'a> = Column<'a, MethodResult>;
    let multi_scene = r.results.iter().any(|m| m.scene != r.results[0].scene);
    let error = |name,
                 pick: fn(&MethodResult) -> Option<strata::metrics::Comparison>,
                 digits,
                 value: fn(&strata::metrics::Comparison) -> f64| {
        C::csv(name, move |m| fixed(pick(m).map(|c| value(&c)), digits))
    };
    vec![
        C::csv("experiment", |_| r.experiment.clone()),
        C::csv("scene", |m| m.scene.clone()),
        C::csv("width", |_| r.width.to_string()),
        C::csv("height", |_| r.height.to_string()),
        C::csv("adapter", |_| r.provenance.adapter.replace(',', " ")),
        C::csv("cpu_figures", |_| r.provenance.cpu_figures.to_string()),
        C::csv("commit", |_| opt(r.provenance.commit.clone())),
        C::csv("label", |m| m.label.clone())
            .shown_as("run", 28, move |m| {
                if multi_scene {
                    format!(
                        "{} {}",
                        short_scene(&m.scene).trim_start_matches("builtin:"),
                        m.label
                    )
                } else {
                    m.label.clone()
                }
            })
            .left(),
        C::csv("method", |m| m.method.clone()),
        C::csv("k", |m| opt(m.k)),
        C::csv("culling", |m| m.culling.to_string()),
        C::csv("storage_layout", |m| m.storage_layout.to_string()),
        C::csv("msaa", |m| m.msaa.to_string()),
        C::csv("median_gpu_ms", |m| fixed(m.median_gpu_ms, 3))
            .shown_as("gpu ms", 10, |m| fmt_ms(m.median_gpu_ms)),
        C::csv("median_wall_ms", |m| {
            fixed(Some(m.median_wall_ms).filter(|v| v.is_finite()), 3)
        })
        .shown_as("wall ms", 10, |m| format!("{:.2}", m.median_wall_ms)),
        C::csv("fps", |m| fixed(m.fps, 2)).shown_as("fps", 8, |m| fixed(m.fps, 1)),
        C::csv("blocking_readbacks", |m| opt(m.blocking_readbacks)),
        C::csv("geometry_passes", |m| opt(m.geometry_passes)).shown("passes", 7),
        C::csv("fragments", |m| opt(m.fragments)).shown("fragments", 10),
        C::csv("fragments_dropped", |m| opt(m.fragments_dropped)).shown("dropped", 8),
        C::csv("max_depth_complexity", |m| opt(m.max_depth_complexity)).shown("max depth", 9),
        C::csv("bytes_allocated", |m| opt(m.bytes_allocated)).shown_as("MiB", 8, |m| {
            format!("{:.1}", m.bytes_allocated.unwrap_or(0) as f64 / 1048576.0)
        }),
        C::csv("gpu_ms_per_mib", |m| fixed(m.gpu_ms_per_mib, 4)),
        C::csv("lock_failures", |m| opt(m.lock_failures)).shown("locks", 9),
        error("rmse", |m| m.error_vs_reference, 6, |c| c.rmse).shown_as("RMSE", 8, |m| {
            fixed(m.error_vs_reference.map(|c| c.rmse), 4)
        }),
        error("flip_mean", |m| m.error_vs_reference, 6, |c| c.flip_mean),
        error("pct_over_2", |m| m.error_vs_reference, 4, |c| c.pct_over_2),
        error("rmse_vs_k", |m| m.error_vs_reference_k, 6, |c| c.rmse),
        error("flip_vs_k", |m| m.error_vs_reference_k, 6, |c| c.flip_mean),
        error(
            "pct_over_2_vs_k",
            |m| m.error_vs_reference_k,
            4,
            |c| c.pct_over_2,
        ),
        C::csv("skipped", |m| {
            opt(m.skipped.clone().map(|w| w.replace(',', ";")))
        }),
    ]
}

/// A bar chart of a depth-complexity histogram (pixels per fragment count, log scale).
pub fn histogram_chart(hist: &[u64]) -> image::RgbaImage {
    let (w, h) = (640u32, 320u32);
    let mut img = image::RgbaImage::from_pixel(w, h, image::Rgba([24, 24, 28, 255]));
    let bins = hist.len().max(1) as u32;
    let top = hist.iter().copied().max().unwrap_or(1).max(1) as f64;
    for (i, &count) in hist.iter().enumerate() {
        if count == 0 {
            continue;
        }
        let x0 = 8 + i as u32 * (w - 16) / bins;
        let x1 = (8 + (i as u32 + 1) * (w - 16) / bins).max(x0 + 1);
        let bar = ((1.0 + count as f64).ln() / (1.0 + top).ln() * (h - 16) as f64) as u32;
        let [r, g, b] = strata::metrics::colormap::colormap(i as f32 / bins as f32);
        for x in x0..x1.min(w - 8) {
            for y in (h - 8 - bar)..(h - 8) {
                img.put_pixel(x, y, image::Rgba([r, g, b, 255]));
            }
        }
    }
    img
}
