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
//! Extensions: `KHR_materials_unlit` gives unlit shading, `KHR_materials_ior` the index of
//! refraction. As a scene (`load_scene`), the first camera node met in the traversal becomes the
//! camera (its target one unit ahead, unless the scene's extras say otherwise; an infinite far
//! plane ends past the scene's bounds), and `KHR_lights_punctual` lights become point, spot
//! (outer cone angle) and directional lights (glTF's inverse-square falloff as attenuation
//! [1, 0, 1]; an infinite range reaches twice the bounds' diagonal).
//!
//! strata's own extras (written by `strata export`, see [`crate::scene::export`]) override the
//! above: a scene's `extras.strata` holds `camera`, `light` and `render` tables with the fields of
//! the TOML scene file, a material's `extras.strata` its `absorption`, `ior`, `shading`,
//! `shininess` and `blend`.
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
use crate::scene::{
    Background, Camera, Light, LightKind, Material, Mesh, Projection, RenderDefaults, Shading,
};

/// Deepest node hierarchy we follow (a cycle would otherwise recurse forever).
const MAX_DEPTH: usize = 256;

/// The largest external buffer file read.
pub const MAX_BUFFER_BYTES: u64 = 4 << 30;

/// What a glTF file holds besides its meshes, for a scene.
pub(super) struct GltfScene {
    pub parts: Vec<Part>,
    /// The camera: from strata's extras, else the first camera node (resolved against the
    /// bounds by [`GltfScene::camera`]).
    camera: Option<CameraSource>,
    /// From strata's extras, else `KHR_lights_punctual` (ranges resolved against the bounds).
    lights: Vec<(Light, bool)>,
    pub defaults: RenderDefaults,
}

enum CameraSource {
    Exact(Camera),
    Node {
        world: Mat4,
        projection: Projection,
        near: f32,
        far: Option<f32>,
    },
}

impl GltfScene {
    /// The camera, with what the file leaves open taken from the scene's bounds.
    pub fn camera(&self, lo: glam::Vec3, hi: glam::Vec3) -> Option<Camera> {
        match self.camera.as_ref()? {
            CameraSource::Exact(c) => Some(*c),
            &CameraSource::Node {
                world,
                projection,
                near,
                far,
            } => {
                let eye = world.transform_point3(glam::Vec3::ZERO);
                let forward = world.transform_vector3(glam::Vec3::NEG_Z).try_normalize()?;
                let up = world.transform_vector3(glam::Vec3::Y).try_normalize()?;
                let reach = [lo, hi]
                    .iter()
                    .flat_map(|a| [lo, hi].map(|b| (a, b)))
                    .flat_map(|(a, b)| [lo, hi].map(|c| glam::Vec3::new(a.x, b.y, c.z)))
                    .map(|corner| (corner - eye).length())
                    .fold(0.0f32, f32::max);
                let far = far.unwrap_or((reach * 1.01).max(near * 2.0));
                Some(Camera {
                    eye,
                    target: eye + forward,
                    up,
                    projection,
                    near,
                    far,
                })
            }
        }
    }

    /// The lights, infinite ranges reaching twice the bounds' diagonal.
    pub fn lights(&self, lo: glam::Vec3, hi: glam::Vec3) -> Vec<Light> {
        let reach = ((hi - lo).length() * 2.0).max(1e-3);
        self.lights
            .iter()
            .map(|&(l, infinite)| Light {
                range: if infinite { reach } else { l.range },
                ..l
            })
            .collect()
    }
}

/// Parses `.gltf` or `.glb` bytes; external buffers are looked up under `base`.
pub(super) fn parse(
    bytes: &[u8],
    base: &Path,
    what: &str,
    warnings: &mut Vec<String>,
) -> Result<GltfScene> {
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
    let extras = match document.default_scene().or(document.scenes().next()) {
        Some(scene) => strata_extras(scene.extras(), what, "scene")?,
        None => None,
    };
    let extras = extras
        .map(|v| {
            serde_json::from_value::<SceneExtras>(v)
                .map_err(|e| Error::input(format!("{what}: scene extras.strata: {}", one_line(e))))
        })
        .transpose()?;
    let mut ctx = Ctx {
        what,
        buffers: &buffers,
        parts: Vec::new(),
        materials: HashMap::new(),
        skipped_modes: 0,
        hidden_nodes: 0,
        camera: None,
        lights: Vec::new(),
    };
    for node in roots {
        ctx.visit(&node, Mat4::IDENTITY, 0)?;
    }
    if ctx.skipped_modes > 0 && ctx.parts.is_empty() {
        return Err(Error::input(format!(
            "{what}: no TRIANGLES primitive to draw ({} of other modes, which strata does not draw)",
            ctx.skipped_modes
        )));
    }
    if ctx.skipped_modes > 0 {
        warnings.push(format!(
            "{what}: skipped {} primitive(s) that are not TRIANGLES",
            ctx.skipped_modes
        ));
    }
    if ctx.hidden_nodes > 0 {
        warnings.push(format!(
            "{what}: {} mesh node(s) with a zero scale draw nothing",
            ctx.hidden_nodes
        ));
    }
    let mut scene = GltfScene {
        parts: ctx.parts,
        camera: ctx.camera,
        lights: ctx.lights,
        defaults: RenderDefaults::default(),
    };
    if let Some(extras) = extras {
        extras.apply(&mut scene, what)?;
    }
    Ok(scene)
}

/// strata's extras of a scene (the TOML scene file's tables, in JSON).
#[derive(serde::Deserialize)]
#[serde(deny_unknown_fields)]
struct SceneExtras {
    camera: Option<super::toml::CameraDef>,
    light: Option<Vec<super::toml::LightDef>>,
    render: Option<RenderExtras>,
}

#[derive(serde::Deserialize)]
#[serde(deny_unknown_fields)]
struct RenderExtras {
    size: Option<[u32; 2]>,
    /// `checker`, `#rrggbb`, or linear `[r, g, b]`.
    background: Option<serde_json::Value>,
    shading: Option<Shading>,
    pipeline: Option<crate::scene::Pipeline>,
}

impl SceneExtras {
    fn apply(self, scene: &mut GltfScene, what: &str) -> Result<()> {
        let err = |part: &str, msg: String| {
            Error::input(format!("{what}: scene extras.strata.{part}: {msg}"))
        };
        if let Some(c) = self.camera {
            scene.camera = Some(CameraSource::Exact(
                super::toml::camera(c).map_err(|m| err("camera", m))?,
            ));
        }
        if let Some(lights) = self.light {
            scene.lights = lights
                .into_iter()
                .enumerate()
                .map(|(i, l)| {
                    super::toml::light(l)
                        .map(|l| (l, false))
                        .map_err(|m| err(&format!("light[{i}]"), m))
                })
                .collect::<Result<_>>()?;
        }
        if let Some(r) = self.render {
            if let Some([w, h]) = r.size {
                if w == 0 || h == 0 {
                    return Err(err("render", format!("size [{w}, {h}] must be positive")));
                }
            }
            let background = match r.background {
                None => None,
                Some(serde_json::Value::String(s)) => Some(
                    s.parse::<Background>()
                        .map_err(|e| err("render", e.to_string()))?,
                ),
                Some(v) => {
                    let c: [f32; 3] = serde_json::from_value(v).map_err(|_| {
                        err(
                            "render",
                            "background must be 'checker', '#rrggbb' or [r, g, b]".into(),
                        )
                    })?;
                    if !c.iter().all(|x| x.is_finite() && *x >= 0.0) {
                        return Err(err(
                            "render",
                            format!("background {c:?} must be finite and non-negative"),
                        ));
                    }
                    Some(Background::Color(c))
                }
            };
            scene.defaults = RenderDefaults {
                size: r.size,
                background,
                shading: r.shading,
                pipeline: r.pipeline,
            };
        }
        Ok(())
    }
}

/// The `strata` member of an element's extras, if it has one.
fn strata_extras(
    extras: &::gltf::json::Extras,
    what: &str,
    element: &str,
) -> Result<Option<serde_json::Value>> {
    let Some(raw) = extras else { return Ok(None) };
    let value: serde_json::Value = serde_json::from_str(raw.get())
        .map_err(|e| Error::input(format!("{what}: {element} extras: {}", one_line(e))))?;
    Ok(value.get("strata").cloned())
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
                        err(format!(
                            "URI '{}' is not valid percent-encoded UTF-8",
                            crate::error::quoted(uri)
                        ))
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
    /// Mesh nodes whose transform is singular (a zero scale: glTF's way to hide a node).
    hidden_nodes: usize,
    camera: Option<CameraSource>,
    lights: Vec<(Light, bool)>,
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
        if let (None, Some(camera)) = (&self.camera, node.camera()) {
            self.camera = Some(self.camera_of(world, &camera, node.index())?);
        }
        if let Some(light) = node.light() {
            self.lights
                .push(self.light_of(world, &light, node.index())?);
        }
        let mesh = node.mesh();
        if mesh.is_some() && world.determinant().abs() < f32::MIN_POSITIVE {
            // Zero or subnormal: a zero scale somewhere flattens the mesh to nothing, which
            // glTF files use to hide a node.
            self.hidden_nodes += 1;
        } else if let Some(mesh) = mesh {
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
                        if !self.materials.contains_key(&i) {
                            let m = convert_material(&prim.material(), self.what)?;
                            self.materials.insert(i, m);
                        }
                        match &self.materials[&i] {
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
                let what = format!("{}: mesh '{}'", self.what, crate::error::quoted(&name));
                let local_mesh = self.read_primitive(&prim, &what)?;
                // Untransformed meshes keep their normals bit for bit (an exported scene).
                let mut m = if world == Mat4::IDENTITY {
                    local_mesh
                } else {
                    local_mesh.transformed(world)
                };
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

    fn camera_of(&self, world: Mat4, camera: &::gltf::Camera, node: usize) -> Result<CameraSource> {
        let bad =
            |msg: String| Error::input(format!("{}: camera of node {node}: {msg}", self.what));
        let (projection, near, far) = match camera.projection() {
            ::gltf::camera::Projection::Perspective(p) => {
                let fov_y_deg = p.yfov().to_degrees();
                if !(fov_y_deg > 0.0 && fov_y_deg < 180.0) {
                    return Err(bad(format!("yfov {} is outside (0, π)", p.yfov())));
                }
                (Projection::Perspective { fov_y_deg }, p.znear(), p.zfar())
            }
            ::gltf::camera::Projection::Orthographic(o) => {
                let height = 2.0 * o.ymag();
                if !(height > 0.0 && height.is_finite()) {
                    return Err(bad(format!("ymag {} must be positive", o.ymag())));
                }
                (
                    Projection::Orthographic { height },
                    o.znear(),
                    Some(o.zfar()),
                )
            }
        };
        if !(near > 0.0 && near.is_finite()) || far.is_some_and(|f| !(f > near && f.is_finite())) {
            return Err(bad(format!(
                "znear {near} and zfar {far:?} must satisfy 0 < znear < zfar"
            )));
        }
        if world
            .x_axis
            .truncate()
            .cross(world.y_axis.truncate())
            .length()
            < 1e-12
        {
            return Err(bad("its node's transform is degenerate".into()));
        }
        Ok(CameraSource::Node {
            world,
            projection,
            near,
            far,
        })
    }

    fn light_of(
        &self,
        world: Mat4,
        light: &::gltf::khr_lights_punctual::Light,
        node: usize,
    ) -> Result<(Light, bool)> {
        use ::gltf::khr_lights_punctual::Kind;
        let bad = |msg: String| Error::input(format!("{}: light of node {node}: {msg}", self.what));
        let color = light.color();
        let intensity = light.intensity();
        if !color.iter().all(|c| c.is_finite() && *c >= 0.0) {
            return Err(bad(format!(
                "color {color:?} must be finite and non-negative"
            )));
        }
        if !(intensity.is_finite() && intensity >= 0.0) {
            return Err(bad(format!("intensity {intensity} must be ≥ 0")));
        }
        let range = light.range();
        if range.is_some_and(|r| !(r > 0.0 && r.is_finite())) {
            return Err(bad(format!("range {range:?} must be positive")));
        }
        let (kind, angle_deg) = match light.kind() {
            Kind::Directional => (LightKind::Directional, Light::default().angle_deg),
            Kind::Point => (LightKind::Point, Light::default().angle_deg),
            Kind::Spot {
                outer_cone_angle, ..
            } => {
                let deg = outer_cone_angle.to_degrees();
                if !(deg > 0.0 && deg < 180.0) {
                    return Err(bad(format!(
                        "outerConeAngle {outer_cone_angle} must be in (0, π)"
                    )));
                }
                (LightKind::Spot, deg)
            }
        };
        let direction = world
            .transform_vector3(glam::Vec3::NEG_Z)
            .try_normalize()
            .ok_or_else(|| bad("its node's transform is degenerate".into()))?;
        Ok((
            Light {
                kind,
                position: world.transform_point3(glam::Vec3::ZERO),
                direction,
                angle_deg,
                color,
                intensity,
                range: range.unwrap_or(1.0),
                attenuation: [1.0, 0.0, 1.0],
            },
            range.is_none(),
        ))
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

/// strata's extras of a material: the fields glTF lacks.
#[derive(serde::Deserialize)]
#[serde(deny_unknown_fields)]
struct MaterialExtras {
    absorption: Option<f32>,
    ior: Option<f32>,
    shading: Option<Shading>,
    shininess: Option<f32>,
    blend: Option<crate::scene::Blend>,
}

/// `None`: the material cuts everything out (MASK with factor alpha below the cutoff).
fn convert_material(m: &::gltf::Material, what: &str) -> Result<Option<Material>> {
    let pbr = m.pbr_metallic_roughness();
    let [r, g, b, a] = pbr.base_color_factor();
    if ![r, g, b, a].iter().all(|c| (0.0..=1.0).contains(c)) {
        return Err(Error::input(format!(
            "{what}: material {} has baseColorFactor [{r}, {g}, {b}, {a}], outside [0, 1]",
            m.index().map_or("default".to_string(), |i| i.to_string())
        )));
    }
    let opacity = match m.alpha_mode() {
        AlphaMode::Blend => a,
        AlphaMode::Opaque => 1.0,
        AlphaMode::Mask => {
            if a < m.alpha_cutoff().unwrap_or(0.5) {
                return Ok(None);
            }
            1.0
        }
    };
    let name = m
        .name()
        .map(str::to_string)
        .unwrap_or_else(|| format!("material {}", m.index().unwrap_or(0)));
    let mut material = Material {
        name,
        color: [r, g, b].map(|c| if c.is_finite() { c.max(0.0) } else { 0.8 }),
        opacity,
        ..Material::default()
    };
    if m.unlit() {
        material.shading = Shading::Unlit;
    }
    // glTF allows 0 for an ior it leaves undefined; strata needs ≥ 1.
    if let Some(ior) = m.ior().filter(|&ior| ior >= 1.0) {
        material.ior = ior;
    }
    let element = format!("material '{}'", crate::error::quoted(&material.name));
    if let Some(v) = strata_extras(m.extras(), what, &element)? {
        let e: MaterialExtras = serde_json::from_value(v).map_err(|e| {
            Error::input(format!("{what}: {element} extras.strata: {}", one_line(e)))
        })?;
        material.absorption = e.absorption.unwrap_or(material.absorption);
        material.ior = e.ior.unwrap_or(material.ior);
        material.shading = e.shading.unwrap_or(material.shading);
        material.shininess = e.shininess.unwrap_or(material.shininess);
        material.blend = e.blend.unwrap_or(material.blend);
    }
    super::toml::check_material(&material)
        .map_err(|msg| Error::input(format!("{what}: {element}: {msg}")))?;
    Ok(Some(material))
}
