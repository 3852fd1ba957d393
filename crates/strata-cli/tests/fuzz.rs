//! The fuzz harness: mutated and generated inputs for every loader (OBJ, PLY, glTF, GLB, TOML,
//! `builtin:` specs) and for the CLI's options, each run through the `strata` binary under a
//! memory and a time bound.
//!
//! Every input must end in one of two ways: exit 0 with a PNG written, or exit 2 with exactly one
//! `error: ` line (warnings aside) and no output file. A panic, another status, a signal (an
//! allocation failure aborts), more than [`MEMORY_BOUND`] of address space or more than
//! [`TIME_BOUND`] is a failure; the input is saved under `target/fuzz-failures/` to be kept as a
//! regression fixture in `crates/strata/tests/fixtures/regressions/`, whose every file is run
//! here too.
//!
//! The inputs come from `strata-fuzz`'s generator, which fuzzes the same parsers in process a
//! million inputs at a time; this harness holds the CLI around them to its contract (status,
//! one error line, no partial output). In the test suite a fixed seed runs a bounded number of
//! cases (a few seconds).
//! `scripts/fuzz [minutes]` runs the same generator for as long as asked with a fresh seed
//! (`STRATA_FUZZ_SECONDS`, `STRATA_FUZZ_SEED`).

use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

mod common;

use strata_fuzz::generate::{builtin_spec, mutate, Rng};

/// Address space a `strata` process may use (`prlimit --as`): inputs are small, so anything
/// near this is a blow-up.
const MEMORY_BOUND: u64 = 4 << 30;
/// Wall time a `strata` process may take on one input (debug build, lavapipe).
const TIME_BOUND: Duration = Duration::from_secs(60);
/// Cases per run in the test suite: one in eight exercises options, one builtin specs, the rest
/// mutated files.
const CASES_IN_TESTS: usize = 48;

fn fixtures_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../strata/tests/fixtures")
}

fn regressions_dir() -> PathBuf {
    fixtures_dir().join("regressions")
}

/// The seed corpus: every model and scene fixture, with the files they refer to.
fn corpus() -> Vec<PathBuf> {
    let mut files: Vec<PathBuf> = std::fs::read_dir(fixtures_dir())
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| {
            matches!(
                p.extension().and_then(|e| e.to_str()),
                Some("obj" | "ply" | "gltf" | "glb" | "toml")
            )
        })
        .collect();
    files.sort();
    files
}

/// Options from sensible to absurd, for `strata render`.
fn option_case(rng: &mut Rng) -> Vec<String> {
    let choices: &[(&str, &[&str])] = &[
        ("--alpha", &["-1", "nan", "1e39", "0.5", "x"]),
        ("--k", &["-1", "0", "99999999", "auto", "x", "4"]),
        ("--budget-mb", &["-1", "0", "1e-9", "1e12", "nan"]),
        (
            "--size",
            &[
                "-1x64",
                "0x0",
                "99999x99999",
                "16384x16384",
                "8x8",
                "x",
                "64",
            ],
        ),
        ("--lights", &["-3", "70000", "4"]),
        ("--fov", &["-5", "0", "180", "1e-30", "nan"]),
        ("--eye", &["nan,0,0", "1e39,0,0", "0,0,3", "1,2"]),
        ("--frame", &["-1", "nan", "1e30", "3"]),
        (
            "--method",
            &[
                "kb-mdt32",
                "f2b",
                "wboit",
                "nope",
                "reference",
                "abuffer-fixed",
            ],
        ),
        ("--max-tries", &["0", "-1", "1"]),
        ("--heap-size", &["-1", "0", "1000000"]),
        ("--layers", &["-1", "0", "100000"]),
        ("--background", &["#zz0000", "checker", "-1"]),
    ];
    let mut args = Vec::new();
    for _ in 0..1 + rng.below(3) {
        let (name, values) = rng.pick(choices);
        args.push(name.to_string());
        args.push(rng.pick(values).to_string());
    }
    args
}

struct Case {
    what: String,
    args: Vec<String>,
    /// The input file, kept when the case fails.
    input: Option<PathBuf>,
}

/// Runs one case; `Err` says what went wrong.
fn run(case: &Case, out: &Path) -> Result<(), String> {
    let _ = std::fs::remove_file(out);
    let mut command = Command::new("prlimit");
    command
        .arg(format!("--as={MEMORY_BOUND}"))
        .arg("--")
        .arg(env!("CARGO_BIN_EXE_strata"))
        .args(&case.args)
        .args(["-o", out.to_str().unwrap()])
        .env("XDG_RUNTIME_DIR", std::env::temp_dir())
        .stdout(Stdio::null())
        .stderr(Stdio::piped());
    let started = Instant::now();
    let mut child = command
        .spawn()
        .expect("run strata under prlimit (util-linux)");
    let mut stderr = child.stderr.take().unwrap();
    let reader = std::thread::spawn(move || {
        let mut text = String::new();
        std::io::Read::read_to_string(&mut stderr, &mut text).ok();
        text
    });
    let status = loop {
        if let Some(status) = child.try_wait().unwrap() {
            break status;
        }
        if started.elapsed() > TIME_BOUND {
            let _ = child.kill();
            let _ = child.wait();
            return Err(format!("took more than {TIME_BOUND:?}"));
        }
        std::thread::sleep(Duration::from_millis(5));
    };
    let err = reader.join().unwrap();
    if err.contains("panicked") {
        return Err(format!("panicked: {err}"));
    }
    match status.code() {
        Some(0) => {
            let bytes = std::fs::read(out).map_err(|_| "exit 0 without an output file")?;
            if !bytes.starts_with(b"\x89PNG") {
                return Err("exit 0 with an output that is not a PNG".into());
            }
            Ok(())
        }
        Some(2) => {
            let lines: Vec<&str> = err
                .lines()
                .filter(|l| !l.trim().is_empty() && !l.starts_with("warning:"))
                .collect();
            if lines.len() != 1 || !lines[0].starts_with("error: ") {
                return Err(format!("exit 2 without exactly one error line: {lines:?}"));
            }
            if out.exists() {
                return Err("exit 2 left an output file".into());
            }
            Ok(())
        }
        other => Err(format!(
            "exit status {other:?} (a signal or an allocation failure?): {err}"
        )),
    }
}

fn workdir(name: &str) -> PathBuf {
    let dir = common::workdir("fuzz", name);
    // Mutated files sit beside copies of what the fixtures refer to (.mtl, .bin).
    for entry in std::fs::read_dir(fixtures_dir()).unwrap() {
        let path = entry.unwrap().path();
        if path.is_file() {
            std::fs::copy(&path, dir.join(path.file_name().unwrap())).unwrap();
        }
    }
    dir
}

fn save_failure(case: &Case, why: &str) -> String {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("../fuzz-failures");
    std::fs::create_dir_all(&dir).unwrap();
    let kept = case.input.as_ref().map(|input| {
        let name = format!(
            "{}-{}",
            std::process::id(),
            input.file_name().unwrap().to_string_lossy()
        );
        let kept = dir.join(name);
        std::fs::copy(input, &kept).unwrap();
        kept.display().to_string()
    });
    format!(
        "{}: {why} (args {:?}{})",
        case.what,
        case.args,
        kept.map(|k| format!(", input kept as {k}"))
            .unwrap_or_default()
    )
}

/// Generates and runs cases until `cases` have run or `deadline` passes; the failures.
fn fuzz(seed: u64, cases: usize, deadline: Option<Instant>) -> (usize, Vec<String>) {
    let dir = workdir("generated");
    let out = dir.join("out.png");
    let corpus = corpus();
    let mut rng = Rng(seed);
    let mut failures = Vec::new();
    let mut ran = 0;
    loop {
        let done = match deadline {
            Some(d) => Instant::now() > d,
            None => ran >= cases,
        };
        if done {
            break;
        }
        let picture = ["--method", "reference", "--size", "8x8"].map(String::from);
        let case = match ran % 8 {
            // One case in eight for options, one for builtin specs, the rest for files.
            0 => {
                let mut args: Vec<String> = ["render", "builtin:spheres?layers=2&segments=8"]
                    .map(String::from)
                    .into();
                let options = option_case(&mut rng);
                if !options.iter().any(|o| o == "--size") {
                    args.extend(["--size", "8x8"].map(String::from));
                }
                args.extend(options);
                Case {
                    what: format!("options case {ran}"),
                    args,
                    input: None,
                }
            }
            1 => {
                let spec = builtin_spec(&mut rng, false);
                let mut args = vec!["render".to_string(), spec];
                args.extend(picture);
                Case {
                    what: format!("builtin case {ran}"),
                    args,
                    input: None,
                }
            }
            _ => {
                let source = rng.pick(&corpus);
                let bytes = mutate(&mut rng, &std::fs::read(source).unwrap());
                let ext = source.extension().unwrap().to_str().unwrap();
                let input = dir.join(format!("case.{ext}"));
                std::fs::write(&input, bytes).unwrap();
                let mut args = vec!["render".to_string(), input.display().to_string()];
                args.extend(picture);
                Case {
                    what: format!(
                        "mutated {} (case {ran}, seed {seed})",
                        source.file_name().unwrap().to_string_lossy()
                    ),
                    args,
                    input: Some(input),
                }
            }
        };
        if let Err(why) = run(&case, &out) {
            failures.push(save_failure(&case, &why));
        }
        ran += 1;
    }
    (ran, failures)
}

#[test]
fn regression_inputs_end_in_a_picture_or_one_error_line() {
    let dir = workdir("regressions");
    let out = dir.join("out.png");
    let mut files: Vec<PathBuf> = std::fs::read_dir(regressions_dir())
        .unwrap()
        .map(|e| e.unwrap().path())
        .collect();
    files.sort();
    assert!(files.len() >= 10, "the regression inputs are missing");
    let failures: Vec<String> = files
        .iter()
        .filter_map(|file| {
            let case = Case {
                what: format!("regression {}", file.display()),
                args: [
                    "render",
                    file.to_str().unwrap(),
                    "--method",
                    "reference",
                    "--size",
                    "8x8",
                ]
                .map(String::from)
                .into(),
                input: Some(file.clone()),
            };
            run(&case, &out).err().map(|why| save_failure(&case, &why))
        })
        .collect();
    assert!(failures.is_empty(), "{failures:#?}");
}

#[test]
fn fuzzed_inputs_end_in_a_picture_or_one_error_line() {
    let seconds: Option<u64> = std::env::var("STRATA_FUZZ_SECONDS")
        .ok()
        .and_then(|s| s.parse().ok());
    let seed = std::env::var("STRATA_FUZZ_SEED")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(0x5EED_F022);
    let deadline = seconds.map(|s| Instant::now() + Duration::from_secs(s));
    let started = Instant::now();
    let (ran, failures) = fuzz(seed, CASES_IN_TESTS, deadline);
    eprintln!(
        "fuzz: {ran} cases with seed {seed} in {:.1} s, {} failed",
        started.elapsed().as_secs_f64(),
        failures.len()
    );
    assert!(failures.is_empty(), "{failures:#?}");
}
