//! wboit against its own closed form on the CPU (`cpu::wboit` over the reference's fragments).
//! Tolerance: 2/255 on ≥ 99.9% of pixels, as for the exact methods. The targets are the paper's
//! f16 (11 significant bits): each of n additive blends rounds the sums by at most 2⁻¹¹ relative,
//! so on the ≤ 6 layers used here the weighted average moves by under 6·2⁻¹¹ ≈ 0.3%, below 1/255.

use super::cpu;
use crate::frame::{Effect, RenderOptions, Weight};
use crate::render::LinearImage;
use crate::scene::{loaders, Scene};
use crate::testing::{assert_close, render_gpu};

fn closed_form(scene: &Scene, options: &RenderOptions) -> LinearImage {
    let lists = crate::reference::fragments(scene, options).unwrap();
    let w = options.width;
    let pixels = lists
        .iter()
        .enumerate()
        .map(|(i, l)| {
            let bg = options.background.at(i as u32 % w, i as u32 / w);
            let bg = [bg[0] as f64, bg[1] as f64, bg[2] as f64];
            let c = cpu::wboit(l, bg, options);
            [c[0] as f32, c[1] as f32, c[2] as f32, l.len() as f32]
        })
        .collect();
    LinearImage {
        width: w,
        height: options.height,
        pixels,
    }
}

#[test]
fn wboit_equals_its_closed_form_for_every_weight() {
    let mut scene =
        loaders::load_scene("builtin:layers?n=6&coverage=0.75&order=random&seed=3").unwrap();
    // Low opacity over black: the coverage 1 − Π(1 − α) shows in every channel.
    scene.override_alpha(0.25);
    for weight in [Weight::Eq7, Weight::Eq8, Weight::Eq9, Weight::Eq10] {
        // Scales that put the layers' distances in each weight's steep part.
        for depth_scale in [1.0, 10.0, 60.0] {
            let opts = RenderOptions {
                width: 40,
                height: 40,
                weight,
                depth_scale,
                background: crate::scene::Background::Color([0.0, 0.0, 0.0]),
                ..Default::default()
            };
            let expected = closed_form(&scene, &opts);
            let (actual, stats) = render_gpu(&scene, &opts, "wboit");
            assert_close(
                &format!("wboit-{}-scale{depth_scale}", weight.name()),
                &actual,
                &expected,
                Effect::Transparency,
                2,
                0.001,
            );
            assert_eq!(stats.fragments_dropped, Some(0));
            assert_eq!(stats.max_depth_complexity, Some(6));
        }
    }
}

/// The weights change the picture (a weight ignored would pass the test above on one weight
/// only if the closed form ignored it too): eq. 7 and eq. 9 differ on overlapping layers.
#[test]
fn wboit_weights_differ_and_the_depth_scale_matters() {
    let scene = loaders::load_scene("builtin:nvpro?objects=96&subdiv=10&seed=8").unwrap();
    let opts = |weight, depth_scale| RenderOptions {
        width: 32,
        height: 32,
        weight,
        depth_scale,
        ..Default::default()
    };
    let (a, _) = render_gpu(&scene, &opts(Weight::Eq7, 1.0), "wboit");
    let (b, _) = render_gpu(&scene, &opts(Weight::Eq9, 1.0), "wboit");
    let (c, _) = render_gpu(&scene, &opts(Weight::Eq7, 100.0), "wboit");
    assert!(a != b && a != c);
    // And the closed form agrees on the nvpro scene too.
    assert_close(
        "wboit-nvpro",
        &c,
        &closed_form(&scene, &opts(Weight::Eq7, 100.0)),
        Effect::Transparency,
        2,
        0.001,
    );
}

#[test]
fn wboit_params_layout_matches_wgsl() {
    assert_eq!(std::mem::size_of::<super::WboitParams>(), 16);
    assert_eq!(std::mem::offset_of!(super::WboitParams, depth_scale), 4);
}
