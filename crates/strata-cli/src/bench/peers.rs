//! `strata bench peers` (issue 16): strata against the transparency a user's engine already has,
//! on the same scenes, the same machine and in the same run.
//!
//! Each scene is prepared once (unlit materials, one solid background, no lit pipeline, so the
//! peers and strata draw the same thing), written with `strata export` to a temporary glTF file,
//! and rendered by the exact CPU reference. Then:
//! - strata's nearest equivalents run as every experiment does (`bench::measure`: real-time
//!   frames, GPU timestamps) and render one picture: abuffer-ll (exact), kb-ab-ll and kplus-heap
//!   at k = 8 with the tail blended (what Bevy's OIT does by default: 8 sorted layers, the rest
//!   blended), wboit (against pygfx's weighted blend) and unsorted (against pygfx's blend);
//! - each peer renders the exported file through its harness in `peers/`: pygfx 0.17's `blend`,
//!   `weighted_blend`, `dither` and `bayer` alpha modes (`peers/pygfx_oit.py`, wall-clock ms per
//!   frame from render to the GPU's completion: pygfx has no GPU timestamps), and Bevy 0.19's
//!   order-independent transparency at its default 8 layers (`peers/bevy-oit`, a headless Bevy
//!   app; GPU ms from Bevy's render diagnostics where the device has timestamps).
//!
//! Every harness takes the same arguments (`SCENE.glb [its own] --background --size --frames
//! --warmup -o PNG --json JSON`) and writes its timings and version as JSON. Every picture's
//! error against the reference (RMSE, FLIP, % of pixels over 2/255) is recorded and the pictures
//! are written beside the results. A peer that is not installed or built (`peers/setup`) is
//! recorded as skipped with the reason.

use crate::bench::{csv_of, fixed, opt, print_rows, scene_column, Column};
use std::path::{Path, PathBuf};
use std::process::Command;
use strata::KBufferOptions;

use serde::Serialize;
use strata::error::{Error, Result};
use strata::gpu::Gpu;
use strata::metrics::Comparison;
use strata::render::Renderer;
use strata::Tail;

use crate::bench::{measure, standalone_setup, Run};
use crate::{prepare, PictureArgs, PipelineArg};

/// The experiment `bench peers` runs.
pub const EXPERIMENT: super::Standalone = super::Standalone {
    name: "peers",
    description: "issue 16: strata against its peers on the same scenes: Bevy 0.19's OIT (peers/bevy-oit) and pygfx 0.17's blend, weighted_blend, dither and bayer (peers/pygfx_oit.py) against abuffer-ll, kb-ab-ll and kplus-heap at k = 8 with tail blend (Bevy's default shape), wboit and unsorted on nvpro, the dragon (opacity 0.5), the demo and balls, unlit on one background: ms, memory, error against the reference, pictures",
    run,
};

/// The scenes and the opacity each is drawn at (the dragon is opaque by default).
const SCENES: [(&str, Option<f32>); 4] = [
    ("builtin:nvpro?objects=1024&subdiv=16&seed=0", None),
    ("builtin:dragon", Some(0.5)),
    ("builtin:demo", None),
    ("builtin:balls", None),
];

/// The background every renderer draws (pygfx has no checkerboard).
pub const BACKGROUND: &str = "#333333";

const PYGFX_MODES: [&str; 4] = ["blend", "weighted_blend", "dither", "bayer"];

/// Bevy OIT's layer count in the comparison: its default.
pub const BEVY_LAYERS: u32 = 8;
/// Bevy's fragment pool, in fragments per pixel on average, for the run that gives it enough
/// (its default is 4; nvpro at 1024 objects averages about 10 per pixel, 86 at most).
pub const BEVY_DEEP_POOL: u32 = 24;

/// A peer's harness and one of its configurations.
struct PeerRun {
    /// The peer's name (`pygfx`, `bevy`).
    peer: &'static str,
    /// Its mode (pygfx's alpha mode; `oit` for Bevy).
    mode: &'static str,
    /// The program and the arguments before the scene's, or why the peer cannot run.
    harness: std::result::Result<(PathBuf, Vec<String>), String>,
    /// Arguments after the common ones.
    extra: Vec<String>,
    label: String,
}

/// Every peer configuration of the comparison, each with its harness found (or not).
fn peer_runs(peers: &Path) -> Vec<PeerRun> {
    let python = PYGFX_PYTHON.find(peers).map(|python| {
        (
            python,
            vec![peers.join("pygfx_oit.py").to_string_lossy().into_owned()],
        )
    });
    let mut runs: Vec<PeerRun> = PYGFX_MODES
        .iter()
        .map(|&mode| PeerRun {
            peer: "pygfx",
            mode,
            harness: python.clone(),
            extra: vec!["--mode".into(), mode.into()],
            label: format!("pygfx {mode}"),
        })
        .collect();
    let bevy = BEVY_HARNESS
        .find(peers)
        .map(|program| (program, Vec::new()));
    // Bevy's defaults (its fragment pool holds 4 fragments per pixel on average: deeper scenes
    // lose fragments), and a pool deep enough for the scenes here.
    for fragments_per_pixel in [None, Some(BEVY_DEEP_POOL)] {
        let mut extra = vec!["--layers".into(), BEVY_LAYERS.to_string()];
        let mut label = format!("bevy oit layers={BEVY_LAYERS}");
        if let Some(f) = fragments_per_pixel {
            extra.extend(["--fragments-per-pixel".into(), f.to_string()]);
            label += &format!(" fpp={f}");
        }
        runs.push(PeerRun {
            peer: "bevy",
            mode: "oit",
            harness: bevy.clone(),
            extra,
            label,
        });
    }
    runs
}

/// Where a peer's program is found: the path in environment variable `var`, else `built` under
/// the peers' folder when that is a file.
struct PeerProgram {
    var: &'static str,
    built: &'static str,
    /// What the error says is missing, and the arguments of the `setup` that makes it.
    missing: &'static str,
    setup_args: &'static str,
}

/// The Python that has pygfx: `STRATA_PEERS_PYTHON`, else `peers/.venv/bin/python`.
const PYGFX_PYTHON: PeerProgram = PeerProgram {
    var: "STRATA_PEERS_PYTHON",
    built: ".venv/bin/python",
    missing: "pygfx is not installed",
    setup_args: "",
};

/// Bevy's harness: `STRATA_BEVY_OIT`, else `peers/bevy-oit/target/release/bevy-oit`.
const BEVY_HARNESS: PeerProgram = PeerProgram {
    var: "STRATA_BEVY_OIT",
    built: "bevy-oit/target/release/bevy-oit",
    missing: "Bevy's harness is not built",
    setup_args: " --bevy",
};

impl PeerProgram {
    fn find(&self, peers: &Path) -> std::result::Result<PathBuf, String> {
        if let Some(p) = std::env::var_os(self.var) {
            return Ok(PathBuf::from(p));
        }
        let built = peers.join(self.built);
        if built.is_file() {
            Ok(built)
        } else {
            Err(format!(
                "{}: run {}/setup{} (or set {})",
                self.missing,
                peers.display(),
                self.setup_args,
                self.var
            ))
        }
    }
}

/// strata's configurations: label, method, k, tail.
const STRATA_RUNS: [(&str, &str, Option<u32>, Tail); 5] = [
    ("abuffer-ll", "abuffer-ll", None, Tail::Drop),
    ("kb-ab-ll k=8 tail=blend", "kb-ab-ll", Some(8), Tail::Blend),
    (
        "kplus-heap k=8 tail=blend",
        "kplus-heap",
        Some(8),
        Tail::Blend,
    ),
    ("wboit", "wboit", None, Tail::Drop),
    ("unsorted", "unsorted", None, Tail::Drop),
];

#[derive(Serialize)]
struct Row {
    scene: String,
    alpha: Option<f32>,
    /// `strata` or the peer's name.
    renderer: String,
    label: String,
    /// strata's method id, or the peer's mode.
    method: String,
    /// Median GPU ms per frame (timestamp queries); null where the renderer exposes none.
    median_gpu_ms: Option<f64>,
    /// Median wall-clock ms per frame: strata's steady loop with two frames in flight; a peer's
    /// render-to-GPU-completion, one frame at a time.
    median_wall_ms: Option<f64>,
    /// Bytes of GPU memory the method allocated; null where unknown (peers).
    bytes_allocated: Option<u64>,
    fragments_dropped: Option<u64>,
    error_vs_reference: Option<Comparison>,
    /// The picture, beside the results.
    picture: Option<String>,
    /// Why the configuration was not measured; null when it was.
    skipped: Option<String>,
}

impl Row {
    /// A configuration with nothing measured yet.
    fn new(scene: &str, alpha: Option<f32>, renderer: &str, label: &str, method: &str) -> Row {
        Row {
            scene: scene.into(),
            alpha,
            renderer: renderer.into(),
            label: label.into(),
            method: method.into(),
            median_gpu_ms: None,
            median_wall_ms: None,
            bytes_allocated: None,
            fragments_dropped: None,
            error_vs_reference: None,
            picture: None,
            skipped: None,
        }
    }
}

#[derive(Serialize)]
struct Report {
    #[serde(flatten)]
    header: crate::bench::Header,
    frames: u32,
    background: &'static str,
    /// Each peer's version and adapter, as its harness reported them.
    peers: Vec<serde_json::Value>,
    rows: Vec<Row>,
}

/// Where the peers' harnesses live: `STRATA_PEERS_DIR`, else `peers/` under the working
/// directory, else the source tree's.
fn peers_dir() -> PathBuf {
    if let Some(dir) = std::env::var_os("STRATA_PEERS_DIR") {
        return PathBuf::from(dir);
    }
    let here = PathBuf::from("peers");
    if here.join("pygfx_oit.py").is_file() {
        return here;
    }
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../peers")
}

pub fn run(gpu: &Gpu, size: Option<crate::Size>, frames: Option<u32>, dir: &Path) -> Result<()> {
    run_scenes(gpu, &SCENES, size, frames, dir)
}

/// [`run`] over `scenes`.
fn run_scenes(
    gpu: &Gpu,
    scenes: &[(&str, Option<f32>)],
    size: Option<crate::Size>,
    frames: Option<u32>,
    dir: &Path,
) -> Result<()> {
    let (cpu_figures, (width, height), frames) =
        standalone_setup(gpu, size, frames, ((192, 192), (1024, 1024)), (5, 20))?;
    let warmup = 2;
    std::fs::create_dir_all(dir)
        .map_err(|e| Error::input(format!("cannot create '{}': {e}", dir.display())))?;
    let scratch = std::env::temp_dir().join(format!("strata-peers-{}", std::process::id()));
    std::fs::create_dir_all(&scratch)
        .map_err(|e| Error::runtime(format!("cannot create '{}': {e}", scratch.display())))?;
    let peers = peers_dir();
    let peer_runs = peer_runs(&peers);
    let per_scene = (STRATA_RUNS.len() + peer_runs.len()) as u64;
    let bar = crate::bench::frames_bar(scenes.len() as u64 * per_scene);
    let mut rows = Vec::new();
    let mut peer_info: Vec<serde_json::Value> = Vec::new();
    let result = (|| -> Result<()> {
        for &(spec, alpha) in scenes {
            let short = crate::bench::short_scene(spec).trim_start_matches("builtin:");
            let picture = PictureArgs {
                size: Some(crate::Size::new(width, height)),
                shading: Some(strata::scene::Shading::Unlit),
                background: Some(BACKGROUND.parse().expect("a color")),
                pipeline: Some(PipelineArg::None),
                alpha,
                ..PictureArgs::for_scene(spec)
            };
            let (scene, options) = prepare(&picture)?;
            let glb = scratch.join(format!("{short}.glb"));
            let defaults = strata::scene::export::ExportDefaults {
                size: Some([width, height]),
                background: Some(options.frame.background),
            };
            let bytes = strata::scene::export::to_gltf(
                &scene,
                &defaults,
                strata::scene::export::GltfContainer::Glb,
            )?;
            std::fs::write(&glb, bytes)
                .map_err(|e| Error::runtime(format!("cannot write '{}': {e}", glb.display())))?;
            bar.set_message(format!("{short}: reference"));
            let truth = strata::reference::render(&scene, &options)?
                .0
                .to_rgba8(options.frame.effect);
            let save = |label: &str, img: &image::RgbaImage| -> Result<String> {
                let name = format!("peers-{short}-{}.png", label.replace([' ', '='], "-"));
                strata::render::save_png(img, &dir.join(&name))?;
                Ok(name)
            };
            save("reference", &truth)?;

            for (label, method, k, tail) in STRATA_RUNS {
                bar.set_message(format!("{short}: strata {label}"));
                let mut options = options.clone();
                options.frame.k = k;
                options.frame.family_mut::<KBufferOptions>().tail = tail;
                let run = match k {
                    Some(k) => Run::with_k(method, k, true),
                    None => Run::plain(method),
                };
                let quiet = indicatif::ProgressBar::hidden();
                let mut row = Row::new(spec, alpha, "strata", label, method);
                match measure(gpu, &scene, &options, &run, warmup, frames, &quiet) {
                    Ok((m, _)) => {
                        let (image, _) = Renderer::new(gpu, &scene, &options)?.render(method)?;
                        let img = image.to_rgba8(options.frame.effect);
                        row.median_gpu_ms = m.median_gpu_ms;
                        row.median_wall_ms = Some(m.median_wall_ms);
                        row.bytes_allocated = m.bytes_allocated;
                        row.fragments_dropped = m.fragments_dropped;
                        row.error_vs_reference = Some(strata::metrics::compare(&truth, &img)?);
                        row.picture = Some(save(label, &img)?);
                    }
                    Err(Error::Unsupported(why)) => row.skipped = Some(why),
                    Err(e) => return Err(e),
                }
                rows.push(row);
                bar.inc(1);
            }

            for peer in &peer_runs {
                bar.set_message(format!("{short}: {}", peer.label));
                let mut row = Row::new(spec, alpha, peer.peer, &peer.label, peer.mode);
                match &peer.harness {
                    Err(why) => row.skipped = Some(why.clone()),
                    Ok((program, before)) => {
                        let stem = peer.label.replace([' ', '='], "-");
                        let png = scratch.join(format!("{short}-{stem}.png"));
                        let json = scratch.join(format!("{short}-{stem}.json"));
                        let mut args = before.clone();
                        args.push(glb.to_string_lossy().into_owned());
                        args.extend(peer.extra.iter().cloned());
                        match run_harness(
                            peer.peer,
                            program,
                            &args,
                            (width, height),
                            (frames, warmup),
                            &png,
                            &json,
                        ) {
                            Err(why) => row.skipped = Some(why),
                            Ok(timings) => {
                                let img = image::open(&png)
                                    .map_err(|e| {
                                        Error::runtime(format!(
                                            "{}'s picture '{}': {e}",
                                            peer.peer,
                                            png.display()
                                        ))
                                    })?
                                    .to_rgba8();
                                row.median_wall_ms =
                                    timings.get("median_wall_ms").and_then(|v| v.as_f64());
                                row.median_gpu_ms =
                                    timings.get("median_gpu_ms").and_then(|v| v.as_f64());
                                row.error_vs_reference =
                                    Some(strata::metrics::compare(&truth, &img)?);
                                row.picture = Some(save(&peer.label, &img)?);
                                let mut info = timings;
                                if let Some(o) = info.as_object_mut() {
                                    for per_frame in [
                                        "wall_ms",
                                        "gpu_ms",
                                        "mode",
                                        "median_wall_ms",
                                        "median_gpu_ms",
                                    ] {
                                        o.remove(per_frame);
                                    }
                                }
                                if !peer_info.contains(&info) {
                                    peer_info.push(info);
                                }
                            }
                        }
                    }
                }
                rows.push(row);
                bar.inc(1);
            }
        }
        Ok(())
    })();
    let _ = std::fs::remove_dir_all(&scratch);
    bar.finish_and_clear();
    result?;
    let report = Report {
        header: crate::bench::Header::new("peers", gpu, cpu_figures, (width, height)),
        frames,
        background: BACKGROUND,
        peers: peer_info,
        rows,
    };
    print(&report);
    crate::write_results(dir, "peers", &report, csv(&report))
}

/// Runs a peer's harness (`program args... --background --size --frames --warmup -o PNG --json
/// JSON`); its timings JSON, or why it failed (its one error line).
fn run_harness(
    peer: &str,
    program: &Path,
    args: &[String],
    (width, height): (u32, u32),
    (frames, warmup): (u32, u32),
    png: &Path,
    json: &Path,
) -> std::result::Result<serde_json::Value, String> {
    let out = Command::new(program)
        .args(args)
        .args(["--background", BACKGROUND])
        .args(["--size", &format!("{width}x{height}")])
        .args([
            "--frames",
            &frames.to_string(),
            "--warmup",
            &warmup.to_string(),
        ])
        .arg("-o")
        .arg(png)
        .arg("--json")
        .arg(json)
        .output()
        .map_err(|e| format!("cannot run {}: {e}", program.display()))?;
    if !out.status.success() {
        let err = String::from_utf8_lossy(&out.stderr);
        let line = err
            .lines()
            .rev()
            .find(|l| !l.trim().is_empty())
            .unwrap_or("no message");
        return Err(format!("{peer} harness failed: {}", line.trim()));
    }
    let text = std::fs::read_to_string(json).map_err(|e| format!("{peer}'s timings: {e}"))?;
    serde_json::from_str(&text).map_err(|e| format!("{peer}'s timings: {e}"))
}

fn columns() -> Vec<Column<'static, Row>> {
    type C = Column<'static, Row>;
    let error = |r: &Row, value: fn(&strata::metrics::Comparison) -> f64, digits| {
        fixed(r.error_vs_reference.as_ref().map(value), digits)
    };
    vec![
        scene_column(|r: &Row| &r.scene),
        C::csv("renderer", |r| r.renderer.clone()),
        C::csv("label", |r| r.label.clone())
            .shown("configuration", 28)
            .left(),
        C::csv("median_gpu_ms", |r| fixed(r.median_gpu_ms, 3))
            .shown_as("GPU ms", 9, |r| fixed(r.median_gpu_ms, 2)),
        C::csv("median_wall_ms", |r| fixed(r.median_wall_ms, 3))
            .shown_as("wall ms", 9, |r| fixed(r.median_wall_ms, 2)),
        C::csv("bytes_allocated", |r| opt(r.bytes_allocated)).shown_as("MiB", 9, |r| {
            fixed(r.bytes_allocated.map(|b| b as f64 / 1048576.0), 1)
        }),
        C::csv("rmse", move |r| error(r, |e| e.rmse, 5))
            .shown_as("RMSE", 8, move |r| error(r, |e| e.rmse, 4)),
        C::csv("flip_mean", move |r| error(r, |e| e.flip_mean, 5))
            .shown_as("FLIP", 7, move |r| error(r, |e| e.flip_mean, 4)),
        C::csv("pct_over_2", move |r| error(r, |e| e.pct_over_2, 3)),
        C::csv("skipped", |r| opt(r.skipped.as_deref()).replace(',', ";")),
    ]
}

fn csv(r: &Report) -> String {
    csv_of(&columns(), &r.rows)
}

fn print(r: &Report) {
    r.header.print_heading(format_args!(
        "{}, background {}, median of {} frames",
        r.header.size(),
        r.background,
        r.frames
    ));
    print_rows(&columns(), &r.rows, |row| row.skipped.clone());
}
