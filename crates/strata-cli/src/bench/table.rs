//! The printed table and the CSV of a run of methods, and the histogram chart.

use super::*;

pub(crate) fn fmt_ms(v: Option<f64>) -> String {
    v.map(|v| format!("{v:.2}"))
        .unwrap_or_else(|| "null".into())
}

pub(crate) fn print_table(r: &BenchReport) {
    println!(
        "{} — {} {}x{} {} on {} ({}){}",
        r.experiment,
        r.scene,
        r.width,
        r.height,
        r.effect,
        r.adapter,
        r.backend,
        if r.cpu_figures {
            " — CPU FIGURES (software rasterizer), not GPU performance"
        } else {
            ""
        }
    );
    let multi_scene = r.results.iter().any(|m| m.scene != r.results[0].scene);
    println!(
        "{:<28} {:>10} {:>10} {:>8} {:>7} {:>10} {:>8} {:>9} {:>8} {:>9} {:>8}",
        "run",
        "gpu ms",
        "wall ms",
        "fps",
        "passes",
        "fragments",
        "dropped",
        "max depth",
        "MiB",
        "locks",
        "RMSE"
    );
    for m in &r.results {
        let label = if multi_scene {
            format!(
                "{} {}",
                short_scene(&m.scene).trim_start_matches("builtin:"),
                m.label
            )
        } else {
            m.label.clone()
        };
        if let Some(why) = &m.skipped {
            println!("{label:<28} skipped: {why}");
            continue;
        }
        let opt = |v: Option<u64>| v.map(|p| p.to_string()).unwrap_or_default();
        println!(
            "{:<28} {:>10} {:>10.2} {:>8} {:>7} {:>10} {:>8} {:>9} {:>8.1} {:>9} {:>8}",
            label,
            fmt_ms(m.median_gpu_ms),
            m.median_wall_ms,
            m.fps.map(|f| format!("{f:.1}")).unwrap_or_default(),
            opt(m.geometry_passes.map(u64::from)),
            opt(m.fragments),
            opt(m.fragments_dropped),
            opt(m.max_depth_complexity.map(u64::from)),
            m.bytes_allocated.unwrap_or(0) as f64 / 1048576.0,
            opt(m.lock_failures),
            m.error_vs_reference
                .map(|c| format!("{:.4}", c.rmse))
                .unwrap_or_default(),
        );
    }
}

pub(crate) fn csv(r: &BenchReport) -> String {
    let mut s = String::from(
        "experiment,scene,width,height,adapter,cpu_figures,commit,label,method,k,culling,msaa,median_gpu_ms,median_wall_ms,fps,blocking_readbacks,geometry_passes,fragments,fragments_dropped,max_depth_complexity,bytes_allocated,gpu_ms_per_mib,lock_failures,rmse,flip_mean,pct_over_2,rmse_vs_k,flip_vs_k,pct_over_2_vs_k,skipped\n",
    );
    let opt = |v: Option<String>| v.unwrap_or_default();
    for m in &r.results {
        let err = |c: Option<strata::metrics::Comparison>| match c {
            Some(c) => format!("{:.6},{:.6},{:.4}", c.rmse, c.flip_mean, c.pct_over_2),
            None => ",,".into(),
        };
        s += &[
            r.experiment.clone(),
            m.scene.clone(),
            r.width.to_string(),
            r.height.to_string(),
            r.adapter.replace(',', " "),
            r.cpu_figures.to_string(),
            opt(r.commit.clone()),
            m.label.clone(),
            m.method.clone(),
            opt(m.k.map(|k| k.to_string())),
            m.culling.to_string(),
            m.msaa.to_string(),
            opt(m.median_gpu_ms.map(|v| format!("{v:.3}"))),
            if m.median_wall_ms.is_finite() {
                format!("{:.3}", m.median_wall_ms)
            } else {
                String::new()
            },
            opt(m.fps.map(|v| format!("{v:.2}"))),
            opt(m.blocking_readbacks.map(|v| v.to_string())),
            opt(m.geometry_passes.map(|v| v.to_string())),
            opt(m.fragments.map(|v| v.to_string())),
            opt(m.fragments_dropped.map(|v| v.to_string())),
            opt(m.max_depth_complexity.map(|v| v.to_string())),
            opt(m.bytes_allocated.map(|v| v.to_string())),
            opt(m.gpu_ms_per_mib.map(|v| format!("{v:.4}"))),
            opt(m.lock_failures.map(|v| v.to_string())),
            err(m.error_vs_reference),
            err(m.error_vs_reference_k),
            opt(m.skipped.clone().map(|w| w.replace(',', ";"))),
        ]
        .join(",");
        s.push('\n');
    }
    s
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
