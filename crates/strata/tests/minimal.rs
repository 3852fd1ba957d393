//! The minimal example (an application's own device and opaque pass, strata drawing the
//! transparent objects over them) against the CPU reference of the same scene with the
//! application's wall added as an opaque object.

#[path = "../../../examples/minimal.rs"]
mod minimal;

use strata::scene::{Background, Material, Mesh, Object, Shading};
use strata::{Effect, RenderOptions};

#[test]
fn minimal_example_matches_the_reference() {
    let picture = minimal::run().unwrap_or_else(|e| panic!("{e}"));
    let mut scene = minimal::scene().unwrap();
    scene.materials.push(Material {
        name: "wall".into(),
        color: minimal::WALL_COLOR,
        opacity: 1.0,
        shading: Shading::Unlit,
        ..Default::default()
    });
    scene.objects.push(Object {
        name: "wall".into(),
        mesh: Mesh {
            positions: minimal::WALL.to_vec(),
            normals: vec![[0.0, 0.0, 1.0]; 6],
            indices: (0..6).collect(),
        },
        material: scene.materials.len() - 1,
    });
    let mut options = RenderOptions::sized(minimal::SIZE, minimal::SIZE);
    options.frame.background = Background::Color(minimal::BACKGROUND);
    let (expected, _) = strata::reference::render(&scene, &options).unwrap();
    // The exact methods' bar (see src/methods/tests.rs): coverage at edges may differ between
    // the GPU's f32 setup and the reference's exact integers.
    if let Err(m) = strata::metrics::testing::check_image(
        "minimal",
        &picture,
        &expected.to_rgba8(Effect::Transparency),
        2,
        0.001,
    ) {
        panic!("{m}");
    }
}
