//! `strata`: render, compare and benchmark multi-fragment methods from the command line.

mod args;
mod bench;
mod claims;
mod commands;
mod family_args;
mod files;
mod method_options;
mod report;
#[cfg(feature = "view")]
mod view;

use std::process::ExitCode;

use clap::{CommandFactory, FromArgMatches, Parser, Subcommand};
use strata::error::{Error, Result};

pub use args::{
    apply_camera, cache_dir, parse_vec3, prepare, prepare_render, BackgroundArg, CameraArgs,
    MethodArgs, PictureArgs, PipelineArg, Size, Toggle, MAX_LIGHTS,
};
pub use commands::compare::{compare, CompareArgs};
pub use commands::convex::{convex, ConvexArgs, ConvexReport};
pub use commands::export::{export, ExportArgs};
pub use commands::histogram::{gpu_histogram, histogram, HistogramArgs};
pub use commands::info::info;
pub use commands::methods::list_methods;
pub use commands::reference::{reference, ReferenceArgs};
pub use commands::render::{
    frame_path, parse_frames, render, render_sequence, spinner, summary, RenderArgs, MAX_FRAMES,
};
pub use files::{
    check_outputs, check_results_dir, write_outputs, write_results, write_results_quietly,
    write_results_so_far,
};

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
    /// List every method with its family, exactness, geometry passes and memory; with
    /// --backend, whether each runs on that wgpu backend and what it lacks where it does not.
    Methods {
        /// Print the catalogue as JSON.
        #[arg(long)]
        json: bool,
        /// vulkan | gl | metal | dx12 | webgpu: the support table of one backend, measured on
        /// this machine's adapter of it where there is one, else from wgpu's documentation;
        /// all: every backend from wgpu's documentation, as the README's Markdown table.
        #[arg(long)]
        backend: Option<String>,
        /// Print the catalogue as the README's Markdown table.
        #[arg(long, conflicts_with_all = ["json", "backend"])]
        markdown: bool,
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
    View(args::ViewArgs),
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
                Error::Runtime(_) | Error::DeviceLost(_) => ExitCode::from(1),
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

fn run(mut command: Command) -> Result<()> {
    match &mut command {
        Command::Render(a) => a.method.resolve(&a.picture)?,
        Command::View(a) => a.method.resolve(&a.picture)?,
        _ => {}
    }
    match command {
        Command::Render(a) => render(a),
        Command::Reference(a) => reference(a),
        Command::Compare(a) => compare(a),
        Command::Methods {
            json,
            backend,
            markdown,
        } => match backend {
            Some(backend) => commands::methods::backend_table(&backend, json),
            None => list_methods(json, markdown),
        },
        Command::Info { json } => info(json),
        Command::Histogram(a) => histogram(a),
        Command::Convex(a) => convex(a),
        Command::Export(a) => export(a),
        Command::Bench(a) => bench::run(a),
        Command::Report(a) => report::run(a),
        Command::View(a) => run_view(a),
    }
}

#[cfg(feature = "view")]
fn run_view(a: args::ViewArgs) -> Result<()> {
    view::run(a)
}

#[cfg(not(feature = "view"))]
fn run_view(_: args::ViewArgs) -> Result<()> {
    Err(Error::unsupported(
        "this strata was built without the viewer: `scripts/strata view` builds it (or cargo's --features view)",
    ))
}

/// `e` with `note` after its message, of the same kind.
pub fn with_context(e: Error, note: &str) -> Error {
    match e {
        Error::Input(m) => Error::Input(format!("{m} ({note})")),
        Error::Unsupported(m) => Error::Unsupported(format!("{m} ({note})")),
        Error::Runtime(m) => Error::Runtime(format!("{m} ({note})")),
        Error::DeviceLost(m) => Error::DeviceLost(format!("{m} ({note})")),
    }
}
