//! Scene loaders: TOML scene files, bare model files (OBJ, PLY, glTF/GLB) and `builtin:` specs.
//!
//! Every error is one line naming the file (and element) and what is wrong; recoverable problems
//! (a missing `.mtl`, skipped glTF primitives) are printed to stderr as one-line warnings.

pub(crate) mod gltf;
pub(crate) mod obj;
pub(crate) mod ply;
pub(crate) mod toml;

use std::path::Path;

use crate::error::{Error, Result};
use crate::scene::{builtin, Material, Mesh, Object, Scene};

/// One piece of a model file: its name, its mesh (valid, with normals, in the file's
/// coordinates) and the material the file gives it, if any.
pub type Part = (String, Mesh, Option<Material>);

/// The formats of scene and model files strata reads.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FileFormat {
    /// A TOML scene file (`.toml`).
    Toml,
    /// A Wavefront OBJ model (`.obj`), with its `.mtl` libraries.
    Obj,
    /// A PLY model (`.ply`), ASCII or binary.
    Ply,
    /// A glTF 2.0 model or scene (`.gltf`, or `.glb`: the two are told apart by their bytes).
    Gltf,
}

impl FileFormat {
    /// The format `path`'s extension names, if strata reads it.
    pub fn of_path(path: &Path) -> Option<FileFormat> {
        let ext = path.extension()?.to_str()?.to_ascii_lowercase();
        Some(match ext.as_str() {
            "toml" => FileFormat::Toml,
            "obj" => FileFormat::Obj,
            "ply" => FileFormat::Ply,
            "gltf" | "glb" => FileFormat::Gltf,
            _ => return None,
        })
    }
}

use FileFormat as Kind;

fn kind_of(path: &Path) -> Option<Kind> {
    FileFormat::of_path(path)
}

/// Loads a scene from `spec`: a `.toml` scene file, a model file (`.obj`, `.ply`, `.gltf`,
/// `.glb`: auto-framed camera, headlight, the file's materials or the default one; a glTF file's camera, lights and strata extras), or
/// `builtin:NAME?key=value&...`. The result has passed [`Scene::validate`].
pub fn load_scene(spec: &str) -> Result<Scene> {
    if let Some(rest) = spec.strip_prefix("builtin:") {
        let scene = builtin::build(rest)?;
        scene
            .validate()
            .map_err(|e| Error::input(format!("{spec}: {e}")))?;
        return Ok(scene);
    }
    let path = Path::new(spec);
    let kind = kind_of(path).ok_or_else(|| {
        Error::input(format!(
            "scene '{spec}': unsupported file type (expected .toml, .obj, .ply, .gltf, .glb or builtin:NAME)"
        ))
    })?;
    check_file(path, "scene file")?;
    let bytes = read_file(path)?;
    let dir = path.parent().unwrap_or(Path::new(""));
    let mut warnings = Vec::new();
    let scene = load_scene_bytes(kind, &bytes, spec, dir, &mut warnings);
    print_warnings(&warnings);
    scene
}

/// Loads a scene from the bytes of a file in `format` (what [`load_scene`] does once it has
/// read the file): `name` names it in errors and warnings (a model's stem names its parts),
/// and the files it refers to — a TOML scene's meshes, an OBJ's `.mtl` libraries, a glTF's
/// external buffers — are looked up under `dir`. Warnings (a missing `.mtl`, skipped glTF
/// primitives) are pushed onto `warnings`. The result has passed [`Scene::validate`]; every
/// error is one line.
pub fn load_scene_bytes(
    format: FileFormat,
    bytes: &[u8],
    name: &str,
    dir: &Path,
    warnings: &mut Vec<String>,
) -> Result<Scene> {
    let scene = match format {
        Kind::Toml => {
            let text = std::str::from_utf8(bytes)
                .map_err(|_| Error::input(format!("{name}: not UTF-8 text")))?;
            toml::parse(text, name, dir, warnings)?
        }
        Kind::Gltf => {
            let mut loaded = gltf::parse(bytes, dir, name, warnings)?;
            if loaded.parts.is_empty() {
                return Err(Error::input(format!("{name}: no triangles found")));
            }
            let mut scene = scene_from_parts(std::mem::take(&mut loaded.parts));
            let (lo, hi) = scene.bounds();
            scene.camera = loaded.camera(lo, hi);
            scene.lights = loaded.lights(lo, hi);
            scene.defaults = loaded.defaults;
            scene
        }
        model => scene_from_parts(model_from_bytes(model, bytes, name, dir, warnings)?),
    };
    scene
        .validate()
        .map_err(|e| Error::input(format!("{name}: {e}")))?;
    Ok(scene)
}

/// The parts of a model file's bytes (`name` its path as errors name it, `dir` where its
/// references are looked up); fails when it holds no triangles.
fn model_from_bytes(
    format: FileFormat,
    bytes: &[u8],
    name: &str,
    dir: &Path,
    warnings: &mut Vec<String>,
) -> Result<Vec<Part>> {
    let parts = match format {
        Kind::Obj => obj::parse_bytes(bytes, name, dir, warnings)?,
        Kind::Ply => {
            let stem = Path::new(name)
                .file_stem()
                .map_or_else(|| name.to_string(), |s| s.to_string_lossy().into_owned());
            ply::parse(bytes, name, &stem)?
        }
        Kind::Gltf => gltf::parse(bytes, dir, name, warnings)?.parts,
        Kind::Toml => {
            return Err(Error::input(format!(
                "model '{name}': a TOML scene is not a model (expected .obj, .ply, .gltf or .glb)"
            )))
        }
    };
    if parts.is_empty() {
        return Err(Error::input(format!("{name}: no triangles found")));
    }
    Ok(parts)
}

/// Loads the meshes (and materials) of a model file: `.obj` (with its `.mtl`), `.ply`, `.gltf`
/// or `.glb`. Warnings go to stderr. Fails when the file holds no triangles.
pub fn load_model(path: &Path) -> Result<Vec<(String, Mesh, Option<Material>)>> {
    let mut warnings = Vec::new();
    let parts = load_model_with_warnings(path, &mut warnings);
    print_warnings(&warnings);
    parts
}

fn print_warnings(warnings: &[String]) {
    for w in warnings {
        eprintln!("warning: {w}");
    }
}

/// [`load_model`], collecting warnings instead of printing them.
pub(crate) fn load_model_with_warnings(
    path: &Path,
    warnings: &mut Vec<String>,
) -> Result<Vec<Part>> {
    let kind = kind_of(path).filter(|k| *k != Kind::Toml).ok_or_else(|| {
        Error::input(format!(
            "model '{}': unsupported file type (expected .obj, .ply, .gltf or .glb)",
            path.display()
        ))
    })?;
    check_file(path, "model file")?;
    let bytes = read_file(path)?;
    let dir = path.parent().unwrap_or(Path::new(""));
    model_from_bytes(kind, &bytes, &path.display().to_string(), dir, warnings)
}

/// A scene of the parts, identical materials shared, the default material for parts without
/// one; no camera (auto-framed), no lights.
fn scene_from_parts(parts: Vec<Part>) -> Scene {
    let mut scene = Scene::default();
    for (name, mesh, material) in parts {
        let material = intern_material(&mut scene, material.unwrap_or_default());
        scene.objects.push(Object {
            name,
            mesh,
            material,
        });
    }
    scene
}

/// Index of `m` in the scene's materials, adding it unless an identical one is there.
pub(crate) fn intern_material(scene: &mut Scene, m: Material) -> usize {
    match scene.materials.iter().position(|x| *x == m) {
        Some(i) => i,
        None => scene.add_material(m),
    }
}

/// One-line errors for a path that is missing or not a file.
fn check_file(path: &Path, role: &str) -> Result<()> {
    match std::fs::metadata(path) {
        Ok(md) if md.is_file() => Ok(()),
        Ok(_) => Err(Error::input(format!(
            "{role} '{}' is not a file",
            path.display()
        ))),
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => Err(Error::input(format!(
            "{role} '{}' not found",
            path.display()
        ))),
        Err(e) => Err(Error::input(format!("{role} '{}': {e}", path.display()))),
    }
}

/// The largest scene or model file read (a 10M-triangle OBJ is about 1 GiB of text).
pub const MAX_FILE_BYTES: u64 = 4 << 30;
/// The largest `.mtl` library read.
pub const MAX_MTL_BYTES: u64 = 64 << 20;

/// Reads a scene or model file of at most [`MAX_FILE_BYTES`].
pub(crate) fn read_file(path: &Path) -> Result<Vec<u8>> {
    read_capped(path, MAX_FILE_BYTES)
        .map_err(|why| Error::input(format!("{}: cannot read: {why}", path.display())))
}

/// Reads a file another file refers to (an `mtllib`, a glTF buffer, a TOML mesh): a regular
/// file of at most `cap` bytes, never a device or FIFO that could be read forever. The error
/// names the referring file, the role and the referenced path.
pub(crate) fn read_referenced(
    referrer: &str,
    role: &str,
    path: &Path,
    cap: u64,
) -> Result<Vec<u8>> {
    read_capped(path, cap)
        .map_err(|why| Error::input(format!("{referrer}: {role} '{}': {why}", path.display())))
}

/// The bytes of the regular file `path` if it has at most `cap`; else why not, as a phrase.
pub(crate) fn read_capped(path: &Path, cap: u64) -> std::result::Result<Vec<u8>, String> {
    use std::io::Read;
    let md = std::fs::metadata(path).map_err(|e| io_phrase(&e))?;
    if !md.is_file() {
        return Err(if md.is_dir() {
            "is a directory".into()
        } else {
            "is not a regular file".into()
        });
    }
    let too_big = |n: u64| {
        format!(
            "is {}, more than the limit of {}",
            bytes_phrase(n),
            bytes_phrase(cap)
        )
    };
    if md.len() > cap {
        return Err(too_big(md.len()));
    }
    let file = std::fs::File::open(path).map_err(|e| io_phrase(&e))?;
    // The file may grow while it is read: never take more than the cap.
    let mut bytes = Vec::with_capacity(md.len() as usize);
    file.take(cap + 1)
        .read_to_end(&mut bytes)
        .map_err(|e| io_phrase(&e))?;
    if bytes.len() as u64 > cap {
        return Err(too_big(bytes.len() as u64));
    }
    Ok(bytes)
}

fn io_phrase(e: &std::io::Error) -> String {
    match e.kind() {
        std::io::ErrorKind::NotFound => "not found".into(),
        std::io::ErrorKind::PermissionDenied => "permission denied".into(),
        _ => e.to_string(),
    }
}

/// `12.5 MiB`, `300 bytes`.
pub(crate) fn bytes_phrase(n: u64) -> String {
    match n {
        n if n >= 1 << 30 => format!("{:.1} GiB", n as f64 / (1u64 << 30) as f64),
        n if n >= 1 << 20 => format!("{:.1} MiB", n as f64 / (1u64 << 20) as f64),
        n if n >= 1 << 10 => format!("{:.1} KiB", n as f64 / 1024.0),
        n => format!("{n} bytes"),
    }
}

/// Gives a mesh normals when it has none (or unusable ones) and validates it.
pub(crate) fn finish_mesh(mut mesh: Mesh, what: &str) -> Result<Mesh> {
    let usable = mesh.normals.len() == mesh.positions.len()
        && mesh
            .normals
            .iter()
            .all(|n| n.iter().all(|c| c.is_finite()) && n.iter().any(|c| *c != 0.0));
    if !usable {
        mesh.normals.clear();
    }
    mesh.validate(what)?;
    if !usable {
        mesh.compute_normals();
    }
    Ok(mesh)
}

#[cfg(test)]
mod tests;
