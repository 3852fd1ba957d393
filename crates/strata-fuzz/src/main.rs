//! `strata-fuzz [TARGET|all] [--inputs N] [--seed S] [--time-limit-s T] [--memory-mb M]
//! [--findings DIR] [--index I]`: fuzzes strata's parsers in this process (see the library's
//! docs). Prints one summary line per target; exits 1 when there were findings, 2 on bad
//! arguments; a hang ends the run with 3 and an input past the memory bound aborts it, each
//! leaving its input in the findings directory.

use std::path::PathBuf;
use std::process::ExitCode;
use std::time::Duration;

use strata_fuzz::target::{make_input, run_input, seeds};
use strata_fuzz::{fuzz, Settings, Target, Tracking};

#[global_allocator]
static ALLOCATOR: Tracking = Tracking;

const USAGE: &str = "usage: strata-fuzz [TARGET|all] [--inputs N] [--seed S] [--time-limit-s T] [--memory-mb M] [--findings DIR] [--index I]";

struct Args {
    targets: Vec<Target>,
    settings: Settings,
    /// Only rerun this generated input (with its seed) and print how it ends.
    index: Option<u64>,
}

fn parse() -> Result<Args, String> {
    let mut targets = Target::ALL.to_vec();
    let mut settings = Settings {
        inputs: 1_000_000,
        seed: 1,
        time_limit: Duration::from_secs(10),
        memory_limit: 1 << 30,
        findings: PathBuf::from("target/fuzz-findings"),
        progress: true,
    };
    let mut index = None;
    let mut args = std::env::args().skip(1);
    while let Some(arg) = args.next() {
        let mut value = |name: &str| args.next().ok_or(format!("{name} needs a value; {USAGE}"));
        let number = |name: &str, v: String| {
            v.parse::<u64>()
                .map_err(|_| format!("{name} '{v}' is not a whole number"))
        };
        match arg.as_str() {
            "--inputs" => settings.inputs = number("--inputs", value("--inputs")?)?,
            "--seed" => settings.seed = number("--seed", value("--seed")?)?,
            "--index" => index = Some(number("--index", value("--index")?)?),
            "--time-limit-s" => {
                let v = number("--time-limit-s", value("--time-limit-s")?)?;
                settings.time_limit = Duration::from_secs(v.max(1));
            }
            "--memory-mb" => {
                let v = number("--memory-mb", value("--memory-mb")?)?;
                settings.memory_limit = (v.max(1) as usize) << 20;
            }
            "--findings" => settings.findings = PathBuf::from(value("--findings")?),
            "--help" | "-h" => return Err(USAGE.into()),
            "all" => targets = Target::ALL.to_vec(),
            name if !name.starts_with('-') => targets = vec![name.parse()?],
            other => return Err(format!("unknown argument '{other}'; {USAGE}")),
        }
    }
    Ok(Args {
        targets,
        settings,
        index,
    })
}

fn main() -> ExitCode {
    let args = match parse() {
        Ok(a) => a,
        Err(e) => {
            eprintln!("error: {e}");
            return ExitCode::from(2);
        }
    };
    if let Some(index) = args.index {
        for target in args.targets {
            let input = make_input(target, &seeds(target), args.settings.seed, index);
            let name = format!("fuzz.{}", target.extension());
            println!(
                "{}: input {index}: {:?}",
                target.name(),
                run_input(target, &input, &name)
            );
        }
        return ExitCode::SUCCESS;
    }
    let mut findings = 0;
    for target in args.targets {
        let summary = fuzz(target, &args.settings);
        println!("{}", summary.line());
        for f in &summary.findings {
            println!(
                "  finding: {} (input saved as {})",
                f.what,
                f.saved.display()
            );
        }
        findings += summary.findings.len();
    }
    match findings {
        0 => ExitCode::SUCCESS,
        _ => ExitCode::from(1),
    }
}
