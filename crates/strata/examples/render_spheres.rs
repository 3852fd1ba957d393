//! Renders nested translucent spheres with an exact method and checks it against the CPU
//! reference: `cargo run -p strata --example render_spheres -- out.png`.

use strata::scene::loaders;
use strata::{gpu::Gpu, metrics, Effect, FrameOptions, RenderOptions, Renderer};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let out = std::env::args()
        .nth(1)
        .unwrap_or_else(|| "spheres.png".into());
    let gpu = Gpu::new()?;
    let scene = loaders::load_scene("builtin:spheres?layers=8")?;
    let options = RenderOptions {
        frame: FrameOptions {
            width: 320,
            height: 240,
            effect: Effect::Translucency,
            ..Default::default()
        },
        ..Default::default()
    };
    let mut renderer = Renderer::new(&gpu, &scene, &options)?;
    let (image, stats) = renderer.render("abuffer-ll")?;
    let picture = image.to_rgba8(options.frame.effect);
    picture.save(&out)?;
    let (exact, _) = strata::reference::render(&scene, &options)?;
    let c = metrics::compare(&exact.to_rgba8(options.frame.effect), &picture)?;
    println!(
        "{out}: {} fragments, {:?} ms GPU; vs reference: max |Δ| {}/255, FLIP {:.5}",
        stats.fragments_generated.unwrap_or(0),
        stats.gpu_ms_total,
        c.max_abs_diff,
        c.flip_mean
    );
    Ok(())
}
