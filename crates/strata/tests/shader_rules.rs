//! Rules every WGSL source of strata keeps so that it translates correctly to every backend.
//!
//! No loop condition short-circuits (`&&`, `||`): naga lowers such a condition to a local flag
//! set in an `if` before the loop's exit test, and Mesa's GLSL compiler (llvmpipe, Mesa 22.3,
//! wgpu's GL backend) miscompiles that shape: an insertion sort written `while j > 0u &&
//! before(f, a[j - 1u])` left 18 of 64 test arrays unsorted on GL and none on Vulkan, and every
//! resolve that sorted at the end of the frame drew 25–38% of its pixels wrong. Written as a
//! single test with `if !(…) { break; }` for each further term, the same loops are exact there.
//!
//! `textureLoad`'s level or sample index is an `i32` (a literal or `i32(…)`): naga's GLSL
//! output clamps a `u32` index with `textureSize(t, index)`, which GLSL has no overload for,
//! so the pipeline fails to build on GL.

use std::path::{Path, PathBuf};

fn wgsl_files(dir: &Path, out: &mut Vec<PathBuf>) {
    for entry in std::fs::read_dir(dir).unwrap() {
        let path = entry.unwrap().path();
        if path.is_dir() {
            wgsl_files(&path, out);
        } else if path.extension().is_some_and(|e| e == "wgsl") {
            out.push(path);
        }
    }
}

/// Every line of strata's WGSL sources, with its place (`path:line`, relative to the crate).
fn wgsl_lines() -> Vec<(String, String)> {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut files = Vec::new();
    wgsl_files(&root.join("src"), &mut files);
    wgsl_files(&root.join("shaders"), &mut files);
    assert!(files.len() > 50, "found only {} WGSL files", files.len());
    let mut lines = Vec::new();
    for file in &files {
        let text = std::fs::read_to_string(file).unwrap();
        let name = file.strip_prefix(root).unwrap().display().to_string();
        for (i, line) in text.lines().enumerate() {
            lines.push((format!("{name}:{}", i + 1), line.to_string()));
        }
    }
    lines
}

/// The condition of a loop that starts on `line` (`while c {`, `for (init; c; step) {`).
fn loop_condition(line: &str) -> Option<&str> {
    let line = line.trim_start();
    if let Some(rest) = line.strip_prefix("while ") {
        return Some(rest.trim_end().trim_end_matches('{'));
    }
    let rest = line.strip_prefix("for (")?;
    let mut parts = rest.splitn(3, ';');
    parts.next()?;
    parts.next()
}

#[test]
fn no_loop_condition_short_circuits() {
    let mut found = Vec::new();
    for (place, line) in wgsl_lines() {
        if let Some(condition) = loop_condition(&line) {
            // The per-pixel lock loops end at their condition on purpose (kbuffer's
            // `lock_winners_leave_their_loop_only_through_its_condition`: a GPU's SIMD group
            // must not let a lock winner leave from inside the lock's `if`); their methods need
            // ordered atomics, which only Vulkan's SPIR-V passthrough gives, so they never pass
            // through GLSL.
            let lock_loop = condition.trim_end().ends_with("&& waiting");
            if !lock_loop && (condition.contains("&&") || condition.contains("||")) {
                found.push(format!("{place}: {}", line.trim()));
            }
        }
    }
    assert!(
        found.is_empty(),
        "loop conditions that short-circuit (write one test and break on the others):\n{}",
        found.join("\n")
    );
}

/// The last argument of each `textureLoad(…)` call on `line` that is neither a literal nor an
/// `i32(…)` conversion.
fn unsigned_load_indices(line: &str) -> Vec<&str> {
    let mut found = Vec::new();
    let mut rest = line;
    while let Some(at) = rest.find("textureLoad(") {
        let args = &rest[at + "textureLoad(".len()..];
        let mut depth = 0;
        let mut end = args.len();
        for (i, c) in args.char_indices() {
            match c {
                '(' => depth += 1,
                ')' if depth == 0 => {
                    end = i;
                    break;
                }
                ')' => depth -= 1,
                _ => {}
            }
        }
        let call = &args[..end];
        if let Some((_, last)) = call.rsplit_once(", ") {
            let literal = last.chars().all(|c| c.is_ascii_digit());
            if !literal && !last.starts_with("i32(") {
                found.push(last);
            }
        }
        rest = &args[end..];
    }
    found
}

#[test]
fn texture_load_indices_are_signed() {
    let mut found = Vec::new();
    for (place, line) in wgsl_lines() {
        for index in unsigned_load_indices(&line) {
            found.push(format!("{place}: {index}"));
        }
    }
    assert!(
        found.is_empty(),
        "textureLoad level or sample indices that are not i32:\n{}",
        found.join("\n")
    );
}

#[test]
fn the_index_rule_reads_nested_calls() {
    assert_eq!(
        unsigned_load_indices("let c = textureLoad(t, vec2<i32>(p), si) + textureLoad(u, p, 0);"),
        vec!["si"]
    );
    assert!(unsigned_load_indices("textureLoad(t, f(a, b), i32(s)).r").is_empty());
}

#[test]
fn the_rule_sees_both_loop_forms() {
    assert_eq!(
        loop_condition("    while j > 0u && f(a) {"),
        Some("j > 0u && f(a) ")
    );
    assert_eq!(
        loop_condition("for (var t = 0u; t < n && w; t++) {"),
        Some(" t < n && w")
    );
    assert_eq!(loop_condition("if a && b {"), None);
}
