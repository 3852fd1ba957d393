//! `strata export`: a scene as glTF 2.0.

use crate::{parse_vec3, prepare, PictureArgs, MAX_LIGHTS};
use clap::Args;
use std::path::PathBuf;
use strata::error::Result;

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
    pub size: Option<String>,
    /// checker | #rrggbb (sRGB): the background the file records as its picture default.
    #[arg(long)]
    pub background: Option<String>,
    /// unlit | lit: every material's shading (unlit materials get KHR_materials_unlit).
    #[arg(long)]
    pub shading: Option<String>,
    /// Sets every material's opacity.
    #[arg(long)]
    pub alpha: Option<f32>,
    /// Animation time in frames: objects and camera are written where they are then.
    #[arg(long)]
    pub frame: Option<f32>,
    /// Add N coloured point lights, a deterministic field over the scene's bounds.
    #[arg(long, value_parser = clap::value_parser!(u32).range(0..=MAX_LIGHTS as i64))]
    pub lights: Option<u32>,
    /// Camera position X,Y,Z (default: the scene's camera, else auto-framed).
    #[arg(long, value_parser = parse_vec3, allow_hyphen_values = true)]
    pub eye: Option<[f32; 3]>,
    /// The point the camera looks at, X,Y,Z.
    #[arg(long, value_parser = parse_vec3, allow_hyphen_values = true)]
    pub target: Option<[f32; 3]>,
    /// The camera's up direction, X,Y,Z.
    #[arg(long, value_parser = parse_vec3, allow_hyphen_values = true)]
    pub up: Option<[f32; 3]>,
    /// Vertical field of view in degrees (perspective cameras), in (0, 180).
    #[arg(long)]
    pub fov: Option<f32>,
}

pub fn export(a: ExportArgs) -> Result<()> {
    let container = strata::scene::export::GltfContainer::for_path(&a.output)?;
    let picture = PictureArgs {
        size: a.size.clone(),
        background: a.background.clone(),
        shading: a.shading,
        alpha: a.alpha,
        frame: a.frame,
        lights: a.lights,
        eye: a.eye,
        target: a.target,
        up: a.up,
        fov: a.fov,
        ..PictureArgs::for_scene(a.scene)
    };
    let (scene, options) = prepare(&picture)?;
    let defaults = strata::scene::export::ExportDefaults {
        size: a.size.map(|_| [options.frame.width, options.frame.height]),
        background: a.background.map(|_| options.frame.background),
    };
    let bytes = strata::scene::export::to_gltf(&scene, &defaults, container)?;
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
