//! The `strata` binary end to end: the commands users and scripts rely on, and bad input —
//! one clear error line, exit status 2, no panic, no output file.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

mod common;

fn strata(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_strata"))
        .args(args)
        .env("XDG_RUNTIME_DIR", std::env::temp_dir())
        .output()
        .expect("run strata")
}

fn workdir(name: &str) -> PathBuf {
    common::workdir("cli", name)
}

fn fixture(name: &str) -> String {
    format!(
        "{}/../strata/tests/fixtures/{name}",
        env!("CARGO_MANIFEST_DIR")
    )
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// Asserts that `text` contains `part` (the whole text the failure's message).
#[track_caller]
fn assert_contains(text: &str, part: &str) {
    assert!(text.contains(part), "{text}");
}

/// Runs `strata`, which must succeed (its error output the failure's message).
#[track_caller]
fn strata_ok(args: &[&str]) -> Output {
    let o = strata(args);
    assert!(o.status.success(), "{args:?}: {}", stderr(&o));
    o
}

/// Runs `strata ARGS -o OUT`, which must succeed.
#[track_caller]
fn strata_to(args: &[&str], out: &Path) -> Output {
    let mut all = args.to_vec();
    all.extend(["-o", out.to_str().unwrap()]);
    strata_ok(&all)
}

/// Runs `strata ARGS -o OUT --stats STATS`, which must succeed; returns its output and the
/// statistics it wrote.
#[track_caller]
fn strata_to_with_stats(args: &[&str], out: &Path, stats: &Path) -> (Output, serde_json::Value) {
    let mut all = args.to_vec();
    all.extend([
        "-o",
        out.to_str().unwrap(),
        "--stats",
        stats.to_str().unwrap(),
    ]);
    (strata_ok(&all), read_json(stats))
}

/// Runs `strata`, which must refuse: exit status 2 and one line of error output.
#[track_caller]
fn strata_refused(args: &[&str]) -> Output {
    let o = strata(args);
    assert_eq!(o.status.code(), Some(2), "{args:?}: {}", stderr(&o));
    assert_eq!(
        stderr(&o).trim().lines().count(),
        1,
        "{args:?}: {}",
        stderr(&o)
    );
    o
}

fn read_json(path: &Path) -> serde_json::Value {
    serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap()
}

/// `strata compare A B --json`'s figures.
#[track_caller]
fn compare_json(a: &Path, b: &Path) -> serde_json::Value {
    let o = strata_ok(&[
        "compare",
        a.to_str().unwrap(),
        b.to_str().unwrap(),
        "--json",
    ]);
    serde_json::from_slice(&o.stdout).unwrap()
}

/// The largest difference of a channel between two pictures (of 255), as `strata compare` finds.
#[track_caller]
fn max_abs_diff(a: &Path, b: &Path) -> u64 {
    compare_json(a, b)["max_abs_diff"].as_u64().unwrap()
}

#[test]
fn render_writes_png_and_stats() {
    let dir = workdir("render");
    let png = dir.join("demo.png");
    let stats = dir.join("stats.json");
    let (_, v) = strata_to_with_stats(&["render", "--size", "96x64"], &png, &stats);
    let img = image::open(&png).unwrap();
    assert_eq!((img.width(), img.height()), (96, 64));
    for key in [
        "method",
        "width",
        "height",
        "k",
        "effect",
        "geometry_passes",
        "gpu_ms",
        "gpu_ms_total",
        "fragments_generated",
        "fragments_stored",
        "fragments_dropped",
        "max_depth_complexity",
        "bytes_allocated",
        "overflow",
        "lock_failures",
        "memory_ordering",
        "blocking_readbacks",
        "submits",
        "frame",
        "adapter",
        "backend",
    ] {
        assert!(v.get(key).is_some(), "stats lack '{key}': {v}");
    }
    assert_eq!(v["method"], "abuffer-ll");
    assert_eq!(v["width"], 96);
    // Exact mode: at least one submit and the waits for the statistics and the picture.
    assert!(v["submits"].as_u64().unwrap() >= 1);
    assert!(v["blocking_readbacks"].as_u64().unwrap() >= 2);
}

#[test]
fn reference_and_gpu_render_compare_close() {
    let dir = workdir("compare");
    let a = dir.join("gpu.png");
    let b = dir.join("ref.png");
    let diff = dir.join("diff.png");
    let scene = "builtin:spheres?layers=6";
    strata_to(&["render", scene, "--method", "f2b", "--size", "64x64"], &a);
    strata_to(&["reference", scene, "--size", "64x64"], &b);
    let o = strata_ok(&[
        "compare",
        a.to_str().unwrap(),
        b.to_str().unwrap(),
        "--diff",
        diff.to_str().unwrap(),
        "--json",
    ]);
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert!(v["max_abs_diff"].as_u64().unwrap() <= 2, "{v}");
    assert!(diff.exists());
    let o = strata(&["compare", a.to_str().unwrap(), a.to_str().unwrap()]);
    assert!(String::from_utf8_lossy(&o.stdout).contains("PSNR"));
}

#[test]
fn methods_and_info_report_json() {
    let o = strata(&["methods", "--json"]);
    assert!(o.status.success());
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let ids: Vec<_> = v
        .as_array()
        .unwrap()
        .iter()
        .map(|m| m["id"].as_str().unwrap().to_string())
        .collect();
    // A method's entry's field.
    let field = |id: &str, key: &str| {
        v.as_array()
            .unwrap()
            .iter()
            .find(|m| m["id"] == id)
            .unwrap()[key]
            .clone()
    };
    assert_eq!(
        field("abuffer-fixed", "raster"),
        serde_json::json!(["hw", "compute"])
    );
    assert_eq!(field("wboit", "raster"), serde_json::json!(["hw"]));
    assert_eq!(field("sbuffer", "msaa"), serde_json::json!([1, 4, 8]));
    assert_eq!(field("kplus-heap", "msaa"), serde_json::json!([1, 4, 8]));
    assert_eq!(field("kb-mdt64", "msaa"), serde_json::json!([1]));
    assert_eq!(
        field("tiled", "blend"),
        serde_json::json!(["over", "add", "multiply"])
    );
    assert_eq!(field("wboit", "blend"), serde_json::json!(["over"]));
    // The application's own shaders: most methods take them, the rest say why not.
    let app = v
        .as_array()
        .unwrap()
        .iter()
        .filter(|m| m["app_shaders"] == true)
        .count();
    assert!(app >= 25, "{app} methods take application shaders");
    assert_eq!(field("kb-keys", "app_shaders"), true);
    assert_eq!(field("tiled", "app_shaders"), false);
    assert!(field("tiled", "app_shaders_why_not")
        .as_str()
        .unwrap()
        .contains("compute"));
    for id in [
        "reference",
        "unsorted",
        "sorted",
        "f2b",
        "dual",
        "abuffer-ll",
    ] {
        assert!(ids.contains(&id.to_string()), "{ids:?}");
    }
    let o = strata_ok(&["info", "--json"]);
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert!(v["adapter"].is_string() && v["limits"].is_object(), "{v}");
}

#[test]
fn bench_writes_json_and_csv() {
    let dir = workdir("bench");
    strata_ok(&[
        "bench",
        "--scene",
        "builtin:layers?n=4",
        "--methods",
        "f2b,abuffer-ll,reference",
        "--frames",
        "2",
        "--warmup",
        "1",
        "--size",
        "32x32",
        "--out",
        dir.to_str().unwrap(),
    ]);
    let v = read_json(&dir.join("adhoc.json"));
    assert_eq!(v["results"].as_array().unwrap().len(), 3);
    // f2b peels exactly the depth complexity the previous frame measured.
    assert_eq!(v["results"][0]["geometry_passes"], 4);
    assert!(dir.join("adhoc.csv").exists());
}

/// Issue 65's soak, short: a session switching method, k, size, scene and --msaa every few
/// frames ends flat (host and GPU memory from its first half to its second), every frame's statistics its
/// own and the exact methods equal to the reference at each checkpoint.
#[test]
fn a_short_soak_is_flat_and_hands_every_frame_its_own_statistics() {
    let dir = workdir("soak");
    strata_ok(&[
        "bench",
        "soak",
        "--frames",
        "400",
        "--size",
        "16x16",
        "--out",
        dir.to_str().unwrap(),
    ]);
    let v = read_json(&dir.join("soak.json"));
    assert_eq!(v["mismatched_stats"], 0, "{v}");
    assert_eq!(v["flat"], true, "{v}");
    assert_eq!(v["reference_failures"], 0, "{v}");
    assert!(v["matched_stats"].as_u64().unwrap() >= 400, "{v}");
    assert!(v["recorders"].as_u64().unwrap() >= 8, "{v}");
    let checkpoints = v["checkpoints"].as_array().unwrap();
    assert!(checkpoints.len() >= 30, "{}", checkpoints.len());
    for c in checkpoints {
        assert!(c["host_rss_bytes"].as_u64().unwrap() > 0, "{c}");
        assert!(c["gpu_bytes_live"].as_i64().unwrap() > 0, "{c}");
        assert!(c["frame"].as_u64().is_some(), "{c}");
    }
}

/// Bad input: exit status 2, one line naming the problem, no panic, no output file.
fn assert_bad_input(args: &[&str], expect_in_message: &str) {
    let dir = workdir(&format!(
        "bad-{}",
        expect_in_message.replace(|c: char| !c.is_alphanumeric(), "_")
    ));
    let out = dir.join("out.png");
    let mut all: Vec<&str> = args.to_vec();
    let out_s = out.to_str().unwrap().to_string();
    all.extend(["-o", &out_s, "--size", "32x32"]);
    let o = strata(&all);
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(2), "{args:?}: {err}");
    assert!(!err.contains("panicked"), "{args:?} panicked: {err}");
    let lines: Vec<_> = err
        .lines()
        .filter(|l| {
            !l.trim().is_empty() && !l.starts_with("warning:") && !l.contains("XDG_RUNTIME_DIR")
        })
        .collect();
    assert_eq!(
        lines.len(),
        1,
        "{args:?}: expected one error line, got {lines:?}"
    );
    assert!(
        lines[0].starts_with("error: ") && lines[0].contains(expect_in_message),
        "{args:?}: {}",
        lines[0]
    );
    assert!(!out.exists(), "{args:?}: wrote an output file");
}

/// `--msaa 4` renders an anti-aliased picture equal to `reference --msaa 4`; what cannot take it
/// says so in one line.
#[test]
fn msaa_renders_match_the_multisampled_reference() {
    let dir = workdir("msaa");
    let (a, b, single) = (
        dir.join("gpu.png"),
        dir.join("ref.png"),
        dir.join("one.png"),
    );
    let scene = "builtin:spheres?layers=4";
    let run = |args: &[&str], out: &std::path::Path| {
        let mut all = args.to_vec();
        all.extend([scene, "--size", "48x48"]);
        strata_to(&all, out);
    };
    run(&["render", "--method", "sbuffer", "--msaa", "4"], &a);
    run(&["reference", "--msaa", "4"], &b);
    run(&["reference"], &single);
    assert!(max_abs_diff(&a, &b) <= 2);
    // Anti-aliased edges differ from the single-sampled picture.
    assert!(max_abs_diff(&b, &single) > 16);
    // The default scene (its deferred pipeline) takes it: transparency anti-aliased over the
    // lit frame.
    let demo = dir.join("demo.png");
    strata_to(&["render", "--msaa", "4", "--size", "64x64"], &demo);
    assert!(demo.exists());
    for (args, message) in [
        (
            &["render", scene, "--msaa", "2"][..],
            "--msaa 2 is not 1, 4 or 8",
        ),
        (
            &["render", scene, "--msaa", "4", "--method", "kb-mdt-pack"],
            "kb-mdt-pack does not support --msaa",
        ),
        (
            &["render", scene, "--msaa", "4", "--raster", "compute"],
            "--raster compute",
        ),
    ] {
        assert_bad_input(args, message);
    }
}

#[test]
fn bad_input_is_one_line_and_exit_2() {
    assert_bad_input(&["render", "no/such/model.obj"], "not found");
    assert_bad_input(&["render", &fixture("malformed.obj")], "malformed.obj");
    assert_bad_input(&["render", &fixture("malformed.ply")], "malformed.ply");
    assert_bad_input(&["render", &fixture("malformed.gltf")], "malformed.gltf");
    assert_bad_input(&["render", &fixture("malformed.toml")], "malformed.toml");
    assert_bad_input(&["render", &fixture("nan.obj")], "non-finite");
    assert_bad_input(&["render", &fixture("out_of_range.obj")], "out of range");
    assert_bad_input(&["render", &fixture("empty.obj")], "no triangles");
    assert_bad_input(
        &["render", &fixture("unknown_material.toml")],
        "unknown material",
    );
    assert_bad_input(
        &["render", "--method", "nope"],
        "invalid value 'nope' for '--method",
    );
    assert_bad_input(&["render", "builtin:nope"], "unknown builtin");
    assert_bad_input(
        &["render", "--method", "mboit", "--moments", "5"],
        "--moments '5' is not 4, 6, 8 (power moments) or trig2, trig3, trig4",
    );
    assert_bad_input(
        &["render", "--method", "mboit", "--moments", "trig9"],
        "--moments 'trig9' is not 4, 6, 8",
    );
    assert_bad_input(
        &["render", "--method", "stochastic", "--passes", "0"],
        "--passes 0 is outside 1..64",
    );
    assert_bad_input(&["render", "builtin:layers?n=abc"], "n");
    assert_bad_input(
        &["render", "--effect", "glow"],
        "expected one of: transparency",
    );
    assert_bad_input(&["render", "--no-such-flag"], "--no-such-flag");
    assert_bad_input(&["render", "--alpha", "2"], "--alpha");
    assert_bad_input(&["render", "--background", "#zz0000"], "background");
    assert_bad_input(
        &["render", "--raster", "compute", "--method", "wboit"],
        "--raster compute",
    );
    assert_bad_input(&["reference", &fixture("nan.obj")], "non-finite");
    assert_bad_input(
        &["render", "builtin:spheres", "--budget-mb", "0.001"],
        "--budget-mb",
    );
}

#[test]
fn bad_size_is_rejected() {
    let o = strata(&["render", "--size", "0x10", "-o", "/nonexistent/never.png"]);
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("--size"));
}

/// mlab says its fragments past k were merged, not dropped, and refuses --tail (it has none).
#[test]
fn mlab_notes_its_merges_and_refuses_a_tail() {
    let dir = workdir("mlab");
    let out = dir.join("mlab.png");
    let scene = "builtin:layers?n=8&coverage=0.75&order=random&seed=3";
    let o = strata_to(
        &["render", scene, "--method", "mlab", "--size", "32x32"],
        &out,
    );
    assert!(
        stderr(&o).contains("beyond k were merged into the farthest layers")
            && stderr(&o).contains("(k=4)"),
        "{}",
        stderr(&o)
    );
    assert_bad_input(
        &["render", scene, "--method", "mlab", "--tail", "blend"],
        "--tail does not apply to mlab",
    );
}

/// wavg's own option and statistics reach the command line from its folder: `--opacity` is
/// taken (and refused for other methods), the statistics JSON has its "wavg" object, and the
/// summary its line.
#[test]
fn wavg_takes_its_option_and_reports_its_statistics() {
    let dir = workdir("wavg");
    let stats = dir.join("stats.json");
    let (o, s) = strata_to_with_stats(
        &[
            "render",
            "builtin:demo",
            "--method",
            "wavg",
            "--opacity",
            "product",
            "--size",
            "48x48",
        ],
        &dir.join("wavg.png"),
        &stats,
    );
    assert_contains(&stderr(&o), "note: wavg: the average opacity");
    let gap = &s["wavg"];
    assert!(gap["opacity_gap_max"].as_f64().unwrap() > 0.0, "{s}");
    assert!(gap["opacity_gap_pixels"].as_u64().is_some(), "{s}");
    assert_bad_input(
        &[
            "render",
            "builtin:demo",
            "--method",
            "wboit",
            "--opacity",
            "product",
        ],
        "--opacity does not apply to wboit",
    );
    assert_bad_input(
        &[
            "render",
            "builtin:demo",
            "--method",
            "wavg",
            "--opacity",
            "median",
        ],
        "--opacity",
    );
}

#[test]
fn k_buffer_render_matches_reference_k_and_reports_k() {
    let dir = workdir("kbuffer");
    let scene = "builtin:layers?n=12&coverage=0.75&order=random&seed=3";
    let gpu = dir.join("kplus.png");
    let reference = dir.join("ref.png");
    let stats = dir.join("stats.json");
    let (o, s) = strata_to_with_stats(
        &[
            "render",
            scene,
            "--method",
            "kplus-heap",
            "--k",
            "5",
            "--size",
            "48x48",
        ],
        &gpu,
        &stats,
    );
    assert_contains(&stderr(&o), "beyond k=5 were dropped");
    strata_to(
        &["reference", scene, "--k", "5", "--size", "48x48"],
        &reference,
    );
    let v = compare_json(&gpu, &reference);
    assert!(v["max_abs_diff"].as_u64().unwrap() <= 2, "{v}");
    assert_eq!(s["k"], 5);
    assert_eq!(s["lock_failures"], 0);
    assert_eq!(s["max_depth_complexity"], 12);
    let blend = dir.join("blend.png");
    let o = strata_to(
        &[
            "render", scene, "--method", "kb-ps", "--k", "5", "--tail", "blend", "--size", "48x48",
        ],
        &blend,
    );
    assert_contains(&stderr(&o), "blended into the tail");
}

#[test]
fn k_buffer_bad_options_are_one_line_and_exit_2() {
    for (method, options, message) in [
        ("kplus-array", &["--k", "0"][..], "--k"),
        // Beyond the locking methods' cap (a pixel's fragments serialize on its lock).
        ("kplus-array", &["--k", "300"], "--k 300"),
        ("f2b", &["--layers", "0"], "--layers"),
        // bucket keeps two fragments per bucket: k is even.
        ("bucket", &["--k", "7"], "--k 7"),
        ("bucket", &["--buckets", "sideways"], "--buckets"),
        ("kplus-array", &["--tail", "keep"], "--tail"),
        ("kplus-array", &["--culling", "maybe"], "--culling"),
        ("kb-mdt-pack", &["--effect", "translucency"], "translucency"),
        (
            "kplus-heap",
            &["--k", "64", "--budget-mb", "0.05"],
            "--budget-mb",
        ),
        (
            "kplus-heap",
            &["--k", "auto", "--budget-mb", "0.01"],
            "cannot hold even k = 1",
        ),
        (
            "kplus-heap",
            &["--robustness", "0.9"],
            "--robustness applies to --k auto",
        ),
        (
            "kplus-heap",
            &["--k", "auto", "--robustness", "1.5"],
            "--robustness 1.5",
        ),
        ("dual", &["--k", "auto"], "--k does not apply to dual"),
        (
            "kpeel",
            &["--layers-per-pass", "0"],
            "--layers-per-pass 0 is outside 1..",
        ),
    ] {
        let mut args = vec!["render", "--method", method];
        args.extend(options);
        assert_bad_input(&args, message);
    }
}

/// An option the method does not read is refused, naming the methods that read it; options
/// it reads pass.
#[test]
fn options_the_method_does_not_read_are_refused() {
    let layers = "builtin:layers?n=2";
    for (args, message) in [
        (
            &["--method", "abuffer-ll", "--k", "5"][..],
            "--k does not apply to abuffer-ll; it applies to reference, bucket, kpeel, tiled, abuffer-fixed",
        ),
        (&["--method", "kb", "--heap-size", "3"], "kplus-semiheap"),
        (&["--method", "kb", "--moments", "6"], "applies to mboit"),
        (
            &["--method", "kb", "--weight", "eq9"],
            "applies to wboit (and, with --tail weighted, to the k-buffers)",
        ),
        (
            &["--method", "abuffer-ll", "--tail", "weighted"],
            "--tail does not apply to abuffer-ll",
        ),
        (
            &["--method", "wboit", "--depth-scale", "2", "--tail", "blend"],
            "--tail does not apply to wboit",
        ),
        (
            &["--method", "kb", "--max-tries", "9"],
            "--max-tries does not apply to kb",
        ),
        (
            &["--method", "kplus-heap", "--max-tries", "2000000"],
            "--max-tries 2000000 is over 1048576",
        ),
        (
            &["--method", "kplus-heap", "--max-tries", "0"],
            "--max-tries must be at least 1",
        ),
        (
            &["--method", "abuffer-fixed", "--culling", "off"],
            "--culling",
        ),
        (&["--method", "kb", "--cache-dir", "."], "applies to convex"),
        (&["--seed", "5"], "--seed applies to --order random"),
        (
            &["--method", "kb", "--temporal-refresh", "5"],
            "applies to --temporal on",
        ),
    ] {
        let mut all = vec!["render", layers];
        all.extend(args);
        assert_bad_input(&all, message);
    }
    let dir = workdir("options-read");
    let out = dir.join("out.png");
    for options in [
        &["--method", "abuffer-fixed", "--k", "2", "--tail", "blend"][..],
        &["--method", "kpeel", "--layers", "2", "--k", "1"],
        &["--method", "wboit", "--weight", "eq8", "--depth-scale", "2"],
        &[
            "--method",
            "kplus-heap",
            "--k",
            "1",
            "--tail",
            "weighted",
            "--weight",
            "eq10",
        ],
        &[
            "--method",
            "kb-ab-ll",
            "--k",
            "1",
            "--tail",
            "weighted",
            "--depth-scale",
            "2",
        ],
        &["--method", "kb", "--order", "random", "--seed", "3"],
        &["--method", "f2b", "--budget-mb", "64"],
    ] {
        let mut args = vec!["render", layers, "--size", "16x16"];
        args.extend(options);
        strata_to(&args, &out);
    }
}

/// A frame sequence is checked whole before the first frame: a frame that cannot be written
/// leaves none behind. One %d takes the frame number; %% is a percent sign.
#[test]
fn frame_sequences_are_written_whole_or_not_at_all() {
    let dir = workdir("frames-whole");
    std::fs::create_dir_all(dir.join("seq_1.png")).unwrap();
    let render_frames = |frames: &str, pattern: &str| {
        let pattern = dir.join(pattern);
        strata(&[
            "render",
            "builtin:layers?n=2",
            "--size",
            "16x16",
            "--frames",
            frames,
            "-o",
            pattern.to_str().unwrap(),
        ])
    };
    let o = render_frames("0..3", "seq_%d.png");
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert_contains(&stderr(&o), "seq_1.png");
    assert!(!dir.join("seq_0.png").exists(), "frame 0 was left behind");
    for (pattern, message) in [
        ("two_%d_%d.png", "more than one %d"),
        ("none.png", "needs a %d"),
        ("frame_%d.jpg", "must end in .png"),
    ] {
        let o = render_frames("0..2", pattern);
        assert_eq!(o.status.code(), Some(2), "{pattern}: {}", stderr(&o));
        assert!(stderr(&o).contains(message), "{pattern}: {}", stderr(&o));
    }
    let o = render_frames("0..2", "100%%_%02d.png");
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(dir.join("100%_01.png").exists());
    let o = render_frames("0..200000", "many_%d.png");
    assert_eq!(o.status.code(), Some(2));
    assert_contains(&stderr(&o), "at most 100000");
}

/// Clap's errors keep to one line that still names the problem.
#[test]
fn command_line_errors_name_what_is_missing() {
    let o = strata(&["compare", "a.png"]);
    assert_eq!(o.status.code(), Some(2));
    let err = stderr(&o);
    assert!(err.contains("<B>") && err.lines().count() == 1, "{err}");
    let o = strata(&[]);
    assert_eq!(o.status.code(), Some(2));
    let err = stderr(&o);
    assert!(
        err.contains("a command is required: one of render") && err.lines().count() == 1,
        "{err}"
    );
    let o = strata(&["render", "--size"]);
    assert!(!stderr(&o).contains("expected one of: )"), "{}", stderr(&o));
    let dir = workdir("png-name");
    let jpg = dir.join("picture.jpg");
    let o = strata(&["render", "--size", "16x16", "-o", jpg.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(2));
    assert_contains(&stderr(&o), "must end in .png");
    assert!(!jpg.exists());
}

/// `--k auto` picks k from the GPU histogram; the stats name it with the predicted and
/// achieved robustness, and the summary says so.
#[test]
fn auto_k_reports_the_chosen_k() {
    let dir = workdir("auto-k");
    let stats = dir.join("stats.json");
    let out = dir.join("auto.png");
    let (o, s) = strata_to_with_stats(
        &[
            "render",
            "builtin:nvpro?objects=160&subdiv=10&seed=3",
            "--method",
            "kplus-sbuffer",
            "--k",
            "auto",
            "--robustness",
            "0.9",
            "--budget-mb",
            "1",
            "--size",
            "64x64",
        ],
        &out,
        &stats,
    );
    assert_contains(&stderr(&o), "k auto: k=");
    let auto = &s["k_auto"];
    assert_eq!(auto["robustness_target"], 0.9);
    assert!(auto["achieved_robustness"].as_f64().unwrap() >= 0.9, "{s}");
    assert!(s["bytes_allocated"].as_u64().unwrap() <= 1 << 20, "{s}");
    assert!(s["k"].as_u64().unwrap() >= 1);
}

/// `strata histogram` counts on the GPU; `--cpu` (the reference) agrees but for the few edge
/// pixels the exact-method bar allows (0.1% of pixels, each moving between two bins).
#[test]
fn histogram_on_the_gpu_agrees_with_the_cpu() {
    let run = |extra: &[&str]| -> Vec<u64> {
        let mut args = vec![
            "histogram",
            "builtin:nvpro?objects=64&subdiv=10&seed=1",
            "--size",
            "48x48",
            "--json",
        ];
        args.extend(extra);
        let o = strata_ok(&args);
        serde_json::from_slice(&o.stdout).unwrap()
    };
    let (gpu, cpu) = (run(&[]), run(&["--cpu"]));
    assert_eq!(gpu.iter().sum::<u64>(), 48 * 48);
    let moved: u64 = (0..gpu.len().max(cpu.len()))
        .map(|i| gpu.get(i).unwrap_or(&0).abs_diff(*cpu.get(i).unwrap_or(&0)))
        .sum();
    assert!(
        moved as f64 <= 2.0 * 0.001 * 48.0 * 48.0,
        "{gpu:?} vs {cpu:?}"
    );
}

/// `--frames` renders an animation's time steps with one renderer (the balls moving on the
/// GPU, the camera on an `--orbit`): each PNG equals the single-frame render of its step (the
/// scene built on the CPU at that time), and the statistics come as one JSON line per frame.
#[test]
fn frame_sequences_match_single_frames() {
    let dir = workdir("frames");
    let pattern = dir.join("frame_%03d.png");
    let stats = dir.join("frames.jsonl");
    let scene = "builtin:balls?count=60";
    // The sequence's and the single frame's picture.
    let picture = ["render", scene, "--method", "kplus-heap", "--size", "48x48"];
    let orbit = ["--orbit", "4"];
    let sequence = ["--frames", "1..=3", "--stats", stats.to_str().unwrap()];
    strata_to(&[&picture[..], &orbit, &sequence].concat(), &pattern);
    let lines: Vec<serde_json::Value> = std::fs::read_to_string(&stats)
        .unwrap()
        .lines()
        .map(|l| serde_json::from_str(l).unwrap())
        .collect();
    assert_eq!(lines.len(), 3);
    assert_eq!(lines[2]["frame"], 3);
    let single = dir.join("single.png");
    strata_to(&[&picture[..], &["--frame", "3"], &orbit].concat(), &single);
    let a = image::open(dir.join("frame_003.png")).unwrap().to_rgba8();
    let b = image::open(&single).unwrap().to_rgba8();
    assert!(
        a == b,
        "frame 3 of the sequence differs from the single render"
    );
    let first = image::open(dir.join("frame_001.png")).unwrap().to_rgba8();
    assert!(first != a, "the balls move between frames");
    assert_bad_input(&["render", "--frames", "3..1"], "--frames");
    assert_bad_input(&["render", "--orbit", "nan"], "--orbit");
}

/// A scene file's `[[camera_key]]` path moves the camera with `--frame`; `--eye` cannot fix it.
#[test]
fn camera_keys_move_the_camera() {
    let dir = workdir("camera-keys");
    let scene = dir.join("keys.toml");
    std::fs::write(
        &scene,
        "[[object]]\nmesh = \"builtin:cube\"\nopacity = 0.5\n\n[[camera_key]]\ntime = 0\neye = [0.0, 1.0, 4.0]\n\n[[camera_key]]\ntime = 10\neye = [4.0, 1.0, 0.0]\n",
    )
    .unwrap();
    let render = |frame: &str, out: &str| {
        let path = dir.join(out);
        let scene = scene.to_str().unwrap();
        strata_to(
            &["render", scene, "--size", "32x32", "--frame", frame],
            &path,
        );
        image::open(path).unwrap().to_rgba8()
    };
    let at_start = render("0", "k0.png");
    let between = render("5", "k5.png");
    assert!(at_start != between, "the camera moves between keys");
    assert_eq!(render("0", "k0b.png"), at_start);
    assert_bad_input(
        &["render", scene.to_str().unwrap(), "--eye", "1,2,3"],
        "camera_key",
    );
    assert_bad_input(
        &["render", scene.to_str().unwrap(), "--orbit", "5"],
        "--orbit replaces this scene's [[camera_key]] path",
    );
    assert_bad_input(
        &[
            "render",
            scene.to_str().unwrap(),
            "--method",
            "convex",
            "--cache-dir",
            scene.to_str().unwrap(),
        ],
        "is not a directory",
    );
}

#[test]
fn lit_pipelines_render_and_match_the_reference() {
    let dir = workdir("pipelines");
    let reference = dir.join("reference.png");
    // The demo with a field of 8 lights.
    let lights = ["--lights", "8", "--size", "64x48"];
    let forward = ["reference", "--pipeline", "forward"];
    strata_to(&[&forward[..], &lights].concat(), &reference);
    for pipeline in ["forward", "deferred"] {
        let png = dir.join(format!("{pipeline}.png"));
        let stats = dir.join(format!("{pipeline}.json"));
        let render = ["render", "--pipeline", pipeline];
        let (_, v) = strata_to_with_stats(&[&render[..], &lights].concat(), &png, &stats);
        assert_eq!(v["lighting"]["pipeline"], pipeline);
        // The demo's 15 lights and the field's 8.
        assert_eq!(v["lighting"]["lights"], 23);
        let c = compare_json(&png, &reference);
        // Forward is exact; deferred carries the G-buffer's quantization (≤ 3/255).
        assert!(c["max_abs_diff"].as_u64().unwrap() <= 3, "{pipeline}: {c}");
    }
    let debug = dir.join("normals.png");
    strata_to(
        &[
            "render",
            "--gbuffer-debug",
            "normal-error",
            "--size",
            "64x48",
        ],
        &debug,
    );
    assert!(debug.exists());
}

#[test]
fn pipeline_options_are_checked() {
    assert_bad_input(
        &["render", "--pipeline", "forward", "--ssao"],
        "--ssao needs --pipeline deferred",
    );
    assert_bad_input(
        &["render", "--pipeline", "none", "--gbuffer-debug", "albedo"],
        "--gbuffer-debug albedo needs --pipeline deferred",
    );
    assert_bad_input(&["render", "--pipeline", "fast"], "expected one of: none");
    assert_bad_input(&["reference", "--ssao"], "--ssao");
    assert_bad_input(&["render", "--lights", "100000000"], "--lights");
}

/// `--raster compute` renders the GPU path's picture (the demo: deferred pipeline, transparent
/// objects through the compute rasterizer) and says so in its statistics; a lock method runs
/// on it with ordered atomics; `--layers-per-pass` is kpeel's.
#[test]
fn compute_raster_renders_the_gpu_paths_picture() {
    let dir = workdir("raster");
    let mut pictures = Vec::new();
    for raster in ["hw", "compute"] {
        let png = dir.join(format!("{raster}.png"));
        let stats = dir.join(format!("{raster}.json"));
        let args = [
            "render",
            "--raster",
            raster,
            // The exact k nearest (FABS's first-k-to-arrive would depend on arrival order, which
            // differs between the rasterizers).
            "--method",
            "kb-ab-fixed",
            "--k",
            "4",
            "--size",
            "64x48",
        ];
        let (_, v) = strata_to_with_stats(&args, &png, &stats);
        assert_eq!(v["raster"], raster);
        assert_eq!(v["k"], 4);
        assert_eq!(v["compute_raster"].is_object(), raster == "compute");
        pictures.push(png);
    }
    let c = compare_json(&pictures[0], &pictures[1]);
    // The same coverage and f32 shading from the same inputs: within 1/255.
    assert!(c["max_abs_diff"].as_u64().unwrap() <= 1, "{c}");
    let on_compute = |method: &str, extra: &[&str]| {
        let png = dir.join(format!("{method}.png"));
        let stats = dir.join(format!("{method}.json"));
        let mut args = vec!["render", "--raster", "compute", "--method", method];
        args.extend_from_slice(extra);
        args.extend(["--size", "64x48"]);
        let (_, v) = strata_to_with_stats(&args, &png, &stats);
        assert_eq!(v["raster"], "compute");
        v
    };
    let v = on_compute("kpeel", &["--layers-per-pass", "4"]);
    assert_eq!(v["k"], 4);
    // A lock method captures there with acquire/release atomics (its lock failures, which
    // lavapipe's preempted threads can cause, are the library tests' to judge).
    let v = on_compute("kplus-heap", &[]);
    assert!(
        v["memory_ordering"]
            .as_str()
            .is_some_and(|o| o.starts_with("acquire-release")),
        "{v}"
    );
    assert_bad_input(
        &["render", "--layers-per-pass", "2", "--method", "f2b"],
        "--layers-per-pass does not apply to f2b; it applies to kpeel",
    );
    assert_bad_input(
        &[
            "render",
            "--method",
            "kpeel",
            "--layers-per-pass",
            "2",
            "--k",
            "3",
        ],
        "--layers-per-pass and --k",
    );
}

/// `strata view`'s tests (the viewer is the `view` feature).
#[cfg(feature = "view")]
mod view {
    use super::*;

    /// An X display for `strata view`: the environment's, or a private Xvfb stopped on drop.
    struct Display {
        name: String,
        xvfb: Option<std::process::Child>,
    }

    impl Drop for Display {
        fn drop(&mut self) {
            if let Some(child) = &mut self.xvfb {
                // SIGTERM lets Xvfb remove its lock and socket; a killed one leaves them, and a later
                // Xvfb on that number would refuse to start while its stale socket looked alive.
                let _ = Command::new("kill")
                    .args(["-TERM", &child.id().to_string()])
                    .status();
                for _ in 0..100 {
                    if matches!(child.try_wait(), Ok(Some(_))) {
                        return;
                    }
                    std::thread::sleep(std::time::Duration::from_millis(20));
                }
                let _ = child.kill();
                let _ = child.wait();
            }
        }
    }

    fn display() -> Display {
        if let Some(d) = std::env::var_os("DISPLAY").filter(|d| !d.is_empty()) {
            return Display {
                name: d.to_string_lossy().into_owned(),
                xvfb: None,
            };
        }
        static NEXT: std::sync::atomic::AtomicU32 = std::sync::atomic::AtomicU32::new(0);
        // A number no server (live or dead) holds: its lock and socket must not exist yet.
        let taken = |n: u32| {
            PathBuf::from(format!("/tmp/.X{n}-lock")).exists()
                || PathBuf::from(format!("/tmp/.X11-unix/X{n}")).exists()
        };
        let n = (0..64)
            .map(|_| {
                100 + std::process::id() % 500 * 4
                    + NEXT.fetch_add(1, std::sync::atomic::Ordering::Relaxed)
            })
            .find(|&n| !taken(n))
            .expect("a free X display number");
        let name = format!(":{n}");
        let child = Command::new("Xvfb")
            .args([name.as_str(), "-screen", "0", "1024x768x24", "-nolisten", "tcp"])
            .stdout(std::process::Stdio::null())
            .stderr(std::process::Stdio::null())
            .spawn()
            .expect("DISPLAY is unset and Xvfb cannot start: install it (Debian: apt-get install xvfb; scripts/test does)");
        let socket = PathBuf::from(format!("/tmp/.X11-unix/X{n}"));
        for _ in 0..200 {
            if socket.exists() {
                break;
            }
            std::thread::sleep(std::time::Duration::from_millis(25));
        }
        assert!(socket.exists(), "Xvfb {name} did not start");
        Display {
            name,
            xvfb: Some(child),
        }
    }

    /// Runs `strata view ... --screenshot` on `display`; returns the 3D area (x, y, w, h) and the
    /// view-as-command line it printed.
    fn view_screenshot(display: &Display, args: &[&str], shot: &Path) -> ([u32; 4], String) {
        let o = Command::new(env!("CARGO_BIN_EXE_strata"))
            .arg("view")
            .args(args)
            .args(["--screenshot", shot.to_str().unwrap(), "--frames", "4"])
            .env("DISPLAY", &display.name)
            .env("XDG_RUNTIME_DIR", std::env::temp_dir())
            .output()
            .expect("run strata view");
        assert!(o.status.success(), "{}", stderr(&o));
        let out = String::from_utf8_lossy(&o.stdout).into_owned();
        let area: Vec<u32> = out
            .lines()
            .find_map(|l| l.strip_prefix("3d-area: "))
            .expect("the 3D area is printed")
            .split(' ')
            .map(|v| v.parse().unwrap())
            .collect();
        let command = out
            .lines()
            .find_map(|l| l.strip_prefix("command: "))
            .expect("the view as a command is printed")
            .to_string();
        ([area[0], area[1], area[2], area[3]], command)
    }

    /// The 3D area of a window screenshot.
    fn crop(shot: &Path, [x, y, w, h]: [u32; 4], to: &Path) {
        let img = image::open(shot).unwrap().to_rgba8();
        image::imageops::crop_imm(&img, x, y, w, h)
            .to_image()
            .save(to)
            .unwrap();
    }

    #[test]
    fn view_screenshot_shows_the_render_of_the_same_view() {
        let dir = workdir("view");
        let display = display();
        let shot = dir.join("window.png");
        let picture = [
            "builtin:spheres",
            "--size",
            "160x120",
            "--method",
            "kplus-heap",
        ];
        let (area, _) = view_screenshot(&display, &picture, &shot);
        assert_eq!((area[2], area[3]), (160, 120), "the whole picture is shown");
        let window = image::open(&shot).unwrap();
        assert!(
            window.width() >= area[0] + 160 && area[0] > 0,
            "panel on the left"
        );
        let shown = dir.join("shown.png");
        crop(&shot, area, &shown);
        let rendered = dir.join("render.png");
        let mut args = vec!["render"];
        args.extend(picture);
        strata_to(&args, &rendered);
        let d = max_abs_diff(&shown, &rendered);
        assert!(
            d <= 2,
            "the viewer's picture differs from render's by {d}/255"
        );
    }

    #[test]
    fn view_as_command_reproduces_the_view() {
        let dir = workdir("view-command");
        let display = display();
        let shot = dir.join("window.png");
        let (area, command) = view_screenshot(
            &display,
            &[
                "builtin:demo",
                "--size",
                "128x96",
                "--method",
                "kb-mdt32",
                "--k",
                "4",
                "--eye",
                "2.5,1.5,3",
                "--fov",
                "50",
            ],
            &shot,
        );
        assert!(command.starts_with("strata render "), "{command}");
        assert!(command.contains("--pipeline deferred"), "{command}");
        let shown = dir.join("shown.png");
        crop(&shot, area, &shown);
        let rendered = dir.join("command.png");
        let mut words: Vec<String> = command
            .split(' ')
            .skip(1)
            .map(|w| w.trim_matches('\'').to_string())
            .collect();
        let out = words.iter().position(|w| w == "-o").expect("-o") + 1;
        words[out] = rendered.to_str().unwrap().to_string();
        let words: Vec<&str> = words.iter().map(String::as_str).collect();
        let o = strata(&words);
        assert!(o.status.success(), "{command}: {}", stderr(&o));
        let d = max_abs_diff(&shown, &rendered);
        assert!(d <= 2, "{command} differs from the view by {d}/255");
    }

    #[test]
    fn view_without_a_display_says_so() {
        let dir = workdir("view-nodisplay");
        let shot = dir.join("w.png");
        let o = Command::new(env!("CARGO_BIN_EXE_strata"))
            .args(["view", "--screenshot", shot.to_str().unwrap()])
            .env_remove("DISPLAY")
            .env_remove("WAYLAND_DISPLAY")
            .env("XDG_RUNTIME_DIR", std::env::temp_dir())
            .output()
            .unwrap();
        assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
        let err = stderr(&o);
        assert_eq!(err.lines().count(), 1, "{err}");
        assert!(err.contains("DISPLAY"), "{err}");
        assert!(!shot.exists());
        let missing = dir.join("no/such/dir/w.png");
        let o = strata(&["view", "--screenshot", missing.to_str().unwrap()]);
        assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
        assert_contains(&stderr(&o), "does not exist");
        let o = strata(&["view", "--method", "reference"]);
        assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    }
}

fn regression(name: &str) -> String {
    fixture(&format!("regressions/{name}"))
}

#[test]
fn method_auto_chooses_says_why_and_refuses_an_unknown_goal() {
    let dir = workdir("method-auto");
    let (out, stats) = (dir.join("auto.png"), dir.join("auto.json"));
    let args = [
        "render",
        "builtin:spheres?layers=2&segments=8",
        "--method",
        "auto:bounded",
        "--size",
        "32x32",
    ];
    let (o, json) = strata_to_with_stats(&args, &out, &stats);
    assert!(stderr(&o).starts_with("method auto: "), "{}", stderr(&o));
    let method = json["method"].as_str().unwrap();
    assert!(["kb-keys", "kplus-heap", "f2b"].contains(&method), "{json}");
    assert!(
        json["method_choice"]
            .as_str()
            .is_some_and(|w| !w.is_empty()),
        "{json}"
    );
    assert_bad_input(
        &["render", "builtin:spheres", "--method", "auto:fast"],
        "auto's goal is exact, bounded or approximate",
    );
}

#[test]
fn negative_option_values_reach_their_range_checks() {
    let spheres = "builtin:spheres?layers=2&segments=8";
    assert_bad_input(&["render", spheres, "--alpha", "-1"], "--alpha -1");
    assert_bad_input(&["render", spheres, "--k", "-1"], "'-1' for '--k");
    assert_bad_input(&["render", spheres, "--budget-mb", "-1"], "--budget-mb -1");
    assert_bad_input(&["render", spheres, "--fov", "-5"], "--fov -5");
    assert_bad_input(&["render", spheres, "--lights", "-3"], "--lights");
    let dir = workdir("negative-size");
    let out = dir.join("out.png");
    let o = strata(&[
        "render",
        spheres,
        "--size",
        "-1x64",
        "-o",
        out.to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(2));
    assert!(
        stderr(&o).starts_with("error: invalid value '-1x64' for '--size <SIZE>': not WxH"),
        "{}",
        stderr(&o)
    );
    assert!(!out.exists());
}

#[test]
fn loader_messages_name_the_file_the_element_and_what_was_expected() {
    let cases = [
        (
            regression("ply_bad_property_type.ply"),
            "header line 5: 'property floot y': expected property TYPE NAME",
        ),
        (
            regression("gltf_missing_buffer.gltf"),
            "gltf_missing_buffer.gltf: buffer 0 '",
        ),
        (
            regression("gltf_buffer_is_device.gltf"),
            "buffer 0 '/dev/zero': is not a regular file",
        ),
        (
            regression("gltf_bad_base64.gltf"),
            "data URI is not valid base64",
        ),
        (regression("glb_truncated_body.glb"), "truncated GLB"),
        (regression("toml_deeply_nested.toml"), "line 1, column"),
        (
            regression("ply_face_count_over_limit.ply"),
            "element face 4000000000 makes 4000000000 triangles",
        ),
        (
            "builtin:nvpro?objects=100000&subdiv=256".to_string(),
            "objects=100000 × subdiv=256 makes 6502400000 triangles",
        ),
    ];
    for (scene, message) in &cases {
        assert_bad_input(&["render", scene], message);
    }
    // An mtllib naming a device is a warning and is never read.
    let dir = workdir("mtllib-device");
    let out = dir.join("out.png");
    let scene = regression("obj_mtllib_device.obj");
    let o = strata_to(&["render", &scene, "--size", "16x16"], &out);
    assert_contains(&stderr(&o), "'/dev/zero' is not a regular file");
}

#[test]
fn blend_modes_render_with_exact_methods_and_are_refused_by_the_others() {
    let dir = workdir("blend");
    let scene = dir.join("blend.toml");
    std::fs::write(
        &scene,
        r#"[[material]]
name = "glow"
color = [1.0, 0.5, 0.1]
opacity = 0.6
shading = "unlit"
blend = "add"

[[object]]
mesh = "builtin:quad"
material = "glow"

[[object]]
mesh = "builtin:quad"
translate = [0.2, 0.2, -0.5]
color = [0.2, 0.4, 1.0]
opacity = 0.5
blend = "multiply"
"#,
    )
    .unwrap();
    let png = dir.join("blend.png");
    let scene_arg = scene.to_str().unwrap();
    strata_to(
        &["render", scene_arg, "--method", "tiled", "--size", "32x32"],
        &png,
    );
    assert!(png.exists());
    let example = format!("{}/../../examples/blend.toml", env!("CARGO_MANIFEST_DIR"));
    strata_to(
        &["render", &example, "--method", "kb-keys", "--size", "64x40"],
        &png,
    );
    assert_bad_input(
        &["render", scene.to_str().unwrap(), "--method", "wboit"],
        "wboit cannot blend 'add' materials",
    );
    assert_bad_input(
        &[
            "render",
            scene.to_str().unwrap(),
            "--method",
            "kplus-heap",
            "--tail",
            "blend",
        ],
        "--tail blend",
    );
    let bad = dir.join("bad.toml");
    std::fs::write(
        &bad,
        "[[object]]\nmesh = \"builtin:quad\"\nblend = \"screen\"\n",
    )
    .unwrap();
    assert_bad_input(&["render", bad.to_str().unwrap()], "screen");
    // glTF cannot say add or multiply: export says so, and the file reads back the same.
    let glb = dir.join("blend.glb");
    let o = strata_to(&["export", scene.to_str().unwrap()], &glb);
    let notes = stderr(&o);
    assert_contains(
        &notes,
        "note: material 'glow' blends 'add', which glTF cannot express",
    );
}

#[test]
fn a_scene_of_100000_objects_loads_within_its_time_bound() {
    // Each element's line number used to be counted from the start of the file (over a minute
    // here); the bound is generous for a debug build on a loaded machine.
    let dir = workdir("many-objects");
    let scene = dir.join("many.toml");
    let mut text = String::from("[[material]]\nname = \"m\"\n");
    for _ in 0..99_999 {
        text.push_str("[[object]]\nmesh = \"builtin:quad\"\nmaterial = \"m\"\n");
    }
    text.push_str("[[object]]\nmesh = \"builtin:quad\"\nmaterial = \"nope\"\n");
    std::fs::write(&scene, text).unwrap();
    let started = std::time::Instant::now();
    assert_bad_input(
        &["render", scene.to_str().unwrap()],
        "object 100000 (line 300000): unknown material 'nope'",
    );
    assert!(
        started.elapsed() < std::time::Duration::from_secs(30),
        "took {:?}",
        started.elapsed()
    );
}

#[test]
fn outputs_never_replace_devices_or_directories_nor_appear_in_part() {
    let dir = workdir("outputs");
    let spheres = "builtin:spheres?layers=2&segments=8";
    let run = |extra: &[&str]| {
        let mut args = vec!["render", spheres, "--size", "16x16"];
        args.extend(extra);
        strata(&args)
    };
    // A directory is refused and left as it was.
    let o = run(&["-o", dir.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(2));
    assert_contains(&stderr(&o), "it is a directory");
    assert_eq!(
        std::fs::read_dir(&dir).unwrap().count(),
        0,
        "left a file behind"
    );
    // A device is refused and stays a device.
    let o = run(&["-o", "/dev/null"]);
    assert_eq!(o.status.code(), Some(2));
    assert_contains(&stderr(&o), "it is a device");
    #[cfg(unix)]
    {
        use std::os::unix::fs::FileTypeExt;
        let md = std::fs::metadata("/dev/null").unwrap();
        assert!(md.file_type().is_char_device());
    }
    // A statistics file that cannot be written: no PNG either.
    let png = dir.join("a.png");
    let stats = dir.join("no-such-dir").join("s.json");
    let (png_arg, stats_arg) = (png.to_str().unwrap(), stats.to_str().unwrap());
    let o = run(&["-o", png_arg, "--stats", stats_arg]);
    assert_eq!(o.status.code(), Some(2));
    assert_contains(&stderr(&o), "does not exist");
    assert!(!png.exists(), "the PNG appeared without its statistics");
    // Two outputs on one file.
    let o = run(&["-o", png_arg, "--stats", png_arg]);
    assert_eq!(o.status.code(), Some(2));
    assert_contains(&stderr(&o), "same output file");
    // A symbolic link is written through: the link stays, its target gets the picture.
    #[cfg(unix)]
    {
        let target = dir.join("target.png");
        std::fs::write(&target, b"old").unwrap();
        let link = dir.join("link.png");
        std::os::unix::fs::symlink("target.png", &link).unwrap();
        let o = run(&["-o", link.to_str().unwrap()]);
        assert!(o.status.success(), "{}", stderr(&o));
        assert!(std::fs::symlink_metadata(&link)
            .unwrap()
            .file_type()
            .is_symlink());
        assert!(std::fs::read(&target).unwrap().starts_with(b"\x89PNG"));
    }
    let names: Vec<String> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    assert!(
        names.iter().all(|n| !n.contains("strata-tmp")),
        "temporaries left: {names:?}"
    );
}

/// 4096×4096 renders on any adapter: where the picture's per-pixel buffers outgrow one storage
/// binding (lavapipe's 128 MiB holds 2048×2048 resolved colors), in bands of rows.
#[test]
fn a_4096_square_frame_renders() {
    let dir = workdir("4k");
    let out = dir.join("4k.png");
    let spheres = "builtin:spheres?layers=2&segments=8";
    let (o, stats) = strata_to_with_stats(
        &["render", spheres, "--size", "4096x4096"],
        &out,
        &dir.join("4k.json"),
    );
    let img = image::open(&out).unwrap();
    assert_eq!((img.width(), img.height()), (4096, 4096));
    assert_eq!(stats["width"], 4096);
    assert_eq!(stats["height"], 4096);
    assert_eq!(stats["fragments_dropped"], 0);
    if let Some(bands) = stats["bands"].as_u64() {
        assert!(bands >= 2, "{bands}");
        assert!(stderr(&o).contains(&format!("rendered in {bands} bands")));
    }
}

/// `strata convex` reports the decomposition (nested shells: one part each, every pair nested)
/// and renders a color per group; a missing model is one error line and no picture.
#[test]
fn convex_reports_the_decomposition_and_renders_its_pieces() {
    let dir = workdir("convex");
    let out = dir.join("pieces.png");
    let o = strata_ok(&[
        "convex",
        "builtin:spheres?layers=8&segments=16",
        "--size",
        "48x48",
        "--json",
        "--out",
        out.to_str().unwrap(),
    ]);
    let report: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(report["decomposition"]["parts"], 4);
    assert_eq!(report["decomposition"]["nested"], 6);
    assert_eq!(report["decomposition"]["unseparated"], 0);
    // Three shells drawn as front and back caps around the innermost one.
    assert_eq!(report["passes"], 7);
    let img = image::open(&out).unwrap().to_rgba8();
    assert_eq!(img.dimensions(), (48, 48));
    let missing = dir.join("missing.png");
    strata_refused(&[
        "convex",
        "no-such-model.obj",
        "--out",
        missing.to_str().unwrap(),
    ]);
    assert!(!missing.exists());
}

/// `--cache-dir` keeps a decomposition between runs: the second run reads what the first made
/// and renders the same picture; a cache directory that cannot be one is refused up front.
#[test]
fn convex_decompositions_persist_in_the_cache_dir() {
    let dir = workdir("convex-cache");
    let cache = dir.join("cache");
    let _ = std::fs::remove_dir_all(&cache);
    let decompose = || {
        let o = strata_ok(&[
            "convex",
            "builtin:teapot",
            "--size",
            "32x32",
            "--json",
            "--cache-dir",
            cache.to_str().unwrap(),
        ]);
        serde_json::from_slice::<serde_json::Value>(&o.stdout).unwrap()
    };
    let made = decompose();
    assert!(made["decomposition"]["read_from_cache_ms"].is_null());
    let files: Vec<_> = std::fs::read_dir(&cache).unwrap().collect();
    assert_eq!(files.len(), 1);
    let read = decompose();
    assert!(read["decomposition"]["read_from_cache_ms"].is_number());
    for field in ["parts", "groups", "overlapping_pairs", "preprocess_ms"] {
        assert_eq!(read["decomposition"][field], made["decomposition"][field]);
    }
    assert_eq!(read["passes"], made["passes"]);

    let render = |name: &str| {
        let out = dir.join(name);
        strata_to(
            &[
                "render",
                "builtin:teapot",
                "--method",
                "convex",
                "--size",
                "32x32",
                "--cache-dir",
                cache.to_str().unwrap(),
            ],
            &out,
        );
        image::open(&out).unwrap().to_rgba8()
    };
    assert_eq!(render("a.png"), render("b.png"));

    let not_a_dir = dir.join("a.png");
    let out = dir.join("never.png");
    let o = strata_refused(&[
        "render",
        "builtin:teapot",
        "--method",
        "convex",
        "--cache-dir",
        not_a_dir.to_str().unwrap(),
        "-o",
        out.to_str().unwrap(),
    ]);
    assert_contains(&stderr(&o), "--cache-dir");
    assert!(!out.exists());
}

/// `bench all` runs the chosen experiments in turn, writes each one's results and records the
/// suite's durations; names it does not know and single-run options are refused. `bench
/// compare` of a results file with itself moves nothing; bad files are one error line.
#[test]
fn bench_all_runs_the_suite_and_bench_compare_finds_nothing_moved_in_a_rerun_of_itself() {
    let dir = workdir("bench-all");
    let out = dir.join("results");
    let _ = std::fs::remove_dir_all(&out);
    bench_smallest(&["all", "--only", "foundation,deferred-lights"], &out);
    for name in ["foundation", "deferred-lights"] {
        assert!(out.join(format!("{name}.json")).exists(), "{name}");
    }
    let record: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out.join("suite.json")).unwrap()).unwrap();
    let names: Vec<_> = record["experiments"]
        .as_array()
        .unwrap()
        .iter()
        .map(|e| e["name"].as_str().unwrap().to_string())
        .collect();
    assert_eq!(names, ["foundation", "deferred-lights"]);
    assert!(record["experiments"][0]["seconds"].as_f64().unwrap() > 0.0);
    assert_eq!(
        record["experiments"][0]["overrides"],
        "--size 24x24 --frames 1"
    );

    // A run compared with itself: every figure compared, none moved.
    let foundation = out.join("foundation.json");
    let f = foundation.to_str().unwrap();
    let o = strata_ok(&["bench", "compare", f, f, "--repeat", f, "--json"]);
    let c: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(c["experiment"], "foundation");
    assert!(c["figures_compared"].as_u64().unwrap() > 20);
    assert_eq!(c["moved"], serde_json::json!([]));
    let broken = dir.join("broken.json");
    std::fs::write(&broken, "{\"experiment\": ").unwrap();
    let deferred = out.join("deferred-lights.json");
    for args in [
        vec!["bench", "compare", f],
        vec!["bench", "compare", f, broken.to_str().unwrap()],
        vec!["bench", "compare", f, deferred.to_str().unwrap()],
        vec!["bench", "foundation", f],
    ] {
        strata_refused(&args);
    }

    for args in [
        &["bench", "all", "--only", "no-such-experiment"][..],
        &[
            "bench",
            "all",
            "--skip",
            "foundation",
            "--scene",
            "builtin:demo",
        ][..],
        &["bench", "foundation", "--only", "foundation"][..],
    ] {
        strata_refused(args);
    }
}

/// Runs `strata bench ARGS` at its smallest (one frame of 24x24) with results in `out`, which
/// must succeed.
#[track_caller]
fn bench_smallest(args: &[&str], out: &Path) {
    let mut all = vec!["bench"];
    all.extend(args);
    all.extend([
        "--frames",
        "1",
        "--size",
        "24x24",
        "--out",
        out.to_str().unwrap(),
    ]);
    strata_ok(&all);
}

/// `strata report`'s arguments: the results in folder `results`, the report written to `out`.
fn report_args<'a>(results: &'a Path, out: &'a Path) -> [&'a str; 5] {
    let (results, out) = (results.to_str().unwrap(), out.to_str().unwrap());
    ["report", "--results", results, "--out", out]
}

/// `bench bandwidth` probes the device and puts every GPU method against its memory-traffic
/// floor; `strata report` turns the results into its tables.
#[test]
fn bench_bandwidth_measures_rates_and_floors_and_the_report_shows_them() {
    let dir = workdir("bandwidth");
    let _ = std::fs::remove_dir_all(&dir);
    let out = dir.join("results/lavapipe");
    bench_smallest(&["bandwidth"], &out);
    let v = read_json(&out.join("bandwidth.json"));
    for rate in [
        "copy_gb_per_s",
        "stream_gb_per_s",
        "atomics_distinct_g_per_s",
        "atomics_per_pixel_g_per_s",
        "atomics_one_word_g_per_s",
    ] {
        assert!(v["device"][rate].as_f64().unwrap() > 0.0, "{rate}: {v}");
    }
    let rows = v["rows"].as_array().unwrap();
    let methods = strata(&["methods", "--json"]);
    let catalogue: serde_json::Value = serde_json::from_slice(&methods.stdout).unwrap();
    // Every GPU method has a row per scene (lavapipe runs one scene, a GPU two): measured
    // against its floor, or skipped with the reason.
    let mut scenes: Vec<&str> = rows.iter().map(|r| r["scene"].as_str().unwrap()).collect();
    scenes.dedup();
    let gpu_methods = catalogue.as_array().unwrap().len() - 1;
    for scene in &scenes {
        let of_scene = rows.iter().filter(|r| r["scene"] == *scene).count();
        assert_eq!(of_scene, gpu_methods, "{scene}");
    }
    assert_eq!(rows.len(), scenes.len() * gpu_methods);
    for row in rows {
        if row["skipped"].is_string() {
            continue;
        }
        let (ms, floor) = (
            row["median_gpu_ms"].as_f64().unwrap(),
            row["floor_ms"].as_f64().unwrap(),
        );
        assert!(
            floor > 0.0 && row["traffic"]["bytes"].as_u64().unwrap() > 0,
            "{row}"
        );
        let ratio = row["measured_over_floor"].as_f64().unwrap();
        assert!((ratio - ms / floor).abs() <= 1e-9 * ratio, "{row}");
    }
    let report = dir.join("REPORT.md");
    strata_ok(&report_args(&dir.join("results"), &report));
    let text = std::fs::read_to_string(&report).unwrap();
    assert_contains(&text, "| device | copy GB/s | stream GB/s |");
    assert_contains(&text, "measured GPU time / memory-traffic floor");
    // One scene on a CPU adapter ("| abuffer-ll |"), two on a GPU ("| dragon · abuffer-ll |").
    assert_contains(&text, " abuffer-ll |");
    assert!(dir.join("charts/bandwidth.png").exists());
}

/// `strata report` refreshes its generated blocks from the results and keeps the prose around
/// them; run twice it changes nothing; a missing results folder is one error line.
#[test]
fn report_refreshes_generated_blocks_and_keeps_the_prose() {
    let dir = workdir("report");
    let results = dir.join("results");
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(results.join("lavapipe")).unwrap();
    let rows: Vec<serde_json::Value> = [4, 8, 16]
        .iter()
        .flat_map(|&k| {
            ["kb", "kplus-heap"].map(|m| {
                serde_json::json!({"label": format!("{m} k={k}"), "method": m, "k": k,
                                   "median_gpu_ms": k as f64 * if m == "kb" { 2.0 } else { 1.0 }})
            })
        })
        .collect();
    let results_file =
        serde_json::json!({"experiment": "kbuffer-k", "cpu_figures": true, "results": rows});
    std::fs::write(
        results.join("lavapipe/kbuffer-k.json"),
        results_file.to_string(),
    )
    .unwrap();
    let report = dir.join("REPORT.md");
    let prose = "# Benchmark report\n\nhand-written intro\n\n## kbuffer-k — seed 003 Fig. 6\nwhat the figure shows\n\n## scale\nmore prose\n";
    std::fs::write(&report, prose).unwrap();
    let args = report_args(&results, &report);
    strata_ok(&args);
    let first = std::fs::read_to_string(&report).unwrap();
    for line in prose.lines() {
        assert!(first.lines().any(|l| l == line), "lost: {line}");
    }
    let block = first.find("<!-- strata report: kbuffer-k -->").unwrap();
    assert!(block > first.find("what the figure shows").unwrap());
    assert!(block < first.find("## scale").unwrap());
    assert!(first.contains("![kbuffer-k](charts/kbuffer-k.svg)"));
    assert!(first.contains("| kb k=16 | 32.00 |"));
    assert!(first.contains("CPU figures"));
    let svg = std::fs::read_to_string(dir.join("charts/kbuffer-k.svg")).unwrap();
    assert!(svg.contains("<svg") && svg.contains("kplus-heap"));
    // The same chart as a PNG (for the README), and the seeds' claims, empty where the results
    // lack what a claim needs (no k = 64 here).
    let png = image::open(dir.join("charts/kbuffer-k.png"))
        .unwrap()
        .to_rgb8();
    assert_eq!(png.dimensions(), (900, 520));
    assert!(png.pixels().any(|p| p.0 != [255, 255, 255]));
    assert!(first.contains("<!-- strata report: claims -->"));
    assert!(first.contains("| 003 Fig. 6 | k = 64, 128 layers: K+B-Heap 3.5×"));
    strata_ok(&args);
    assert_eq!(std::fs::read_to_string(&report).unwrap(), first);

    strata_refused(&report_args(&dir.join("none"), &report));
    assert_eq!(std::fs::read_to_string(&report).unwrap(), first);
}

/// `strata export` writes a scene as glTF that renders to the same picture as the scene itself:
/// the demo (lights, deferred pipeline), a moving scene at a frame, and a scene file with
/// translucent, unlit and lit materials under the translucency effect.
#[test]
fn exported_gltf_renders_the_same_picture() {
    let dir = workdir("export");
    let balls = "builtin:balls?count=40".to_string();
    let scene_file = fixture("scene.toml");
    let cases: [(&str, &str, &[&str], &[&str]); 3] = [
        ("demo.glb", "builtin:demo", &[], &["--size", "64x48"]),
        (
            "balls.gltf",
            &balls,
            &["--frame", "4"],
            &["--size", "64x48"],
        ),
        (
            "file.glb",
            &scene_file,
            &[],
            &[
                "--effect",
                "translucency",
                "--method",
                "abuffer-fixed",
                "--k",
                "32",
            ],
        ),
    ];
    for (name, scene, export_args, render_args) in cases {
        let exported = dir.join(name);
        let mut args = vec!["export", scene, "-o", exported.to_str().unwrap()];
        args.extend(export_args);
        strata_ok(&args);
        let (direct, reloaded) = (
            dir.join(format!("{name}.direct.png")),
            dir.join(format!("{name}.png")),
        );
        for (source, extra, out) in [
            (scene, export_args, &direct),
            (exported.to_str().unwrap(), &[][..], &reloaded),
        ] {
            let mut args = vec!["render", source, "-o", out.to_str().unwrap()];
            args.extend(extra);
            args.extend(render_args);
            let o = strata(&args);
            assert!(o.status.success(), "{}", stderr(&o));
        }
        assert_eq!(
            std::fs::read(&direct).unwrap(),
            std::fs::read(&reloaded).unwrap(),
            "{name}: the exported scene renders differently"
        );
    }
    // assert_bad_input adds `-o out.png`: not a glTF name.
    assert_bad_input(&["export", "builtin:demo"], "must end in .glb or .gltf");
}

/// `--layers N` peels N layers once: what lies deeper is counted as dropped, and the frame is
/// not peeled again (its passes are N's).
#[test]
fn fixed_layers_peel_once() {
    let dir = workdir("fixed-layers");
    let out = dir.join("out.png");
    let stats = dir.join("stats.json");
    // kpeel's lock-free capture (64-bit atomics) takes a keys and a colors pass per layer group.
    let info = strata(&["info"]);
    let cascade = String::from_utf8_lossy(&info.stdout).contains("SHADER_INT64_ATOMIC_ALL_OPS");
    let kpeel_passes = if cascade { 2 } else { 1 };
    for (method, passes) in [("f2b", 2), ("dual", 2), ("kpeel", kpeel_passes)] {
        let args = [
            "render",
            "builtin:layers?n=8",
            "--size",
            "32x32",
            "--method",
            method,
            "--layers",
            "2",
        ];
        let (_, v) = strata_to_with_stats(&args, &out, &stats);
        assert_eq!(v["geometry_passes"], passes, "{method}: {v}");
        // Two layers kept, the rest dropped (kpeel's k of 8 keeps all 8).
        let count = |key: &str| v[key].as_u64().unwrap();
        assert_eq!(v["max_depth_complexity"], 8, "{v}");
        let dropped = count("fragments_generated") - count("fragments_stored");
        assert_eq!(count("fragments_dropped"), dropped, "{method}: {v}");
        assert_eq!(dropped > 0, method != "kpeel", "{method}: {v}");
    }
}

/// With WebGL2's limits (no storage buffers, no compute) `--method auto` renders with f2b
/// through render targets: the demo's picture, its deferred pipeline set aside with a note, equal
/// to the full device's picture without the pipeline, with the same fragment count; other
/// methods and a bad `STRATA_LIMITS` are refused in one line.
#[test]
fn a_webgl2_device_renders_with_depth_peeling() {
    let dir = workdir("webgl2");
    let run = |args: &[&str], limits: &str| {
        Command::new(env!("CARGO_BIN_EXE_strata"))
            .args(args)
            .env("XDG_RUNTIME_DIR", std::env::temp_dir())
            .env("STRATA_LIMITS", limits)
            .output()
            .expect("run strata")
    };
    let path = |name: &str| dir.join(name).to_str().unwrap().to_owned();
    let o = run(
        &[
            "render",
            "--method",
            "auto",
            "--size",
            "96x72",
            "-o",
            &path("webgl2.png"),
            "--stats",
            &path("webgl2.json"),
        ],
        "webgl2",
    );
    assert!(o.status.success(), "{}", stderr(&o));
    assert_contains(&stderr(&o), "is a downlevel device");
    assert!(
        stderr(&o)
            .contains("note: the scene's pipeline (deferred) does not run on a downlevel device"),
        "{}",
        stderr(&o)
    );
    let o = strata(&[
        "render",
        "--pipeline",
        "none",
        "--size",
        "96x72",
        "-o",
        &path("full.png"),
        "--stats",
        &path("full.json"),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let read = |name: &str| -> serde_json::Value {
        serde_json::from_str(&std::fs::read_to_string(dir.join(name)).unwrap()).unwrap()
    };
    let (webgl2, full) = (read("webgl2.json"), read("full.json"));
    assert_eq!(webgl2["method"], "f2b");
    assert_eq!(webgl2["exact"], true);
    assert_eq!(webgl2["fragments_generated"], full["fragments_generated"]);
    assert_eq!(webgl2["max_depth_complexity"], full["max_depth_complexity"]);
    let o = strata(&["compare", &path("webgl2.png"), &path("full.png")]);
    let out = String::from_utf8_lossy(&o.stdout).into_owned() + &stderr(&o);
    assert!(out.contains("pixels > 2/255  0.0000%"), "{out}");
    let o = run(
        &["render", "--method", "kb-keys", "-o", &path("no.png")],
        "webgl2",
    );
    assert_eq!(o.status.code(), Some(2));
    let errors: Vec<_> = stderr(&o)
        .lines()
        .filter(|l| l.starts_with("error:"))
        .map(str::to_owned)
        .collect();
    assert!(
        errors.len() == 1 && errors[0].starts_with("error: kb-keys does not run here:"),
        "{}",
        stderr(&o)
    );
    assert!(!dir.join("no.png").exists());
    let o = run(
        &[
            "render",
            "--method",
            "auto:approximate",
            "--size",
            "32x32",
            "-o",
            &path("wboit.png"),
        ],
        "webgl2",
    );
    assert!(o.status.success(), "{}", stderr(&o));
    assert_contains(&stderr(&o), "wboit: 32x32");
    let o = run(&["render", "-o", &path("no.png")], "webgl3");
    assert_eq!(o.status.code(), Some(2));
    assert_contains(
        &stderr(&o),
        "STRATA_LIMITS='webgl3' is not one of: adapter, webgl2",
    );
}
