//! glTF 2.0 (`.gltf` with embedded or external buffers, `.glb`) through the `gltf` crate.
//!
//! Every primitive of mode TRIANGLES reachable from the default scene (or from every scene when
//! there is no default) becomes one part, in world space (node matrices composed down the parent
//! chain; winding flipped under mirroring transforms), named after its mesh (`mesh[i]` for a
//! mesh's later primitives, `mesh N` when unnamed). Other primitive modes are skipped with a
//! warning. Images are never decoded.
//!
//! Materials: one [`Material`] per glTF material, named after it: `baseColorFactor` rgb → color
//! (glTF factors are linear already); `alphaMode` BLEND → opacity = factor alpha; OPAQUE →
//! opacity 1; MASK → opacity 1, except that a primitive whose factor alpha is below
//! `alphaCutoff` (default 0.5) is cut out entirely and dropped. Textures are ignored. A
//! primitive without a material gets none (the caller's default).
//!
//! Buffers: the GLB binary chunk, `data:` URIs in base64, or files relative to the glTF file
//! (regular files of at most [`MAX_BUFFER_BYTES`]); every failure names the buffer and, for a
//! file, its path.

use std::collections::HashMap;
use std::path::Path;

use ::gltf::accessor::{DataType, Dimensions};
use ::gltf::material::AlphaMode;
use ::gltf::mesh::Mode;
use ::gltf::{Accessor, Gltf, Node};
use glam::Mat4;

use super::{finish_mesh, Part};
use crate::error::{Error, Result};
use crate::scene::{Material, Mesh};

/// Deepest node hierarchy we follow (a cycle would otherwise recurse forever).
const MAX_DEPTH: usize = 256;

/// The largest external buffer file read.
pub const MAX_BUFFER_BYTES: u64 = 4 << 30;

pub(super) fn load(path: &Path, warnings: &mut Vec<String>) -> Result<Vec<Part>> {
    let bytes = super::read_file(path)?;
    let base = path.parent().unwrap_or(Path::new(""));
    parse(&bytes, base, &path.display().to_string(), warnings)
}

/// Parses `.gltf` or `.glb` bytes; external buffers are looked up under `base`.
pub(super) fn parse(
    bytes: &[u8],
    base: &Path,
    what: &str,
    warnings: &mut Vec<String>,
) -> Result<Vec<Part>> {
    let gltf_err = |e: ::gltf::Error| Error::input(format!("{what}: {}", describe(e)));
    let Gltf { document, blob } = Gltf::from_slice_without_validation(bytes).map_err(gltf_err)?;
    // gltf-json's validator indexes the POSITION accessor unchecked: check references first.
    let json = document.into_json();
    for (m, mesh) in json.meshes.iter().enumerate() {
        for (p, prim) in mesh.primitives.iter().enumerate() {
            if let Some(bad) = prim
                .attributes
                .values()
                .map(|a| a.value())
                .find(|&a| a >= json.accessors.len())
            {
                return Err(Error::input(format!(
                    "{what}: mesh {m} primitive {p} refers to accessor {bad}, but there are {}",
                    json.accessors.len()
                )));
            }
        }
    }
    let document = ::gltf::Document::from_json(json).map_err(gltf_err)?;
    let buffers = load_buffers(&document, base, blob, what)?;
    let buffers: Vec<&[u8]> = buffers.iter().map(|b| &b[..]).collect();

    let roots: Vec<Node> = match document.default_scene() {
        Some(scene) => scene.nodes().collect(),
        None => document.scenes().flat_map(|s| s.nodes()).collect(),
    };
    let mut ctx = Ctx {
        what,
        buffers: &buffers,
        parts: Vec::new(),
        materials: HashMap::new(),
        skipped_modes: 0,
    };
    for node in roots {
        ctx.visit(&node, Mat4::IDENTITY, 0)?;
    }
    if ctx.skipped_modes > 0 {
        warnings.push(format!(
            "{what}: skipped {} primitive(s) that are not TRIANGLES",
            ctx.skipped_modes
        ));
    }
    Ok(ctx.parts)
}

/// Each buffer's bytes, from the GLB chunk, a `data:` URI or a file beside the glTF file.
fn load_buffers(
    document: &::gltf::Document,
    base: &Path,
    mut blob: Option<Vec<u8>>,
    what: &str,
) -> Result<Vec<Vec<u8>>> {
    let mut out = Vec::new();
    for buffer in document.buffers() {
        let i = buffer.index();
        let err = |msg: String| Error::input(format!("{what}: buffer {i}: {msg}"));
        let data = match buffer.source() {
            ::gltf::buffer::Source::Bin => blob.take().ok_or_else(|| {
                err("refers to the GLB binary chunk, which the file lacks".into())
            })?,
            ::gltf::buffer::Source::Uri(uri) => {
                if let Some(rest) = uri.strip_prefix("data:") {
                    let (media, payload) = rest
                        .split_once(',')
                        .ok_or_else(|| err("data URI without a ',' before its payload".into()))?;
                    if !media.ends_with(";base64") {
                        return Err(err(format!(
                            "data URI '{}' is not base64 (only ';base64,' payloads are read)",
                            media
                        )));
                    }
                    base64::decode(payload).map_err(|e| err(describe_base64(&e, payload)))?
                } else if uri.contains(':') && !uri.starts_with("file:") {
                    let scheme = uri.split(':').next().unwrap_or_default();
                    return Err(err(format!(
                        "URI scheme '{scheme}:' is not supported (files and data: URIs are)"
                    )));
                } else {
                    let path = uri.strip_prefix("file://").or(uri.strip_prefix("file:"));
                    let relative = path.is_none();
                    let decoded = urlencoding::decode(path.unwrap_or(uri)).map_err(|_| {
                        err(format!("URI '{uri}' is not valid percent-encoded UTF-8"))
                    })?;
                    let file = if relative {
                        base.join(&*decoded)
                    } else {
                        std::path::PathBuf::from(&*decoded)
                    };
                    super::read_referenced(what, &format!("buffer {i}"), &file, MAX_BUFFER_BYTES)?
                }
            }
        };
        if data.len() < buffer.length() {
            return Err(err(format!(
                "has {} bytes, but the file declares byteLength {}",
                data.len(),
                buffer.length()
            )));
        }
        out.push(data);
    }
    Ok(out)
}

/// A base64 failure as a phrase naming the character and where it is.
fn describe_base64(e: &base64::DecodeError, payload: &str) -> String {
    match *e {
        base64::DecodeError::InvalidByte(at, byte)
        | base64::DecodeError::InvalidLastSymbol(at, byte) => {
            let c = payload[at..].chars().next().unwrap_or(byte as char);
            format!("data URI is not valid base64: character {c:?} at payload offset {at}")
        }
        base64::DecodeError::InvalidLength => format!(
            "data URI is not valid base64: its payload has {} characters, which no base64 text has",
            payload.len()
        ),
    }
}

/// A `gltf` failure as one line saying what was expected and found.
fn describe(e: ::gltf::Error) -> String {
    use ::gltf::binary::{ChunkType, Error as Glb};
    let chunk = |t: &ChunkType| match t {
        ChunkType::Json => "JSON",
        ChunkType::Bin => "BIN",
    };
    match e {
        ::gltf::Error::Binary(b) => match b {
            Glb::Io(_) => {
                "truncated GLB: the file ends inside its 12-byte header or a chunk header".into()
            }
            Glb::Version(v) => format!("GLB version {v} is not supported (expected 2)"),
            Glb::Magic(m) => format!(
                "not a GLB file (magic {:?}, expected \"glTF\")",
                String::from_utf8_lossy(&m)
            ),
            // Both lengths count what follows the 12-byte header.
            Glb::Length {
                length,
                length_read,
            } => format!(
                "truncated GLB: its header declares {} bytes, the file has {}",
                length as usize + 12,
                length_read + 12
            ),
            Glb::ChunkLength {
                ty,
                length,
                length_read,
            } => format!(
                "truncated GLB: the {} chunk declares {length} bytes, {length_read} remain",
                chunk(&ty)
            ),
            Glb::ChunkType(ty) => format!("GLB chunk {} is not where it may be", chunk(&ty)),
            Glb::UnknownChunkType(t) => format!(
                "GLB has an unknown chunk type {:?}",
                String::from_utf8_lossy(&t)
            ),
        },
        ::gltf::Error::Deserialize(j) => format!("invalid glTF JSON: {}", one_line(j)),
        other => one_line(other),
    }
}

fn one_line(e: impl std::fmt::Display) -> String {
    e.to_string()
        .split_whitespace()
        .collect::<Vec<_>>()
        .join(" ")
}

struct Ctx<'a> {
    what: &'a str,
    buffers: &'a [&'a [u8]],
    parts: Vec<Part>,
    /// Converted materials by glTF index; `None` means "cut out" (MASK below cutoff).
    materials: HashMap<usize, Option<Material>>,
    skipped_modes: usize,
}

impl Ctx<'_> {
    fn visit(&mut self, node: &Node, parent: Mat4, depth: usize) -> Result<()> {
        if depth > MAX_DEPTH {
            return Err(Error::input(format!(
                "{}: node hierarchy deeper than {MAX_DEPTH} (a cycle?) at node {}",
                self.what,
                node.index()
            )));
        }
        let local = Mat4::from_cols_array_2d(&node.transform().matrix());
        let world = parent * local;
        if !world.is_finite() {
            return Err(Error::input(format!(
                "{}: node {} has a non-finite transform",
                self.what,
                node.index()
            )));
        }
        if let Some(mesh) = node.mesh() {
            let mesh_name = mesh
                .name()
                .map(str::to_string)
                .unwrap_or_else(|| format!("mesh {}", mesh.index()));
            for (p, prim) in mesh.primitives().enumerate() {
                if prim.mode() != Mode::Triangles {
                    self.skipped_modes += 1;
                    continue;
                }
                let material = match prim.material().index() {
                    None => None,
                    Some(i) => {
                        let m = self
                            .materials
                            .entry(i)
                            .or_insert_with(|| convert_material(&prim.material()));
                        match m {
                            None => continue, // cut out
                            Some(m) => Some(m.clone()),
                        }
                    }
                };
                let name = if p == 0 {
                    mesh_name.clone()
                } else {
                    format!("{mesh_name}[{p}]")
                };
                let what = format!("{}: mesh '{name}'", self.what);
                let local_mesh = self.read_primitive(&prim, &what)?;
                let mut m = local_mesh.transformed(world);
                if world.determinant() < 0.0 {
                    for t in m.indices.chunks_exact_mut(3) {
                        t.swap(1, 2);
                    }
                }
                self.parts.push((name, finish_mesh(m, &what)?, material));
            }
        }
        for child in node.children() {
            self.visit(&child, world, depth + 1)?;
        }
        Ok(())
    }

    fn read_primitive(&self, prim: &::gltf::Primitive, what: &str) -> Result<Mesh> {
        let positions = prim
            .get(&::gltf::Semantic::Positions)
            .ok_or_else(|| Error::input(format!("{what}: primitive has no POSITION")))?;
        check_accessor(
            &positions,
            &[DataType::F32],
            Dimensions::Vec3,
            what,
            "POSITION",
        )?;
        let normals = prim.get(&::gltf::Semantic::Normals);
        if let Some(n) = &normals {
            check_accessor(n, &[DataType::F32], Dimensions::Vec3, what, "NORMAL")?;
        }
        if let Some(i) = prim.indices() {
            check_accessor(
                &i,
                &[DataType::U8, DataType::U16, DataType::U32],
                Dimensions::Scalar,
                what,
                "indices",
            )?;
        }
        let reader = prim.reader(|b| self.buffers.get(b.index()).copied());
        let positions: Vec<[f32; 3]> = reader
            .read_positions()
            .ok_or_else(|| Error::input(format!("{what}: POSITION data lies outside its buffer")))?
            .collect();
        let normals: Vec<[f32; 3]> = match normals {
            None => Vec::new(),
            Some(_) => reader
                .read_normals()
                .ok_or_else(|| {
                    Error::input(format!("{what}: NORMAL data lies outside its buffer"))
                })?
                .collect(),
        };
        let indices: Vec<u32> = match prim.indices() {
            None => (0..positions.len() as u32).collect(),
            Some(_) => reader
                .read_indices()
                .ok_or_else(|| Error::input(format!("{what}: index data lies outside its buffer")))?
                .into_u32()
                .collect(),
        };
        let mut mesh = Mesh {
            positions,
            normals,
            indices,
        };
        // A trailing partial triangle is dropped, as a GPU would.
        mesh.indices.truncate(mesh.indices.len() / 3 * 3);
        mesh.validate(what)?;
        Ok(mesh)
    }
}

/// Checks what the `gltf` reader assumes (and debug-asserts) before reading an accessor.
fn check_accessor(
    a: &Accessor,
    types: &[DataType],
    dims: Dimensions,
    what: &str,
    role: &str,
) -> Result<()> {
    let bad = |msg: String| {
        Err(Error::input(format!(
            "{what}: {role} accessor {}: {msg}",
            a.index()
        )))
    };
    if a.dimensions() != dims || !types.contains(&a.data_type()) {
        return bad(format!(
            "type {:?} {:?} is not supported here (expected {dims:?} of {types:?})",
            a.dimensions(),
            a.data_type()
        ));
    }
    if a.normalized() {
        return bad("normalized values are not supported here".into());
    }
    if a.count() == 0 {
        return bad("count is 0".into());
    }
    let size = a.size();
    if let Some(view) = a.view() {
        if view.stride().is_some_and(|s| s < size) {
            return bad(format!(
                "byte stride {:?} is smaller than an element",
                view.stride()
            ));
        }
    }
    if let Some(sparse) = a.sparse() {
        if sparse.count() == 0 {
            return bad("sparse count is 0".into());
        }
        let vs = sparse.values().view().stride();
        if vs.is_some_and(|s| s < size) {
            return bad("sparse value stride is smaller than an element".into());
        }
    }
    Ok(())
}

/// `None`: the material cuts everything out (MASK with factor alpha below the cutoff).
fn convert_material(m: &::gltf::Material) -> Option<Material> {
    let pbr = m.pbr_metallic_roughness();
    let [r, g, b, a] = pbr.base_color_factor();
    let opacity = match m.alpha_mode() {
        AlphaMode::Blend => a.clamp(0.0, 1.0),
        AlphaMode::Opaque => 1.0,
        AlphaMode::Mask => {
            if a < m.alpha_cutoff().unwrap_or(0.5) {
                return None;
            }
            1.0
        }
    };
    Some(Material {
        name: m
            .name()
            .map(str::to_string)
            .unwrap_or_else(|| format!("material {}", m.index().unwrap_or(0))),
        color: [r, g, b].map(|c| if c.is_finite() { c.max(0.0) } else { 0.8 }),
        opacity,
        ..Material::default()
    })
}
