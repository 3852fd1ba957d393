//! `strata bench soak --frames N` (issue 65): one long real-time session that changes something
//! every few frames — the method (every method that blends add and multiply materials and takes
//! `--msaa`), k, the size, the scene (another triangle count: the scene buffers are rebuilt) and
//! the sample count (a new recorder: the old one dropped) — recording each frame into an encoder
//! and polling the statistics ring without waiting, as an application does. Every other frame
//! an application with its own shaders and buffers records its frame into the same encoder
//! through its own long-lived recorder (`soak_app`).
//!
//! It checks three things. **Nothing grows**: at checkpoints, the process's resident memory and
//! wgpu's live resources on the device (buffers, textures, bind groups, pipelines and their
//! bytes: `Device::get_internal_counters`, after a tour of two frames of every method at the
//! base settings) are recorded; the largest of the session's second half may exceed the
//! largest of its first by at most 5%.
//! **Every frame's statistics are that frame's**: each report the ring hands back is matched,
//! by its frame number, to what was recorded then (method, k, size); a report of another frame's
//! settings, or for no frame recorded, counts in `mismatched_stats`. **Exact methods stay exact**:
//! at checkpoints the current exact method renders a complete frame on the long-lived recorder,
//! held to the CPU reference at the exact methods' bar, and the application's long-lived
//! recorder renders a complete frame equal to a fresh recorder's.
//!
//! By default 2000 frames at 16² on a CPU device and 20,000 at 64² on a GPU; the long
//! session is `--frames 100000` (about 50 minutes on lavapipe). Writes `soak.json` (`checkpoints` with `frame`, `host_rss_bytes`, `gpu_bytes_live`, the live
//! resource counts and the reference check; `mismatched_stats`) and `soak.csv`.

use std::collections::HashMap;
use std::path::Path;

use serde::Serialize;
use strata::error::{Error, Result};
use strata::frame::FrameStats;
use strata::gpu::Gpu;
use strata::scene::{loaders, Blend, Scene};
use strata::{Effect, FrameRecorder, MethodId, RenderOptions};

use super::soak_app::App;
use crate::bench::{csv_of, opt, print_rows, standalone_setup, Column};
use crate::Size;

/// The experiment `bench soak` runs.
pub const EXPERIMENT: super::Standalone = super::Standalone {
    name: "soak",
    description: "issue 65: a long real-time session switching method, k, size, scene and --msaa every few frames: host and GPU memory at checkpoints (flat from the first half to the second), every frame's statistics matched to its frame, exact methods against the reference at checkpoints",
    run,
};

/// The methods the session cycles through: exact and approximate, lists, arrays, peeling and
/// compute, each taking add and multiply materials and --msaa.
const METHODS: [MethodId; 8] = [
    MethodId::AbufferLl,
    MethodId::KbAbFixed,
    MethodId::KplusHeap,
    MethodId::F2b,
    MethodId::Tiled,
    MethodId::Sbuffer,
    MethodId::Kpeel,
    MethodId::AbufferFixed,
];
const KS: [u32; 3] = [4, 8, 16];
/// Frames between switches of each kind (co-prime, so that the combinations keep changing).
const METHOD_EVERY: u64 = 5;
const K_EVERY: u64 = 7;
const SIZE_EVERY: u64 = 11;
const SCENE_EVERY: u64 = 13;
/// Frames between the application's frames.
const APP_EVERY: u64 = 2;

/// Checkpoints over the session.
const CHECKPOINTS: u64 = 40;
/// How far memory may grow from the session's first half to its second, as a fraction
/// (allocator slack).
const FLAT_BOUND: f64 = 0.05;

#[derive(Serialize, Clone)]
struct Checkpoint {
    frame: u64,
    host_rss_bytes: u64,
    gpu_bytes_live: i64,
    buffers: i64,
    textures: i64,
    bind_groups: i64,
    pipelines: i64,
    method: &'static str,
    samples: u32,
    /// The exact method's complete frame against the reference: `None` for a method not exact
    /// at this k, else whether it met the exact bar.
    equals_reference: Option<bool>,
    /// The application's complete frame on its long-lived recorder equals a fresh recorder's.
    app_equals_fresh: bool,
}

#[derive(Serialize)]
struct Report {
    #[serde(flatten)]
    header: crate::bench::Header,
    frames: u64,
    size: (u32, u32),
    checkpoints: Vec<Checkpoint>,
    /// Reports the ring handed back for another frame's settings, or for no recorded frame.
    mismatched_stats: u64,
    /// Reports matched to their frames.
    matched_stats: u64,
    /// Frames whose statistics the ring skipped (every slot in flight): allowed, counted.
    skipped_stats: u64,
    /// Recorders made (each --msaa switch makes one and drops the last).
    recorders: u64,
    /// Growth of the host's resident memory and of the GPU's live bytes (each sample count
    /// against itself) from the session's first half to its second: the largest checkpoint of
    /// each, as a fraction.
    host_growth: f64,
    gpu_growth: f64,
    /// Checkpoints whose exact frame missed the reference, or whose application frame differed
    /// from a fresh recorder's.
    reference_failures: u64,
    app_failures: u64,
    /// The application's reports matched to its frames, and those that were not.
    app_matched_stats: u64,
    app_mismatched_stats: u64,
    flat: bool,
}

/// The process's resident memory (Linux: /proc/self/status).
fn host_rss_bytes() -> u64 {
    crate::bench::scale::host_memory()
        .0
        .map_or(0, |mib| (mib * 1048576.0) as u64)
}

/// The two scenes the session swaps between: layered quads with add and multiply materials,
/// and nested spheres (another triangle count, so the scene buffers are rebuilt).
fn scenes() -> Result<[Scene; 2]> {
    let mut layers = loaders::load_scene("builtin:layers?n=6&coverage=0.8&order=random&seed=3")?;
    for (i, m) in layers.materials.iter_mut().enumerate() {
        m.blend = [Blend::Over, Blend::Add, Blend::Multiply][i % 3];
    }
    let mut spheres = loaders::load_scene("builtin:spheres?layers=4&segments=12")?;
    // A recorder keeps its camera when the geometry changes (set_geometry replaces triangles).
    spheres.camera = layers.camera;
    Ok([layers, spheres])
}

/// What a frame was recorded with, to match its statistics against.
#[derive(Clone, Copy, PartialEq, Debug)]
struct Recorded {
    method: MethodId,
    k: Option<u32>,
    size: (u32, u32),
}

struct Session<'g> {
    gpu: &'g Gpu,
    scenes: [Scene; 2],
    base: (u32, u32),
    samples: u32,
    recorder: FrameRecorder,
    scene: usize,
    recorded: HashMap<u64, Recorded>,
    mismatched: u64,
    matched: u64,
    skipped_before: u64,
    recorders: u64,
    /// Frames between --msaa switches: an eighth of the session, so that each half has seen
    /// both sample counts, twice.
    samples_every: u64,
    /// The application's capture path, recorded into the same encoders every APP_EVERY frames.
    app: App,
}

impl<'g> Session<'g> {
    fn options(&self, frame: u64) -> RenderOptions {
        let mut options = RenderOptions::sized(self.base.0, self.base.1);
        options.frame.effect = Effect::Transparency;
        options.frame.k = Some(KS[((frame / K_EVERY) % KS.len() as u64) as usize]);
        options.build.msaa = self.samples;
        options
    }

    fn new(gpu: &'g Gpu, base: (u32, u32), frames: u64) -> Result<Session<'g>> {
        let scenes = scenes()?;
        let mut options = RenderOptions::sized(base.0, base.1);
        options.frame.k = Some(KS[0]);
        let recorder = FrameRecorder::new(gpu, &scenes[0], METHODS[0], &options)?;
        Ok(Session {
            gpu,
            scenes,
            base,
            samples: 1,
            recorder,
            scene: 0,
            recorded: HashMap::new(),
            mismatched: 0,
            matched: 0,
            skipped_before: 0,
            recorders: 1,
            samples_every: (frames / 8).max(1),
            app: App::new(gpu, base)?,
        })
    }

    /// Applies frame `frame`'s switches.
    fn switch(&mut self, frame: u64) -> Result<()> {
        if frame > 0 && frame.is_multiple_of(self.samples_every) {
            self.drain()?;
            self.samples = if self.samples == 1 { 4 } else { 1 };
            let options = self.options(frame);
            self.skipped_before += self.recorder.skipped_stats();
            let next = FrameRecorder::new(
                self.gpu,
                &self.scenes[self.scene],
                self.recorder.method(),
                &options,
            )?;
            // The last recorder is dropped here: what it held must go with it.
            self.recorder = next;
            self.recorders += 1;
            self.recorded.clear();
        }
        if frame.is_multiple_of(METHOD_EVERY) {
            let m = METHODS[((frame / METHOD_EVERY) % METHODS.len() as u64) as usize];
            self.recorder.set_method(m)?;
        }
        if frame.is_multiple_of(SCENE_EVERY) {
            self.scene = 1 - self.scene;
            self.recorder.set_geometry(&self.scenes[self.scene])?;
        }
        let mut frame_options = self.options(frame).frame;
        if (frame / SIZE_EVERY) % 2 == 1 {
            frame_options.width = self.base.0 * 2 - 8;
            frame_options.height = self.base.1 + 8;
        }
        self.recorder.set_frame_options(&frame_options)
    }

    /// What the recorder records with now.
    fn now(&self) -> Recorded {
        let options = self.recorder.options();
        Recorded {
            method: self.recorder.method(),
            k: options.frame.k,
            size: (options.frame.width, options.frame.height),
        }
    }

    /// Records a frame, and with `with_app` the application's frame after it into the same
    /// encoder, and submits them; matches whatever statistics came back.
    fn frame(&mut self, with_app: bool) -> Result<()> {
        let mut encoder = self.gpu.device.create_command_encoder(&Default::default());
        let n = self
            .recorder
            .record(&mut encoder, &Default::default(), None)?;
        if with_app {
            self.app.record(&mut encoder)?;
        }
        self.gpu.queue.submit([encoder.finish()]);
        self.recorded.insert(n, self.now());
        let done = self.recorder.poll_stats();
        self.check(done);
        self.app.poll();
        Ok(())
    }

    fn check(&mut self, done: Vec<FrameStats>) {
        for stats in done {
            let recorded = self.recorded.remove(&stats.frame);
            let matches = recorded.is_some_and(|r| {
                r.method.as_str() == stats.method
                    && (stats.k.is_none() || stats.k == r.k)
                    && r.size == (stats.width, stats.height)
            });
            match matches {
                true => self.matched += 1,
                false => self.mismatched += 1,
            }
        }
    }

    /// Waits for every frame in flight and matches its statistics.
    fn drain(&mut self) -> Result<()> {
        self.gpu.wait()?;
        let done = self.recorder.poll_stats();
        self.check(done);
        self.app.poll();
        Ok(())
    }

    /// A complete frame of the current exact method on this recorder, against the reference.
    fn reference_check(&mut self) -> Result<Option<bool>> {
        let method = self.recorder.method();
        if !method.descriptor().exact {
            return Ok(None);
        }
        self.drain()?;
        // The frames render_once records are this recorder's too, with the same settings (it
        // consumes their statistics itself).
        let first = self.recorder.next_frame();
        let stats = self.recorder.render_once(&Default::default(), None)?;
        for n in first..self.recorder.next_frame() {
            self.recorded.insert(n, self.now());
        }
        let picture = self.recorder.picture()?;
        let mut options = self.recorder.options().clone();
        // What the frame says it is (strata decides exactness in one place): the whole scene's
        // picture, or each pixel's k nearest (`reference --k`).
        match (stats.exact, stats.exact_k_nearest) {
            (Some(true), _) => options.frame.k = None,
            (_, Some(true)) => {}
            _ => return Ok(Some(false)),
        }
        let (expected, _) = strata::reference::render(&self.scenes[self.scene], &options)?;
        let effect = options.frame.effect;
        let ok = strata::metrics::testing::check_image(
            "soak",
            &picture.to_rgba8(effect),
            &expected.to_rgba8(effect),
            2,
            0.001,
        )
        .is_ok();
        Ok(Some(ok))
    }
}

impl Session<'_> {
    /// Two frames of every method at the base size, k and scene (the second's pools sized from
    /// the first's need), what is then live on the device, and back to where the session was:
    /// the same state at every checkpoint, so that a leak shows as growth between tours.
    fn tour(&mut self) -> Result<wgpu::HalCounters> {
        let (method, scene) = (self.recorder.method(), self.scene);
        let options = self.recorder.options().frame.clone();
        let mut base = self.options(0).frame;
        base.k = Some(KS[1]);
        self.recorder.set_frame_options(&base)?;
        if scene != 0 {
            self.scene = 0;
            self.recorder.set_geometry(&self.scenes[0])?;
        }
        for m in METHODS {
            self.recorder.set_method(m)?;
            self.frame(false)?;
            self.frame(false)?;
        }
        self.app.tour()?;
        self.drain()?;
        let live = self.gpu.device.get_internal_counters().hal;
        if scene != 0 {
            self.scene = scene;
            self.recorder.set_geometry(&self.scenes[scene])?;
        }
        self.recorder.set_method(method)?;
        self.recorder.set_frame_options(&options)?;
        Ok(live)
    }
}

fn checkpoint(session: &mut Session<'_>, frame: u64) -> Result<Checkpoint> {
    let equals_reference = session.reference_check()?;
    let app_equals_fresh = session.app.equals_fresh()?;
    let c = session.tour()?;
    Ok(Checkpoint {
        frame,
        host_rss_bytes: host_rss_bytes(),
        gpu_bytes_live: (c.buffer_memory.read() + c.texture_memory.read()) as i64,
        buffers: c.buffers.read() as i64,
        textures: c.textures.read() as i64,
        bind_groups: c.bind_groups.read() as i64,
        pipelines: (c.render_pipelines.read() + c.compute_pipelines.read()) as i64,
        method: session.recorder.method().as_str(),
        samples: session.samples,
        equals_reference,
        app_equals_fresh,
    })
}

/// How far the largest value of the session's second half exceeds the largest of its first,
/// as a fraction, among the checkpoints `keep` takes. Pools that follow a frame's need go up
/// and down with what the session switches to (and start over with each recorder), so single
/// checkpoints differ; what a leak does is grow from one half to the next.
fn growth(
    points: &[Checkpoint],
    keep: impl Fn(&Checkpoint) -> bool,
    value: impl Fn(&Checkpoint) -> f64,
) -> f64 {
    let half = points.len() / 2;
    let largest = |range: &[Checkpoint]| {
        range
            .iter()
            .filter(|c| keep(c))
            .map(&value)
            .fold(0.0, f64::max)
    };
    let (first, second) = (largest(&points[..half]), largest(&points[half..]));
    match first > 0.0 {
        true => (second - first).max(0.0) / first,
        false => 0.0,
    }
}

fn run(gpu: &Gpu, size: Option<Size>, frames: Option<u32>, dir: &Path) -> Result<()> {
    let (cpu_figures, base, frames) =
        standalone_setup(gpu, size, frames, ((16, 16), (64, 64)), (2000, 20_000))?;
    let frames = frames as u64;
    if frames < CHECKPOINTS {
        return Err(Error::input(format!(
            "bench soak needs --frames of at least {CHECKPOINTS} (one per checkpoint)"
        )));
    }
    crate::check_results_dir(dir)?;
    let mut session = Session::new(gpu, base, frames)?;
    // Not a multiple of the method's period, so that checkpoints meet every method.
    let mut every = frames / CHECKPOINTS;
    if every.is_multiple_of(METHOD_EVERY) {
        every += 1;
    }
    let bar = crate::bench::frames_bar(frames);
    let mut checkpoints = Vec::new();
    for frame in 0..frames {
        session.switch(frame)?;
        session.frame(frame.is_multiple_of(APP_EVERY))?;
        if (frame + 1) % every == 0 {
            let c = checkpoint(&mut session, frame + 1)?;
            // A long session's curve so far, should it be cut short.
            bar.println(format!(
                "soak: frame {} host {:.1} MiB, GPU {:.3} MiB live, {} buffers, {} bind groups, {} pipelines, statistics matched {} mismatched {}, reference {:?}",
                c.frame,
                c.host_rss_bytes as f64 / 1048576.0,
                c.gpu_bytes_live as f64 / 1048576.0,
                c.buffers,
                c.bind_groups,
                c.pipelines,
                session.matched,
                session.mismatched,
                c.equals_reference
            ));
            checkpoints.push(c);
        }
        bar.inc(1);
    }
    bar.finish_and_clear();
    session.drain()?;
    let host_growth = growth(&checkpoints, |_| true, |c| c.host_rss_bytes as f64);
    // A multisampled recorder keeps more: each sample count against itself.
    let gpu_growth = [1, 4]
        .into_iter()
        .map(|s| {
            growth(
                &checkpoints,
                |c| c.samples == s,
                |c| c.gpu_bytes_live as f64,
            )
        })
        .fold(0.0, f64::max);
    let reference_failures = checkpoints
        .iter()
        .filter(|c| c.equals_reference == Some(false))
        .count() as u64;
    let app_failures = checkpoints.iter().filter(|c| !c.app_equals_fresh).count() as u64;
    let report = Report {
        header: crate::bench::Header::new("soak", gpu, cpu_figures, base),
        frames,
        size: base,
        mismatched_stats: session.mismatched,
        matched_stats: session.matched,
        skipped_stats: session.skipped_before + session.recorder.skipped_stats(),
        recorders: session.recorders,
        host_growth,
        gpu_growth,
        reference_failures,
        app_failures,
        app_matched_stats: session.app.matched,
        app_mismatched_stats: session.app.mismatched,
        flat: host_growth <= FLAT_BOUND && gpu_growth <= FLAT_BOUND,
        checkpoints,
    };
    type C = Column<'static, Checkpoint>;
    let columns: Vec<C> = vec![
        C::csv("frame", |c| c.frame.to_string()).shown("frame", 8),
        C::csv("host_rss_mib", |c| {
            format!("{:.1}", c.host_rss_bytes as f64 / 1048576.0)
        })
        .shown("RSS MiB", 8),
        C::csv("gpu_live_mib", |c| {
            format!("{:.2}", c.gpu_bytes_live as f64 / 1048576.0)
        })
        .shown("GPU MiB", 8),
        C::csv("buffers", |c| c.buffers.to_string()).shown("buffers", 8),
        C::csv("bind_groups", |c| c.bind_groups.to_string()).shown("groups", 7),
        C::csv("pipelines", |c| c.pipelines.to_string()).shown("pipelines", 9),
        C::csv("method", |c| c.method.to_string()).shown("method", 14),
        C::csv("samples", |c| c.samples.to_string()).shown("msaa", 4),
        C::csv("reference", |c| opt(c.equals_reference)).shown("exact", 6),
        C::csv("app_equals_fresh", |c| c.app_equals_fresh.to_string()).shown("app", 5),
    ];
    print_rows(&columns, &report.checkpoints, |_| None);
    println!(
        "soak: {frames} frames at {}x{}, {} recorders; statistics matched {} mismatched {} skipped {}; the application's matched {} mismatched {}; host memory grew {:.1}%, GPU memory {:.1}% from the first half to the second ({}); {} reference checks failed, {} application checks",
        base.0,
        base.1,
        report.recorders,
        report.matched_stats,
        report.mismatched_stats,
        report.skipped_stats,
        report.app_matched_stats,
        report.app_mismatched_stats,
        host_growth * 100.0,
        gpu_growth * 100.0,
        if report.flat { "flat" } else { "NOT flat" },
        reference_failures,
        app_failures
    );
    crate::write_results(dir, "soak", &report, csv_of(&columns, &report.checkpoints))?;
    let mismatched = report.mismatched_stats + report.app_mismatched_stats;
    if mismatched > 0 || reference_failures > 0 || app_failures > 0 || !report.flat {
        return Err(Error::runtime(format!(
            "soak failed: {mismatched} mismatched statistics, {reference_failures} reference checks and {app_failures} application checks failed, memory {}",
            if report.flat { "flat" } else { "grew" }
        )));
    }
    Ok(())
}
