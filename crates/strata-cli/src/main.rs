//! `strata`: render, compare and benchmark multi-fragment methods from the command line.

mod auto_k;
mod bandwidth;
mod bench;
mod claims;
mod compare;
mod convex_experiment;
mod cuda_renderer;
mod deferred_lights;
mod method_options;
mod online_culling;
mod peers;
mod report;
mod scale;
mod suite;
mod view;

use std::path::{Path, PathBuf};
use std::process::ExitCode;

use clap::{Args, CommandFactory, FromArgMatches, Parser, Subcommand, ValueEnum};
use strata::error::{Error, Result};
use strata::frame::{Effect, FrameStats, RenderOptions, Tail};
use strata::gpu::Gpu;
use strata::methods::{self, MethodId};
use strata::output::Outputs;
use strata::render::{save_png, LinearImage, Renderer};
use strata::scene::{loaders, Background, CameraPath, Scene, Shading};

#[derive(Parser)]
#[command(
    name = "strata",
    version,
    about = "Multi-fragment rendering on the GPU: order-independent transparency, translucency, depth complexity"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Render a scene on the GPU with one method.
    Render(RenderArgs),
    /// Render a scene with the exact CPU reference.
    Reference(ReferenceArgs),
    /// Compare two PNG images: RMSE, PSNR, max abs diff, FLIP mean, % pixels over 2/255.
    Compare(CompareArgs),
    /// List every method with its family, exactness, geometry passes and memory.
    Methods {
        /// Print the catalogue as JSON.
        #[arg(long)]
        json: bool,
    },
    /// Report the GPU adapter, backend, driver, features and limits.
    Info {
        /// Print the report as JSON.
        #[arg(long)]
        json: bool,
    },
    /// Depth-complexity histogram of a scene (number of pixels per fragment count).
    Histogram(HistogramArgs),
    /// The convex decomposition `convex` orders (seed 001): parts, groups, nesting, pairs
    /// without a separating plane, this view's passes; --out renders a color per group.
    Convex(ConvexArgs),
    /// Write a scene as glTF 2.0 (.glb, or .gltf with the data embedded): meshes, materials
    /// (alphaMode BLEND), camera and lights, so other renderers draw exactly strata's scene;
    /// strata reloads it to the same picture.
    Export(ExportArgs),
    /// Refresh the generated charts and tables of bench/REPORT.md from bench/results/ (the
    /// hand-written text outside the generated blocks is kept).
    Report(report::ReportArgs),
    /// Benchmark methods: median GPU ms per pass after warm-up.
    Bench(bench::BenchArgs),
    /// Explore the methods live in a window: every option, per-pass timings, statistics, a
    /// diff against the reference.
    View(view::ViewArgs),
}

/// Options shared by everything that makes a picture.
#[derive(Args, Clone, Debug)]
pub struct PictureArgs {
    /// A scene file (.toml, .obj, .ply, .gltf, .glb) or builtin:NAME?key=value&...
    #[arg(default_value = "builtin:demo")]
    pub scene: String,
    /// Image size, WxH (default: the scene's, else 512x512).
    #[arg(long, allow_hyphen_values = true)]
    pub size: Option<String>,
    #[arg(long, value_enum, default_value = "transparency")]
    pub effect: Effect,
    /// unlit | lit: overrides every material's shading.
    #[arg(long)]
    pub shading: Option<String>,
    /// checker | #rrggbb (sRGB)
    #[arg(long)]
    pub background: Option<String>,
    /// Sets every material's opacity.
    #[arg(long)]
    pub alpha: Option<f32>,
    /// Per-pixel capacity for k-buffer methods; for `reference`, keep each pixel's k nearest.
    #[arg(long)]
    pub k: Option<String>,
    /// Animation time in frames: moves the scene's animated objects (builtin:balls) and its
    /// camera path ([[camera_key]] in a scene file, or --orbit).
    #[arg(long)]
    pub frame: Option<f32>,
    /// Camera path: orbit the camera about its target (around its up axis) at DEG degrees per
    /// frame, for any scene; --frame and --frames pick the time.
    #[arg(long, allow_hyphen_values = true)]
    pub orbit: Option<f32>,
    /// Light opaque objects forward (every light per fragment) or deferred (G-buffer and light
    /// volumes), the method drawing only the transparent ones over them; none: every surface,
    /// opaque ones too, through the method. Default: the scene's (builtin:demo: deferred), else
    /// none.
    #[arg(long, value_enum)]
    pub pipeline: Option<PipelineArg>,
    /// Add N coloured point lights, a deterministic field over the scene's bounds.
    #[arg(long, value_parser = clap::value_parser!(u32).range(0..=MAX_LIGHTS as i64))]
    pub lights: Option<u32>,
    /// The lit pipelines' tone map (neutral: colors below 0.8 unchanged, highlights roll off).
    #[arg(long, value_enum, default_value = "neutral")]
    pub tonemap: strata::frame::Tonemap,
    /// Camera position X,Y,Z (default: the scene's camera, else auto-framed).
    #[arg(long, value_parser = parse_vec3, allow_hyphen_values = true)]
    pub eye: Option<[f32; 3]>,
    /// The point the camera looks at, X,Y,Z.
    #[arg(long, value_parser = parse_vec3, allow_hyphen_values = true)]
    pub target: Option<[f32; 3]>,
    /// The camera's up direction, X,Y,Z.
    #[arg(long, value_parser = parse_vec3, allow_hyphen_values = true)]
    pub up: Option<[f32; 3]>,
    /// Vertical field of view in degrees (perspective cameras), in (0, 180).
    #[arg(long)]
    pub fov: Option<f32>,
    /// Samples per pixel: 1, or 4 and 8 for multisample anti-aliasing at the standard sample
    /// positions (fragments shaded once per pixel, composited per sample; every method but
    /// kb-mdt64 and kb-mdt-pack, and the reference). 8 where the device has it (lavapipe: 4).
    #[arg(long, default_value_t = 1)]
    pub msaa: u32,
}

impl PictureArgs {
    /// The picture options' defaults for `scene` (what the command line gives without options).
    pub fn for_scene(scene: impl Into<String>) -> PictureArgs {
        PictureArgs {
            scene: scene.into(),
            size: None,
            effect: Effect::Transparency,
            shading: None,
            background: None,
            alpha: None,
            k: None,
            frame: None,
            orbit: None,
            pipeline: None,
            lights: None,
            tonemap: Default::default(),
            eye: None,
            target: None,
            up: None,
            fov: None,
            msaa: 1,
        }
    }
}

/// `X,Y,Z` as three finite numbers.
pub fn parse_vec3(s: &str) -> std::result::Result<[f32; 3], String> {
    let v: Vec<f32> = s
        .split(',')
        .map(|c| c.trim().parse::<f32>())
        .collect::<std::result::Result<_, _>>()
        .map_err(|_| format!("'{s}' is not X,Y,Z (three numbers)"))?;
    match v[..] {
        [x, y, z] if v.iter().all(|c| c.is_finite()) => Ok([x, y, z]),
        _ => Err(format!("'{s}' is not X,Y,Z (three finite numbers)")),
    }
}

#[derive(Args)]
struct RenderArgs {
    #[command(flatten)]
    picture: PictureArgs,
    #[command(flatten)]
    method: MethodArgs,
    #[arg(short, long, default_value = "out.png")]
    output: PathBuf,
    /// Write the frame's statistics as JSON (with --frames: one JSON line per frame).
    #[arg(long)]
    stats: Option<PathBuf>,
    /// Render the animation's frames A..B (B excluded) or A..=B, each to -o with its number in a
    /// %d or %0Nd pattern (e.g. -o frame_%04d.png); one renderer for the whole sequence.
    #[arg(long)]
    frames: Option<String>,
}

/// The method and its options (`render` and `view`).
#[derive(Args, Clone, Debug)]
pub struct MethodArgs {
    /// Method id (see `strata methods`).
    #[arg(
        long,
        value_enum,
        default_value = "abuffer-ll",
        hide_possible_values = true
    )]
    pub method: MethodId,
    /// hw: the GPU's rasterizer; compute: strata's compute-shader rasterizer (seed 002), for
    /// the lock-free storage methods (abuffer-fixed, kb-ab-fixed, kb-mdt*, abuffer-ll, kb-ab-ll,
    /// sbuffer, kb-sbuffer, dual, kb, kpeel).
    #[arg(long, value_enum, default_value = "hw")]
    pub raster: strata::frame::Raster,
    /// kpeel: layers captured per geometry pass (seed 002's multi-layer peeling: ⌈N/M⌉ passes;
    /// 1 is depth peeling). The same as --k for kpeel.
    #[arg(long)]
    pub layers_per_pass: Option<u32>,
    /// Memory a method may allocate, MiB.
    #[arg(long)]
    pub budget_mb: Option<f64>,
    /// With --k auto: the fraction of the fragments k must capture, in (0, 1] (default 0.95);
    /// k is the smallest that does within --budget-mb.
    #[arg(long)]
    pub robustness: Option<f64>,
    /// kplus-semiheap: slots of its max-heap (default 1, the paper's); the other k - h are
    /// unordered.
    #[arg(long)]
    pub heap_size: Option<u32>,
    /// bucket: split each pixel's depth range into k/2 equal buckets (uniform, the paper's
    /// method) or share the buckets among the occupied parts of a 1024-part histogram
    /// (adaptive, one more geometry pass).
    #[arg(long, value_enum, default_value = "uniform")]
    pub buckets: strata::BucketSplit,
    /// wboit: the weight function (McGuire & Bavoil 2013, equations 7-10).
    #[arg(long, value_enum, default_value = "eq7")]
    pub weight: strata::Weight,
    /// wboit: multiplies view-space distances before the weight function (its constants assume
    /// distances of 0.1 to 500 units).
    #[arg(long, default_value_t = 1.0)]
    pub depth_scale: f64,
    /// mboit: power moments, 4, 6 or 8 (more follow more layers, at more memory and work).
    #[arg(long, default_value_t = 4)]
    pub moments: u32,
    /// Fragments beyond k (k-buffer methods).
    #[arg(long, value_enum, default_value = "drop")]
    pub tail: Tail,
    /// k-buffers cull fragments behind a full pixel's farthest before taking the lock.
    #[arg(long, value_enum, default_value = "on")]
    pub culling: Toggle,
    /// Spin-lock tries per fragment for the locking k-buffers (default 65536, at most 1048576).
    #[arg(long)]
    pub max_tries: Option<u32>,
    /// Depth peeling (f2b, dual): peel this many layers (default: the scene's depth complexity,
    /// measured by the frame itself).
    #[arg(long)]
    pub layers: Option<u32>,
    /// --pipeline deferred: screen-space ambient occlusion on the ambient term.
    #[arg(long)]
    pub ssao: bool,
    /// --pipeline deferred: the G-buffer's normal encoding.
    #[arg(long, value_enum, default_value = "spheremap")]
    pub normal_encoding: strata::frame::NormalEncoding,
    /// --pipeline deferred: write a G-buffer view instead of the picture.
    #[arg(long, value_enum)]
    pub gbuffer_debug: Option<strata::frame::GbufferView>,
    /// Resubmit the triangles every frame sorted on the GPU by centroid depth (front: nearest
    /// first; back: farthest first), randomly permuted (random), or as the scene lists them
    /// (scene); the statistics report the Kendall distance to depth order.
    #[arg(long, value_enum)]
    pub order: Option<strata::order::Order>,
    /// --order random: the seed its per-frame permutations draw from.
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// Reverse-reprojection culling (seed 000; kplus-array, kplus-heap, kplus-array-r,
    /// kplus-semiheap, kb-ps, kb): each frame culls, before any
    /// lock, fragments that lay behind last frame's (k+1)-th nearest depth. Approximate: the
    /// first frame culls nothing, moving objects can be culled wrongly until their tile
    /// refreshes.
    #[arg(long, value_enum, default_value = "off")]
    pub temporal: Toggle,
    /// --temporal on: frames between refreshes of each 16x16 tile, which then skips culling (0:
    /// never).
    #[arg(long, default_value_t = strata::methods::kbuffer::temporal::DEFAULT_REFRESH)]
    pub temporal_refresh: u32,
    /// --temporal on: window depth a fragment must lie behind the interface to be culled.
    #[arg(long, default_value_t = strata::methods::kbuffer::temporal::DEFAULT_EPSILON)]
    pub temporal_epsilon: f32,
    /// Keep preprocesses (convex's decomposition of a mesh) in DIR between runs: read when
    /// there, written when made.
    #[arg(long)]
    pub cache_dir: Option<PathBuf>,
    /// The options above given on the command line (clap ids), so that those the method does
    /// not read are refused; empty where the options were not parsed from a command line.
    #[arg(skip)]
    pub given: Vec<String>,
}

#[derive(Args)]
struct ReferenceArgs {
    #[command(flatten)]
    picture: PictureArgs,
    #[arg(short, long, default_value = "reference.png")]
    output: PathBuf,
    #[arg(long)]
    stats: Option<PathBuf>,
}

#[derive(Args)]
struct CompareArgs {
    a: PathBuf,
    b: PathBuf,
    /// Write a heatmap of per-pixel differences.
    #[arg(long)]
    diff: Option<PathBuf>,
    /// Print the metrics as JSON.
    #[arg(long)]
    json: bool,
}

#[derive(Args)]
struct HistogramArgs {
    #[arg(default_value = "builtin:demo")]
    scene: String,
    /// Image size, WxH (default: the scene's, else 512x512).
    #[arg(long, allow_hyphen_values = true)]
    size: Option<String>,
    /// Write the histogram as a bar chart PNG (log scale).
    #[arg(long)]
    out: Option<PathBuf>,
    /// Print the histogram as JSON.
    #[arg(long)]
    json: bool,
    /// Count with the CPU reference instead of the GPU (the GPU's check).
    #[arg(long)]
    cpu: bool,
}

#[derive(Args)]
struct ExportArgs {
    /// A scene file (.toml, .obj, .ply, .gltf, .glb) or builtin:NAME?key=value&...
    #[arg(default_value = "builtin:demo")]
    scene: String,
    /// The glTF file to write: .glb, or .gltf with its buffer as a base64 data: URI.
    #[arg(short, long, default_value = "scene.glb")]
    output: PathBuf,
    /// Image size WxH the file records as its picture default (with the camera's aspect ratio).
    #[arg(long, allow_hyphen_values = true)]
    size: Option<String>,
    /// checker | #rrggbb (sRGB): the background the file records as its picture default.
    #[arg(long)]
    background: Option<String>,
    /// unlit | lit: every material's shading (unlit materials get KHR_materials_unlit).
    #[arg(long)]
    shading: Option<String>,
    /// Sets every material's opacity.
    #[arg(long)]
    alpha: Option<f32>,
    /// Animation time in frames: objects and camera are written where they are then.
    #[arg(long)]
    frame: Option<f32>,
    /// Add N coloured point lights, a deterministic field over the scene's bounds.
    #[arg(long, value_parser = clap::value_parser!(u32).range(0..=MAX_LIGHTS as i64))]
    lights: Option<u32>,
    /// Camera position X,Y,Z (default: the scene's camera, else auto-framed).
    #[arg(long, value_parser = parse_vec3, allow_hyphen_values = true)]
    eye: Option<[f32; 3]>,
    /// The point the camera looks at, X,Y,Z.
    #[arg(long, value_parser = parse_vec3, allow_hyphen_values = true)]
    target: Option<[f32; 3]>,
    /// The camera's up direction, X,Y,Z.
    #[arg(long, value_parser = parse_vec3, allow_hyphen_values = true)]
    up: Option<[f32; 3]>,
    /// Vertical field of view in degrees (perspective cameras), in (0, 180).
    #[arg(long)]
    fov: Option<f32>,
}

#[derive(Args)]
struct ConvexArgs {
    /// The model or scene to decompose.
    #[arg(default_value = "builtin:teapot")]
    scene: String,
    /// The view's size, WxH, for its passes and --out (default: the scene's, else 512x512).
    #[arg(long, allow_hyphen_values = true)]
    size: Option<String>,
    /// Render the decomposition to this PNG: one opaque color per group (paired groups
    /// darker), from the scene's camera.
    #[arg(long)]
    out: Option<PathBuf>,
    /// Print the statistics as JSON.
    #[arg(long)]
    json: bool,
    /// Keep the decomposition in DIR: read when there, written when made.
    #[arg(long)]
    cache_dir: Option<PathBuf>,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum Toggle {
    On,
    Off,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum PipelineArg {
    None,
    Forward,
    Deferred,
}

/// A command-line error as one line: clap's first line, with what it lists on the following
/// lines (the missing arguments, the valid values) folded in.
fn one_line(e: &clap::Error) -> String {
    use clap::error::{ContextKind, ContextValue, ErrorKind};
    if e.kind() == ErrorKind::DisplayHelpOnMissingArgumentOrSubcommand {
        let commands: Vec<String> = Cli::command()
            .get_subcommands()
            .map(|c| c.get_name().to_string())
            .collect();
        return format!(
            "a command is required: one of {} (strata --help says what each does)",
            commands.join(", ")
        );
    }
    let rendered = e.render().to_string();
    let first = rendered
        .lines()
        .next()
        .unwrap_or("invalid command line")
        .trim_start_matches("error: ")
        .trim_end_matches(':')
        .to_string();
    let listed = |kind| match e.get(kind) {
        Some(ContextValue::Strings(values)) if !values.is_empty() => Some(values.join(", ")),
        Some(ContextValue::String(value)) if !value.is_empty() => Some(value.clone()),
        _ => None,
    };
    if e.kind() == ErrorKind::MissingRequiredArgument {
        if let Some(missing) = listed(ContextKind::InvalidArg) {
            return format!("{first}: {missing}");
        }
    }
    match listed(ContextKind::ValidValue) {
        Some(values) => format!("{first} (expected one of: {values})"),
        None => first,
    }
}

fn main() -> ExitCode {
    // Rust ignores SIGPIPE, so printing into a closed pipe (`strata bench compare … | head`)
    // would panic; the default action ends the process quietly instead.
    #[cfg(unix)]
    // SAFETY: called before any other thread exists; SIG_DFL is a valid disposition.
    unsafe {
        libc::signal(libc::SIGPIPE, libc::SIG_DFL);
    }
    // Mesa's drivers complain on stderr when this is unset; keep errors to one line.
    if std::env::var_os("XDG_RUNTIME_DIR").is_none() {
        std::env::set_var("XDG_RUNTIME_DIR", std::env::temp_dir());
    }
    let cli = match command().try_get_matches().and_then(|m| {
        let mut cli = Cli::from_arg_matches(&m)?;
        if let (Command::Render(a), Some((_, given))) = (&mut cli.command, m.subcommand()) {
            a.method.given = given_options(given);
        }
        Ok(cli)
    }) {
        Ok(cli) => cli,
        Err(e) if !e.use_stderr() => e.exit(), // --help, --version
        Err(e) => {
            eprintln!("error: {}", one_line(&e));
            return ExitCode::from(2);
        }
    };
    match run(cli.command) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e}");
            match e {
                Error::Input(_) | Error::Unsupported(_) => ExitCode::from(2),
                Error::Runtime(_) => ExitCode::from(1),
            }
        }
    }
}

/// The ids of the options given on the command line (not taken from their defaults).
fn given_options(matches: &clap::ArgMatches) -> Vec<String> {
    matches
        .ids()
        .filter(|id| {
            matches.value_source(id.as_str()) == Some(clap::parser::ValueSource::CommandLine)
        })
        .map(|id| id.as_str().to_string())
        .collect()
}

/// The parser: every option that takes a value accepts a negative number (`--alpha -1`), so its
/// own range check names it, instead of the parser reading `-1` as a flag.
fn command() -> clap::Command {
    fn negative_numbers(cmd: clap::Command) -> clap::Command {
        cmd.mut_args(|arg| {
            if arg.get_action().takes_values() {
                arg.allow_negative_numbers(true)
            } else {
                arg
            }
        })
        .mut_subcommands(negative_numbers)
    }
    negative_numbers(Cli::command())
}

fn run(command: Command) -> Result<()> {
    match command {
        Command::Render(a) => render(a),
        Command::Reference(a) => reference(a),
        Command::Compare(a) => compare(a),
        Command::Methods { json } => list_methods(json),
        Command::Info { json } => info(json),
        Command::Histogram(a) => histogram(a),
        Command::Convex(a) => convex(a),
        Command::Export(a) => export(a),
        Command::Bench(a) => bench::run(a),
        Command::Report(a) => report::run(a),
        Command::View(a) => view::run(a),
    }
}

/// `--lights` stops here: every transparent fragment loops over the whole list.
const MAX_LIGHTS: u32 = 65536;
/// The light field is the same for every run.
const LIGHT_FIELD_SEED: u64 = 1;

pub fn parse_size(s: &str) -> Result<(u32, u32)> {
    let bad = || {
        Error::input(format!(
            "--size '{s}' is not WxH with integers in 1..{} (e.g. 512x512)",
            strata::frame::MAX_SIDE
        ))
    };
    let (w, h) = s.split_once(['x', 'X']).ok_or_else(bad)?;
    let w: u32 = w.trim().parse().map_err(|_| bad())?;
    let h: u32 = h.trim().parse().map_err(|_| bad())?;
    let side = 1..=strata::frame::MAX_SIDE;
    if !side.contains(&w) || !side.contains(&h) {
        return Err(bad());
    }
    Ok((w, h))
}

/// Loads the scene and applies the picture options to it; returns the render options.
pub fn prepare(p: &PictureArgs) -> Result<(Scene, RenderOptions)> {
    let effect = p.effect;
    let (k, k_auto) = match p.k.as_deref() {
        None => (None, None),
        Some("auto") => (
            None,
            Some(strata::methods::kbuffer::predict::DEFAULT_ROBUSTNESS),
        ),
        Some(s) => {
            let k = s.parse::<u32>().ok().filter(|&k| k > 0).ok_or_else(|| {
                Error::input(format!("--k '{s}' is not a positive integer or 'auto'"))
            })?;
            (Some(k), None)
        }
    };
    if let Some(a) = p.alpha {
        if !(0.0..=1.0).contains(&a) {
            return Err(Error::input(format!("--alpha {a} is outside [0, 1]")));
        }
    }
    if let Some(f) = p.frame {
        if !f.is_finite() || f < 0.0 {
            return Err(Error::input(format!(
                "--frame {f} must be a non-negative number"
            )));
        }
    }
    let mut scene = loaders::load_scene(&p.scene)?;
    apply_camera(&mut scene, p)?;
    if let Some(degrees) = p.orbit {
        if matches!(scene.camera_path, Some(CameraPath::Keys { .. })) {
            return Err(Error::input(
                "--orbit replaces this scene's [[camera_key]] path: leave out one of them",
            ));
        }
        scene.camera_path = Some(CameraPath::orbit(scene.camera_or_framing(), degrees)?);
    }
    if let Some(f) = p.frame.or(scene.camera_path.as_ref().map(|_| scene.time)) {
        scene.set_time(f);
    }
    if let Some(a) = p.alpha {
        scene.override_alpha(a);
    }
    if let Some(n) = p.lights {
        if n > MAX_LIGHTS {
            return Err(Error::input(format!(
                "--lights {n} is more than {MAX_LIGHTS}"
            )));
        }
        scene.add_light_field(n, LIGHT_FIELD_SEED);
    }
    let shading = p
        .shading
        .as_deref()
        .map(str::parse::<Shading>)
        .transpose()?
        .or(scene.defaults.shading);
    if let Some(s) = shading {
        scene.override_shading(s);
    }
    let background = match p.background.as_deref() {
        Some(b) => b.parse::<Background>()?,
        None => scene.defaults.background.unwrap_or_default(),
    };
    let (width, height) = match p.size.as_deref() {
        Some(s) => parse_size(s)?,
        None => scene
            .defaults
            .size
            .map(|[w, h]| (w, h))
            .unwrap_or((512, 512)),
    };
    let options = RenderOptions {
        width,
        height,
        effect,
        background,
        k,
        k_auto,
        pipeline: match p.pipeline {
            None => scene.defaults.pipeline,
            Some(PipelineArg::None) => None,
            Some(PipelineArg::Forward) => Some(strata::frame::Pipeline::Forward),
            Some(PipelineArg::Deferred) => Some(strata::frame::Pipeline::Deferred),
        },
        tonemap: p.tonemap,
        msaa: p.msaa,
        ..Default::default()
    };
    options.validate()?;
    Ok((scene, options))
}

/// `--eye`, `--target`, `--up`, `--fov` over the scene's camera (or its framing); `--up` and
/// `--fov` also apply to a camera path's keys, which `--eye` and `--target` cannot override.
fn apply_camera(scene: &mut Scene, p: &PictureArgs) -> Result<()> {
    if p.eye.is_none() && p.target.is_none() && p.up.is_none() && p.fov.is_none() {
        return Ok(());
    }
    if let Some(path) = &mut scene.camera_path {
        if p.eye.is_some() || p.target.is_some() {
            return Err(Error::input(
                "--eye and --target fix the camera, but this scene's [[camera_key]] path moves it: leave them out, or the keys",
            ));
        }
        let mut moved = PictureArgs {
            eye: None,
            target: None,
            ..p.clone()
        };
        moved.scene.clear();
        let mut base = Scene {
            camera: Some(*path.base()),
            ..Scene::default()
        };
        apply_camera(&mut base, &moved)?;
        *path.base_mut() = base.camera.expect("set above");
        return Ok(());
    }
    let mut camera = scene.camera_or_framing();
    if let Some(e) = p.eye {
        camera.eye = e.into();
    }
    if let Some(t) = p.target {
        camera.target = t.into();
    }
    if let Some(u) = p.up {
        camera.up = u.into();
    }
    if let Some(f) = p.fov {
        if !(f > 0.0 && f < 180.0) {
            return Err(Error::input(format!(
                "--fov {f} is outside (0, 180) degrees"
            )));
        }
        match &mut camera.projection {
            strata::scene::Projection::Perspective { fov_y_deg } => *fov_y_deg = f,
            strata::scene::Projection::Orthographic { .. } => {
                return Err(Error::input(
                    "--fov applies to perspective cameras; this scene's camera is orthographic",
                ))
            }
        }
    }
    let forward = camera.target - camera.eye;
    if forward.length_squared() == 0.0 || forward.cross(camera.up).length_squared() == 0.0 {
        return Err(Error::input(
            "the camera's eye, target and up do not define a view (eye = target, or up along the view direction)",
        ));
    }
    scene.camera = Some(camera);
    Ok(())
}

fn write_outputs(
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
fn check_outputs<'a>(paths: impl IntoIterator<Item = &'a Path>) -> Result<()> {
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
fn write_results_quietly(
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

fn summary(stats: &FrameStats, output: &Path, tail: Tail) {
    let ms = stats
        .gpu_ms_total
        .map(|t| format!("{t:.2} ms GPU"))
        .unwrap_or_else(|| "untimed".into());
    eprintln!(
        "{}: {}x{} {} — {} geometry pass(es), {} fragments, max depth {}, {ms} → {}",
        stats.method,
        stats.width,
        stats.height,
        stats.effect,
        stats.geometry_passes.unwrap_or(0),
        stats.fragments_generated.unwrap_or(0),
        stats.max_depth_complexity.unwrap_or(0),
        output.display()
    );
    if let (Some(culled), Some(generated)) = (stats.culled_temporal, stats.fragments_generated) {
        eprintln!(
            "temporal culling: {culled} of {generated} fragments culled by last frame's interface ({:.1}%)",
            100.0 * culled as f64 / generated.max(1) as f64
        );
    }
    if let (Some(order), Some(tau)) = (&stats.order, stats.kendall_tau) {
        eprintln!(
            "order: {order}, Kendall distance to front-to-back order {tau:.3} (0 front to back, 1 back to front)"
        );
    }
    if let Some(bands) = stats.bands {
        eprintln!(
            "note: rendered in {bands} bands of rows: the whole picture's per-pixel buffers outgrow this device's largest storage binding"
        );
    }
    if let (Some(a), Some(k)) = (&stats.k_auto, stats.k) {
        let percent = |r: Option<f64>| {
            r.map(|r| format!("{:.2}%", 100.0 * r))
                .unwrap_or_else(|| "unknown".into())
        };
        eprintln!(
            "k auto: k={k} (the budget holds k ≤ {}), target {:.2}%, predicted {}, achieved {}",
            a.k_budget,
            100.0 * a.robustness_target,
            percent(a.predicted_robustness),
            percent(a.achieved_robustness)
        );
    }
    let dropped = stats.fragments_dropped.unwrap_or(0);
    if dropped > 0 {
        match (stats.k, tail) {
            (Some(k), _) if stats.method == "bucket" => eprintln!("note: {dropped} fragments collided in buckets that already held two and were dropped (k={k}; a larger even --k splits each pixel's depth range finer)"),
            (Some(k), Tail::Blend) => eprintln!("note: {dropped} fragments beyond k={k} were blended into the tail"),
            (Some(k), Tail::Drop) => {
                let blends = stats.method.parse::<MethodId>().is_ok_and(|m| {
                    method_options::applies(method_options::Opt::Tail, m, None)
                });
                let hint = if blends { " (--tail blend keeps them as one term)" } else { "" };
                eprintln!("note: {dropped} fragments beyond k={k} were dropped{hint}")
            }
            (None, _) => eprintln!("warning: {dropped} fragments dropped"),
        }
    }
    if stats.overflow == Some(true) && stats.geometry_passes > Some(1) && dropped == 0 {
        eprintln!("note: the fragment pool overflowed; it was grown and the frame re-rendered (output exact)");
    }
    if stats.lock_failures.unwrap_or(0) > 0 {
        eprintln!(
            "warning: {} fragments failed to take their pixel's lock (--max-tries); the picture is not exact",
            stats.lock_failures.unwrap_or(0)
        );
    }
}

/// A spinner on stderr while long work runs (hidden when stderr is not a terminal).
fn spinner(message: String) -> indicatif::ProgressBar {
    let bar = indicatif::ProgressBar::new_spinner();
    bar.set_message(message);
    bar.enable_steady_tick(std::time::Duration::from_millis(120));
    bar
}

fn render(a: RenderArgs) -> Result<()> {
    if let Some(range) = a.frames.clone() {
        return render_sequence(a, &range);
    }
    let (scene, options) = prepare_render(&a.method, &a.picture)?;
    check_outputs(std::iter::once(a.output.as_path()).chain(a.stats.as_deref()))?;
    strata::output::check_png_name(&a.output)?;
    let busy = spinner(format!(
        "rendering {}x{} with {}",
        options.width, options.height, a.method.method
    ));
    let rendered = if a.method.method == MethodId::Reference {
        strata::reference::render(&scene, &options)
    } else {
        Gpu::new().and_then(|gpu| {
            Renderer::new(&gpu, &scene, &options)?.render_method(a.method.method, None)
        })
    };
    busy.finish_and_clear();
    let (image, stats) = rendered?;
    write_outputs(
        &image,
        &stats,
        options.effect,
        &a.output,
        a.stats.as_deref(),
    )?;
    summary(&stats, &a.output, options.tail);
    Ok(())
}

/// `--cache-dir DIR`, made if missing: refused now, not after a long preprocess, when it cannot
/// be a directory.
fn cache_dir(dir: &Path) -> Result<PathBuf> {
    if dir.exists() && !dir.is_dir() {
        return Err(Error::input(format!(
            "--cache-dir '{}' is not a directory",
            dir.display()
        )));
    }
    std::fs::create_dir_all(dir)
        .map_err(|e| Error::input(format!("--cache-dir {}: {e}", dir.display())))?;
    Ok(dir.to_path_buf())
}

/// The scene and options of a render: the picture's, then the method options.
pub fn prepare_render(a: &MethodArgs, picture: &PictureArgs) -> Result<(Scene, RenderOptions)> {
    let (scene, mut options) = prepare(picture)?;
    method_options::check_given(a, picture)?;
    if let Some(r) = a.robustness {
        if options.k_auto.is_none() {
            return Err(Error::input("--robustness applies to --k auto"));
        }
        options.k_auto = Some(r);
    }
    options.budget_mb = a.budget_mb;
    options.tail = a.tail;
    options.culling = a.culling == Toggle::On;
    options.max_tries = a.max_tries;
    options.layers = a.layers;
    options.heap_size = a.heap_size;
    options.buckets = a.buckets;
    options.weight = a.weight;
    options.depth_scale = a.depth_scale;
    options.moments = a.moments;
    options.ssao = a.ssao;
    options.normal_encoding = a.normal_encoding;
    options.gbuffer_debug = a.gbuffer_debug;
    options.raster = a.raster;
    options.order = a.order;
    options.order_seed = a.seed;
    options.temporal =
        (a.temporal == Toggle::On).then_some(strata::methods::kbuffer::temporal::TemporalCulling {
            refresh: a.temporal_refresh,
            epsilon: a.temporal_epsilon,
        });
    strata::methods::kbuffer::temporal::check(a.method, options.temporal)?;
    options.cache_dir = a.cache_dir.as_deref().map(cache_dir).transpose()?;
    if let Some(m) = a.layers_per_pass {
        if a.method != MethodId::Kpeel {
            return Err(Error::input(format!(
                "--layers-per-pass applies to kpeel (multi-layer peeling), not {}",
                a.method
            )));
        }
        let max = strata::methods::kbuffer::max_k(MethodId::Kpeel);
        if !(1..=max).contains(&m) {
            return Err(Error::input(format!(
                "--layers-per-pass {m} is outside 1..{max}"
            )));
        }
        if options.k.is_some_and(|k| k != m) {
            return Err(Error::input(
                "--layers-per-pass and --k name the same thing for kpeel: give one",
            ));
        }
        options.k = Some(m);
    }
    options.validate()?;
    Ok((scene, options))
}

/// The frames of `--frames A..B` or `A..=B`.
fn parse_frames(range: &str) -> Result<std::ops::Range<u32>> {
    let bad = || {
        Error::input(format!(
            "--frames '{range}' is not A..B or A..=B with A <= B"
        ))
    };
    let (a, b, inclusive) = match range.split_once("..=") {
        Some((a, b)) => (a, b, true),
        None => range
            .split_once("..")
            .map(|(a, b)| (a, b, false))
            .ok_or_else(bad)?,
    };
    let a: u32 = a.trim().parse().map_err(|_| bad())?;
    let b: u32 = b.trim().parse().map_err(|_| bad())?;
    let end = if inclusive {
        b.checked_add(1).ok_or_else(bad)?
    } else {
        b
    };
    if end <= a {
        return Err(bad());
    }
    if (end - a) as usize > MAX_FRAMES {
        return Err(Error::input(format!(
            "--frames '{range}' is {} frames; one run writes at most {MAX_FRAMES}",
            end - a
        )));
    }
    Ok(a..end)
}

/// `pattern` with its one %d or %0Nd replaced by `n` (%% is a literal %, as is a % that starts
/// no frame number).
fn frame_path(pattern: &Path, n: u32) -> Result<PathBuf> {
    let text = pattern.to_string_lossy();
    let bad = |why: &str| {
        Error::input(format!(
            "-o '{text}' {why} with --frames (e.g. frame_%04d.png)"
        ))
    };
    let mut path = String::with_capacity(text.len() + 10);
    let mut numbers = 0;
    let mut rest = text.as_ref();
    while let Some(at) = rest.find('%') {
        path.push_str(&rest[..at]);
        let after = &rest[at + 1..];
        if let Some(tail) = after.strip_prefix('%') {
            path.push('%');
            rest = tail;
            continue;
        }
        // %d, or %0Nd with N of 1 or 2 digits.
        let spec = match after.find('d') {
            Some(d) if d == 0 => Some((0, d)),
            Some(d)
                if d <= 3
                    && after.starts_with('0')
                    && after[1..d].bytes().all(|b| b.is_ascii_digit()) =>
            {
                Some((after[1..d].parse::<usize>().unwrap_or(0), d))
            }
            _ => None,
        };
        match spec {
            Some((digits, d)) => {
                numbers += 1;
                path.push_str(&format!("{n:0digits$}"));
                rest = &after[d + 1..];
            }
            None => {
                path.push('%');
                rest = after;
            }
        }
    }
    path.push_str(rest);
    match numbers {
        0 => Err(bad("needs a %d or %0Nd for the frame number")),
        1 => Ok(PathBuf::from(path)),
        _ => Err(bad(
            "has more than one %d or %0Nd; the frame number goes in one place",
        )),
    }
}

/// The most frames one `render --frames` writes.
const MAX_FRAMES: usize = 100_000;

/// `strata render --frames`: each time step of the animation with one renderer — the GPU
/// moves the objects and the camera follows its path, nothing is rebuilt between frames — PNGs
/// by pattern, statistics as JSON lines.
fn render_sequence(a: RenderArgs, range: &str) -> Result<()> {
    let frames = parse_frames(range)?;
    if a.picture.frame.is_some() {
        return Err(Error::input("--frame and --frames exclude each other"));
    }
    let paths: Vec<PathBuf> = frames
        .clone()
        .map(|n| frame_path(&a.output, n))
        .collect::<Result<_>>()?;
    // Distinct by their numbers; each checked alone (a check of all together is quadratic).
    for path in &paths {
        strata::output::check_target(path)?;
    }
    strata::output::check_png_name(&paths[0])?;
    if let Some(stats) = &a.stats {
        check_outputs([paths[0].as_path(), stats.as_path()])?;
    }
    let picture = PictureArgs {
        frame: Some(frames.start as f32),
        ..a.picture.clone()
    };
    let (scene, options) = prepare_render(&a.method, &picture)?;
    let gpu = if a.method.method == MethodId::Reference {
        None
    } else {
        Some(Gpu::new()?)
    };
    let bar = indicatif::ProgressBar::new(frames.len() as u64);
    let mut renderer = match &gpu {
        Some(gpu) => Some(Renderer::new(gpu, &scene, &options)?),
        None => None,
    };
    let mut lines = String::new();
    let mut last = None;
    let mut written = 0;
    let mut frame_by_frame = || -> Result<()> {
        for (n, path) in frames.clone().zip(&paths) {
            let (image, stats) = match renderer.as_mut() {
                None => strata::reference::render(&scene.at_time(n as f32), &options)?,
                Some(r) => {
                    r.set_time(n as f32);
                    r.render_method(a.method.method, None)?
                }
            };
            save_png(&image.to_rgba8(options.effect), path)?;
            written += 1;
            let mut stats = stats;
            stats.frame = n as u64;
            lines += &serde_json::to_string(&stats).map_err(|e| Error::runtime(e.to_string()))?;
            lines.push('\n');
            last = Some((stats, path, options.tail));
            bar.inc(1);
        }
        if let Some(path) = &a.stats {
            let mut outputs = Outputs::new();
            outputs.add(path, std::mem::take(&mut lines).into_bytes())?;
            outputs.commit()?;
        }
        Ok(())
    };
    let done = frame_by_frame();
    bar.finish_and_clear();
    if let Err(e) = done {
        // A sequence is written whole or not at all, like any other output.
        for path in &paths[..written] {
            let _ = std::fs::remove_file(path);
        }
        return Err(match written {
            0 => e,
            _ => with_context(
                e,
                &format!("the {written} frames written before were removed"),
            ),
        });
    }
    if let Some((stats, path, tail)) = last {
        summary(&stats, path, tail);
        eprintln!("{} frames written", frames.len());
    }
    Ok(())
}

/// `e` with `note` after its message, of the same kind.
fn with_context(e: Error, note: &str) -> Error {
    match e {
        Error::Input(m) => Error::Input(format!("{m} ({note})")),
        Error::Unsupported(m) => Error::Unsupported(format!("{m} ({note})")),
        Error::Runtime(m) => Error::Runtime(format!("{m} ({note})")),
    }
}

fn reference(a: ReferenceArgs) -> Result<()> {
    let (scene, options) = prepare(&a.picture)?;
    check_outputs(std::iter::once(a.output.as_path()).chain(a.stats.as_deref()))?;
    strata::output::check_png_name(&a.output)?;
    let busy = spinner(format!(
        "rendering {}x{} with the CPU reference",
        options.width, options.height
    ));
    let rendered = strata::reference::render(&scene, &options);
    busy.finish_and_clear();
    let (image, stats) = rendered?;
    write_outputs(
        &image,
        &stats,
        options.effect,
        &a.output,
        a.stats.as_deref(),
    )?;
    summary(&stats, &a.output, options.tail);
    Ok(())
}

fn compare(a: CompareArgs) -> Result<()> {
    if let Some(d) = &a.diff {
        check_outputs([d.as_path()])?;
        strata::output::check_png_name(d)?;
    }
    let ia = strata::metrics::load_png(&a.a)?;
    let ib = strata::metrics::load_png(&a.b)?;
    let c = strata::metrics::compare(&ia, &ib)?;
    if let Some(d) = &a.diff {
        save_png(&strata::metrics::diff_heatmap(&ia, &ib), d)?;
    }
    if a.json {
        println!(
            "{}",
            serde_json::to_string_pretty(&c).map_err(|e| Error::runtime(e.to_string()))?
        );
    } else {
        println!("RMSE            {:.6}", c.rmse);
        println!(
            "PSNR            {}",
            if c.psnr.is_finite() {
                format!("{:.2} dB", c.psnr)
            } else {
                "inf (identical)".into()
            }
        );
        println!("max abs diff    {}/255", c.max_abs_diff);
        println!("FLIP mean       {:.6}", c.flip_mean);
        println!("pixels > 2/255  {:.4}%", c.pct_over_2);
    }
    Ok(())
}

/// The rasterizers a method runs on (`--raster`).
fn rasters(id: &str) -> &'static str {
    match id.parse::<MethodId>() {
        Ok(MethodId::Reference) | Err(_) => "cpu",
        Ok(m) if strata::raster::supports(m) => "hw,compute",
        Ok(_) => "hw",
    }
}

/// The `--msaa` sample counts `method` takes (8 only where the device rasterizes it).
fn msaa_counts(method: &str) -> Vec<u32> {
    match method.parse::<MethodId>() {
        Ok(m) if strata::frame::msaa::supported(m) => strata::frame::msaa::SAMPLE_COUNTS.to_vec(),
        _ => vec![1],
    }
}

fn list_methods(json: bool) -> Result<()> {
    let all = methods::catalogue();
    if json {
        let entries: Vec<serde_json::Value> = all
            .iter()
            .map(|m| {
                let mut v = serde_json::to_value(m).unwrap_or_default();
                v["raster"] = rasters(m.id).split(',').collect::<Vec<_>>().into();
                v["msaa"] = msaa_counts(m.id).into();
                v
            })
            .collect();
        println!(
            "{}",
            serde_json::to_string_pretty(&entries).map_err(|e| Error::runtime(e.to_string()))?
        );
        return Ok(());
    }
    let width = |f: &dyn Fn(&methods::MethodInfo) -> usize| all.iter().map(f).max().unwrap_or(0);
    let (wi, wf, wp, wm) = (
        width(&|m| m.id.len()),
        width(&|m| m.family.len()),
        width(&|m| m.geometry_passes.chars().count()),
        width(&|m| m.memory.chars().count()),
    );
    println!(
        "{:<wi$}  {:<wf$}  exact  {:<10}  {:<5}  {:<wp$}  {:<wm$}  summary",
        "id", "family", "raster", "msaa", "geometry passes", "memory (bytes)"
    );
    for m in &all {
        let msaa: Vec<String> = msaa_counts(m.id).iter().map(u32::to_string).collect();
        println!(
            "{:<wi$}  {:<wf$}  {:<5}  {:<10}  {:<5}  {:<wp$}  {:<wm$}  {}",
            m.id,
            m.family,
            if m.exact { "yes" } else { "no" },
            rasters(m.id),
            msaa.join(","),
            m.geometry_passes,
            m.memory,
            m.summary
        );
    }
    Ok(())
}

fn info(json: bool) -> Result<()> {
    let gpu = Gpu::new()?;
    let r = gpu.report();
    if json {
        println!(
            "{}",
            serde_json::to_string_pretty(&r).map_err(|e| Error::runtime(e.to_string()))?
        );
        return Ok(());
    }
    println!("adapter   {}", r.adapter);
    println!("backend   {}", r.backend);
    println!("type      {}", r.device_type);
    println!("driver    {} {}", r.driver, r.driver_info);
    println!(
        "timestamp {}",
        r.timestamp_period_ns
            .map(|p| format!("{p} ns/tick"))
            .unwrap_or_else(|| "unsupported".into())
    );
    println!("features  {}", r.features.join(", "));
    println!("limits    {}", r.limits);
    Ok(())
}

/// One frame with the GPU histogram on (a count pass and a binning pass, read back with the
/// frame's statistics).
fn gpu_histogram(scene: &Scene, options: &RenderOptions) -> Result<Vec<u64>> {
    let gpu = Gpu::new()?;
    let mut recorder = strata::FrameRecorder::new(&gpu, scene, MethodId::Unsorted, options)?;
    recorder.set_histogram(true);
    let mut encoder = gpu.device.create_command_encoder(&Default::default());
    recorder.record(&mut encoder, &Default::default(), None)?;
    gpu.queue.submit([encoder.finish()]);
    let stats = recorder.wait_stats()?.stats;
    let clipped = stats.depth_histogram_clipped.unwrap_or(0);
    if clipped > 0 {
        eprintln!(
            "note: {clipped} pixels have {} or more fragments; the last bin counts them together (--cpu counts them exactly)",
            strata::metrics::gpu_histogram::HISTOGRAM_BINS - 1
        );
    }
    stats
        .depth_histogram
        .ok_or_else(|| Error::runtime("the GPU histogram did not arrive"))
}

/// What `strata convex` reports: the preprocess, and the order of the scene's view.
#[derive(serde::Serialize)]
struct ConvexReport {
    decomposition: strata::methods::convex::decompose::DecompositionStats,
    width: u32,
    height: u32,
    passes: usize,
    culled: u32,
    overlapping_pairs: u64,
    unseparated_pairs: u64,
    cycles_broken: u32,
    order_ms: f64,
}

fn convex(a: ConvexArgs) -> Result<()> {
    use strata::methods::convex::{self, order};
    let picture = PictureArgs {
        size: a.size,
        ..PictureArgs::for_scene(a.scene)
    };
    let (scene, options) = prepare(&picture)?;
    if let Some(out) = &a.out {
        check_outputs([out.as_path()])?;
        strata::output::check_png_name(out)?;
    }
    let triangles = convex::triangles_of(&scene);
    let bar = indicatif::ProgressBar::new(100).with_message("decomposing");
    bar.set_style(
        indicatif::ProgressStyle::with_template("{msg} [{bar:40}] {percent}% ({elapsed})")
            .map_err(|e| Error::runtime(e.to_string()))?,
    );
    if triangles.len() < 50_000 || a.json {
        bar.set_draw_target(indicatif::ProgressDrawTarget::hidden());
    }
    let cache = a.cache_dir.as_deref().map(cache_dir).transpose()?;
    let d = convex::decomposition_of(&triangles, cache.as_deref(), &|f| {
        bar.set_position((f * 100.0) as u64)
    });
    bar.finish_and_clear();
    let camera = scene.camera_or_framing();
    let view_proj = strata::frame::uniforms::band_projection(&camera, &options);
    let plan = order::plan(&d, &camera, view_proj, options.width, options.height, 1);
    let report = ConvexReport {
        decomposition: d.stats.clone(),
        width: options.width,
        height: options.height,
        passes: plan.passes.len(),
        culled: plan.culled,
        overlapping_pairs: plan.overlapping,
        unseparated_pairs: plan.unseparated,
        cycles_broken: plan.cycles_broken,
        order_ms: plan.order_ms,
    };
    if let Some(out) = &a.out {
        let pieces = convex::pieces_scene(&scene, &triangles, &d);
        let gpu = Gpu::new()?;
        let (image, _) = Renderer::new(&gpu, &pieces, &options)?.render("abuffer-ll")?;
        let mut outputs = Outputs::new();
        outputs.add_png(out, &image.to_rgba8(Effect::Transparency))?;
        outputs.commit()?;
    }
    if a.json {
        println!(
            "{}",
            serde_json::to_string_pretty(&report).map_err(|e| Error::runtime(e.to_string()))?
        );
        return Ok(());
    }
    let s = &report.decomposition;
    println!(
        "{} triangles -> {} convex parts -> {} groups ({} inseparable pairs joined; up to {} layers per pixel and group), preprocess {:.0} ms",
        s.triangles, s.parts, s.groups, s.paired, s.layers_per_group, s.preprocess_ms
    );
    if let Some(ms) = s.read_from_cache_ms {
        println!(
            "read from the cache in {ms:.0} ms (the preprocess above is the run that made it)"
        );
    }
    println!(
        "pairs with overlapping boxes: {} ({} nested, {} without a separating plane: ordered by centroid)",
        s.overlapping_pairs, s.nested, s.unseparated
    );
    println!(
        "this view at {}x{}: {} passes, {} groups culled, {} overlapping pairs on screen ({} without a plane), {} cycles broken, order {:.2} ms",
        report.width,
        report.height,
        report.passes,
        report.culled,
        report.overlapping_pairs,
        report.unseparated_pairs,
        report.cycles_broken,
        report.order_ms
    );
    if let Some(out) = &a.out {
        println!("-> {}", out.display());
    }
    Ok(())
}

fn export(a: ExportArgs) -> Result<()> {
    let container = strata::scene::export::GltfContainer::for_path(&a.output)?;
    let picture = PictureArgs {
        size: a.size.clone(),
        background: a.background.clone(),
        shading: a.shading,
        alpha: a.alpha,
        frame: a.frame,
        lights: a.lights,
        eye: a.eye,
        target: a.target,
        up: a.up,
        fov: a.fov,
        ..PictureArgs::for_scene(a.scene)
    };
    let (scene, options) = prepare(&picture)?;
    let defaults = strata::scene::export::ExportDefaults {
        size: a.size.map(|_| [options.width, options.height]),
        background: a.background.map(|_| options.background),
    };
    let bytes = strata::scene::export::to_gltf(&scene, &defaults, container)?;
    let mut outputs = strata::output::Outputs::new();
    outputs.add(&a.output, bytes)?;
    outputs.commit()?;
    println!(
        "{}: {} objects, {} triangles, {} materials, {} lights",
        a.output.display(),
        scene.objects.len(),
        scene.triangle_count(),
        scene.materials.len(),
        scene.lights.len()
    );
    Ok(())
}

fn histogram(a: HistogramArgs) -> Result<()> {
    let picture = PictureArgs {
        size: a.size,
        effect: Effect::Complexity,
        ..PictureArgs::for_scene(a.scene)
    };
    let (scene, options) = prepare(&picture)?;
    if let Some(out) = &a.out {
        check_outputs([out.as_path()])?;
        strata::output::check_png_name(out)?;
    }
    let hist = if a.cpu {
        let (image, _) = strata::reference::render(&scene, &options)?;
        strata::metrics::depth_complexity_histogram(&image.counts())
    } else {
        gpu_histogram(&scene, &options)?
    };
    if let Some(out) = &a.out {
        save_png(&bench::histogram_chart(&hist), out)?;
    }
    if a.json {
        println!(
            "{}",
            serde_json::to_string(&hist).map_err(|e| Error::runtime(e.to_string()))?
        );
    } else {
        for (count, pixels) in hist.iter().enumerate().filter(|(_, &p)| p > 0) {
            println!("{count:>5} fragments: {pixels} pixels");
        }
    }
    Ok(())
}
