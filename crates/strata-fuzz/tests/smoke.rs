//! CI's smoke run of every fuzz target in process: each target's regression inputs and seeds,
//! then a few thousand generated inputs (a few hundred `builtin:` specs, which build scenes),
//! with no finding. `scripts/fuzz-in-process` runs a million per target.

use std::time::Duration;

use strata_fuzz::{fuzz, Settings, Target, Tracking};

#[global_allocator]
static ALLOCATOR: Tracking = Tracking;

#[test]
fn every_target_ends_each_input_in_a_scene_or_one_error_line() {
    let findings = std::path::Path::new(env!("CARGO_TARGET_TMPDIR")).join("fuzz-findings");
    let mut failures = Vec::new();
    for target in Target::ALL {
        let inputs = match target {
            Target::Builtin => 300,
            Target::Toml => 1000,
            _ => 3000,
        };
        let settings = Settings {
            inputs,
            seed: 0x5EED,
            time_limit: Duration::from_secs(60),
            memory_limit: 1 << 30,
            findings: findings.clone(),
            progress: false,
        };
        let summary = fuzz(target, &settings);
        eprintln!("{}", summary.line());
        if !matches!(target, Target::Builtin | Target::Options) {
            assert!(summary.inputs > inputs, "{}: no seeds", target.name());
        }
        failures.extend(
            summary
                .findings
                .iter()
                .map(|f| format!("{}: {} ({})", target.name(), f.what, f.saved.display())),
        );
    }
    assert!(failures.is_empty(), "{failures:#?}");
}
