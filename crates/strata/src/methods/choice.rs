//! `--method auto`: the method an application gets when it says what it needs instead of naming
//! one, chosen from what the adapter has.
//!
//! | goal | candidates, best first |
//! |---|---|
//! | [`Goal::Exact`] | on a GPU (not a CPU device such as lavapipe or llvmpipe), tiled first: exact in compute, the fastest exact method measured on an H100 (2026-11-27, 1024²: 5.7 ms on nvpro against 13.3 for abuffer-ll, 0.99 against 1.47 on the dragon); then abuffer-ll (every fragment, sorted per pixel at resolve, in one geometry pass; its relaxed, lock-free capture needs no ordered atomics, and its pool follows the last frame's count); f2b; sbuffer. On a CPU device abuffer-ll leads (there tiled's compute ran 4–16× slower than the fragment-shader A-buffers: README, Tiled) |
//! | [`Goal::Bounded`] (exact for each pixel's k nearest, memory fixed per pixel) | kb-keys where there are 64-bit atomics (lock-free); kplus-heap where captures get acquire/release atomics; f2b depth peeling (exact at any depth, 72 bytes per pixel, one geometry pass per layer); kb-mdt32 (a 32-bit cascade, relaxed) |
//! | [`Goal::Approximate`] (fastest) | wboit (one geometry pass into two targets, no per-pixel storage); mboit |
//! | on a downlevel device (no storage buffers or compute: WebGL2-class; [`crate::methods::downlevel`]) | exact and bounded: f2b, peeling through render targets; approximate: wboit in blended targets |
//!
//! With [`Geometry::Application`] (the application draws with its own shaders) only the
//! methods that take them remain (every one listed here does).
//!
//! [`candidates`] filters by the adapter's features; a device that still refuses one for a
//! limit (a method's setup runs under `crate::gpu::validated`) moves to the next: `strata
//! render --method auto` does, and says so. Each choice names its reason ([`Choice::why`]),
//! which the CLI prints and writes into the statistics (`FrameStats::method_choice`).

use crate::gpu::{ordered, Gpu};
use crate::methods::downlevel::{is_downlevel, F2B_PIXEL_BYTES};

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

/// How the application's transparent geometry reaches strata.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum Geometry {
    /// A [`crate::scene::Scene`] strata draws ([`crate::FrameRecorder::new`]).
    #[default]
    Scene,
    /// The application's own buffers and shaders ([`crate::FrameRecorder::for_application`]):
    /// only methods that take them (`app_shaders` in the catalogue).
    Application,
}

/// The method chosen, and why.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Choice {
    /// The method to run; [`crate::methods::create`] builds it.
    pub method: MethodId,
    /// One line on why it was chosen, naming the adapter's missing features on a fallback;
    /// the CLI prints it and records it as `FrameStats::method_choice`.
    pub why: String,
}

/// The best method for `goal` on `gpu` for geometry drawn as `geometry` says (see the module
/// docs); an error where none serves (a downlevel device takes no application shaders).
///
/// ```
/// use strata::methods::choice::{choose, Geometry, Goal};
///
/// let gpu = strata::gpu::Gpu::new()?; // or Gpu::from_device with your own
/// let choice = choose(&gpu, Goal::Bounded, Geometry::Application)?;
/// assert!(choice.method.descriptor().exact && choice.method.descriptor().app_shaders.yes());
/// println!("{}: {}", choice.method, choice.why);
/// # Ok::<(), strata::Error>(())
/// ```
pub fn choose(gpu: &Gpu, goal: Goal, geometry: Geometry) -> crate::error::Result<Choice> {
    candidates(gpu, goal, geometry)
        .into_iter()
        .next()
        .ok_or_else(|| {
            crate::error::Error::unsupported(format!(
                "no method takes the application's own shaders on '{}', a downlevel device (no storage buffers or compute): draw through a scene",
                gpu.info.name
            ))
        })
}

/// Every method that serves `goal` on `gpu`'s features for `geometry`, best first: the first
/// is [`choose`]'s; where a device refuses it for a limit (`crate::gpu::validated`), the next
/// is the fallback.
pub fn candidates(gpu: &Gpu, goal: Goal, geometry: Geometry) -> Vec<Choice> {
    if geometry == Geometry::Application && is_downlevel(gpu) {
        // A downlevel device's frames are strata's render-target passes over its own scene.
        return Vec::new();
    }
    let mut list = scene_candidates(gpu, goal);
    if geometry == Geometry::Application {
        list.retain(|c| c.method.descriptor().app_shaders.yes());
    }
    // What the device's backend cannot run (mboit on GL) is no candidate.
    let offer = super::backends::Offer::of_gpu(gpu);
    list.retain(|c| super::backends::verdict(c.method.descriptor(), &offer).runs());
    list
}

/// Whether exact transparency is faster in compute (`tiled`) than through the fragment shader on
/// this adapter: on GPUs, as measured on an H100; not on CPU devices (lavapipe, llvmpipe), which
/// run a tile's 64 pixels as 8-lane batches and were 4–16× slower with tiled than abuffer-ll.
pub fn compute_is_faster(info: &wgpu::AdapterInfo) -> bool {
    info.device_type != wgpu::DeviceType::Cpu
}

/// [`candidates`] for strata's own geometry.
fn scene_candidates(gpu: &Gpu, goal: Goal) -> Vec<Choice> {
    let adapter = &gpu.info.name;
    let choice = |method, why: String| Choice { method, why };
    if is_downlevel(gpu) {
        let device = format!("'{adapter}' is a downlevel device (no storage buffers or compute)");
        return vec![match goal {
            Goal::Approximate => choice(
                MethodId::Wboit,
                format!("{device}: weighted blended OIT in blended render targets, one geometry pass"),
            ),
            _ => choice(
                MethodId::F2b,
                format!("{device}: depth peeling through render targets, exact, {F2B_PIXEL_BYTES} bytes per pixel, one geometry pass per layer"),
            ),
        }];
    }
    let peeling = || {
        choice(
            MethodId::F2b,
            "depth peeling: exact in fixed memory (72 bytes per pixel), one geometry pass per layer"
                .into(),
        )
    };
    match goal {
        Goal::Exact => {
            let mut list = Vec::new();
            let lists = "exact at any depth complexity in one geometry pass, with a lock-free capture that needs no ordered atomics";
            if compute_is_faster(&gpu.info) {
                list.push(choice(
                    MethodId::Tiled,
                    format!("'{adapter}' is a GPU, where exact transparency in compute is fastest: tiled (an H100 at 1024²: 5.7 ms on nvpro against abuffer-ll's 13.3)"),
                ));
                list.push(choice(MethodId::AbufferLl, lists.into()));
            } else {
                list.push(choice(
                    MethodId::AbufferLl,
                    format!("{lists} ('{adapter}' is a CPU device, whose fragment shaders beat tiled's compute)"),
                ));
            }
            list.push(peeling());
            list.push(choice(
                MethodId::Sbuffer,
                "exact at any depth complexity in two geometry passes (a count, then every fragment in its pixel's region), lock-free".into(),
            ));
            list
        }
        Goal::Bounded => {
            let mut list = Vec::new();
            if gpu.has(wgpu::Features::SHADER_INT64_ATOMIC_ALL_OPS) {
                list.push(choice(
                    MethodId::KbKeys,
                    format!("'{adapter}' has 64-bit storage atomics: the lock-free k-buffer keeps each pixel's k nearest without a lock"),
                ));
            }
            if ordered::available(gpu) {
                list.push(choice(
                    MethodId::KplusHeap,
                    format!("'{adapter}' gives captures acquire/release atomics: the k+-buffer's max-heap under a per-pixel lock"),
                ));
            }
            let mut last = peeling();
            let mut cascade = choice(
                MethodId::KbMdt32,
                "the multi-depth test: each pixel's k nearest depths by a 32-bit atomicMax cascade, their colours in a second geometry pass; relaxed atomics".into(),
            );
            if list.is_empty() {
                let lacks = format!("'{adapter}' has neither 64-bit storage atomics nor ordered atomics for a lock");
                last.why = format!("{lacks}: {}", last.why);
                cascade.why = format!("{lacks}: {}", cascade.why);
            }
            list.push(last);
            list.push(cascade);
            list
        }
        Goal::Approximate => vec![
            choice(
                MethodId::Wboit,
                "the fastest approximation: one geometry pass into two blended targets, no per-pixel storage".into(),
            ),
            choice(
                MethodId::Mboit,
                "moment-based OIT: two geometry passes, closer to the reference than weighted blending".into(),
            ),
        ],
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
            for geometry in [Geometry::Scene, Geometry::Application] {
                let c = choose(gpu(), goal, geometry).unwrap();
                let d = c.method.descriptor();
                assert_eq!(d.exact, goal != Goal::Approximate, "{goal:?}: {}", d.name);
                assert!(!c.why.is_empty());
                if geometry == Geometry::Application {
                    // Every candidate, not only the first, takes the application's shaders.
                    for c in candidates(gpu(), goal, geometry) {
                        assert!(c.method.descriptor().app_shaders.yes(), "{}", c.method);
                    }
                }
            }
        }
    }

    #[test]
    fn exact_takes_tiled_first_on_a_gpu_and_abuffer_ll_on_a_cpu() {
        let mut info = gpu().info.clone();
        assert_eq!(info.device_type, wgpu::DeviceType::Cpu, "lavapipe");
        assert_eq!(
            choose(gpu(), Goal::Exact, Geometry::Scene).unwrap().method,
            MethodId::AbufferLl
        );
        for device_type in [
            wgpu::DeviceType::DiscreteGpu,
            wgpu::DeviceType::IntegratedGpu,
        ] {
            info.device_type = device_type;
            assert!(compute_is_faster(&info));
        }
        // tiled takes no application shaders: there abuffer-ll still leads.
        assert!(!MethodId::Tiled.descriptor().app_shaders.yes());
    }

    #[test]
    fn bounded_falls_back_with_what_the_adapter_lacks_and_stays_exact() {
        let int64 = wgpu::Features::SHADER_INT64_ATOMIC_ALL_OPS;
        let ordered = wgpu::Features::PASSTHROUGH_SHADERS;
        let cases = [
            (wgpu::Features::empty(), MethodId::KbKeys, MethodId::KbKeys),
            (int64, MethodId::KplusHeap, MethodId::KplusHeap),
            (int64 | ordered, MethodId::F2b, MethodId::F2b),
        ];
        for (missing, expected, application) in cases {
            let restricted = gpu_without(missing);
            if !missing.contains(int64) && !restricted.has(int64) {
                // An adapter without them to begin with decides the first case by itself.
                continue;
            }
            let c = choose(&restricted, Goal::Bounded, Geometry::Scene).unwrap();
            assert_eq!(c.method, expected, "without {missing:?}: {}", c.why);
            assert_matches_reference(&restricted, c.method, "builtin:spheres?layers=4&segments=8");
            let c = choose(&restricted, Goal::Bounded, Geometry::Application).unwrap();
            assert_eq!(c.method, application, "without {missing:?}: {}", c.why);
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
        for storage in [4, 2, 0] {
            // 0: WebGL2-class limits (no storage buffers, no compute), at the adapter's sizes.
            let mut limits = if storage == 0 {
                wgpu::Limits::downlevel_webgl2_defaults().using_resolution(gpu().limits.clone())
            } else {
                gpu().limits.clone()
            };
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
        // A WebGL2-class device: f2b and wboit render (through render targets), every other
        // method is refused up front, naming what the device lacks.
        for o in outcomes
            .iter()
            .filter(|o| o.starts_with("0 storage buffers"))
        {
            if o.starts_with("0 storage buffers, f2b:")
                || o.starts_with("0 storage buffers, wboit:")
            {
                assert!(o.ends_with("rendered"), "{o}");
            } else {
                assert!(o.contains("is a downlevel device: strata's frames need 4 storage buffers per shader stage (it has 0) and compute workgroups of 64 invocations (it has 0)"), "{o}");
            }
        }
    }

    /// A WebGL2-class device gets depth peeling through render targets, or for the fastest
    /// approximation wboit, and the reason names the device's kind (the pictures:
    /// `methods::downlevel`'s tests).
    #[test]
    fn a_downlevel_device_gets_depth_peeling_or_wboit() {
        let limits =
            wgpu::Limits::downlevel_webgl2_defaults().using_resolution(gpu().limits.clone());
        let webgl2 = Gpu::new_restricted(wgpu::Features::empty(), limits).expect("opens");
        use super::{candidates, choose, Geometry, Goal};
        for goal in [Goal::Exact, Goal::Bounded, Goal::Approximate] {
            assert!(candidates(&webgl2, goal, Geometry::Application).is_empty());
            let e = choose(&webgl2, goal, Geometry::Application).unwrap_err();
            assert!(e.to_string().contains("downlevel"), "{e}");
            let list = candidates(&webgl2, goal, Geometry::Scene);
            assert_eq!(list.len(), 1, "{goal:?}");
            let expected = match goal {
                Goal::Approximate => MethodId::Wboit,
                _ => MethodId::F2b,
            };
            assert_eq!(list[0].method, expected, "{goal:?}");
            assert!(
                list[0].why.contains("is a downlevel device"),
                "{}",
                list[0].why
            );
        }
    }

    /// Where the device refuses the first candidates for a limit (8 storage buffers per stage:
    /// the k-buffers bind 10), the next ones are tried in order: depth peeling renders, exact.
    #[test]
    fn candidates_fall_back_to_what_a_small_device_can_make() {
        let mut limits = gpu().limits.clone();
        limits.max_storage_buffers_per_shader_stage = 8;
        let small = Gpu::new_restricted(wgpu::Features::empty(), limits).expect("opens");
        let scene =
            crate::scene::loaders::load_scene("builtin:spheres?layers=4&segments=8").unwrap();
        let options = RenderOptions::sized(32, 32);
        let list = super::candidates(&small, super::Goal::Bounded, super::Geometry::Scene);
        assert!(list.iter().any(|c| c.method == MethodId::F2b));
        let mut rendered = None;
        for c in &list {
            match Renderer::new(&small, &scene, &options)
                .and_then(|mut r| r.render_method(c.method, None))
            {
                Ok((image, _)) => {
                    rendered = Some((c.method, image));
                    break;
                }
                Err(e) => assert!(
                    matches!(e, crate::Error::Unsupported(_)),
                    "{}: {e}",
                    c.method
                ),
            }
        }
        let (method, image) = rendered.expect("a candidate renders");
        assert_eq!(method, MethodId::F2b);
        let expected = crate::testing::render_reference(&scene, &options);
        crate::testing::assert_close(
            "auto-fallback",
            &image,
            &expected,
            options.frame.effect,
            2,
            0.001,
        );
    }
}
