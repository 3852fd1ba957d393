//! TOML scene files (the README's "Scene files (TOML)" shows one with every key).
//!
//! Unknown keys are errors (typos must not pass silently). Errors name the file, the element —
//! `render`, `camera`, `material N`, `object N`, `light N`, `camera_key N`, counted from 1 in file order — and the
//! element's line, e.g. `scene.toml: object 2 (line 14): unknown material 'glas'`.
//!
//! Objects: `mesh` is a model file relative to the scene file's directory, or `builtin:quad`,
//! `builtin:cube`, `builtin:sphere?segments=N`. The transform is M = T · Rz · Ry · Rx · S
//! (`scale` first, then rotations about X, Y, Z in degrees, then `translate`); meshes are stored
//! in world space. Materials: `material = "name"` picks a `[[material]]`, replacing any
//! materials of the model file; the inline fields (`color`, `opacity`, `absorption`, `ior`,
//! `shading`, `shininess`, `blend`) override single fields of the base material — the named one if given, else each
//! of the model's own materials, else the default material.
//!
//! Defaults: camera `target` [0,0,0], `up` [0,1,0], perspective, `fov_y_deg` 45, `height` 2,
//! `near` 0.1, `far` 100 (`eye` is required); materials and lights take the fields they omit
//! from [`Material::default`] and [`Light::default`]; `[camera]` omitted means auto-framed.
//!
//! Camera paths: a `[[camera_key]]` list (`time` in frames, `eye`, `target` default [0,0,0])
//! moves the camera between keys, linearly, holding the first before it and the last after it;
//! projection, up and planes stay the `[camera]`'s (or the framing's). `--frame T` and
//! `--frames A..B` pick the time.

use std::collections::HashMap;
use std::path::{Path, PathBuf};

use ::toml::{Spanned, Table, Value};
use glam::{Mat4, Vec3};
use serde::Deserialize;

use super::{intern_material, Part};
use crate::error::{Error, Result};
use crate::scene::animation::check_key;
use crate::scene::{
    builtin, Background, Blend, Camera, CameraKey, CameraPath, Light, LightKind, Material, Object,
    Projection, RenderDefaults, Scene, Shading,
};

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct FileDef {
    render: Option<Spanned<Table>>,
    camera: Option<Spanned<Table>>,
    #[serde(default)]
    material: Vec<Spanned<Table>>,
    #[serde(default)]
    object: Vec<Spanned<Table>>,
    #[serde(default)]
    light: Vec<Spanned<Table>>,
    #[serde(default)]
    camera_key: Vec<Spanned<Table>>,
}

/// The same file, typed (parsed second, so field errors carry their own line and column).
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct TypedFileDef {
    render: Option<RenderDef>,
    camera: Option<CameraDef>,
    #[serde(default)]
    material: Vec<MaterialDef>,
    #[serde(default)]
    object: Vec<ObjectDef>,
    #[serde(default)]
    light: Vec<LightDef>,
    #[serde(default)]
    camera_key: Vec<CameraKeyDef>,
}

/// One `[[camera_key]]`: where the camera is at `time` (frames).
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct CameraKeyDef {
    time: f32,
    eye: [f32; 3],
    #[serde(default)]
    target: [f32; 3],
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RenderDef {
    size: Option<[u32; 2]>,
    background: Option<String>,
    shading: Option<Shading>,
    pipeline: Option<crate::scene::Pipeline>,
}

#[derive(Deserialize, Default, Clone, Copy)]
#[serde(rename_all = "lowercase")]
enum ProjectionKind {
    #[default]
    Perspective,
    Orthographic,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct CameraDef {
    eye: [f32; 3],
    #[serde(default)]
    target: [f32; 3],
    #[serde(default = "y_up")]
    up: [f32; 3],
    #[serde(default)]
    projection: ProjectionKind,
    #[serde(default = "default_fov")]
    fov_y_deg: f32,
    #[serde(default = "default_height")]
    height: f32,
    #[serde(default = "default_near")]
    near: f32,
    #[serde(default = "default_far")]
    far: f32,
}

fn y_up() -> [f32; 3] {
    [0.0, 1.0, 0.0]
}
fn default_fov() -> f32 {
    45.0
}
fn default_height() -> f32 {
    2.0
}
fn default_near() -> f32 {
    0.1
}
fn default_far() -> f32 {
    100.0
}

/// The material fields shared by `[[material]]` and inline object materials.
#[derive(Default)]
struct MaterialFields {
    color: Option<[f32; 3]>,
    opacity: Option<f32>,
    absorption: Option<f32>,
    ior: Option<f32>,
    shading: Option<Shading>,
    shininess: Option<f32>,
    blend: Option<Blend>,
}

impl MaterialFields {
    fn is_empty(&self) -> bool {
        self.color.is_none()
            && self.opacity.is_none()
            && self.absorption.is_none()
            && self.ior.is_none()
            && self.shading.is_none()
            && self.shininess.is_none()
            && self.blend.is_none()
    }

    fn apply(&self, base: &Material) -> Material {
        Material {
            name: base.name.clone(),
            color: self.color.unwrap_or(base.color),
            opacity: self.opacity.unwrap_or(base.opacity),
            absorption: self.absorption.unwrap_or(base.absorption),
            ior: self.ior.unwrap_or(base.ior),
            shading: self.shading.unwrap_or(base.shading),
            shininess: self.shininess.unwrap_or(base.shininess),
            blend: self.blend.unwrap_or(base.blend),
        }
    }
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct MaterialDef {
    name: String,
    color: Option<[f32; 3]>,
    opacity: Option<f32>,
    absorption: Option<f32>,
    ior: Option<f32>,
    shading: Option<Shading>,
    shininess: Option<f32>,
    blend: Option<Blend>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct ObjectDef {
    mesh: String,
    material: Option<String>,
    color: Option<[f32; 3]>,
    opacity: Option<f32>,
    absorption: Option<f32>,
    ior: Option<f32>,
    shading: Option<Shading>,
    shininess: Option<f32>,
    blend: Option<Blend>,
    translate: Option<[f32; 3]>,
    rotate_deg: Option<[f32; 3]>,
    scale: Option<Value>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct LightDef {
    kind: Option<LightKind>,
    position: Option<[f32; 3]>,
    direction: Option<[f32; 3]>,
    angle_deg: Option<f32>,
    color: Option<[f32; 3]>,
    intensity: Option<f32>,
    range: Option<f32>,
    attenuation: Option<[f32; 3]>,
}

/// Where an element came from, for error messages.
struct Ctx<'a> {
    file: &'a str,
    text: &'a str,
    /// (offset where the element starts, `object 2`), in file order.
    elements: Vec<(usize, String)>,
    /// Offsets of the file's newlines, so a line number costs a binary search (a scene of
    /// 100,000 objects must not count from the start of the file for each one).
    newlines: Vec<usize>,
}

impl Ctx<'_> {
    fn line_of(&self, offset: usize) -> usize {
        let offset = offset.min(self.text.len());
        self.newlines.partition_point(|&n| n < offset) + 1
    }

    /// `line 3, column 11 (opacity = "x")`.
    fn position(&self, offset: usize) -> String {
        let offset = offset.min(self.text.len());
        let line_start = self.text[..offset].rfind('\n').map_or(0, |i| i + 1);
        let line_end = self.text[offset..]
            .find('\n')
            .map_or(self.text.len(), |i| offset + i);
        let column = self.text[line_start..offset].chars().count() + 1;
        let source = self.text[line_start..line_end].trim();
        let source = if source.is_empty() || source.chars().count() > 60 {
            String::new()
        } else {
            format!(" ({source})")
        };
        format!("line {}, column {column}{source}", self.line_of(offset))
    }

    /// `object 2 (line 14)`.
    fn label<T>(&self, kind: &str, index: Option<usize>, spanned: &Spanned<T>) -> String {
        let line = self.line_of(spanned.span().start);
        match index {
            Some(i) => format!("{kind} {} (line {line})", i + 1),
            None => format!("{kind} (line {line})"),
        }
    }

    fn err(&self, label: &str, msg: impl std::fmt::Display) -> Error {
        Error::input(format!(
            "{}: {label}: {}",
            self.file,
            one_line(&msg.to_string())
        ))
    }

    /// A `toml` error as one line: the element it falls in, line, column, message.
    fn toml_err(&self, e: ::toml::de::Error) -> Error {
        let at = match e.span() {
            None => String::new(),
            Some(span) => {
                let element = self
                    .elements
                    .iter()
                    .rev()
                    .find(|(start, _)| *start <= span.start)
                    .map(|(_, name)| format!("{name}: "))
                    .unwrap_or_default();
                format!("{element}{}: ", self.position(span.start))
            }
        };
        Error::input(format!("{}: {at}{}", self.file, one_line(e.message())))
    }
}

fn one_line(s: &str) -> String {
    s.lines()
        .map(str::trim)
        .filter(|l| !l.is_empty())
        .collect::<Vec<_>>()
        .join("; ")
}

fn finite3(v: [f32; 3]) -> bool {
    v.iter().all(|c| c.is_finite())
}

/// Parses scene text; `file` names it in errors, `dir` resolves mesh paths.
pub(crate) fn parse(
    text: &str,
    file: &str,
    dir: &Path,
    warnings: &mut Vec<String>,
) -> Result<Scene> {
    let mut ctx = Ctx {
        file,
        text,
        elements: Vec::new(),
        newlines: text
            .bytes()
            .enumerate()
            .filter(|&(_, b)| b == b'\n')
            .map(|(i, _)| i)
            .collect(),
    };
    // First pass: syntax, top-level keys, and where each element starts.
    let spans: FileDef = ::toml::from_str(text).map_err(|e| ctx.toml_err(e))?;
    let render_label = spans.render.as_ref().map(|t| ctx.label("render", None, t));
    let camera_label = spans.camera.as_ref().map(|t| ctx.label("camera", None, t));
    let labels = |kind: &str, v: &[Spanned<Table>]| -> Vec<String> {
        v.iter()
            .enumerate()
            .map(|(i, t)| ctx.label(kind, Some(i), t))
            .collect()
    };
    let material_labels = labels("material", &spans.material);
    let object_labels = labels("object", &spans.object);
    let light_labels = labels("light", &spans.light);
    let key_labels = labels("camera_key", &spans.camera_key);
    let mut elements: Vec<(usize, String)> = Vec::new();
    for (name, t) in [("render", &spans.render), ("camera", &spans.camera)] {
        if let Some(t) = t {
            elements.push((t.span().start, name.to_string()));
        }
    }
    for (kind, v) in [
        ("material", &spans.material),
        ("object", &spans.object),
        ("light", &spans.light),
        ("camera_key", &spans.camera_key),
    ] {
        for (i, t) in v.iter().enumerate() {
            elements.push((t.span().start, format!("{kind} {}", i + 1)));
        }
    }
    elements.sort_by_key(|(start, _)| *start);
    ctx.elements = elements;
    // Second pass: the typed elements.
    let def: TypedFileDef = ::toml::from_str(text).map_err(|e| ctx.toml_err(e))?;

    let mut scene = Scene::default();

    if let (Some(r), Some(label)) = (def.render, render_label) {
        if let Some([w, h]) = r.size {
            let side = 1..=crate::scene::MAX_SIDE;
            if !side.contains(&w) || !side.contains(&h) {
                return Err(ctx.err(
                    &label,
                    format!(
                        "size [{w}, {h}] must be 1..{} per side",
                        crate::scene::MAX_SIDE
                    ),
                ));
            }
        }
        let background = r
            .background
            .map(|b| b.parse::<Background>())
            .transpose()
            .map_err(|e| ctx.err(&label, e))?;
        scene.defaults = RenderDefaults {
            size: r.size,
            background,
            shading: r.shading,
            pipeline: r.pipeline,
        };
    }

    if let (Some(c), Some(label)) = (def.camera, camera_label) {
        scene.camera = Some(camera(c).map_err(|msg| ctx.err(&label, msg))?);
    }

    let mut named: HashMap<String, usize> = HashMap::new();
    for (m, label) in def.material.into_iter().zip(material_labels) {
        if named.contains_key(&m.name) {
            return Err(ctx.err(
                &label,
                format!(
                    "material '{}' is defined twice",
                    crate::error::quoted(&m.name)
                ),
            ));
        }
        let base = Material {
            name: m.name.clone(),
            ..Material::default()
        };
        let fields = MaterialFields {
            color: m.color,
            opacity: m.opacity,
            absorption: m.absorption,
            ior: m.ior,
            shading: m.shading,
            shininess: m.shininess,
            blend: m.blend,
        };
        let material = fields.apply(&base);
        check_material(&material).map_err(|msg| ctx.err(&label, msg))?;
        named.insert(m.name, scene.add_material(material));
    }

    let mut models: HashMap<PathBuf, Vec<Part>> = HashMap::new();
    let mut triangles = 0u64;
    for (i, (o, label)) in def.object.into_iter().zip(object_labels).enumerate() {
        let err = |msg: String| ctx.err(&label, msg);

        let parts: Vec<Part> = if let Some(spec) = o.mesh.strip_prefix("builtin:") {
            let mesh = builtin::primitive(spec).map_err(|e| err(e.to_string()))?;
            let name = spec.split('?').next().unwrap_or(spec).to_string();
            vec![(name, mesh, None)]
        } else {
            let p = dir.join(&o.mesh);
            if !models.contains_key(&p) {
                let loaded = super::load_model_with_warnings(&p, warnings)
                    .map_err(|e| err(e.to_string()))?;
                models.insert(p.clone(), loaded);
            }
            models[&p].clone()
        };

        let inline = MaterialFields {
            color: o.color,
            opacity: o.opacity,
            absorption: o.absorption,
            ior: o.ior,
            shading: o.shading,
            shininess: o.shininess,
            blend: o.blend,
        };
        let base_named = match &o.material {
            None => None,
            Some(name) => Some(*named.get(name).ok_or_else(|| {
                err(format!("unknown material '{}'", crate::error::quoted(name)))
            })?),
        };
        let transform = transform(&o).map_err(err)?;
        let flip = transform.determinant() < 0.0;
        triangles += parts
            .iter()
            .map(|(_, m, _)| m.triangle_count() as u64)
            .sum::<u64>();
        crate::scene::check_triangle_estimate("the scene up to here", triangles)
            .map_err(|e| err(e.to_string()))?;

        for (part_name, mesh, part_material) in parts {
            let material = match (base_named, inline.is_empty()) {
                (Some(m), true) => m,
                (base, _) => {
                    let base = match base {
                        Some(m) => scene.materials[m].clone(),
                        None => part_material.unwrap_or_default(),
                    };
                    let mut m = inline.apply(&base);
                    if !inline.is_empty() {
                        m.name = if base.name == Material::default().name {
                            format!("object {}", i + 1)
                        } else {
                            format!("{} (object {})", base.name, i + 1)
                        };
                    }
                    check_material(&m).map_err(err)?;
                    intern_material(&mut scene, m)
                }
            };
            let mut mesh = mesh.transformed(transform);
            if flip {
                for t in mesh.indices.chunks_exact_mut(3) {
                    t.swap(1, 2);
                }
            }
            scene.objects.push(Object {
                name: part_name,
                mesh,
                material,
            });
        }
    }

    for (l, label) in def.light.into_iter().zip(light_labels) {
        scene
            .lights
            .push(light(l).map_err(|msg| ctx.err(&label, msg))?);
    }

    if scene.objects.is_empty() {
        return Err(Error::input(format!("{file}: no [[object]] in the scene")));
    }
    if !def.camera_key.is_empty() {
        let base = scene.camera_or_framing();
        let keys: Vec<CameraKey> = def
            .camera_key
            .iter()
            .map(|k| CameraKey {
                time: k.time,
                eye: Vec3::from(k.eye),
                target: Vec3::from(k.target),
            })
            .collect();
        for (i, label) in key_labels.iter().enumerate() {
            check_key(&base, &keys, i).map_err(|why| ctx.err(label, why))?;
        }
        scene.camera_path = Some(CameraPath::keys(base, keys)?);
        scene.set_time(0.0);
    }
    Ok(scene)
}

pub(super) fn camera(c: CameraDef) -> std::result::Result<Camera, String> {
    if !(finite3(c.eye) && finite3(c.target) && finite3(c.up)) {
        return Err("eye, target and up must be finite".into());
    }
    let (eye, target, up) = (Vec3::from(c.eye), Vec3::from(c.target), Vec3::from(c.up));
    if (target - eye).length() < 1e-6 {
        return Err("eye and target are the same point".into());
    }
    if (target - eye).normalize().cross(up).length() < 1e-6 {
        return Err("up is parallel to the view direction (or zero)".into());
    }
    if !(c.near > 0.0 && c.far > c.near && c.far.is_finite()) {
        return Err(format!(
            "near {} and far {} must satisfy 0 < near < far",
            c.near, c.far
        ));
    }
    let projection = match c.projection {
        ProjectionKind::Perspective => {
            if !(c.fov_y_deg > 0.0 && c.fov_y_deg < 180.0) {
                return Err(format!("fov_y_deg {} must be in (0, 180)", c.fov_y_deg));
            }
            Projection::Perspective {
                fov_y_deg: c.fov_y_deg,
            }
        }
        ProjectionKind::Orthographic => {
            if !(c.height > 0.0 && c.height.is_finite()) {
                return Err(format!("height {} must be positive", c.height));
            }
            Projection::Orthographic { height: c.height }
        }
    };
    Ok(Camera {
        eye,
        target,
        up,
        projection,
        near: c.near,
        far: c.far,
    })
}

pub(super) fn check_material(m: &Material) -> std::result::Result<(), String> {
    if !m.color.iter().all(|c| c.is_finite() && *c >= 0.0) {
        return Err(format!(
            "color {:?} must be finite and non-negative",
            m.color
        ));
    }
    if !(0.0..=1.0).contains(&m.opacity) {
        return Err(format!("opacity {} is outside [0, 1]", m.opacity));
    }
    if !(m.absorption.is_finite() && m.absorption >= 0.0) {
        return Err(format!("absorption {} must be ≥ 0", m.absorption));
    }
    if !(m.ior.is_finite() && m.ior >= 1.0) {
        return Err(format!("ior {} must be ≥ 1", m.ior));
    }
    if !(m.shininess.is_finite() && m.shininess > 0.0) {
        return Err(format!("shininess {} must be positive", m.shininess));
    }
    Ok(())
}

fn transform(o: &ObjectDef) -> std::result::Result<Mat4, String> {
    let scale = match &o.scale {
        None => Vec3::ONE,
        Some(v) => {
            let num = |v: &Value| v.as_float().or_else(|| v.as_integer().map(|i| i as f64));
            match v {
                Value::Array(a) if a.len() == 3 => {
                    let c: Vec<f64> = a.iter().filter_map(num).collect();
                    if c.len() != 3 {
                        return Err("scale must be a number or [sx, sy, sz]".into());
                    }
                    Vec3::new(c[0] as f32, c[1] as f32, c[2] as f32)
                }
                v => Vec3::splat(num(v).ok_or("scale must be a number or [sx, sy, sz]")? as f32),
            }
        }
    };
    if !scale.is_finite() || scale.x == 0.0 || scale.y == 0.0 || scale.z == 0.0 {
        return Err(format!(
            "scale {:?} must be finite and non-zero",
            scale.to_array()
        ));
    }
    let t = o.translate.unwrap_or([0.0; 3]);
    let r = o.rotate_deg.unwrap_or([0.0; 3]);
    if !finite3(t) || !finite3(r) {
        return Err("translate and rotate_deg must be finite".into());
    }
    Ok(Mat4::from_translation(Vec3::from(t))
        * Mat4::from_rotation_z(r[2].to_radians())
        * Mat4::from_rotation_y(r[1].to_radians())
        * Mat4::from_rotation_x(r[0].to_radians())
        * Mat4::from_scale(scale))
}

pub(super) fn light(l: LightDef) -> std::result::Result<Light, String> {
    let d = Light::default();
    let kind = l.kind.unwrap_or(d.kind);
    let position = l.position.unwrap_or(d.position.to_array());
    let direction = l.direction.unwrap_or(d.direction.to_array());
    let color = l.color.unwrap_or(d.color);
    let (angle_deg, intensity, range) = (
        l.angle_deg.unwrap_or(d.angle_deg),
        l.intensity.unwrap_or(d.intensity),
        l.range.unwrap_or(d.range),
    );
    if !(finite3(position) && finite3(direction)) {
        return Err("position and direction must be finite".into());
    }
    if !color.iter().all(|c| c.is_finite() && *c >= 0.0) {
        return Err(format!("color {color:?} must be finite and non-negative"));
    }
    if !(intensity.is_finite() && intensity >= 0.0) {
        return Err(format!("intensity {intensity} must be ≥ 0"));
    }
    if !(range.is_finite() && range > 0.0) {
        return Err(format!("range {range} must be positive"));
    }
    if !(angle_deg > 0.0 && angle_deg < 180.0) {
        return Err(format!("angle_deg {angle_deg} must be in (0, 180)"));
    }
    let attenuation = l.attenuation.unwrap_or(d.attenuation);
    let [a, b, c] = attenuation;
    if !(finite3(attenuation) && a > 0.0 && b >= 0.0 && c >= 0.0) {
        return Err(format!(
            "attenuation {attenuation:?} must be [a, b, c] with a > 0 and b, c ≥ 0 (1 / (a + b·d + c·d²))"
        ));
    }
    // A direction already of unit length (to float precision) is kept bit for bit, so that a
    // scene written out and read back (glTF extras) lights the same.
    let direction = Vec3::from(direction);
    let direction = if (direction.length_squared() - 1.0).abs() < 1e-6 {
        Some(direction)
    } else {
        direction.try_normalize()
    };
    let direction = match kind {
        LightKind::Spot | LightKind::Directional => {
            direction.ok_or("direction must be non-zero")?
        }
        _ => direction.unwrap_or(d.direction),
    };
    Ok(Light {
        kind,
        position: Vec3::from(position),
        direction,
        angle_deg,
        color,
        intensity,
        range,
        attenuation,
    })
}
