//! strata's in-process fuzzer (issue 65): every input strata parses — OBJ, PLY (ASCII and
//! binary), glTF and GLB, TOML scenes, `builtin:` specs and the library's options — generated
//! from the repository's fixtures and examples by structured mutation, and run through the
//! library's own entry points in this process, a million inputs per target in minutes.
//!
//! Each input must end in a scene (or options) strata accepts, or in an error of exactly one
//! line. A finding is a panic, an error of several lines or none, an input that takes more than
//! the time bound (a watchdog thread ends the run), or one that makes strata's live heap grow
//! past the memory bound (the [`Tracking`] allocator refuses the allocation: the run aborts).
//! Every finding's input is saved under the findings directory, to be kept in
//! `crates/strata/tests/fixtures/regressions/` once fixed; every file there runs first in each
//! run. The generator is deterministic: `--seed S --index I` makes the same input again.
//!
//! The fuzzer is structured rather than coverage-guided: it runs on the stable toolchain the
//! project builds with, and its mutations are the ones that have broken strata's parsers
//! before (`generate`).

pub mod generate;
pub mod target;

use std::alloc::{GlobalAlloc, Layout, System};
use std::io::Write;
use std::panic::AssertUnwindSafe;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, AtomicU64, AtomicUsize, Ordering};
use std::sync::{Mutex, OnceLock};
use std::time::{Duration, Instant};

pub use target::Target;
use target::{make_input, run_input, seeds, seeds_in, Input, Seed};

/// Bytes the heap holds now, the most it held since the last [`reset_peak`], and the bound past
/// which an allocation is refused (0: none).
static LIVE: AtomicUsize = AtomicUsize::new(0);
static PEAK: AtomicUsize = AtomicUsize::new(0);
static LIMIT: AtomicUsize = AtomicUsize::new(0);
/// Set once an allocation was refused: the process aborts next.
static REFUSED: AtomicBool = AtomicBool::new(false);

/// The global allocator of a fuzzing process: the system's, counting live bytes, refusing an
/// allocation that would take them past the memory bound. Before refusing it writes the input
/// being run to the findings file opened for that (it allocates nothing there), so that the
/// abort that follows leaves the input behind.
pub struct Tracking;

unsafe impl GlobalAlloc for Tracking {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        if !admit(layout.size()) {
            return std::ptr::null_mut();
        }
        let p = unsafe { System.alloc(layout) };
        if p.is_null() {
            LIVE.fetch_sub(layout.size(), Ordering::Relaxed);
        }
        p
    }

    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        if !admit(layout.size()) {
            return std::ptr::null_mut();
        }
        let p = unsafe { System.alloc_zeroed(layout) };
        if p.is_null() {
            LIVE.fetch_sub(layout.size(), Ordering::Relaxed);
        }
        p
    }

    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        unsafe { System.dealloc(ptr, layout) };
        LIVE.fetch_sub(layout.size(), Ordering::Relaxed);
    }

    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        let old = layout.size();
        if new_size > old && !admit(new_size - old) {
            return std::ptr::null_mut();
        }
        let p = unsafe { System.realloc(ptr, layout, new_size) };
        match (p.is_null(), new_size > old) {
            (true, true) => {
                LIVE.fetch_sub(new_size - old, Ordering::Relaxed);
            }
            (false, false) => {
                LIVE.fetch_sub(old - new_size, Ordering::Relaxed);
            }
            _ => {}
        }
        p
    }
}

/// Counts `bytes` more as live unless that passes the bound.
fn admit(bytes: usize) -> bool {
    let live = LIVE.fetch_add(bytes, Ordering::Relaxed) + bytes;
    let limit = LIMIT.load(Ordering::Relaxed);
    if limit != 0 && live > limit {
        LIVE.fetch_sub(bytes, Ordering::Relaxed);
        if !REFUSED.swap(true, Ordering::Relaxed) {
            save_refused_input(bytes, live);
        }
        return false;
    }
    PEAK.fetch_max(live, Ordering::Relaxed);
    true
}

/// Live heap bytes now.
pub fn live_bytes() -> usize {
    LIVE.load(Ordering::Relaxed)
}

/// The most live heap bytes since the last call.
pub fn reset_peak() -> usize {
    PEAK.swap(LIVE.load(Ordering::Relaxed), Ordering::Relaxed)
}

/// The input being run, for the allocator's and the watchdog's findings: its bytes are copied
/// here before it runs, and the file the allocator writes them to is opened beforehand.
struct Current {
    bytes: Mutex<Vec<u8>>,
    /// Run start + input start, in microseconds since the run began; 0 while idle.
    started_us: AtomicU64,
    refused_file: OnceLock<std::fs::File>,
}

static CURRENT: Current = Current {
    bytes: Mutex::new(Vec::new()),
    started_us: AtomicU64::new(0),
    refused_file: OnceLock::new(),
};

fn save_refused_input(bytes: usize, live: usize) {
    let mut err = std::io::stderr();
    let _ = writeln!(
        err,
        "finding: an allocation of {bytes} bytes would take the heap to {live} bytes, past the memory bound; the input is saved as over-memory-input in the findings directory"
    );
    if let (Some(mut file), Ok(input)) = (CURRENT.refused_file.get(), CURRENT.bytes.try_lock()) {
        let _ = file.write_all(&input);
    }
}

/// Bounds and where findings go.
#[derive(Clone, Debug)]
pub struct Settings {
    /// Generated inputs per target (the seeds and regression inputs come on top).
    pub inputs: u64,
    /// The run's seed.
    pub seed: u64,
    /// Wall time one input may take.
    pub time_limit: Duration,
    /// Live heap bytes one input may grow the process to.
    pub memory_limit: usize,
    /// Where findings' inputs are saved.
    pub findings: PathBuf,
    /// Print progress every few seconds.
    pub progress: bool,
}

/// A finding: what went wrong with which input.
#[derive(Clone, Debug)]
pub struct Finding {
    /// What went wrong.
    pub what: String,
    /// Where its input was saved.
    pub saved: PathBuf,
}

/// What a target's run did.
#[derive(Clone, Debug)]
pub struct Summary {
    /// The target.
    pub target: Target,
    /// Inputs run: regression inputs, seeds and generated ones.
    pub inputs: u64,
    /// Inputs strata accepted.
    pub accepted: u64,
    /// Inputs strata refused with one error line.
    pub refused: u64,
    /// The most the live heap grew for one input, in bytes.
    pub peak_growth: usize,
    /// The slowest input, and its number in the run (regression inputs first).
    pub slowest: Duration,
    /// See `slowest`.
    pub slowest_input: u64,
    /// The input that grew the heap most, by its number in the run.
    pub largest_input: u64,
    /// Wall time of the run.
    pub elapsed: Duration,
    /// Findings.
    pub findings: Vec<Finding>,
}

impl Summary {
    /// One line for a person.
    pub fn line(&self) -> String {
        let secs = self.elapsed.as_secs_f64();
        format!(
            "{}: {} inputs in {:.1} s ({:.0}/s): {} accepted, {} refused in one line, {} findings; slowest input {:.1} ms (#{}), largest heap growth {:.1} MiB (#{})",
            self.target.name(),
            self.inputs,
            secs,
            self.inputs as f64 / secs.max(1e-9),
            self.accepted,
            self.refused,
            self.findings.len(),
            self.slowest.as_secs_f64() * 1e3,
            self.slowest_input,
            self.peak_growth as f64 / 1048576.0,
            self.largest_input
        )
    }
}

thread_local! {
    static PANIC: std::cell::RefCell<Option<String>> = const { std::cell::RefCell::new(None) };
}

/// Installs the process's fuzzing hooks once: panics while an input runs are recorded, not
/// printed (a run may see many inputs; others go to the previous hook), and the watchdog thread ends the process when an input outlives the time
/// bound, saving it first.
fn install(settings: &Settings) {
    static ONCE: OnceLock<()> = OnceLock::new();
    ONCE.get_or_init(|| {
        let outside = std::panic::take_hook();
        std::panic::set_hook(Box::new(move |info| {
            if CURRENT.started_us.load(Ordering::Relaxed) == 0 {
                return outside(info);
            }
            let what = info.to_string().replace('\n', " ");
            PANIC.with(|p| *p.borrow_mut() = Some(what));
        }));
        let limit = settings.time_limit;
        let findings = settings.findings.clone();
        let epoch = run_epoch();
        std::thread::spawn(move || loop {
            std::thread::sleep(Duration::from_millis(50));
            let started = CURRENT.started_us.load(Ordering::Relaxed);
            if started == 0 {
                continue;
            }
            let now = epoch.elapsed().as_micros() as u64;
            if now.saturating_sub(started) > limit.as_micros() as u64 {
                let saved = findings.join("hang-input");
                let bytes = CURRENT.bytes.lock().map(|b| b.clone()).unwrap_or_default();
                let _ = std::fs::write(&saved, bytes);
                eprintln!(
                    "finding: an input ran for more than {:.1} s; saved as {}",
                    limit.as_secs_f64(),
                    saved.display()
                );
                std::process::exit(3);
            }
        });
    });
}

fn run_epoch() -> Instant {
    static EPOCH: OnceLock<Instant> = OnceLock::new();
    *EPOCH.get_or_init(Instant::now)
}

/// Fuzzes `target`: its regression inputs and seeds as they are, then `settings.inputs`
/// generated ones.
pub fn fuzz(target: Target, settings: &Settings) -> Summary {
    std::fs::create_dir_all(&settings.findings).expect("create the findings directory");
    install(settings);
    let refused_path = settings.findings.join("over-memory-input");
    if CURRENT.refused_file.get().is_none() {
        let file = std::fs::File::create(&refused_path).expect("open the over-memory file");
        let _ = CURRENT.refused_file.set(file);
    }
    let regressions = seeds_in(target, &[target::regressions_dir()]);
    let seeds: Vec<Seed> = seeds(target);
    let mut summary = Summary {
        target,
        inputs: 0,
        accepted: 0,
        refused: 0,
        peak_growth: 0,
        slowest: Duration::ZERO,
        slowest_input: 0,
        largest_input: 0,
        elapsed: Duration::ZERO,
        findings: Vec::new(),
    };
    let started = Instant::now();
    let mut last_report = Instant::now();
    let fixed = regressions.iter().map(|r| Input::File {
        bytes: r.bytes.clone(),
        dir: r.path.parent().unwrap_or(Path::new("")).to_path_buf(),
    });
    let generated = (0..settings.inputs).map(|i| make_input(target, &seeds, settings.seed, i));
    let name = format!("fuzz.{}", target.extension());
    for (n, input) in fixed.chain(generated).enumerate() {
        let bytes = input.bytes();
        if let Ok(mut current) = CURRENT.bytes.lock() {
            current.clear();
            current.extend_from_slice(&bytes);
        }
        let base = live_bytes();
        reset_peak();
        LIMIT.store(base + settings.memory_limit, Ordering::Relaxed);
        let t0 = Instant::now();
        CURRENT.started_us.store(
            run_epoch().elapsed().as_micros().max(1) as u64,
            Ordering::Relaxed,
        );
        let result =
            std::panic::catch_unwind(AssertUnwindSafe(|| run_input(target, &input, &name)));
        CURRENT.started_us.store(0, Ordering::Relaxed);
        LIMIT.store(0, Ordering::Relaxed);
        let took = t0.elapsed();
        if took > summary.slowest {
            (summary.slowest, summary.slowest_input) = (took, n as u64);
        }
        let growth = reset_peak().saturating_sub(base);
        if growth > summary.peak_growth {
            (summary.peak_growth, summary.largest_input) = (growth, n as u64);
        }
        summary.inputs += 1;
        let problem = match result {
            Ok(Ok(())) => {
                summary.accepted += 1;
                None
            }
            Ok(Err(message)) if !message.trim().is_empty() && !message.contains('\n') => {
                summary.refused += 1;
                None
            }
            Ok(Err(message)) => Some(format!("an error that is not one line: {message:?}")),
            Err(_) => Some(format!(
                "a panic: {}",
                PANIC.with(|p| p.borrow_mut().take()).unwrap_or_default()
            )),
        };
        if let Some(what) = problem {
            let saved = settings.findings.join(format!(
                "{}-seed{}-input{}.{}",
                target.name(),
                settings.seed,
                n,
                target.extension()
            ));
            let _ = std::fs::write(&saved, &bytes);
            summary.findings.push(Finding { what, saved });
        }
        if settings.progress && last_report.elapsed() > Duration::from_secs(10) {
            last_report = Instant::now();
            let secs = started.elapsed().as_secs_f64();
            eprintln!(
                "{}: {} inputs, {:.0}/s, {} findings",
                target.name(),
                summary.inputs,
                summary.inputs as f64 / secs,
                summary.findings.len()
            );
        }
    }
    summary.elapsed = started.elapsed();
    summary
}
