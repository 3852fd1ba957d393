//! The contention harness on the test adapter (lavapipe in CI: workgroups on parallel CPU
//! threads; `testing::gpu` runs it with more threads than cores).

use super::*;
use crate::testing::gpu;

/// Repetitions per method: each a new shuffle, new ties and new garbage in the storage.
/// `STRATA_CONTENTION_REPS` sets it (the GPU check runs more).
fn repetitions() -> u64 {
    std::env::var("STRATA_CONTENTION_REPS")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(400)
}

/// Runs `reps` cases of `method` at `k`; returns the failures.
fn failures(harness: &Harness<'_>, method: MethodId, k: u32, reps: u64) -> Vec<String> {
    // lavapipe runs more threads than cores: a descheduled lock holder can outlast any spin,
    // so counted lock failures are allowed there (each costing at most one of the k nearest);
    // on a GPU none is.
    let cpu = gpu().info.device_type == wgpu::DeviceType::Cpu;
    (0..reps)
        .filter_map(|seed| {
            let case = Case {
                allow_starvation: cpu,
                ..Case::new(method, k, seed)
            };
            let (inputs, outcome) = harness.run(&case).unwrap();
            check(&case, &inputs, &outcome).err()
        })
        .collect()
}

/// Every exact capture keeps each pixel's k nearest with no lock failure and nothing lost, with
/// WGSL's relaxed atomics and with the acquire/release atomics of the fragment captures (and of
/// the compute rasterizer's captures of the methods that order), at k = 16 (the array and
/// cascade paths) and k = 4 (deep contention for few slots). The failures of every method are
/// reported.
///
/// On lavapipe before Mesa 22.3.7 the ordered captures run in workgroups of one SIMD vector
/// (`gpu::ordered::workgroup_limit`): in larger ones that Mesa stops running some of a
/// workgroup's invocations, and the ordered lock methods starved and kb-ll's lists came out
/// wrong here — the "lost triangles" of issue 9's compute captures.
#[test]
fn every_exact_capture_keeps_the_k_nearest_under_contention() {
    let gpu = gpu();
    let reps = repetitions();
    let mut all = Vec::new();
    let cpu = gpu.info.device_type == wgpu::DeviceType::Cpu;
    for method in subjects().into_iter().filter(|&m| m != MethodId::Kb) {
        for ordered in [true, false] {
            let harness = Harness::new(gpu, method, ordered, None).unwrap();
            // Where the adapter has no ordered path the relaxed run covers the method.
            if ordered && !harness.ordered {
                continue;
            }
            // x86 orders what a GPU may not, so on a CPU adapter the ordered runs check the
            // ordered modules and their workgroups, not the ordering: an eighth as many.
            let runs = match (harness.ordered, cpu) {
                (true, true) => reps / 16,
                _ => reps / 2,
            };
            for k in [16, 4] {
                let start = std::time::Instant::now();
                let found = failures(&harness, method, k, runs);
                eprintln!(
                    "contention: {method} {} k = {k}: {} of {} runs failed in {:.1} s",
                    if harness.ordered {
                        "ordered"
                    } else {
                        "relaxed"
                    },
                    found.len(),
                    runs,
                    start.elapsed().as_secs_f64()
                );
                if let Some(first) = found.first() {
                    all.push(format!(
                        "{method} {} k = {k}: {} of {} runs failed; first: {first}",
                        if harness.ordered {
                            "ordered"
                        } else {
                            "relaxed"
                        },
                        found.len(),
                        runs
                    ));
                }
            }
        }
    }
    assert!(all.is_empty(), "{}", all.join("\n"));
}

/// The harness has teeth: `kb`'s unlocked sorted insertion, whose read-modify-write hazards are
/// its documented flaw, loses or duplicates fragments under the same contention.
#[test]
fn the_unlocked_k_buffer_races() {
    let harness = Harness::new(gpu(), MethodId::Kb, false, None).unwrap();
    let found = failures(&harness, MethodId::Kb, 16, 20);
    assert!(
        !found.is_empty(),
        "kb kept every pixel's 16 nearest in 20 contended runs"
    );
}

/// Seeded protocol defects fail the harness: the critical section outside the lock (a lock
/// every try takes), and a cascade's read-modify-write of a slot done as a load and a store.
#[test]
fn seeded_protocol_defects_fail() {
    let gpu = gpu();
    let cases: [(MethodId, &str, &str, &str); 3] = [
        (
            MethodId::KplusArray,
            "critical section outside the lock",
            "return atomicLoad(&pixels[word]) == 0u && acquire_lock(word);",
            "return true;",
        ),
        (
            MethodId::KbPs,
            "critical section outside the lock",
            "return atomicLoad(&pixels[word]) == 0u && acquire_lock(word);",
            "return true;",
        ),
        (
            MethodId::KbKeys,
            "non-atomic read-modify-write of a key slot",
            "let old = atomicMax(&fragment_keys[key_word(p, i)], key);",
            "let old = atomicLoad(&fragment_keys[key_word(p, i)]); atomicStore(&fragment_keys[key_word(p, i)], max(old, key));",
        ),
    ];
    let mut missed = Vec::new();
    for (method, what, from, to) in cases {
        let harness = Harness::new(gpu, method, false, Some((from, to))).unwrap();
        if failures(&harness, method, 16, 20).is_empty() {
            missed.push(format!("{method}: {what}"));
        }
    }
    assert!(missed.is_empty(), "defects the harness missed: {missed:?}");
}

/// A fast store published before it is written: a lock holder can read the slot before it
/// holds the fragment. This shows only when a thread is interrupted between the two, so the
/// harness catches it by chance on a CPU; the test reports how often it did, and fails only
/// when a defect-free run fails.
#[test]
fn publication_before_the_store_is_reported_when_caught() {
    let gpu = gpu();
    let seeded = (
        "        store_slot(p, s, f);\n        release_published(pixel_word(p, FILLED), 1u);",
        "        release_published(pixel_word(p, FILLED), 1u);\n        store_slot(p, s, f);",
    );
    let harness = Harness::new(gpu, MethodId::KplusArrayR, false, Some(seeded)).unwrap();
    let caught = failures(&harness, MethodId::KplusArrayR, 16, 20).len();
    eprintln!("publication before the store: caught in {caught} of 20 runs");
    let sound = Harness::new(gpu, MethodId::KplusArrayR, false, None).unwrap();
    assert!(failures(&sound, MethodId::KplusArrayR, 16, 20).is_empty());
}

/// The inputs hold each pixel's fragments once, shuffled, with ties.
#[test]
fn inputs_are_shuffled_with_ties() {
    let case = Case::new(MethodId::KbKeys, 16, 7);
    let inputs = inputs(&case);
    assert_eq!(inputs.len(), 8 * 512);
    let first_pixels: Vec<u32> = inputs.iter().take(16).map(|f| f.pixel).collect();
    assert!(
        first_pixels.windows(2).any(|w| w[0] != w[1]),
        "{first_pixels:?}"
    );
    let mine: Vec<&Input> = inputs.iter().filter(|f| f.pixel == 3).collect();
    let mut tags: Vec<u32> = mine.iter().map(|f| f.tag).collect();
    tags.sort();
    tags.dedup();
    assert_eq!(tags.len(), 512);
    let mut depths: Vec<u32> = mine.iter().map(|f| f.depth.to_bits()).collect();
    depths.sort();
    depths.dedup();
    assert!(depths.len() <= 48);
    assert_ne!(inputs, super::inputs(&Case::new(MethodId::KbKeys, 16, 8)));
}

#[test]
fn harness_params_layout_matches_wgsl() {
    crate::gpu::twin::assert_twin::<HarnessParams>();
    crate::gpu::shader::validate(&stage(MethodId::KbKeys, true).unwrap().0);
    for method in subjects() {
        crate::gpu::shader::validate(&stage(method, true).unwrap().0);
    }
}

/// The harness drives each distinct capture whose kept set it predicts, from the table
/// (`Descriptor::contended`), each on its own family's layout.
#[test]
fn the_harness_drives_each_distinct_capture() {
    use MethodId::*;
    let mut subjects = subjects();
    subjects.sort();
    let mut expected = vec![
        KbKeys,
        KplusArray,
        KplusHeap,
        KplusArrayR,
        KplusSemiheap,
        KbPs,
        KbLl,
        AbufferLl,
        Kb,
    ];
    expected.sort();
    assert_eq!(subjects, expected);
    let e = stage(Mlab, false).err().map(|e| e.to_string());
    assert!(e.is_none(), "mlab has a layout and a capture step: {e:?}");
    let e = stage(Tiled, false).err().unwrap().to_string();
    assert!(e.contains("does not drive tiled"), "{e}");
}
