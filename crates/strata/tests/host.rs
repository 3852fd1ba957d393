//! The host example (an application with its own device, pipelines and vertex layout calling
//! strata's capture) against the CPU reference of the same scene.

#[path = "../../../examples/host.rs"]
mod host;

use strata::frame::FrameOptions;
use strata::{Effect, MethodId, RenderOptions};

/// Tolerance: the exact-method bar (max |Δ| ≤ 2/255 on ≥ 99.9% of pixels; see
/// src/methods/tests.rs for why not 100%): coverage at edges may differ between the GPU's f32
/// setup and the reference's exact integers. The opaque floor's extra 8-bit rounding in the
/// application's sRGB target stays within it.
const MAX_DIFF: u8 = 2;
const MAX_FRACTION: f64 = 0.001;

#[test]
fn host_example_matches_the_reference() {
    // A list, fixed arrays, a locking k+-buffer (ordered atomics in the application's shader),
    // the lock-free two-pass kb-keys and dual peeling's passes, all through the application's
    // shader.
    for method in [
        MethodId::AbufferLl,
        MethodId::KbAbFixed,
        MethodId::KbAbLl,
        MethodId::KplusHeap,
        MethodId::KbKeys,
        MethodId::Dual,
    ] {
        let run = host::run(method, 96, 3).unwrap_or_else(|e| panic!("{method}: {e}"));
        let options = RenderOptions {
            frame: FrameOptions {
                width: 96,
                height: 96,
                effect: Effect::Transparency,
                background: run.background,
                k: method
                    .descriptor()
                    .reads(strata::methods::options::K)
                    .then_some(16),
                ..Default::default()
            },
            ..Default::default()
        };
        let (expected, reference) = strata::reference::render(&run.scene, &options).unwrap();
        let expected = expected.to_rgba8(Effect::Transparency);
        if let Err(m) = strata::metrics::testing::check_image(
            &format!("host-{method}"),
            &run.picture,
            &expected,
            MAX_DIFF,
            MAX_FRACTION,
        ) {
            panic!("{m}");
        }
        assert_eq!(run.stats.lock_failures.unwrap_or(0), 0, "{method}");
        if method == MethodId::KplusHeap {
            // The application's shader got the lock's acquire/release atomics.
            let ordering = run.stats.memory_ordering.clone().unwrap_or_default();
            assert!(ordering.contains("acquire"), "{method}: {ordering}");
        }
        // Real-time frames: no blocking readback, no submit inside strata.
        assert_eq!(run.stats.blocking_readbacks, 0);
        assert_eq!(run.stats.submits, 0);
        assert!(
            run.stats.frame >= 2,
            "{method}: stats of frame {}",
            run.stats.frame
        );
        // The transparent fragments strata captured are the reference's (less the opaque floor's).
        let generated = run.stats.fragments_generated.unwrap();
        assert!(generated > 0 && generated < reference.fragments_generated.unwrap());
    }
}
