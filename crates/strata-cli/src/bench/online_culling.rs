//! `strata bench online-culling` (seed 000 Table 1): how triangle order changes the cost of a
//! one-pass k-buffer, and what in-frame culling, the semi-heap and reverse-reprojection
//! temporal culling recover. Two sequences — 1500 `balls` of 288 triangles (432K, depth
//! complexity 50–62: the paper's N-body scene) moving on the GPU, and a large nvpro field under
//! a camera orbit of 1° a frame (1M triangles on a CPU adapter, 10M on a GPU; on a GPU also
//! 100K balls, 4.8M triangles, moving) — are each rendered under triangle
//! orders front to back, ten random permutations and back to front (`--order`, sorted on
//! the GPU every frame), with four configurations: kplus-heap without culling, kplus-heap with
//! in-frame culling, kplus-semiheap (|H| = 1), and kplus-semiheap with temporal culling. A
//! second table sweeps the refresh period of temporal culling on `balls`.
//!
//! Per row: the median GPU ms of the frames after the first (the order and animation passes
//! excluded: they are the experiment's instruments, not the method's cost), the Kendall distance, the fraction of
//! fragments temporal culling rejected and, for temporal culling (approximate by design), the
//! worst RMSE and share of pixels over 2/255 over the sequence against the same method and k
//! without temporal culling, rendered on the same device (an exact k-buffer: `reference --k N`
//! at the device's own fragments). The reference is a GPU frame, not the CPU renderer, so a
//! multi-million-triangle sequence costs the device seconds, not minutes, and the error is
//! temporal culling's alone, not the rasterizer's.
//! Frames are waited for one by one (exact mode), so times are per frame, not a steady loop.
//! A run past [`RUN_BUDGET`] of wall time renders no more frames (its row's `frames` says how
//! many it did), and the results are written after every run.

use crate::bench::{csv_of, fixed, opt, Column};
use std::path::Path;
use strata::frame::FrameOptions;
use strata::methods::kbuffer::KBufferOptions;

use serde::Serialize;
use strata::error::Result;
use strata::frame::FrameStats;
use strata::gpu::Gpu;
use strata::methods::kbuffer::temporal::TemporalCulling;
use strata::order::Order;
use strata::scene::{loaders, CameraPath, Scene};
use strata::{Effect, LinearImage, MethodId, RenderOptions, Renderer};

use crate::bench::standalone_setup;

/// The experiment `bench online-culling` runs.
pub const EXPERIMENT: super::Standalone = super::Standalone {
    name: "online-culling",
    description: "seed 000 Table 1: balls and a >= 1M-triangle scene x order (front, random, back) x {kplus-heap without / with culling, kplus-semiheap, + temporal culling}: frame ms, culled fraction, error; and temporal culling's refresh period",
    run,
};

const K: u32 = 16;

#[derive(Clone, Copy, Serialize)]
struct Config {
    name: &'static str,
    method: MethodId,
    culling: bool,
    temporal: bool,
}

const CONFIGS: [Config; 4] = [
    Config {
        name: "kplus-heap, no culling",
        method: MethodId::KplusHeap,
        culling: false,
        temporal: false,
    },
    Config {
        name: "kplus-heap, in-frame culling",
        method: MethodId::KplusHeap,
        culling: true,
        temporal: false,
    },
    Config {
        name: "kplus-semiheap",
        method: MethodId::KplusSemiheap,
        culling: true,
        temporal: false,
    },
    Config {
        name: "kplus-semiheap + temporal",
        method: MethodId::KplusSemiheap,
        culling: true,
        temporal: true,
    },
];

#[derive(Serialize)]
struct Row {
    sequence: String,
    triangles: usize,
    order: &'static str,
    seed: Option<u64>,
    config: &'static str,
    method: MethodId,
    refresh: Option<u32>,
    /// Frames rendered: the sequence's, or fewer when the run outlasted [`RUN_BUDGET`].
    frames: u32,
    /// Median over the frames after the first, the order pass excluded.
    gpu_ms: Option<f64>,
    kendall_tau: Option<f64>,
    fragments: Option<u64>,
    culled_temporal_fraction: Option<f64>,
    lock_failures: u64,
    /// Temporal culling only (the other configurations are exact): worst over the frames.
    rmse_max: Option<f64>,
    pct_over_2_max: Option<f64>,
}

#[derive(Serialize)]
struct Report {
    #[serde(flatten)]
    header: crate::bench::Header,
    k: u32,
    /// False while the run is under way: the results are written after every run of a
    /// configuration, so a run stopped early (a time limit) leaves what it measured.
    complete: bool,
    rows: Vec<Row>,
}

/// A sequence: a scene that moves with time (objects on the GPU, or the camera on a path),
/// shown at frames 0, 1, ...
struct Sequence {
    name: String,
    scene: Scene,
    frames: u32,
    /// Reference pictures per frame (the method without temporal culling), made once and
    /// shared by every order of a configuration.
    references: Vec<Option<image::RgbaImage>>,
}

impl Sequence {
    fn new(name: String, scene: Scene, frames: u32) -> Sequence {
        Sequence {
            name,
            scene,
            frames,
            references: vec![None; frames as usize],
        }
    }
}

/// The balls' radius: 1500 of them (432K triangles, the paper's 435K) reach the paper's depth
/// complexity, 48–62 (at 128², frames 0–90: 50–56).
const BALLS_RADIUS: f32 = 0.08;

/// `count` balls of 288 triangles (18 segments) moving on the GPU; `radius` sets how deep the
/// pixels are.
fn balls(count: u32, radius: f32, frames: u32) -> Result<Sequence> {
    let spec = format!("balls?count={count}&segments=18&radius={radius}");
    let scene = loaders::load_scene(&format!("builtin:{spec}"))?;
    Ok(Sequence::new(spec, scene, frames))
}

/// A large static field whose camera turns 1° a frame around its vertical axis.
fn orbit(objects: u32, frames: u32) -> Result<Sequence> {
    let spec = format!("builtin:nvpro?objects={objects}&subdiv=16&seed=0");
    let mut scene = loaders::load_scene(&spec)?;
    scene.camera_path = Some(CameraPath::orbit(scene.camera_or_framing(), 1.0)?);
    Ok(Sequence::new(
        spec.trim_start_matches("builtin:").to_string(),
        scene,
        frames,
    ))
}

fn options(
    size: (u32, u32),
    config: &Config,
    order: Order,
    seed: u64,
    refresh: u32,
) -> RenderOptions {
    RenderOptions {
        frame: FrameOptions {
            width: size.0,
            height: size.1,
            k: Some(K),
            order: Some(order),
            order_seed: seed,
            temporal: config.temporal.then_some(TemporalCulling {
                refresh,
                ..Default::default()
            }),
            ..Default::default()
        }
        .with_family(KBufferOptions {
            culling: config.culling,
            ..Default::default()
        }),
        ..Default::default()
    }
}

fn median(mut v: Vec<f64>) -> Option<f64> {
    if v.is_empty() {
        return None;
    }
    v.sort_by(f64::total_cmp);
    Some(v[v.len() / 2])
}

fn method_ms(s: &FrameStats) -> Option<f64> {
    let passes = s.gpu_ms.as_ref()?;
    Some(
        passes
            .iter()
            .filter(|(name, _)| *name != "order" && *name != "animate")
            .map(|(_, ms)| ms)
            .sum(),
    )
}

/// Wall time after which a run renders no more frames (a configuration that starves on a
/// device, say), so that one slow configuration leaves time for the others; the row's `frames`
/// says how many it rendered.
const RUN_BUDGET: std::time::Duration = std::time::Duration::from_secs(60);

/// Runs one order and configuration over a sequence (within [`RUN_BUDGET`], at least two
/// frames).
fn run_one(gpu: &Gpu, seq: &mut Sequence, options: &RenderOptions, config: &Config) -> Result<Row> {
    let start = std::time::Instant::now();
    let mut renderer = Renderer::new(gpu, &seq.scene, options)?;
    let (mut times, mut taus) = (Vec::new(), Vec::new());
    let (mut fragments, mut culled, mut lock_failures) = (0u64, 0u64, 0u64);
    let (mut rmse_max, mut over_max) = (0.0f64, 0.0f64);
    let mut rendered = 0;
    // The reference's renderer, made when a frame first needs it.
    let mut exact_renderer: Option<Renderer> = None;
    for t in 0..seq.frames as usize {
        if t >= 2 && start.elapsed() > RUN_BUDGET {
            eprintln!(
                "warning: {} {}: {t} of {} frames in {:.0} s, the rest skipped",
                seq.name,
                config.name,
                seq.frames,
                start.elapsed().as_secs_f64()
            );
            break;
        }
        rendered += 1;
        renderer.set_time(t as f32);
        let (image, stats) = renderer.render_method(config.method, None)?;
        lock_failures += stats.lock_failures.unwrap_or(0);
        if t > 0 {
            times.extend(method_ms(&stats));
            taus.extend(stats.kendall_tau);
            fragments += stats.fragments_generated.unwrap_or(0);
            culled += stats.culled_temporal.unwrap_or(0);
        }
        if config.temporal {
            let reference = match &seq.references[t] {
                Some(r) => r.clone(),
                None => {
                    let exact = match &mut exact_renderer {
                        Some(r) => r,
                        None => {
                            let options = {
                                let mut options = options.clone();
                                options.frame.temporal = None;
                                options.frame.order = None;
                                options
                            };
                            exact_renderer.insert(Renderer::new(gpu, &seq.scene, &options)?)
                        }
                    };
                    exact.set_time(t as f32);
                    let r = to_rgba(&exact.render_method(config.method, None)?.0);
                    seq.references[t] = Some(r.clone());
                    r
                }
            };
            let c = strata::metrics::compare(&reference, &to_rgba(&image))?;
            rmse_max = rmse_max.max(c.rmse);
            over_max = over_max.max(c.pct_over_2);
        }
    }
    Ok(Row {
        sequence: seq.name.clone(),
        triangles: seq.scene.triangle_count(),
        order: options.frame.order.map_or("scene", |o| o.name()),
        seed: (options.frame.order == Some(Order::Random)).then_some(options.frame.order_seed),
        config: config.name,
        method: config.method,
        refresh: options.frame.temporal.map(|t| t.refresh),
        frames: rendered,
        gpu_ms: median(times),
        kendall_tau: median(taus),
        fragments: Some(fragments),
        culled_temporal_fraction: config
            .temporal
            .then(|| culled as f64 / fragments.max(1) as f64),
        lock_failures,
        rmse_max: config.temporal.then_some(rmse_max),
        pct_over_2_max: config.temporal.then_some(over_max),
    })
}

fn to_rgba(image: &LinearImage) -> image::RgbaImage {
    image.to_rgba8(Effect::Transparency)
}

pub fn run(gpu: &Gpu, size: Option<crate::Size>, frames: Option<u32>, dir: &Path) -> Result<()> {
    let (cpu_figures, size, frames) =
        standalone_setup(gpu, size, frames, ((128, 128), (640, 480)), (4, 16))?;
    let frames = frames.max(2);
    // The field: ≥ 10M triangles on a GPU, ≥ 1M on a CPU (224 triangles an object); ten
    // random permutations, as the paper's table.
    let (ball_count, objects, randoms) = if cpu_figures {
        (1500, 4608, 10)
    } else {
        (1500, 45000, 10)
    };
    let mut sequences = vec![
        balls(ball_count, BALLS_RADIUS, frames)?,
        orbit(objects, frames)?,
    ];
    if !cpu_figures {
        // The animation's scale: 100K balls (4.8M triangles) moved on the GPU every frame.
        sequences.push(Sequence::new(
            "balls?count=100000&segments=8".into(),
            loaders::load_scene("builtin:balls?count=100000&segments=8")?,
            frames,
        ));
    }
    let orders: Vec<(Order, u64)> = std::iter::once((Order::Front, 0))
        .chain((0..randoms).map(|s| (Order::Random, s)))
        .chain(std::iter::once((Order::Back, 0)))
        .collect();
    let sweep = [0, 2, 4, 8, 16];
    let bar = crate::bench::frames_bar(
        (sequences.len() * orders.len() * CONFIGS.len() + sweep.len()) as u64,
    );
    let header = crate::bench::Header::new("online-culling", gpu, cpu_figures, size);
    let report = |rows: Vec<Row>, complete: bool| Report {
        header: header.clone(),
        k: K,
        complete,
        rows,
    };
    let write_so_far = |rows: Vec<Row>| {
        let so_far = report(rows, false);
        crate::write_results_so_far(dir, "online-culling", &so_far, csv(&so_far));
        so_far.rows
    };
    let mut rows = Vec::new();
    for seq in &mut sequences {
        for &(order, seed) in &orders {
            for config in &CONFIGS {
                if crate::bench::out_of_time().is_some() {
                    break;
                }
                bar.set_message(format!("{} {} {}", seq.name, order.name(), config.name));
                let opts = options(size, config, order, seed, temporal_default_refresh());
                rows.push(run_one(gpu, seq, &opts, config)?);
                bar.inc(1);
                rows = write_so_far(rows);
            }
        }
    }
    let temporal = &CONFIGS[3];
    for refresh in sweep {
        if crate::bench::out_of_time().is_some() {
            break;
        }
        bar.set_message(format!("refresh {refresh}"));
        let opts = options(size, temporal, Order::Random, 0, refresh);
        let mut row = run_one(gpu, &mut sequences[0], &opts, temporal)?;
        row.sequence += " (refresh sweep)";
        rows.push(row);
        bar.inc(1);
    }
    bar.finish_and_clear();
    // Not complete when --budget-s cut it short.
    let report = report(rows, crate::bench::out_of_time().is_none());
    print(&report);
    crate::write_results(dir, "online-culling", &report, csv(&report))
}

fn temporal_default_refresh() -> u32 {
    strata::methods::kbuffer::temporal::DEFAULT_REFRESH
}

fn csv(r: &Report) -> String {
    type C = Column<'static, Row>;
    let columns = [
        C::csv("sequence", |r| r.sequence.clone()),
        C::csv("triangles", |r| r.triangles.to_string()),
        C::csv("order", |r| r.order.to_string()),
        C::csv("seed", |r| opt(r.seed)),
        C::csv("config", |r| r.config.to_string()),
        C::csv("method", |r| r.method.to_string()),
        C::csv("refresh", |r| opt(r.refresh)),
        C::csv("frames", |r| r.frames.to_string()),
        C::csv("gpu_ms", |r| fixed(r.gpu_ms, 3)),
        C::csv("kendall_tau", |r| fixed(r.kendall_tau, 4)),
        C::csv("fragments", |r| opt(r.fragments)),
        C::csv("culled_temporal_fraction", |r| {
            fixed(r.culled_temporal_fraction, 4)
        }),
        C::csv("lock_failures", |r| r.lock_failures.to_string()),
        C::csv("rmse_max", |r| fixed(r.rmse_max, 5)),
        C::csv("pct_over_2_max", |r| fixed(r.pct_over_2_max, 3)),
    ];
    csv_of(&columns, &r.rows)
}

/// The paper's Table 1 shape: per sequence and configuration, the best (front), the mean of the
/// random orders and the worst (back), with random against both.
fn print(r: &Report) {
    println!(
        "online-culling — {}x{} k = {} on {}",
        r.header.width,
        r.header.height,
        r.k,
        r.header.device()
    );
    println!(
        "{:<34} {:<30} {:>9} {:>9} {:>9} {:>11} {:>11} {:>8} {:>9}",
        "sequence",
        "configuration",
        "front ms",
        "random",
        "back ms",
        "vs front",
        "vs back",
        "culled",
        "RMSE max"
    );
    let mut keys: Vec<(&str, &str)> = Vec::new();
    for row in &r.rows {
        if !row.sequence.ends_with("(refresh sweep)")
            && !keys.contains(&(&row.sequence, row.config))
        {
            keys.push((&row.sequence, row.config));
        }
    }
    for (sequence, config) in keys {
        let of = |order: &str| -> Vec<&Row> {
            r.rows
                .iter()
                .filter(|x| x.sequence == sequence && x.config == config && x.order == order)
                .collect()
        };
        let ms = |rows: &[&Row]| {
            let v: Vec<f64> = rows.iter().filter_map(|x| x.gpu_ms).collect();
            (!v.is_empty()).then(|| v.iter().sum::<f64>() / v.len() as f64)
        };
        let (front, random, back) = (ms(&of("front")), ms(&of("random")), ms(&of("back")));
        let pct = |a: Option<f64>, b: Option<f64>| match (a, b) {
            (Some(a), Some(b)) if b > 0.0 => format!("{:+.1}%", 100.0 * (a / b - 1.0)),
            _ => "-".into(),
        };
        let randoms = of("random");
        let culled = randoms
            .iter()
            .filter_map(|x| x.culled_temporal_fraction)
            .fold(None, |m: Option<f64>, v| Some(m.map_or(v, |m| m.max(v))));
        let rmse = randoms
            .iter()
            .filter_map(|x| x.rmse_max)
            .fold(None, |m: Option<f64>, v| Some(m.map_or(v, |m| m.max(v))));
        let f = |v: Option<f64>| v.map(|v| format!("{v:.2}")).unwrap_or("-".into());
        println!(
            "{:<34} {:<30} {:>9} {:>9} {:>9} {:>11} {:>11} {:>8} {:>9}",
            sequence,
            config,
            f(front),
            f(random),
            f(back),
            pct(random, front),
            pct(random, back),
            culled
                .map(|c| format!("{:.1}%", 100.0 * c))
                .unwrap_or("-".into()),
            rmse.map(|v| format!("{v:.4}")).unwrap_or("-".into()),
        );
    }
    println!("temporal culling's refresh period (balls, random order):");
    for row in r
        .rows
        .iter()
        .filter(|x| x.sequence.ends_with("(refresh sweep)"))
    {
        println!(
            "  refresh {:>2}: {:>8} ms, culled {:>5.1}%, RMSE max {:.4}, pixels over 2/255 max {:.2}%",
            opt(row.refresh),
            row.gpu_ms.map(|v| format!("{v:.2}")).unwrap_or("-".into()),
            100.0 * row.culled_temporal_fraction.unwrap_or(0.0),
            row.rmse_max.unwrap_or(0.0),
            row.pct_over_2_max.unwrap_or(0.0)
        );
    }
}
