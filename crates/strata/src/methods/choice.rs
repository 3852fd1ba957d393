//! `--method auto`: the method an application gets when it says what it needs instead of naming
//! one, chosen from what the adapter has.
//!
//! | goal | choice, in order of preference |
//! |---|---|
//! | [`Goal::Exact`] | abuffer-ll: every fragment, sorted per pixel at resolve, in one geometry pass; its relaxed, lock-free capture runs on any adapter with fragment storage, and its pool follows the last frame's count |
//! | [`Goal::Bounded`] (exact for each pixel's k nearest, memory fixed per pixel) | kb-keys with 64-bit atomics (lock-free); else kplus-heap where captures get acquire/release atomics; else f2b depth peeling (exact at any depth, 56 bytes per pixel, one geometry pass per layer) |
//! | [`Goal::Approximate`] (fastest) | wboit: one geometry pass into two targets, no per-pixel storage |
//!
//! The choice names its reason ([`Choice::why`]), which the CLI prints and writes into the
//! statistics (`FrameStats::method_choice`).

use crate::gpu::{ordered, Gpu};

use super::MethodId;

/// What an application asks of the method.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
pub enum Goal {
    /// The reference's picture at any depth complexity; memory follows the frame.
    Exact,
    /// Each pixel's k nearest exactly in memory fixed per pixel (`--k`, `--budget-mb`).
    Bounded,
    /// The fastest approximation.
    Approximate,
}

/// The method chosen, and why.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Choice {
    pub method: MethodId,
    pub why: String,
}

/// The best method for `goal` on `gpu` (see the module docs).
pub fn choose(gpu: &Gpu, goal: Goal) -> Choice {
    let adapter = &gpu.info.name;
    let choice = |method, why: String| Choice { method, why };
    match goal {
        Goal::Exact => choice(
            MethodId::AbufferLl,
            "exact at any depth complexity in one geometry pass, with a lock-free capture that needs no ordered atomics".into(),
        ),
        Goal::Bounded if gpu.has(wgpu::Features::SHADER_INT64_ATOMIC_ALL_OPS) => choice(
            MethodId::KbKeys,
            format!("'{adapter}' has 64-bit storage atomics: the lock-free k-buffer keeps each pixel's k nearest without a lock"),
        ),
        Goal::Bounded if ordered::available(gpu) => choice(
            MethodId::KplusHeap,
            format!("'{adapter}' lacks 64-bit storage atomics but gives captures acquire/release atomics: the k+-buffer's max-heap under a per-pixel lock"),
        ),
        Goal::Bounded => choice(
            MethodId::F2b,
            format!("'{adapter}' has neither 64-bit storage atomics nor ordered atomics for a lock: depth peeling, exact in fixed memory at one geometry pass per layer"),
        ),
        Goal::Approximate => choice(
            MethodId::Wboit,
            "the fastest approximation: one geometry pass into two blended targets, no per-pixel storage".into(),
        ),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testing::{assert_close, gpu, render_reference};
    use crate::{RenderOptions, Renderer};

    /// The method's picture on `gpu` against the reference, with the exact methods' tolerance.
    fn assert_matches_reference(gpu: &Gpu, method: MethodId, spec: &str) {
        let scene = crate::scene::loaders::load_scene(spec).unwrap();
        let options = RenderOptions::sized(64, 64);
        let (image, _) = Renderer::new(gpu, &scene, &options)
            .and_then(|mut r| r.render_method(method, None))
            .unwrap_or_else(|e| panic!("{method}: {e}"));
        let expected = render_reference(&scene, &options);
        let name = format!("choice-{method}");
        assert_close(&name, &image, &expected, options.frame.effect, 2, 0.001);
    }

    /// The adapter, opened again without `missing` (it stands in for adapters that lack them).
    fn gpu_without(missing: wgpu::Features) -> Gpu {
        Gpu::new_without(missing).expect("lavapipe opens")
    }

    #[test]
    fn each_goal_picks_a_method_of_its_kind() {
        for goal in [Goal::Exact, Goal::Bounded, Goal::Approximate] {
            let c = choose(gpu(), goal);
            let d = c.method.descriptor();
            assert_eq!(d.exact, goal != Goal::Approximate, "{goal:?}: {}", d.name);
            assert!(!c.why.is_empty());
        }
    }

    #[test]
    fn bounded_falls_back_with_what_the_adapter_lacks_and_stays_exact() {
        let int64 = wgpu::Features::SHADER_INT64_ATOMIC_ALL_OPS;
        let ordered = wgpu::Features::PASSTHROUGH_SHADERS;
        let cases = [
            (wgpu::Features::empty(), MethodId::KbKeys),
            (int64, MethodId::KplusHeap),
            (int64 | ordered, MethodId::F2b),
        ];
        for (missing, expected) in cases {
            let restricted = gpu_without(missing);
            if !missing.contains(int64) && !restricted.has(int64) {
                // An adapter without them to begin with decides the first case by itself.
                continue;
            }
            let c = choose(&restricted, Goal::Bounded);
            assert_eq!(c.method, expected, "without {missing:?}: {}", c.why);
            assert_matches_reference(&restricted, c.method, "builtin:spheres?layers=4&segments=8");
        }
    }
}

#[cfg(test)]
mod restricted {
    use crate::gpu::Gpu;
    use crate::methods::MethodId;
    use crate::testing::gpu;
    use crate::{RenderOptions, Renderer};

    /// On a device with fewer storage bindings per stage than the capture methods use (a stand-in
    /// for smaller adapters), every method renders or refuses with one line naming the device
    /// and its reason: never wgpu's uncaptured-error panic.
    #[test]
    fn methods_refuse_what_a_small_device_cannot_make_in_one_line() {
        let scene =
            crate::scene::loaders::load_scene("builtin:spheres?layers=2&segments=8").unwrap();
        let options = RenderOptions::sized(16, 16);
        let mut outcomes = Vec::new();
        for storage in [4, 2] {
            let mut limits = gpu().limits.clone();
            limits.max_storage_buffers_per_shader_stage = storage;
            let small = Gpu::new_restricted(wgpu::Features::empty(), limits).expect("opens");
            for method in MethodId::gpu_methods() {
                let outcome = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
                    Renderer::new(&small, &scene, &options)
                        .and_then(|mut r| r.render_method(method, None))
                }));
                outcomes.push(match outcome {
                    Ok(Ok(_)) => format!("{storage} storage buffers, {method}: rendered"),
                    Ok(Err(e)) => format!("{storage} storage buffers, {method}: refused: {e}"),
                    Err(_) => format!("{storage} storage buffers, {method}: PANICKED"),
                });
            }
        }
        eprintln!("{}", outcomes.join("\n"));
        assert!(
            !outcomes.iter().any(|o| o.ends_with("PANICKED")),
            "{outcomes:#?}"
        );
        assert!(outcomes.iter().all(|o| !o.contains('\n')), "{outcomes:#?}");
    }
}
