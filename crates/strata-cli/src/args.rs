//! The arguments shared by the commands that make a picture (`PictureArgs`, `MethodArgs`) and
//! what they become: a scene and the render options.

use clap::{Args, ValueEnum};
use std::path::{Path, PathBuf};
use strata::error::{Error, Result};
use strata::frame::{BuildOptions, Effect, FrameOptions, Lighting, RenderOptions};
use strata::methods::choice::Goal;
use strata::methods::MethodId;
use strata::scene::{loaders, Background, CameraPath, Scene, Shading};

/// Options shared by everything that makes a picture.
#[derive(Args, Clone, Debug)]
pub struct PictureArgs {
    /// A scene file (.toml, .obj, .ply, .gltf, .glb) or builtin:NAME?key=value&...
    #[arg(default_value = "builtin:demo")]
    pub scene: String,
    /// Image size, WxH (default: the scene's, else 512x512).
    #[arg(long, allow_hyphen_values = true)]
    pub size: Option<Size>,
    #[arg(long, value_enum, default_value = "transparency")]
    pub effect: Effect,
    /// Overrides every material's shading.
    #[arg(long, value_enum)]
    pub shading: Option<Shading>,
    /// checker | #rrggbb (sRGB)
    #[arg(long)]
    pub background: Option<BackgroundArg>,
    /// Sets every material's opacity.
    #[arg(long)]
    pub alpha: Option<f32>,
    /// Per-pixel capacity for k-buffer methods (a positive integer, or `auto`: chosen from the
    /// depth-complexity histogram); for `reference`, keep each pixel's k nearest.
    #[arg(long, value_parser = parse_k)]
    pub k: Option<KArg>,
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
    #[command(flatten)]
    pub camera: CameraArgs,
    // Samples per pixel; the methods that take no --msaa from the table.
    #[arg(long, default_value_t = 1, help = format!(
        "Samples per pixel: 1, or 4 and 8 for multisample anti-aliasing at the standard sample positions (fragments shaded once per pixel, composited per sample; every method but {}). 8 where the device has it (lavapipe: 4; tiled finds its samples in compute, so 8 there too)",
        methods_where(|d| !d.msaa.yes())
    ))]
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
            camera: CameraArgs::default(),
            msaa: 1,
        }
    }
}

/// The camera over the scene's (render, view, export).
#[derive(Args, Clone, Copy, Debug, Default, PartialEq)]
pub struct CameraArgs {
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
}

impl CameraArgs {
    pub fn is_empty(&self) -> bool {
        *self == CameraArgs::default()
    }
}

/// `--size WxH`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Size {
    pub width: u32,
    pub height: u32,
}

impl Size {
    pub const fn new(width: u32, height: u32) -> Size {
        Size { width, height }
    }
}

impl std::str::FromStr for Size {
    type Err = String;
    fn from_str(s: &str) -> std::result::Result<Size, String> {
        let side = 1..=strata::frame::MAX_SIDE;
        let parsed = s.split_once(['x', 'X']).and_then(|(w, h)| {
            let (w, h) = (w.trim().parse().ok()?, h.trim().parse().ok()?);
            (side.contains(&w) && side.contains(&h)).then_some(Size::new(w, h))
        });
        parsed.ok_or_else(|| {
            format!(
                "not WxH with integers in 1..{} (e.g. 512x512)",
                strata::frame::MAX_SIDE
            )
        })
    }
}

impl std::fmt::Display for Size {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}x{}", self.width, self.height)
    }
}

/// `--background`: the checkerboard or an sRGB color, kept as written so that the viewer's
/// command line repeats it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BackgroundArg {
    Checker,
    Srgb([u8; 3]),
}

impl BackgroundArg {
    pub fn background(self) -> Background {
        match self {
            BackgroundArg::Checker => Background::Checker,
            BackgroundArg::Srgb(c) => {
                Background::Color(c.map(|v| strata::scene::srgb_to_linear(v as f32 / 255.0)))
            }
        }
    }
}

impl std::str::FromStr for BackgroundArg {
    type Err = String;
    fn from_str(s: &str) -> std::result::Result<BackgroundArg, String> {
        if s == "checker" {
            return Ok(BackgroundArg::Checker);
        }
        let hex = s.strip_prefix('#').filter(|h| h.len() == 6 && h.is_ascii());
        let channel = |h: &str, i: usize| u8::from_str_radix(&h[i..i + 2], 16).ok();
        hex.and_then(|h| Some([channel(h, 0)?, channel(h, 2)?, channel(h, 4)?]))
            .map(BackgroundArg::Srgb)
            .ok_or_else(|| "neither 'checker' nor a color '#rrggbb'".to_string())
    }
}

impl std::fmt::Display for BackgroundArg {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            BackgroundArg::Checker => f.write_str("checker"),
            BackgroundArg::Srgb([r, g, b]) => write!(f, "#{r:02x}{g:02x}{b:02x}"),
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

/// `--method`: a method id, or `auto` with an optional goal.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum MethodArg {
    Id(MethodId),
    /// `auto[:exact|bounded|approximate]` (no goal: bounded when `--k` or `--budget-mb` is
    /// given, else exact).
    Auto(Option<Goal>),
}

/// Parses `--method`.
pub fn parse_method(s: &str) -> std::result::Result<MethodArg, String> {
    let goal = |g: &str| match g {
        "exact" => Some(Goal::Exact),
        "bounded" => Some(Goal::Bounded),
        "approximate" => Some(Goal::Approximate),
        _ => None,
    };
    match s.split_once(':') {
        None if s == "auto" => Ok(MethodArg::Auto(None)),
        Some(("auto", g)) => goal(g).map(|g| MethodArg::Auto(Some(g))).ok_or_else(|| {
            "auto's goal is exact, bounded or approximate (auto:exact, auto:bounded, auto:approximate)".to_string()
        }),
        _ => s
            .parse::<MethodId>()
            .map(MethodArg::Id)
            .map_err(|e| e.to_string()),
    }
}

impl std::fmt::Display for MethodArg {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            MethodArg::Id(id) => f.write_str(id.as_str()),
            MethodArg::Auto(None) => f.write_str("auto"),
            MethodArg::Auto(Some(g)) => write!(f, "auto:{}", format!("{g:?}").to_lowercase()),
        }
    }
}

/// The method and its options (`render` and `view`).
#[derive(Args, Clone, Debug)]
pub struct MethodArgs {
    /// Method id (see `strata methods`), or auto[:exact|bounded|approximate]: the best method
    /// this adapter runs for that goal (default: bounded with --k or --budget-mb, else exact).
    #[arg(long, value_parser = parse_method, default_value = "abuffer-ll")]
    pub method: MethodArg,
    /// What `auto` chose and why, then its fallbacks (set by [`MethodArgs::resolve`]).
    #[arg(skip)]
    pub candidates: Vec<strata::methods::choice::Choice>,
    // The methods each help lists come from the method table (`methods_where`).
    #[arg(long, value_enum, default_value = "hw", help = format!(
        "hw: the GPU's rasterizer; compute: strata's compute-shader rasterizer (seed 002), for {}",
        methods_where(|d| d.compute_raster.yes())
    ))]
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
    /// The families' options (`--tail`, `--layers`, `--weight`, …), made from their specs.
    #[command(flatten)]
    pub family: crate::family_args::FamilyArgs,
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
    // Reverse-reprojection culling; its methods from the table.
    #[arg(long, value_enum, default_value = "off", help = format!(
        "Reverse-reprojection culling (seed 000; {}): each frame culls, before any lock, fragments that lay behind last frame's (k+1)-th nearest depth. Approximate: the first frame culls nothing, moving objects can be culled wrongly until their tile refreshes",
        methods_where(|d| d.temporal)
    ))]
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

/// `--lights` stops here: every transparent fragment loops over the whole list.
pub const MAX_LIGHTS: u32 = 65536;
/// The light field is the same for every run.
pub const LIGHT_FIELD_SEED: u64 = 1;

/// `--k`: a count of fragments per pixel, or `auto`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum KArg {
    Count(u32),
    Auto,
}

impl std::fmt::Display for KArg {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            KArg::Count(k) => write!(f, "{k}"),
            KArg::Auto => f.write_str("auto"),
        }
    }
}

/// Parses `--k`.
pub fn parse_k(s: &str) -> std::result::Result<KArg, String> {
    if s == "auto" {
        return Ok(KArg::Auto);
    }
    s.parse::<u32>()
        .ok()
        .filter(|&k| k > 0)
        .map(KArg::Count)
        .ok_or_else(|| "not a positive integer or 'auto'".to_string())
}

/// Loads the scene and applies the picture options to it; returns the render options.
pub fn prepare(p: &PictureArgs) -> Result<(Scene, RenderOptions)> {
    let effect = p.effect;
    let (k, k_auto) = match p.k {
        None => (None, None),
        Some(KArg::Auto) => (
            None,
            Some(strata::methods::kbuffer::predict::DEFAULT_ROBUSTNESS),
        ),
        Some(KArg::Count(k)) => (Some(k), None),
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
    apply_camera(&mut scene, &p.camera)?;
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
    let shading = p.shading.or(scene.defaults.shading);
    if let Some(s) = shading {
        scene.override_shading(s);
    }
    let background = match p.background {
        Some(b) => b.background(),
        None => scene.defaults.background.unwrap_or_default(),
    };
    let (width, height) = match p.size {
        Some(s) => (s.width, s.height),
        None => scene
            .defaults
            .size
            .map(|[w, h]| (w, h))
            .unwrap_or((512, 512)),
    };
    let options = RenderOptions {
        build: BuildOptions {
            msaa: p.msaa,
            lighting: Lighting {
                pipeline: match p.pipeline {
                    None => scene.defaults.pipeline,
                    Some(PipelineArg::None) => None,
                    Some(PipelineArg::Forward) => Some(strata::frame::Pipeline::Forward),
                    Some(PipelineArg::Deferred) => Some(strata::frame::Pipeline::Deferred),
                },
                tonemap: p.tonemap,
                ..Default::default()
            },
            ..Default::default()
        },
        frame: FrameOptions {
            width,
            height,
            effect,
            background,
            k,
            k_auto,
            ..Default::default()
        },
    };
    options.validate()?;
    Ok((scene, options))
}

/// `--eye`, `--target`, `--up`, `--fov` over the scene's camera (or its framing); `--up` and
/// `--fov` also apply to a camera path's keys, which `--eye` and `--target` cannot override.
pub fn apply_camera(scene: &mut Scene, p: &CameraArgs) -> Result<()> {
    if p.is_empty() {
        return Ok(());
    }
    if let Some(path) = &mut scene.camera_path {
        if p.eye.is_some() || p.target.is_some() {
            return Err(Error::input(
                "--eye and --target fix the camera, but this scene's [[camera_key]] path moves it: leave them out, or the keys",
            ));
        }
        let moved = CameraArgs {
            eye: None,
            target: None,
            ..*p
        };
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

/// `--cache-dir DIR`, made if missing: refused now, not after a long preprocess, when it cannot
/// be a directory.
pub fn cache_dir(dir: &Path) -> Result<PathBuf> {
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

impl MethodArgs {
    /// The families' options these arguments give (`--tail`, `--layers`, `--weight`, …).
    pub fn set_family_options(&self, frame: &mut strata::frame::FrameOptions) {
        self.family.apply(frame);
    }

    /// The method: `--method`'s id, or the one `auto` chose.
    pub fn id(&self) -> MethodId {
        match (self.method, self.candidates.first()) {
            (MethodArg::Id(id), _) => id,
            (MethodArg::Auto(_), Some(c)) => c.method,
            (MethodArg::Auto(_), None) => unreachable!("--method auto is resolved before use"),
        }
    }

    /// Why `auto` chose the method (`None` for a named one).
    pub fn choice(&self) -> Option<String> {
        self.candidates.first().map(|c| c.why.clone())
    }

    /// After the chosen method was refused with `why`: with `auto`, moves to the next candidate
    /// (saying so) and returns true; else false.
    pub fn fall_back(&mut self, why: &str) -> bool {
        if self.candidates.len() < 2 {
            return false;
        }
        let refused = self.candidates.remove(0);
        let next = &mut self.candidates[0];
        eprintln!(
            "method auto: {} cannot run here; {} instead",
            refused.method, next.method
        );
        next.why = format!("{} ({} was refused: {why})", next.why, refused.method);
        true
    }

    /// With `--method auto`: chooses on the adapter strata opens (see
    /// `strata::methods::choice`) and says which and why on stderr.
    pub fn resolve(&mut self, picture: &PictureArgs) -> Result<()> {
        let MethodArg::Auto(goal) = self.method else {
            return Ok(());
        };
        let bounded = picture.k.is_some() || self.budget_mb.is_some();
        let goal = goal.unwrap_or(if bounded { Goal::Bounded } else { Goal::Exact });
        self.candidates = strata::methods::choice::candidates(
            &strata::gpu::Gpu::new()?,
            goal,
            strata::methods::choice::Geometry::Scene,
        );
        let first = &self.candidates[0];
        eprintln!("method auto: {} ({})", first.method, first.why);
        Ok(())
    }
}

/// The scene and options of a render: the picture's, then the method options.
pub fn prepare_render(a: &MethodArgs, picture: &PictureArgs) -> Result<(Scene, RenderOptions)> {
    let (scene, mut options) = prepare(picture)?;
    crate::method_options::check_given(a, picture)?;
    if let Some(r) = a.robustness {
        if options.frame.k_auto.is_none() {
            return Err(Error::input("--robustness applies to --k auto"));
        }
        options.frame.k_auto = Some(r);
    }
    options.frame.budget_mb = a.budget_mb;
    a.set_family_options(&mut options.frame);
    // A method that needs samples (stochastic's stipples) takes its fewest unless --msaa says
    // more.
    options.build.msaa = options.build.msaa.max(a.id().descriptor().min_samples);
    let lighting = &mut options.build.lighting;
    lighting.ssao = a.ssao;
    lighting.normal_encoding = a.normal_encoding;
    lighting.gbuffer_debug = a.gbuffer_debug;
    options.build.raster = a.raster;
    options.frame.order = a.order;
    options.frame.order_seed = a.seed;
    options.frame.temporal =
        (a.temporal == Toggle::On).then_some(strata::methods::kbuffer::temporal::TemporalCulling {
            refresh: a.temporal_refresh,
            epsilon: a.temporal_epsilon,
        });
    // Refused here, before any device: the recorder admits it again (Descriptor::admit).
    a.id()
        .descriptor()
        .check_temporal(options.frame.temporal.is_some())?;
    options.frame.validate()?;
    options.build.cache_dir = a.cache_dir.as_deref().map(cache_dir).transpose()?;
    if let Some(m) = a.layers_per_pass {
        // A method that does not read it was refused by `check_given`.
        let max = a.id().descriptor().max_k;
        if !(1..=max).contains(&m) {
            return Err(Error::input(format!(
                "--layers-per-pass {m} is outside 1..{max}"
            )));
        }
        if options.frame.k.is_some_and(|k| k != m) {
            return Err(Error::input(
                "--layers-per-pass and --k name the same thing for kpeel: give one",
            ));
        }
        options.frame.k = Some(m);
    }
    options.validate()?;
    Ok((scene, options))
}

/// `strata view`'s arguments (the viewer itself is the `view` feature).
#[derive(Args)]
pub struct ViewArgs {
    #[command(flatten)]
    pub picture: PictureArgs,
    #[command(flatten)]
    pub method: MethodArgs,
    /// Render --frames frames, save the window (panel included) to this PNG and exit; prints
    /// where the 3D area is and the view as a `strata render` command.
    #[arg(long)]
    pub screenshot: Option<PathBuf>,
    /// With --screenshot: frames to render before saving.
    #[arg(long, requires = "screenshot", default_value_t = 3)]
    pub frames: u32,
}

/// The methods of the table for which `keep` holds, in the table's order, for a flag's help.
fn methods_where(keep: impl Fn(&strata::methods::table::Descriptor) -> bool) -> String {
    strata::methods::TABLE
        .iter()
        .filter(|d| keep(d))
        .map(|d| d.name)
        .collect::<Vec<_>>()
        .join(", ")
}
