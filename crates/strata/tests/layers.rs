//! The library's modules import only downward, in the order ARCHITECTURE.md draws (its
//! "Layers" section). Reads every non-test source file of `src/` (files named `tests.rs` or
//! `testing.rs`, and `#[cfg(test)]` items, are skipped), finds the crate modules each names
//! (`crate::x`, and the first segment of each path in `crate::{…}`), and lists every reference
//! to a module of the same or a higher layer. `scripts/layers` runs it.

use std::path::Path;

/// Lowest first; modules of one layer may not import each other.
const LAYERS: &[&[&str]] = &[
    &["error"],
    &["keyword"],
    &["output"],
    &["gpu"],
    &["resolve"],
    &["scene"],
    &["order"],
    &["animation"],
    &["frame"],
    &["raster", "deferred"],
    &["metrics"],
    &["reference"],
    &["methods"],
    &["render"],
];

fn level(module: &str) -> Option<usize> {
    LAYERS.iter().position(|layer| layer.contains(&module))
}

/// The text with `#[cfg(test)]` items blanked (their lines kept, so line numbers hold).
fn without_tests(text: &str) -> String {
    let mut out = String::with_capacity(text.len());
    let mut rest = text;
    while let Some(at) = rest.find("#[cfg(test)]") {
        out.push_str(&rest[..at]);
        let item = &rest[at..];
        let brace = item.find('{');
        let semicolon = item.find(';');
        let end = match (brace, semicolon) {
            (_, Some(s)) if brace.is_none_or(|b| s < b) => s + 1,
            (Some(b), _) => {
                let mut depth = 0;
                let mut end = item.len();
                for (i, c) in item[b..].char_indices() {
                    match c {
                        '{' => depth += 1,
                        '}' => {
                            depth -= 1;
                            if depth == 0 {
                                end = b + i + 1;
                                break;
                            }
                        }
                        _ => {}
                    }
                }
                end
            }
            _ => item.len(),
        };
        out.extend(item[..end].chars().filter(|&c| c == '\n'));
        rest = &item[end..];
    }
    out.push_str(rest);
    out
}

fn identifier(s: &str) -> &str {
    let end = s
        .find(|c: char| !(c.is_ascii_lowercase() || c.is_ascii_digit() || c == '_'))
        .unwrap_or(s.len());
    &s[..end]
}

/// The crate modules `code` names, with the byte offset of each.
fn references(code: &str) -> Vec<(usize, String)> {
    let mut found = Vec::new();
    for (at, _) in code.match_indices("crate::") {
        if at > 0 && code[..at].ends_with(|c: char| c.is_alphanumeric() || c == '_') {
            continue;
        }
        let after = &code[at + "crate::".len()..];
        if let Some(group) = after.strip_prefix('{') {
            // The first segment of each path of the group's top level.
            let (mut depth, mut start) = (0, true);
            let mut i = 0;
            while i < group.len() {
                let c = group[i..].chars().next().unwrap();
                match c {
                    '{' => depth += 1,
                    '}' if depth == 0 => break,
                    '}' => depth -= 1,
                    ',' if depth == 0 => start = true,
                    c if c.is_ascii_lowercase() && start && depth == 0 => {
                        found.push((at, identifier(&group[i..]).to_string()));
                        start = false;
                    }
                    _ => {}
                }
                i += c.len_utf8();
            }
        } else {
            found.push((at, identifier(after).to_string()));
        }
    }
    found
}

fn visit(dir: &Path, root: &Path, violations: &mut Vec<String>) {
    let mut entries: Vec<_> = std::fs::read_dir(dir).unwrap().flatten().collect();
    entries.sort_by_key(|e| e.path());
    for entry in entries {
        let path = entry.path();
        let name = entry.file_name().to_string_lossy().into_owned();
        if path.is_dir() {
            if name != "tests" {
                visit(&path, root, violations);
            }
            continue;
        }
        if !name.ends_with(".rs") || name == "tests.rs" || name == "testing.rs" {
            continue;
        }
        let relative = path.strip_prefix(root).unwrap();
        let top = relative
            .components()
            .next()
            .unwrap()
            .as_os_str()
            .to_string_lossy()
            .trim_end_matches(".rs")
            .to_string();
        let Some(own) = level(&top) else { continue };
        let text = without_tests(&std::fs::read_to_string(&path).unwrap());
        let code: String = text
            .lines()
            .map(|l| l.split("//").next().unwrap_or(""))
            .collect::<Vec<_>>()
            .join("\n");
        for (at, other) in references(&code) {
            if other == top {
                continue;
            }
            if let Some(theirs) = level(&other) {
                if theirs >= own {
                    let line = code[..at].matches('\n').count() + 1;
                    violations.push(format!("{}:{line}: {top} -> {other}", relative.display()));
                }
            }
        }
    }
}

#[test]
fn modules_import_only_downward() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let mut violations = Vec::new();
    visit(&root, &root, &mut violations);
    assert!(
        violations.is_empty(),
        "{} upward or sideways reference(s) between the library's layers (ARCHITECTURE.md, Layers):\n{}",
        violations.len(),
        violations.join("\n")
    );
}

#[test]
fn the_check_sees_grouped_and_plain_paths_and_skips_tests() {
    let code =
        "use crate::{frame::A, methods::{B, C}};\nlet x = crate::render::f();\nmy_crate::gpu::g();";
    let names: Vec<String> = references(code).into_iter().map(|(_, n)| n).collect();
    assert_eq!(names, ["frame", "methods", "render"]);
    let text = "a\n#[cfg(test)]\nmod tests {\n crate::render::x();\n}\nb";
    assert_eq!(without_tests(text), "a\n\n\n\n\nb");
}

/// Every non-test source file of the workspace's crates (files named `tests.rs` or `testing.rs`
/// and folders named `tests` are test code), with its line count.
fn source_files(dir: &Path, found: &mut Vec<(std::path::PathBuf, usize)>) {
    for entry in std::fs::read_dir(dir).unwrap().flatten() {
        let path = entry.path();
        let name = entry.file_name().to_string_lossy().into_owned();
        if path.is_dir() {
            if name != "tests" && name != "target" {
                source_files(&path, found);
            }
        } else if name.ends_with(".rs") && name != "tests.rs" && name != "testing.rs" {
            let lines = std::fs::read_to_string(&path).unwrap().lines().count();
            found.push((path, lines));
        }
    }
}

/// A source file past 1000 lines holds more than one idea: split it.
#[test]
fn no_source_file_is_over_1000_lines() {
    let crates = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    let mut files = Vec::new();
    source_files(&crates, &mut files);
    assert!(files.len() > 100, "found only {} source files", files.len());
    let long: Vec<String> = files
        .iter()
        .filter(|(_, lines)| *lines > 1000)
        .map(|(path, lines)| format!("{}: {lines} lines", path.display()))
        .collect();
    assert!(
        long.is_empty(),
        "source files over 1000 lines:\n{}",
        long.join("\n")
    );
}
