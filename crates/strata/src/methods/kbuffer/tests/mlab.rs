//! `mlab` on lavapipe: exact up to k fragments, its closed form one fragment past k (a single
//! merge, whatever the arrival order), and on deep scenes the total opacity of every pixel
//! exact. Which layers merge past k + 1 depends on the order fragments take the lock, which a
//! GPU does not fix: those pictures are measured against the reference (`bench approx-quality`),
//! not asserted. Tolerance as for the exact methods: max |Δ| ≤ 2/255 on ≥ 99.9% of pixels.

use super::options;
use crate::frame::Effect;
use crate::methods::kbuffer::cpu;
use crate::render::LinearImage;
use crate::resolve::RefFragment;
use crate::scene::{loaders, Background, Scene};
use crate::testing::{
    assert_exact, per_pixel, render_gpu, render_reference, EXACT_MAX_DIFF, EXACT_MAX_FRACTION,
};
use crate::{MethodId, RenderOptions};

fn scene(spec: &str) -> Scene {
    loaders::load_scene(spec).unwrap_or_else(|e| panic!("{spec}: {e}"))
}

/// The closed form: each pixel's fragments arriving in draw (primitive) order through
/// `cpu::mlab`, the layers composited over the background.
fn closed_form(scene: &Scene, options: &RenderOptions, k: usize) -> LinearImage {
    per_pixel(scene, options, |_, list, bg| {
        let mut arrivals = list.to_vec();
        arrivals.sort_by_key(|f| f.prim);
        crate::resolve::composite(&cpu::mlab(&arrivals, k), bg, false)
    })
}

#[test]
fn mlab_up_to_k_fragments_equals_the_reference() {
    let s = scene("builtin:layers?n=6&coverage=0.75&order=random&seed=3");
    for msaa in [1, 4] {
        for k in [6, 8] {
            let mut opts = options(48, k);
            opts.build.msaa = msaa;
            let expected = render_reference(
                &s,
                &RenderOptions {
                    frame: crate::frame::FrameOptions {
                        k: None,
                        ..opts.frame.clone()
                    },
                    ..opts.clone()
                },
            );
            let (actual, stats) = render_gpu(&s, &opts, "mlab");
            assert_eq!(stats.lock_failures, Some(0));
            assert_exact(
                &format!("mlab-layers-k{k}-msaa{msaa}"),
                &actual,
                &expected,
                Effect::Transparency,
            );
            assert_eq!(stats.fragments_dropped, Some(0), "k {k} msaa {msaa}");
            assert_eq!(stats.k, Some(k));
        }
    }
}

/// Five layers at k = 4: pixels with all five merge once, the two farthest, whatever the
/// arrival order — the closed form, and (compositing a merged pair equals compositing both) the
/// reference's picture; the fifth fragment counts as past k.
#[test]
fn mlab_one_past_k_merges_the_two_farthest() {
    let s = scene("builtin:layers?n=5&coverage=0.75&order=random&seed=8");
    let opts = options(48, 4);
    let (actual, stats) = render_gpu(&s, &opts, "mlab");
    assert_eq!(stats.lock_failures, Some(0));
    assert_exact(
        "mlab-layers5-k4-closed-form",
        &actual,
        &closed_form(&s, &opts, 4),
        Effect::Transparency,
    );
    let full = RenderOptions {
        frame: crate::frame::FrameOptions {
            k: None,
            ..opts.frame.clone()
        },
        ..opts.clone()
    };
    assert_exact(
        "mlab-layers5-k4-reference",
        &actual,
        &render_reference(&s, &full),
        Effect::Transparency,
    );
    let lists = crate::reference::fragments(&s, &opts).unwrap();
    let past_k: u64 = lists.iter().map(|l| l.len().saturating_sub(4) as u64).sum();
    assert!(past_k > 0, "the scene has pixels of five fragments");
    let dropped = stats.fragments_dropped.unwrap() as f64;
    assert!(
        (dropped - past_k as f64).abs() <= past_k as f64 * EXACT_MAX_FRACTION,
        "{dropped} fragments past k, reference {past_k}"
    );
}

/// `s` with every material black and unlit: its picture over white is each pixel's
/// transmittance alone, whatever colors the merges made.
fn black_and_unlit(mut s: Scene) -> Scene {
    for m in &mut s.materials {
        m.color = [0.0; 3];
        m.shading = crate::scene::Shading::Unlit;
    }
    s
}

/// Deep pixels (nvpro, the dragon) merge many times, in an order the GPU chooses: every
/// pixel's total opacity must still be the reference's. It is read from one picture of the
/// scene in black over white (two pictures over black and white would merge in two orders:
/// on the H100 their colors differed at 14–21 of 4096 pixels, 2026-11-27).
#[test]
fn mlab_keeps_every_pixels_opacity_on_deep_scenes() {
    let mut dragon = scene("builtin:dragon");
    dragon.override_alpha(0.4);
    for (name, s, size, k) in [
        (
            "nvpro",
            scene("builtin:nvpro?objects=160&subdiv=10&seed=3"),
            64,
            4,
        ),
        ("dragon", dragon, 96, 2),
    ] {
        let s = black_and_unlit(s);
        let mut opts = options(size, k);
        opts.frame.background = Background::Color([1.0; 3]);
        let (white, stats) = render_gpu(&s, &opts, "mlab");
        assert_eq!(stats.lock_failures, Some(0), "{name}");
        assert!(
            white.pixels.iter().all(|p| p[0] == p[1] && p[1] == p[2]),
            "{name}: a black scene over white is grey"
        );
        let actual: Vec<f64> = white.pixels.iter().map(|p| f64::from(p[1])).collect();
        let lists = crate::reference::fragments(&s, &opts).unwrap();
        assert!(
            lists.iter().any(|l| l.len() > k as usize + 1),
            "{name} is deep"
        );
        let expected = lists.iter().map(|l| {
            l.iter()
                .map(|f: &RefFragment| 1.0 - f.alpha)
                .product::<f64>()
        });
        let off = actual
            .iter()
            .zip(expected)
            .filter(|(a, e)| (*a - e).abs() > EXACT_MAX_DIFF as f64 / 255.0)
            .count();
        assert!(
            off as f64 <= actual.len() as f64 * EXACT_MAX_FRACTION,
            "{name}: {off} of {} pixels' transmittance off by more than {EXACT_MAX_DIFF}/255",
            actual.len()
        );
    }
}

#[test]
fn mlab_takes_k_from_1_to_256_and_4_by_default() {
    use crate::methods::kbuffer::k_of;
    assert_eq!(k_of(None, MethodId::Mlab).unwrap(), 4);
    assert_eq!(k_of(Some(1), MethodId::Mlab).unwrap(), 1);
    assert_eq!(k_of(Some(256), MethodId::Mlab).unwrap(), 256);
    assert!(k_of(Some(0), MethodId::Mlab).is_err());
    assert!(k_of(Some(257), MethodId::Mlab).is_err());
}
