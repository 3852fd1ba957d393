//! `strata export`: a scene as glTF 2.0.

use crate::{prepare, BackgroundArg, CameraArgs, PictureArgs, Size, MAX_LIGHTS};
use clap::Args;
use std::path::PathBuf;
use strata::error::Result;
use strata::scene::Shading;

#[derive(Args)]
pub struct ExportArgs {
    /// A scene file (.toml, .obj, .ply, .gltf, .glb) or builtin:NAME?key=value&...
    #[arg(default_value = "builtin:demo")]
    pub scene: String,
    /// The glTF file to write: .glb, or .gltf with its buffer as a base64 data: URI.
    #[arg(short, long, default_value = "scene.glb")]
    pub output: PathBuf,
    /// Image size WxH the file records as its picture default (with the camera's aspect ratio).
    #[arg(long, allow_hyphen_values = true)]
    pub size: Option<Size>,
    /// checker | #rrggbb (sRGB): the background the file records as its picture default.
    #[arg(long)]
    pub background: Option<BackgroundArg>,
    /// Every material's shading (unlit materials get KHR_materials_unlit).
    #[arg(long, value_enum)]
    pub shading: Option<Shading>,
    /// Sets every material's opacity.
    #[arg(long)]
    pub alpha: Option<f32>,
    /// Animation time in frames: objects and camera are written where they are then.
    #[arg(long)]
    pub frame: Option<f32>,
    /// Add N coloured point lights, a deterministic field over the scene's bounds.
    #[arg(long, value_parser = clap::value_parser!(u32).range(0..=MAX_LIGHTS as i64))]
    pub lights: Option<u32>,
    #[command(flatten)]
    pub camera: CameraArgs,
}

pub fn export(a: ExportArgs) -> Result<()> {
    let container = strata::scene::export::GltfContainer::for_path(&a.output)?;
    let picture = PictureArgs {
        size: a.size,
        background: a.background,
        shading: a.shading,
        alpha: a.alpha,
        frame: a.frame,
        lights: a.lights,
        camera: a.camera,
        ..PictureArgs::for_scene(a.scene)
    };
    let (scene, options) = prepare(&picture)?;
    let defaults = strata::scene::export::ExportDefaults {
        size: a.size.map(|_| [options.frame.width, options.frame.height]),
        background: a.background.map(|_| options.frame.background),
    };
    let bytes = strata::scene::export::to_gltf(&scene, &defaults, container)?;
    for loss in strata::scene::export::unexported(&scene) {
        eprintln!("note: {loss}");
    }
    let mut outputs = strata::output::Outputs::new();
    outputs.add(&a.output, bytes)?;
    outputs.commit()?;
    println!(
        "{}: {} objects, {} triangles, {} materials, {} lights",
        a.output.display(),
        scene.objects.len(),
        scene.triangle_count(),
        scene.materials.len(),
        scene.lights.len()
    );
    Ok(())
}
