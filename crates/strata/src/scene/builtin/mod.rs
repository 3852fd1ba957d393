//! Built-in scenes (`builtin:NAME?key=value&...`) and mesh primitives.
//!
//! | scene | parameters (defaults) | what it is |
//! |---|---|---|
//! | `demo` | — | the default: three translucent models (spot, teapot, suzanne) on an opaque checkerboard floor with an opaque gold ball and column, three point lights and a ring of twelve coloured ones; rendered with the deferred pipeline by default |
//! | `layers` | `n=16`, `coverage=0.75`, `order=random` (`front`, `back`), `seed=1` | `n` unlit screen-aligned layers with a closed-form composite, see [`layer_colors`] |
//! | `spheres` | `layers=16` (even), `segments=48` | `layers/2` nested sphere shells: a ray through the centre crosses `layers` surfaces |
//! | `nvpro` | `objects=1024`, `subdiv=16`, `seed=0` | random translucent UV spheres in [-1,1]³ (the NVIDIA OIT sample's scene) |
//! | `balls` | `count=1000`, `frame=0`, `segments=12`, `radius` | small spheres on seeded circular orbits (moved on the GPU); `frame` (30 per second) moves them |
//! | `dragon`, `bunny`, `suzanne`, `spot`, `teapot` | — | the embedded public test meshes, default material, auto-framed camera |
//!
//! Every scene is deterministic: the same spec gives the same scene on every machine. A scene's
//! triangle count is computed from its parameters before anything is built, and a scene over
//! [`MAX_SCENE_TRIANGLES`](crate::scene::MAX_SCENE_TRIANGLES) is refused naming them.

mod models;
mod params;
pub(crate) mod primitives;
pub(crate) mod scenes;

pub use primitives::{cube, quad, uv_sphere, uv_sphere_triangles};
pub use scenes::{layer_colors, layer_depth, LAYERS_EXTENT};

use crate::error::{Error, Result};
use crate::scene::{Mesh, Scene};
use params::Params;

const NAMES: [&str; 11] = [
    "demo", "layers", "spheres", "stack", "nvpro", "balls", "dragon", "bunny", "suzanne", "spot",
    "teapot",
];

/// Names of the built-in scenes, `demo` first.
pub fn builtin_names() -> &'static [&'static str] {
    &NAMES
}

/// Builds the built-in scene `spec` (what follows `builtin:`), e.g.
/// `layers?n=16&coverage=0.75&order=random&seed=1`.
pub fn build(spec: &str) -> Result<Scene> {
    let (name, query) = spec.split_once('?').unwrap_or((spec, ""));
    let what = format!("builtin:{name}");
    let allowed: &[&str] = match name {
        "demo" => &[],
        "layers" => &["n", "coverage", "order", "seed"],
        "spheres" => &["layers", "segments"],
        "stack" => &["layers", "columns", "segments"],
        "nvpro" => &["objects", "subdiv", "seed"],
        "balls" => &["count", "frame", "segments", "radius"],
        m if models::MODEL_NAMES.contains(&m) => &["subdivide"],
        _ => {
            return Err(Error::input(format!(
                "unknown builtin scene '{}' (available: {})",
                crate::error::quoted(name),
                NAMES.join(", ")
            )))
        }
    };
    let p = Params::parse(what, query, allowed)?;
    match name {
        "demo" => scenes::demo(),
        "layers" => scenes::layers(&p),
        "spheres" => scenes::spheres(&p),
        "stack" => scenes::stack(&p),
        "nvpro" => scenes::nvpro(&p),
        "balls" => scenes::balls(&p),
        model => scenes::model(model, &p),
    }
}

/// A mesh primitive for scene files: `quad`, `cube` or `sphere?segments=32` (what follows
/// `builtin:`).
pub fn primitive(spec: &str) -> Result<Mesh> {
    let (name, query) = spec.split_once('?').unwrap_or((spec, ""));
    let what = format!("builtin:{name}");
    match name {
        "quad" => {
            Params::parse(what, query, &[])?;
            Ok(quad())
        }
        "cube" => {
            Params::parse(what, query, &[])?;
            Ok(cube())
        }
        "sphere" => {
            let p = Params::parse(what, query, &["segments"])?;
            Ok(uv_sphere(p.int("segments", 32, 3, 1024)? as u32))
        }
        _ => Err(Error::input(format!(
            "unknown builtin mesh '{name}' (available: quad, cube, sphere?segments=N)"
        ))),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn unknown_scene_and_key_are_one_line_errors() {
        let e = build("foo").unwrap_err().to_string();
        assert_eq!(
            e,
            "unknown builtin scene 'foo' (available: demo, layers, spheres, stack, nvpro, balls, dragon, bunny, suzanne, spot, teapot)"
        );
        let long = "x".repeat(10_000);
        let e = build(&long).unwrap_err().to_string();
        assert!(
            e.len() < 300 && e.contains(&format!("'{}…'", &long[..60])),
            "{e}"
        );
        let e = build("layers?m=3").unwrap_err().to_string();
        assert!(
            e.contains("builtin:layers") && e.contains("unknown parameter 'm'"),
            "{e}"
        );
        assert!(!e.contains('\n'));
        let e = build("layers?n=x").unwrap_err().to_string();
        assert!(e.contains("n='x'"), "{e}");
        let e = build("layers?order=sideways").unwrap_err().to_string();
        assert!(e.contains("order='sideways'") && e.contains("front"), "{e}");
        let e = build("bunny?x=1").unwrap_err().to_string();
        assert!(e.contains("unknown parameter 'x'"), "{e}");
        let e = build("bunny?subdivide=5").unwrap_err().to_string();
        assert!(e.contains("subdivide=5") && e.contains("0..=4"), "{e}");
        let e = build("spheres?layers=3").unwrap_err().to_string();
        assert!(e.contains("even"), "{e}");
        let e = build("layers?n=0").unwrap_err().to_string();
        assert!(e.contains("out of range"), "{e}");
    }

    #[test]
    fn primitives_by_name() {
        assert_eq!(primitive("quad").unwrap(), quad());
        assert_eq!(primitive("cube").unwrap(), cube());
        assert_eq!(primitive("sphere").unwrap(), uv_sphere(32));
        assert_eq!(primitive("sphere?segments=8").unwrap(), uv_sphere(8));
        assert!(primitive("cone")
            .unwrap_err()
            .to_string()
            .contains("unknown builtin mesh 'cone'"));
        assert!(primitive("sphere?segs=8").is_err());
        assert!(primitive("sphere?segments=2").is_err());
    }

    #[test]
    fn names_list_is_complete() {
        assert_eq!(builtin_names()[0], "demo");
        for m in models::MODEL_NAMES {
            assert!(builtin_names().contains(&m));
        }
    }
}
