//! What is fuzzed: each input format strata parses, the built-in scene specs and the options
//! the library parses and validates. A target makes input `index` of a run from its seeds and
//! runs it through strata's own entry point, in this process.

use std::path::{Path, PathBuf};
use std::str::FromStr;
use strata::KBufferOptions;
use strata::PeelingOptions;
use strata::WeightedOptions;

use strata::scene::loaders::{load_scene, load_scene_bytes, FileFormat};

use crate::generate::{builtin_spec, count, mutate, number, word, Rng};

/// A fuzz target.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Target {
    /// Wavefront OBJ models (with `.mtl` libraries beside them).
    Obj,
    /// PLY models in ASCII.
    PlyAscii,
    /// PLY models in binary, little- and big-endian.
    PlyBinary,
    /// glTF 2.0 JSON, with external and data-URI buffers.
    Gltf,
    /// glTF 2.0 binary (GLB), with embedded buffers.
    Glb,
    /// TOML scene files, with the meshes they refer to.
    Toml,
    /// `builtin:` scene specs.
    Builtin,
    /// The library's option words and values, and `RenderOptions::validate`.
    Options,
}

impl Target {
    /// Every target, in the order `all` runs them.
    pub const ALL: [Target; 8] = [
        Target::Obj,
        Target::PlyAscii,
        Target::PlyBinary,
        Target::Gltf,
        Target::Glb,
        Target::Toml,
        Target::Builtin,
        Target::Options,
    ];

    /// The target's name on the command line.
    pub fn name(self) -> &'static str {
        match self {
            Target::Obj => "obj",
            Target::PlyAscii => "ply-ascii",
            Target::PlyBinary => "ply-binary",
            Target::Gltf => "gltf",
            Target::Glb => "glb",
            Target::Toml => "toml",
            Target::Builtin => "builtin",
            Target::Options => "options",
        }
    }

    /// The extension its inputs are saved with.
    pub fn extension(self) -> &'static str {
        match self {
            Target::Obj => "obj",
            Target::PlyAscii | Target::PlyBinary => "ply",
            Target::Gltf => "gltf",
            Target::Glb => "glb",
            Target::Toml => "toml",
            Target::Builtin | Target::Options => "txt",
        }
    }

    fn format(self) -> Option<FileFormat> {
        match self {
            Target::Obj => Some(FileFormat::Obj),
            Target::PlyAscii | Target::PlyBinary => Some(FileFormat::Ply),
            Target::Gltf | Target::Glb => Some(FileFormat::Gltf),
            Target::Toml => Some(FileFormat::Toml),
            Target::Builtin | Target::Options => None,
        }
    }

    /// Whether the file at `path` seeds this target.
    fn takes(self, path: &Path, bytes: &[u8]) -> bool {
        let ext = path.extension().and_then(|e| e.to_str()).unwrap_or("");
        let binary_ply = bytes.windows(13).take(64).any(|w| w == b"format binary");
        match self {
            Target::PlyAscii => ext == "ply" && !binary_ply,
            Target::PlyBinary => ext == "ply" && binary_ply,
            t => t.format().is_some() && ext == t.extension(),
        }
    }
}

impl FromStr for Target {
    type Err = String;
    fn from_str(s: &str) -> Result<Target, String> {
        Target::ALL
            .into_iter()
            .find(|t| t.name() == s)
            .ok_or_else(|| {
                let names: Vec<&str> = Target::ALL.iter().map(|t| t.name()).collect();
                format!("unknown target '{s}' (targets: {}, all)", names.join(", "))
            })
    }
}

/// The repository's fixtures: the model and scene files strata's tests load.
pub fn fixtures_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../strata/tests/fixtures")
}

/// Inputs that once failed: every one is run as it is before a run's generated inputs.
pub fn regressions_dir() -> PathBuf {
    fixtures_dir().join("regressions")
}

/// A seed: a file's bytes and the directory its references are resolved in.
#[derive(Clone, Debug)]
pub struct Seed {
    /// Where it came from.
    pub path: PathBuf,
    /// Its bytes.
    pub bytes: Vec<u8>,
}

fn files_in(dir: &Path) -> Vec<PathBuf> {
    let mut files: Vec<PathBuf> = std::fs::read_dir(dir)
        .map(|d| d.filter_map(|e| e.ok()).map(|e| e.path()).collect())
        .unwrap_or_default();
    files.retain(|p| p.is_file());
    files.sort();
    files
}

/// The seeds of `target` in `dirs` (each file of the target's format).
pub fn seeds_in(target: Target, dirs: &[PathBuf]) -> Vec<Seed> {
    dirs.iter()
        .flat_map(|d| files_in(d))
        .filter_map(|path| {
            let bytes = std::fs::read(&path).ok()?;
            target.takes(&path, &bytes).then_some(Seed { path, bytes })
        })
        .collect()
}

/// The seed corpus of `target`: the fixtures and the shipped examples of its format.
pub fn seeds(target: Target) -> Vec<Seed> {
    let examples = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples");
    seeds_in(target, &[fixtures_dir(), examples])
}

/// One input of a run.
#[derive(Clone, Debug)]
pub enum Input {
    /// A file's bytes, its references resolved in `dir`.
    File {
        /// The bytes.
        bytes: Vec<u8>,
        /// The directory of the seed it was made from.
        dir: PathBuf,
    },
    /// A `builtin:` spec.
    Spec(String),
    /// Option words and values.
    Options(OptionCase),
}

impl Input {
    /// The input as a file saves it.
    pub fn bytes(&self) -> Vec<u8> {
        match self {
            Input::File { bytes, .. } => bytes.clone(),
            Input::Spec(spec) => spec.clone().into_bytes(),
            Input::Options(case) => format!("{case:#?}\n").into_bytes(),
        }
    }
}

/// Words for each keyword option, and numbers for the numeric ones.
#[derive(Clone, Debug, Default)]
pub struct OptionCase {
    /// (option, word) pairs, each parsed by the option's parser.
    pub words: Vec<(&'static str, String)>,
    /// Width and height.
    pub size: (u32, u32),
    /// `--k`, `--k auto`'s fraction, `--budget-mb`.
    pub k: Option<u32>,
    /// `--k auto`'s fraction.
    pub k_auto: Option<f64>,
    /// `--budget-mb`.
    pub budget_mb: Option<f64>,
    /// `--msaa`.
    pub msaa: u32,
    /// `--max-tries`, `--heap-size`, `--layers`, `--passes`, `--coefficients`.
    pub counts: [Option<u32>; 5],
    /// `--depth-scale`.
    pub depth_scale: f64,
}

/// Makes input `index` of a run of `target` seeded `seed` from `seeds` (the first
/// `seeds.len()` inputs are the seeds themselves).
pub fn make_input(target: Target, seeds: &[Seed], seed: u64, index: u64) -> Input {
    let mut rng = Rng::for_input(seed, index);
    match target {
        Target::Builtin => Input::Spec(builtin_spec(&mut rng, index % 4096 == 7)),
        Target::Options => Input::Options(option_case(&mut rng)),
        _ => {
            let from = match (index as usize) < seeds.len() {
                true => &seeds[index as usize],
                false => rng.pick(seeds),
            };
            let bytes = match (index as usize) < seeds.len() {
                true => from.bytes.clone(),
                false => mutate(&mut rng, &from.bytes),
            };
            Input::File {
                bytes,
                dir: from.path.parent().unwrap_or(Path::new("")).to_path_buf(),
            }
        }
    }
}

/// Every keyword option the library parses, with its valid words.
const KEYWORDS: &[(&str, &[&str])] = &[
    (
        "--method",
        &[
            "tiled",
            "abuffer-ll",
            "kb-mdt32",
            "f2b",
            "wboit",
            "reference",
            "auto",
        ],
    ),
    ("--effect", &["transparency", "translucency", "complexity"]),
    ("--tail", &["drop", "blend", "weighted"]),
    ("--weight", &["none", "depth", "view"]),
    ("--buckets", &["uniform", "adaptive"]),
    ("--storage-layout", &["pixel-major", "slot-major"]),
    ("--raster", &["hw", "compute"]),
    ("--order", &["random", "front", "back", "object"]),
    ("--pipeline", &["none", "forward", "deferred"]),
    ("--tonemap", &["none", "reinhard", "aces"]),
    ("--normal-encoding", &["octahedral", "spheremap", "exact"]),
    ("--moments", &["4", "6", "8", "trig2", "trig3", "trig4"]),
    (
        "--background",
        &["#336699", "checker", "white", "#fff", "0.5,0.5,0.5"],
    ),
];

fn option_case(rng: &mut Rng) -> OptionCase {
    let mut case = OptionCase {
        size: (count(rng), count(rng)),
        msaa: *rng.pick(&[0, 1, 2, 4, 8, 16]),
        depth_scale: number(rng),
        ..Default::default()
    };
    for _ in 0..1 + rng.below(4) {
        let (name, valid) = *rng.pick(KEYWORDS);
        case.words.push((name, word(rng, valid)));
    }
    if rng.below(2) == 0 {
        case.k = Some(count(rng));
    }
    if rng.below(4) == 0 {
        case.k_auto = Some(number(rng));
    }
    if rng.below(3) == 0 {
        case.budget_mb = Some(number(rng));
    }
    for c in &mut case.counts {
        if rng.below(4) == 0 {
            *c = Some(count(rng));
        }
    }
    case
}

/// How an input ended: what strata accepted, or the one-line error it refused it with.
pub type Outcome = Result<(), String>;

/// Runs `input` through strata's entry point for `target`. `Err` carries strata's refusal,
/// which the caller holds to one line; a panic propagates.
pub fn run_input(target: Target, input: &Input, name: &str) -> Outcome {
    match input {
        Input::File { bytes, dir } => {
            let format = target.format().expect("a file target");
            let mut warnings = Vec::new();
            load_scene_bytes(format, bytes, name, dir, &mut warnings)
                .map(drop)
                .map_err(|e| e.to_string())
        }
        Input::Spec(spec) => load_scene(spec).map(drop).map_err(|e| e.to_string()),
        Input::Options(case) => run_options(case),
    }
}

fn parsed<T: FromStr<Err = strata::Error>>(s: &str) -> Result<T, String> {
    s.parse::<T>().map_err(|e| e.to_string())
}

fn run_options(case: &OptionCase) -> Outcome {
    use strata::frame::{NormalEncoding, Raster, Tonemap};
    let mut options = strata::RenderOptions::default();
    for (name, word) in &case.words {
        let w = word.as_str();
        match *name {
            "--method" => {
                if w != "auto" {
                    parsed::<strata::MethodId>(w)?;
                }
            }
            "--effect" => options.frame.effect = parsed(w)?,
            "--tail" => options.frame.family_mut::<KBufferOptions>().tail = parsed(w)?,
            "--weight" => options.frame.family_mut::<WeightedOptions>().weight = parsed(w)?,
            "--buckets" => options.frame.family_mut::<PeelingOptions>().buckets = parsed(w)?,
            "--storage-layout" => options.frame.family_mut::<KBufferOptions>().layout = parsed(w)?,
            "--raster" => options.build.raster = parsed::<Raster>(w)?,
            "--order" => options.frame.order = Some(parsed(w)?),
            "--pipeline" => options.build.lighting.pipeline = Some(parsed(w)?),
            "--tonemap" => options.build.lighting.tonemap = parsed::<Tonemap>(w)?,
            "--normal-encoding" => {
                options.build.lighting.normal_encoding = parsed::<NormalEncoding>(w)?
            }
            "--moments" => options.frame.family_mut::<WeightedOptions>().moments = parsed(w)?,
            "--background" => options.frame.background = parsed(w)?,
            other => unreachable!("no parser for {other}"),
        }
    }
    options.frame.width = case.size.0;
    options.frame.height = case.size.1;
    options.frame.k = case.k;
    options.frame.k_auto = case.k_auto;
    options.frame.budget_mb = case.budget_mb;
    options.build.msaa = case.msaa;
    let [max_tries, heap_size, layers, passes, coefficients] = case.counts;
    options.frame.family_mut::<KBufferOptions>().max_tries = max_tries;
    options.frame.family_mut::<KBufferOptions>().heap_size = heap_size;
    options.frame.family_mut::<PeelingOptions>().layers = layers;
    if let Some(p) = passes {
        options.frame.family_mut::<WeightedOptions>().passes = p;
    }
    if let Some(c) = coefficients {
        options.frame.family_mut::<WeightedOptions>().coefficients = c;
    }
    options.frame.family_mut::<WeightedOptions>().depth_scale = case.depth_scale;
    options.validate().map_err(|e| e.to_string())
}
