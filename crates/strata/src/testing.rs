//! Helpers for the crate's own tests: one shared GPU per test process (a missing adapter fails
//! the test — never a skip), small scenes, and GPU-vs-reference image checks that write the
//! actual and diff images under `target/` when they fail.

use std::sync::OnceLock;

use crate::frame::RenderOptions;
use crate::gpu::Gpu;
use crate::render::{LinearImage, Renderer};
use crate::scene::Scene;

pub fn gpu() -> &'static Gpu {
    static GPU: OnceLock<Gpu> = OnceLock::new();
    GPU.get_or_init(|| {
        // lavapipe: more threads than cores, so workgroups of the contention harness
        // (methods::kbuffer::contention) interleave at any instruction. Set before the first
        // Vulkan call, inside this one-time initialisation.
        if std::env::var_os("LP_NUM_THREADS").is_none() {
            std::env::set_var("LP_NUM_THREADS", "8");
        }
        new_gpu()
    })
}

fn new_gpu() -> Gpu {
    match Gpu::new() {
        Ok(g) => g,
        Err(e) => panic!("GPU tests need an adapter (lavapipe in CI): {e}"),
    }
}

pub fn render_gpu(
    scene: &Scene,
    options: &RenderOptions,
    method: &str,
) -> (LinearImage, crate::FrameStats) {
    let mut r = Renderer::new(gpu(), scene, options).unwrap_or_else(|e| panic!("{method}: {e}"));
    r.render(method).unwrap_or_else(|e| panic!("{method}: {e}"))
}

/// A picture made pixel by pixel from the reference's fragments (the device's at the pixels
/// where its rasterizer made some fragment otherwise: `fragments_where_rasterizers_agree`):
/// `pixel(index, fragments, background)` is the pixel's linear color (the approximate methods'
/// closed forms); the fragment counts are those lists'.
pub fn per_pixel(
    scene: &Scene,
    options: &RenderOptions,
    pixel: impl Fn(u32, &[crate::resolve::RefFragment], [f64; 3]) -> [f64; 3],
) -> LinearImage {
    let lists = crate::methods::kbuffer::tests::fragments_where_rasterizers_agree(scene, options);
    let w = options.frame.width;
    let pixels = lists
        .iter()
        .enumerate()
        .map(|(i, l)| {
            let bg = options.frame.background.at(i as u32 % w, i as u32 / w);
            let c = pixel(i as u32, l, bg.map(|c| c as f64));
            [c[0] as f32, c[1] as f32, c[2] as f32, l.len() as f32]
        })
        .collect();
    LinearImage {
        width: w,
        height: options.frame.height,
        pixels,
    }
}

pub fn render_reference(scene: &Scene, options: &RenderOptions) -> LinearImage {
    crate::reference::render(scene, options)
        .expect("reference")
        .0
}

/// What an exact picture is checked against on a device.
pub struct ExactTruth {
    /// The reference's picture, except at the pixels where the device's rasterizer gave some
    /// fragment a depth or shading beyond the agreement bounds of
    /// `the_devices_fragments_are_the_references` (methods/kbuffer/tests.rs): there the
    /// reference over the device's own fragments. The H100's interpolation puts a few normals
    /// that are nearly perpendicular to the view on the other side of it, and two-sided lighting
    /// then turns them the other way (up to 0.19 in color, 2026-11-27); either side is a right
    /// picture of what that rasterizer produced. On lavapipe no pixel is taken.
    pub expected: LinearImage,
    /// The reference over the device's fragments: their depths, samples, facing and shading.
    pub at_device: LinearImage,
    /// Fragments only one of the reference and the device has (pixel centres on an edge).
    pub unmatched: u64,
    /// Pixels of `expected` taken from `at_device`.
    pub disagreeing: usize,
}

/// Compares 8-bit sRGB pictures: at most `max_fraction` of pixels may differ by more than
/// `max_diff` in some channel. Panics with where the images were written.
pub fn assert_close(
    name: &str,
    actual: &LinearImage,
    expected: &LinearImage,
    effect: crate::Effect,
    max_diff: u8,
    max_fraction: f64,
) {
    let (a, e) = (actual.to_rgba8(effect), expected.to_rgba8(effect));
    if let Err(msg) = crate::metrics::testing::check_image(name, &a, &e, max_diff, max_fraction) {
        panic!("{msg}");
    }
}

/// The bar of an exact method's picture: max |Δ| ≤ 2/255 per sRGB channel on ≥ 99.9% of pixels
/// (why not 100%: see methods/tests.rs).
pub const EXACT_MAX_DIFF: u8 = 2;
/// See [`EXACT_MAX_DIFF`].
pub const EXACT_MAX_FRACTION: f64 = 0.001;

/// [`assert_close`] at the exact methods' bar ([`EXACT_MAX_DIFF`], [`EXACT_MAX_FRACTION`]).
pub fn assert_exact(
    name: &str,
    actual: &LinearImage,
    expected: &LinearImage,
    effect: crate::Effect,
) {
    assert_close(
        name,
        actual,
        expected,
        effect,
        EXACT_MAX_DIFF,
        EXACT_MAX_FRACTION,
    );
}

/// The picture a method must give, with the effect pictures are compared in: a test's truth for
/// several pictures at the exact methods' bar.
pub struct Expected {
    pub image: LinearImage,
    pub effect: crate::Effect,
}

impl Expected {
    /// The reference's picture of `scene` under `options`.
    pub fn reference(scene: &Scene, options: &RenderOptions) -> Self {
        Expected {
            image: render_reference(scene, options),
            effect: options.frame.effect,
        }
    }

    /// [`assert_exact`]: `actual` against this picture (images named `name`).
    pub fn assert_exact(&self, name: &str, actual: &LinearImage) {
        assert_exact(name, actual, &self.image, self.effect);
    }
}

/// How many pixels of two pictures of one size differ.
pub fn differing_pixels(a: &LinearImage, b: &LinearImage) -> usize {
    a.pixels
        .iter()
        .zip(&b.pixels)
        .filter(|(x, y)| x != y)
        .count()
}

/// The name of a builtin scene's spec: `builtin:NAME?…` → `NAME`.
pub fn scene_name(spec: &str) -> &str {
    spec.split('?')
        .next()
        .unwrap()
        .trim_start_matches("builtin:")
}

/// Asserts a `#[repr(C)]` struct's size and its fields' offsets in bytes, as its WGSL twin lays
/// them out: `assert_layout!(Params, 48, count: 16, samples: 32)`.
macro_rules! assert_layout {
    ($t:ty, $size:expr $(, $field:ident: $offset:expr)* $(,)?) => {{
        assert_eq!(std::mem::size_of::<$t>(), $size, "size of {}", stringify!($t));
        $(
            assert_eq!(
                std::mem::offset_of!($t, $field),
                $offset,
                "offset of {}.{}",
                stringify!($t),
                stringify!($field)
            );
        )*
    }};
}
pub(crate) use assert_layout;

/// A front-facing fragment blended over, covering its one sample, without absorption: primitive
/// `prim` at `depth` (its distance too).
pub fn fragment(prim: u32, depth: f64, alpha: f64, color: [f64; 3]) -> crate::resolve::RefFragment {
    crate::resolve::RefFragment {
        depth,
        prim,
        front_facing: true,
        color,
        alpha,
        absorption: 0.0,
        distance: depth,
        coverage: 1,
        blend: crate::scene::Blend::Over,
    }
}

/// A renderer of `scene` on the shared GPU.
pub fn renderer(scene: &Scene, options: &RenderOptions) -> Renderer<'static> {
    Renderer::new(gpu(), scene, options).unwrap_or_else(|e| panic!("renderer: {e}"))
}

/// Two frames of `method`, the second after its storage was filled with garbage: the same
/// picture and the same number of fragments.
pub fn assert_poison_changes_nothing(
    scene: &Scene,
    options: &RenderOptions,
    method: crate::MethodId,
) {
    let mut r = renderer(scene, options);
    let (clean, a) = r.render_method(method, None).unwrap();
    r.recorder().unwrap().poison();
    let (poisoned, b) = r.render_method(method, None).unwrap();
    assert!(
        clean == poisoned,
        "{method}: poisoned memory changed the picture"
    );
    assert_eq!(a.fragments_generated, b.fragments_generated, "{method}");
}

/// Asserts that `e` is an input error (a wrong option or value) that says `says`; `what` names
/// the case.
pub fn assert_input_error(what: &str, e: &crate::Error, says: &str) {
    let input = matches!(e, crate::Error::Input(_));
    assert!(input && e.to_string().contains(says), "{what}: {e}");
}

/// Asserts that `e` says what is unsupported, `says`; `what` names the case.
pub fn assert_unsupported(what: &str, e: &crate::Error, says: &str) {
    let unsupported = matches!(e, crate::Error::Unsupported(_));
    assert!(unsupported && e.to_string().contains(says), "{what}: {e}");
}

/// The failures of a test that checks several methods: every method runs, and the test fails
/// at the end naming each failing method and why, so one run on a scarce GPU says everything.
#[derive(Default)]
pub struct Failures(Vec<String>);

impl Failures {
    /// Records `method`'s failure, if any.
    pub fn check(&mut self, method: &str, result: Result<(), String>) {
        if let Err(why) = result {
            self.0.push(format!("{method}: {why}"));
        }
    }

    /// Records a frame's lock failures first, as the cause of whatever else differs: returns
    /// false (and records it) when the frame lost fragments to its locks, so the caller skips
    /// the picture checks that would only repeat it.
    pub fn locks_held(&mut self, method: &str, stats: &crate::FrameStats) -> bool {
        let failures = stats.lock_failures.unwrap_or(0);
        if failures > 0 {
            self.0.push(format!(
                "{method}: {failures} lock failures (memory ordering: {})",
                stats.memory_ordering.as_deref().unwrap_or("-")
            ));
        }
        failures == 0
    }

    /// A frame that matched the reference says what the catalogue says of its method: a
    /// k-buffer run with a k that its k nearest are kept (`FrameStats::exact_k_nearest`), and
    /// exact (`FrameStats::exact`) when it dropped nothing beyond them; any other method exact
    /// as its catalogue entry is.
    pub fn frame_says_exact(&mut self, method: &str, stats: &crate::FrameStats) {
        let Ok(d) = method.parse::<crate::MethodId>().map(|m| m.descriptor()) else {
            return self.check(method, Err(format!("{method} is not a method")));
        };
        let dropped = stats.fragments_dropped.unwrap_or(0);
        let promise = d.exact && d.reads(crate::methods::options::K) && stats.k.is_some();
        let says = (stats.exact, stats.exact_k_nearest);
        let expected = match promise {
            true => (Some(dropped == 0), Some(true)),
            false => (
                Some(d.exact || (d.exact_without_drops && dropped == 0)),
                None,
            ),
        };
        let result = if says == expected {
            Ok(())
        } else {
            Err(format!(
                "the frame says (exact, exact_k_nearest) = {says:?}, the catalogue {expected:?}"
            ))
        };
        self.check(method, result);
    }

    /// Checks an exact method's picture against the reference (max |Δ| ≤ 2/255 on ≥ 99.9% of
    /// pixels; where the device shaded a fragment otherwise, the reference over the device's
    /// fragments stands in: see [`ExactTruth`]) and against the reference over the device's own
    /// fragments alone, where every pixel must match unless some fragments only one side has:
    /// there a difference is the method's, not the rasterizer's.
    pub fn check_exact_picture(
        &mut self,
        method: &str,
        name: &str,
        actual: &LinearImage,
        truth: &ExactTruth,
        effect: crate::Effect,
    ) {
        let at_device_fraction = if truth.unmatched == 0 {
            0.0
        } else {
            EXACT_MAX_FRACTION
        };
        let taken = truth.disagreeing;
        let actual = actual.to_rgba8(effect);
        for (suffix, truth, fraction) in [
            ("", &truth.expected, EXACT_MAX_FRACTION),
            ("-device-depths", &truth.at_device, at_device_fraction),
        ] {
            let result = crate::metrics::testing::check_image(
                &format!("{name}{suffix}"),
                &actual,
                &truth.to_rgba8(effect),
                EXACT_MAX_DIFF,
                fraction,
            )
            .map(|_| ())
            .map_err(|e| match (suffix, taken) {
                ("", 1..) => format!(
                    "{e} ({taken} pixels' truth from the device's fragments, where its rasterizer made some otherwise)"
                ),
                _ => e,
            });
            self.check(method, result);
        }
    }

    /// Records every failure of `case`'s own [`Failures`], each under the case's name.
    pub fn absorb(&mut self, case: &str, failures: Failures) {
        self.0
            .extend(failures.0.into_iter().map(|f| format!("{case}: {f}")));
    }

    /// Panics with every failure recorded.
    pub fn finish(self, test: &str) {
        if !self.0.is_empty() {
            panic!(
                "{test}: {} failure(s):\n{}",
                self.0.len(),
                self.0.join("\n")
            );
        }
    }
}

mod tests {
    use std::path::Path;

    /// The files a test's module path may be written in: `a/b.rs` or `a/b/mod.rs` for
    /// `a::b::name`, and its parent's for a module written inline (`mod tests { … }`).
    fn module_files(src: &Path, modules: &[&str]) -> Vec<std::path::PathBuf> {
        let mut files = Vec::new();
        for end in (1..=modules.len()).rev().take(2) {
            let dir = modules[..end]
                .iter()
                .fold(src.to_path_buf(), |p, m| p.join(m));
            files.push(dir.with_extension("rs"));
            files.push(dir.join("mod.rs"));
        }
        files
    }

    /// Every test that `scripts/gpu-check` runs first by name (`bench/gpu-runs/h100-failures.txt`
    /// and `untested-on-gpu.txt`) is still written where its path says: under `--exact` a renamed
    /// or merged test would run nothing in that step, and lose its place without a word.
    #[test]
    fn the_gpu_runs_lists_name_tests_that_exist() {
        let root = Path::new(env!("CARGO_MANIFEST_DIR"));
        let lists = root.join("../../bench/gpu-runs");
        let mut stale = Vec::new();
        for list in ["h100-failures.txt", "untested-on-gpu.txt"] {
            let text = std::fs::read_to_string(lists.join(list)).unwrap();
            for name in text
                .lines()
                .filter(|l| !l.is_empty() && !l.starts_with('#'))
            {
                let path: Vec<&str> = name.split("::").collect();
                let (leaf, modules) = path.split_last().unwrap();
                let written = module_files(&root.join("src"), modules)
                    .iter()
                    .filter_map(|file| std::fs::read_to_string(file).ok())
                    .any(|source| source.contains(&format!("fn {leaf}(")));
                if !written {
                    stale.push(format!("{list}: {name}"));
                }
            }
        }
        assert!(stale.is_empty(), "not a test any more: {stale:#?}");
    }
}
