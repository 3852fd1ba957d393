//! A scene as glTF 2.0 (`strata export`), so that other renderers draw exactly strata's scene.
//!
//! What a glTF reader sees: one node and mesh per object (world-space positions, normals and
//! 32-bit indices in one binary buffer, the objects in scene order, so primitive order survives),
//! one material per scene material (`baseColorFactor` = linear color and opacity, `alphaMode`
//! BLEND below opacity 1, else OPAQUE; double-sided, metallic 0, roughness 1;
//! `KHR_materials_unlit` for unlit shading, `KHR_materials_ior` for the index of refraction),
//! the camera as a camera node, and the point, spot and directional lights through
//! `KHR_lights_punctual` (strata's intensities are unitless: they are written as they are).
//!
//! What only strata reads back: the `extras.strata` of the scene (`camera`, `light`, `render`,
//! with the fields and meaning of the TOML scene file's `[camera]`, `[[light]]` and `[render]`)
//! and of each material (`absorption`, `ior`, `shading`, `shininess`, `blend`). They carry what
//! glTF has no field for (ambient lights, attenuation, the translucency effect's absorption, the
//! picture defaults, blend modes other than over) and the exact camera, so the file reloads to
//! the same picture. glTF blends every transparent material over (`alphaMode` BLEND): another
//! reader draws add and multiply materials over, and [`unexported`] says so.
//!
//! Animation is not exported: moving objects are written where they are at the scene's time.

use glam::{Quat, Vec3};
use serde_json::{json, Value};

use crate::error::{Error, Result};
use crate::scene::{Background, Blend, Camera, LightKind, Mesh, Projection, Scene, Shading};

/// What of `scene` a glTF reader other than strata cannot see, one line each: the materials
/// that blend other than over, which glTF has no mode for (they travel in strata's extras).
pub fn unexported(scene: &Scene) -> Vec<String> {
    scene
        .materials
        .iter()
        .filter(|m| m.blend != Blend::Over)
        .map(|m| {
            format!(
                "material '{}' blends '{}', which glTF cannot express: other readers draw it over (alphaMode BLEND); strata reads it back from extras.strata",
                m.name,
                m.blend.name()
            )
        })
        .collect()
}

/// The container: binary `.glb`, or `.gltf` JSON with the buffer as a base64 `data:` URI.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum GltfContainer {
    /// A binary `.glb` file.
    Glb,
    /// A `.gltf` JSON file with the buffer inside as a base64 `data:` URI.
    Embedded,
}

impl GltfContainer {
    /// From an output path's extension (`.glb` or `.gltf`).
    pub fn for_path(path: &std::path::Path) -> Result<GltfContainer> {
        let ext = path
            .extension()
            .and_then(|e| e.to_str())
            .map(str::to_ascii_lowercase);
        match ext.as_deref() {
            Some("glb") => Ok(GltfContainer::Glb),
            Some("gltf") => Ok(GltfContainer::Embedded),
            _ => Err(Error::input(format!(
                "'{}': the export's file name must end in .glb or .gltf",
                path.display()
            ))),
        }
    }
}

/// The picture defaults written into the file (what `render` would otherwise take from options).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ExportDefaults {
    /// Picture size in pixels.
    pub size: Option<[u32; 2]>,
    /// The background.
    pub background: Option<Background>,
}

/// Encodes `scene` (camera: its own or the framing one) as glTF 2.0 bytes.
pub fn to_gltf(
    scene: &Scene,
    defaults: &ExportDefaults,
    container: GltfContainer,
) -> Result<Vec<u8>> {
    scene.validate()?;
    let mut bin: Vec<u8> = Vec::new();
    let mut buffer_views: Vec<Value> = Vec::new();
    let mut accessors: Vec<Value> = Vec::new();
    let mut view = |bin: &mut Vec<u8>, bytes: &[u8], target: u32| -> usize {
        let offset = bin.len();
        bin.extend_from_slice(bytes);
        buffer_views.push(json!({
            "buffer": 0, "byteOffset": offset, "byteLength": bytes.len(), "target": target
        }));
        buffer_views.len() - 1
    };
    const ARRAY_BUFFER: u32 = 34962;
    const ELEMENT_ARRAY_BUFFER: u32 = 34963;
    const FLOAT: u32 = 5126;
    const UNSIGNED_INT: u32 = 5125;

    let mut meshes = Vec::new();
    let mut nodes = Vec::new();
    for object in &scene.objects {
        let mesh = with_vertex_normals(&object.mesh);
        let (lo, hi) = mesh.bounds();
        let positions = view(
            &mut bin,
            bytemuck::cast_slice(&mesh.positions),
            ARRAY_BUFFER,
        );
        accessors.push(json!({
            "bufferView": positions, "componentType": FLOAT, "count": mesh.positions.len(),
            "type": "VEC3", "min": lo.to_array(), "max": hi.to_array()
        }));
        let normals = view(&mut bin, bytemuck::cast_slice(&mesh.normals), ARRAY_BUFFER);
        accessors.push(json!({
            "bufferView": normals, "componentType": FLOAT, "count": mesh.normals.len(),
            "type": "VEC3"
        }));
        let indices = view(
            &mut bin,
            bytemuck::cast_slice(&mesh.indices),
            ELEMENT_ARRAY_BUFFER,
        );
        accessors.push(json!({
            "bufferView": indices, "componentType": UNSIGNED_INT, "count": mesh.indices.len(),
            "type": "SCALAR"
        }));
        let a = accessors.len();
        meshes.push(json!({
            "name": object.name,
            "primitives": [{
                "attributes": { "POSITION": a - 3, "NORMAL": a - 2 },
                "indices": a - 1,
                "material": object.material,
                "mode": 4
            }]
        }));
        nodes.push(json!({ "name": object.name, "mesh": meshes.len() - 1 }));
    }

    let materials: Vec<Value> = scene
        .materials
        .iter()
        .map(|m| {
            let [r, g, b] = m.color;
            let mut extensions = serde_json::Map::new();
            if m.shading == Shading::Unlit {
                extensions.insert("KHR_materials_unlit".into(), json!({}));
            }
            extensions.insert("KHR_materials_ior".into(), json!({ "ior": m.ior }));
            json!({
                "name": m.name,
                "pbrMetallicRoughness": {
                    "baseColorFactor": [r, g, b, m.opacity],
                    "metallicFactor": 0.0,
                    "roughnessFactor": 1.0
                },
                "alphaMode": if m.opacity < 1.0 { "BLEND" } else { "OPAQUE" },
                "doubleSided": true,
                "extensions": extensions,
                "extras": { "strata": {
                    "absorption": m.absorption,
                    "ior": m.ior,
                    "shading": m.shading,
                    "shininess": m.shininess,
                    "blend": m.blend.name()
                }}
            })
        })
        .collect();

    let (width, height) = match defaults.size.or(scene.defaults.size) {
        Some([w, h]) => (w, h),
        None => (512, 512),
    };
    let aspect = width as f32 / height.max(1) as f32;
    let camera = scene.camera_or_framing();
    nodes.push(json!({
        "name": "camera",
        "camera": 0,
        "matrix": camera.view().inverse().to_cols_array()
    }));
    let gltf_camera = match camera.projection {
        Projection::Perspective { fov_y_deg } => json!({
            "type": "perspective",
            "perspective": {
                "yfov": fov_y_deg.to_radians(), "aspectRatio": aspect,
                "znear": camera.near, "zfar": camera.far
            }
        }),
        Projection::Orthographic { height } => json!({
            "type": "orthographic",
            "orthographic": {
                "xmag": height * 0.5 * aspect, "ymag": height * 0.5,
                "znear": camera.near, "zfar": camera.far
            }
        }),
    };

    let mut punctual = Vec::new();
    for light in &scene.lights {
        let description = match light.kind {
            LightKind::Ambient => continue,
            LightKind::Point => json!({ "type": "point", "range": light.range }),
            LightKind::Spot => json!({
                "type": "spot", "range": light.range,
                "spot": { "innerConeAngle": 0.0, "outerConeAngle": light.angle_deg.to_radians().min(std::f32::consts::FRAC_PI_2) }
            }),
            LightKind::Directional => json!({ "type": "directional" }),
        };
        let mut description = description;
        description["color"] = json!(light.color);
        description["intensity"] = json!(light.intensity);
        punctual.push(description);
        let rotation =
            Quat::from_rotation_arc(Vec3::NEG_Z, light.direction.normalize_or(Vec3::NEG_Z));
        nodes.push(json!({
            "name": format!("light {}", punctual.len()),
            "translation": light.position.to_array(),
            "rotation": rotation.to_array(),
            "extensions": { "KHR_lights_punctual": { "light": punctual.len() - 1 } }
        }));
    }

    let mut render = serde_json::Map::new();
    if let Some(size) = defaults.size.or(scene.defaults.size) {
        render.insert("size".into(), json!(size));
    }
    if let Some(bg) = defaults.background.or(scene.defaults.background) {
        render.insert("background".into(), json!(background_name(bg)));
    }
    if let Some(s) = scene.defaults.shading {
        render.insert("shading".into(), json!(s));
    }
    if let Some(p) = scene.defaults.pipeline {
        render.insert("pipeline".into(), json!(p));
    }
    let strata = json!({
        "camera": camera_fields(&camera),
        "light": scene.lights.iter().map(|l| json!({
            "kind": l.kind,
            "position": l.position.to_array(),
            "direction": l.direction.to_array(),
            "angle_deg": l.angle_deg,
            "color": l.color,
            "intensity": l.intensity,
            "range": l.range,
            "attenuation": l.attenuation
        })).collect::<Vec<_>>(),
        "render": render,
    });

    let mut extensions_used = vec!["KHR_materials_ior"];
    if scene.materials.iter().any(|m| m.shading == Shading::Unlit) {
        extensions_used.push("KHR_materials_unlit");
    }
    let mut root = json!({
        "asset": { "version": "2.0", "generator": concat!("strata ", env!("CARGO_PKG_VERSION")) },
        "extensionsUsed": extensions_used,
        "scene": 0,
        "scenes": [{ "name": "strata", "nodes": (0..nodes.len()).collect::<Vec<_>>(), "extras": { "strata": strata } }],
        "nodes": nodes,
        "meshes": meshes,
        "materials": materials,
        "cameras": [gltf_camera],
        "accessors": accessors,
        "bufferViews": buffer_views,
        "buffers": [{ "byteLength": bin.len() }],
    });
    if !punctual.is_empty() {
        root["extensionsUsed"]
            .as_array_mut()
            .expect("an array")
            .push(json!("KHR_lights_punctual"));
        root["extensions"] = json!({ "KHR_lights_punctual": { "lights": punctual } });
    }
    Ok(match container {
        GltfContainer::Embedded => {
            root["buffers"][0]["uri"] = json!(format!(
                "data:application/octet-stream;base64,{}",
                base64::encode(&bin)
            ));
            let mut text = serde_json::to_vec_pretty(&root).map_err(encode_err)?;
            text.push(b'\n');
            text
        }
        GltfContainer::Glb => glb(&root, bin)?,
    })
}

fn encode_err(e: serde_json::Error) -> Error {
    Error::runtime(format!("cannot encode the glTF JSON: {e}"))
}

/// The GLB container: header, JSON chunk padded with spaces, BIN chunk padded with zeros.
fn glb(root: &Value, mut bin: Vec<u8>) -> Result<Vec<u8>> {
    let mut text = serde_json::to_vec(root).map_err(encode_err)?;
    text.resize(text.len().next_multiple_of(4), b' ');
    bin.resize(bin.len().next_multiple_of(4), 0);
    let total = 12 + 8 + text.len() + 8 + bin.len();
    let total = u32::try_from(total).map_err(|_| {
        Error::input(format!(
            "the scene needs a {total}-byte GLB, more than the format's 4 GiB: export it as .gltf"
        ))
    })?;
    let mut out = Vec::with_capacity(total as usize);
    out.extend_from_slice(b"glTF");
    out.extend_from_slice(&2u32.to_le_bytes());
    out.extend_from_slice(&total.to_le_bytes());
    out.extend_from_slice(&(text.len() as u32).to_le_bytes());
    out.extend_from_slice(b"JSON");
    out.extend_from_slice(&text);
    out.extend_from_slice(&(bin.len() as u32).to_le_bytes());
    out.extend_from_slice(b"BIN\0");
    out.extend_from_slice(&bin);
    Ok(out)
}

/// `mesh` with one normal per vertex: its own, or (when it has none) each triangle's face normal
/// on three vertices of its own — what [`Scene::triangles`] draws either way.
fn with_vertex_normals(mesh: &Mesh) -> std::borrow::Cow<'_, Mesh> {
    if mesh.normals.len() == mesh.positions.len() {
        return std::borrow::Cow::Borrowed(mesh);
    }
    let list = Scene {
        objects: vec![crate::scene::Object {
            name: String::new(),
            mesh: mesh.clone(),
            material: 0,
        }],
        ..Scene::default()
    }
    .triangles();
    std::borrow::Cow::Owned(Mesh {
        positions: list.vertices.iter().map(|v| v.position).collect(),
        normals: list.vertices.iter().map(|v| v.normal).collect(),
        indices: (0..list.vertices.len() as u32).collect(),
    })
}

/// The camera as the fields of a TOML scene file's `[camera]`.
fn camera_fields(c: &Camera) -> Value {
    let mut v = json!({
        "eye": c.eye.to_array(),
        "target": c.target.to_array(),
        "up": c.up.to_array(),
        "near": c.near,
        "far": c.far,
    });
    match c.projection {
        Projection::Perspective { fov_y_deg } => {
            v["projection"] = json!("perspective");
            v["fov_y_deg"] = json!(fov_y_deg);
        }
        Projection::Orthographic { height } => {
            v["projection"] = json!("orthographic");
            v["height"] = json!(height);
        }
    }
    v
}

/// `checker`, or the color as `#rrggbb` when that spelling gives it back exactly, else as linear
/// `[r, g, b]`.
fn background_name(bg: Background) -> Value {
    match bg {
        Background::Checker => json!("checker"),
        Background::Color(c) => {
            let hex = c.map(|x| (crate::scene::linear_to_srgb(x) * 255.0).round() as u32);
            let name = format!("#{:02x}{:02x}{:02x}", hex[0], hex[1], hex[2]);
            match name.parse::<Background>() {
                Ok(Background::Color(back)) if back == c => json!(name),
                _ => json!(c),
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::loaders::load_scene;
    use crate::scene::{Light, Material, Object};
    use glam::Vec3;

    fn scratch(name: &str) -> std::path::PathBuf {
        let dir = std::env::temp_dir().join(format!("strata-export-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        dir.join(name)
    }

    fn fixture(name: &str) -> String {
        format!("{}/tests/fixtures/{name}", env!("CARGO_MANIFEST_DIR"))
    }

    /// Writes `scene` in `container` and loads it back.
    fn round_trip(scene: &Scene, defaults: &ExportDefaults, container: GltfContainer) -> Scene {
        let name = match container {
            GltfContainer::Glb => "scene.glb",
            GltfContainer::Embedded => "scene.gltf",
        };
        let path = scratch(name);
        std::fs::write(&path, to_gltf(scene, defaults, container).unwrap()).unwrap();
        load_scene(path.to_str().unwrap()).unwrap()
    }

    /// What the picture depends on: each triangle's corners, normals and material, the camera,
    /// the lights and the picture defaults.
    fn assert_same_picture(a: &Scene, b: &Scene) {
        let (ta, tb) = (a.triangles(), b.triangles());
        assert_eq!(ta.vertices, tb.vertices);
        let material = |s: &Scene, t: &crate::scene::TriangleList, i: usize| {
            let mut m = s.materials[t.materials[i] as usize].clone();
            m.name.clear();
            m
        };
        for i in 0..ta.materials.len() {
            assert_eq!(material(a, &ta, i), material(b, &tb, i), "triangle {i}");
        }
        assert_eq!(a.camera_or_framing(), b.camera_or_framing());
        assert_eq!(a.lights, b.lights);
        assert_eq!(a.defaults, b.defaults);
    }

    #[test]
    fn every_field_of_a_scene_file_survives_both_containers() {
        let scene = load_scene(&fixture("scene.toml")).unwrap();
        for container in [GltfContainer::Glb, GltfContainer::Embedded] {
            let back = round_trip(&scene, &ExportDefaults::default(), container);
            assert_same_picture(&scene, &back);
            assert_eq!(
                back.objects.iter().map(|o| &o.name).collect::<Vec<_>>(),
                scene.objects.iter().map(|o| &o.name).collect::<Vec<_>>()
            );
        }
    }

    fn hand_made() -> Scene {
        // No normals (flat-shaded when drawn), an orthographic camera, an ambient light, an
        // unlit material, a background that no #rrggbb spells.
        let mesh = Mesh {
            positions: vec![
                [0.0, 0.0, 0.0],
                [1.0, 0.0, 0.0],
                [0.0, 1.0, 0.3],
                [1.0, 1.0, -0.2],
            ],
            normals: Vec::new(),
            indices: vec![0, 1, 2, 2, 1, 3],
        };
        let mut scene = Scene::default();
        let m = scene.add_material(Material {
            name: "flat".into(),
            color: [0.3, 0.6, 0.9],
            opacity: 0.35,
            absorption: 0.7,
            ior: 1.33,
            shading: Shading::Unlit,
            shininess: 12.0,
            blend: Blend::Multiply,
        });
        scene.objects.push(Object {
            name: "sheet".into(),
            mesh,
            material: m,
        });
        scene.camera = Some(Camera {
            eye: Vec3::new(0.5, 0.5, 4.0),
            target: Vec3::new(0.5, 0.4, 0.0),
            up: Vec3::Y,
            projection: Projection::Orthographic { height: 1.7 },
            near: 0.25,
            far: 9.0,
        });
        scene.lights = vec![
            Light {
                kind: LightKind::Ambient,
                color: [0.2, 0.1, 0.05],
                ..Light::default()
            },
            Light {
                kind: LightKind::Spot,
                direction: Vec3::new(0.0, -0.6, -0.8),
                angle_deg: 20.0,
                attenuation: [1.0, 0.5, 0.25],
                ..Light::default()
            },
        ];
        scene.defaults.pipeline = Some(crate::deferred::Pipeline::Forward);
        scene
    }

    #[test]
    fn what_gltf_has_no_field_for_survives_in_the_extras() {
        let scene = hand_made();
        let defaults = ExportDefaults {
            size: Some([96, 64]),
            background: Some(Background::Color([0.123, 0.456, 0.789])),
        };
        let back = round_trip(&scene, &defaults, GltfContainer::Glb);
        let mut expected = scene.clone();
        expected.defaults.size = defaults.size;
        expected.defaults.background = defaults.background;
        assert_same_picture(&expected, &back);
        assert_eq!(
            back.materials[back.objects[0].material].blend,
            Blend::Multiply
        );
        let lost = unexported(&scene);
        assert_eq!(lost.len(), 1);
        assert!(
            lost[0].contains("material 'flat' blends 'multiply'"),
            "{lost:?}"
        );
    }

    #[test]
    fn without_strata_extras_the_standard_fields_give_camera_lights_and_materials() {
        let scene = hand_made();
        let text = to_gltf(&scene, &ExportDefaults::default(), GltfContainer::Embedded).unwrap();
        let mut root: Value = serde_json::from_slice(&text).unwrap();
        root["scenes"][0].as_object_mut().unwrap().remove("extras");
        root["materials"][0]
            .as_object_mut()
            .unwrap()
            .remove("extras");
        let path = scratch("plain.gltf");
        std::fs::write(&path, serde_json::to_vec(&root).unwrap()).unwrap();
        let back = load_scene(path.to_str().unwrap()).unwrap();

        let (c, b) = (scene.camera.unwrap(), back.camera.unwrap());
        assert!(c.eye.distance(b.eye) < 1e-5, "{:?} {:?}", c.eye, b.eye);
        let forward = |c: &Camera| (c.target - c.eye).normalize();
        assert!(forward(&c).dot(forward(&b)) > 1.0 - 1e-6);
        assert!(c.up.normalize().dot(b.up.normalize()) > 0.99);
        assert_eq!((b.near, b.far), (c.near, c.far));
        let Projection::Orthographic { height } = b.projection else {
            panic!("{:?}", b.projection)
        };
        assert!((height - 1.7).abs() < 1e-6);

        // The ambient light has no glTF form; the spot keeps its cone and direction.
        assert_eq!(back.lights.len(), 1);
        let spot = back.lights[0];
        assert_eq!(spot.kind, LightKind::Spot);
        assert!((spot.angle_deg - 20.0).abs() < 1e-4);
        assert!(spot.direction.dot(Vec3::new(0.0, -0.6, -0.8)) > 1.0 - 1e-5);
        assert!(spot.position.distance(Light::default().position) < 1e-5);

        let m = &back.materials[back.objects[0].material];
        assert_eq!(m.shading, Shading::Unlit);
        assert_eq!(m.ior, 1.33);
        assert_eq!((m.color, m.opacity), ([0.3, 0.6, 0.9], 0.35));
        assert_eq!(m.absorption, Material::default().absorption);
        // glTF has no multiply: without the extras it is over.
        assert_eq!(m.blend, Blend::Over);
    }

    #[test]
    fn bad_strata_extras_are_one_line_errors_naming_the_field() {
        let text = to_gltf(
            &hand_made(),
            &ExportDefaults::default(),
            GltfContainer::Embedded,
        )
        .unwrap();
        /// A file name, an edit of the exported JSON, and what the error must say.
        type Case = (&'static str, fn(&mut Value), &'static str);
        let cases: [Case; 3] = [
            (
                "near_far.gltf",
                |r| r["scenes"][0]["extras"]["strata"]["camera"]["near"] = json!(20.0),
                "scene extras.strata.camera: near 20 and far 9 must satisfy 0 < near < far",
            ),
            (
                "unknown.gltf",
                |r| r["scenes"][0]["extras"]["strata"]["colour"] = json!(1),
                "unknown field `colour`",
            ),
            (
                "ior.gltf",
                |r| r["materials"][0]["extras"]["strata"]["ior"] = json!(0.5),
                "material 'flat': ior 0.5 must be ≥ 1",
            ),
        ];
        for (name, edit, expected) in cases {
            let mut root: Value = serde_json::from_slice(&text).unwrap();
            edit(&mut root);
            let path = scratch(name);
            std::fs::write(&path, serde_json::to_vec(&root).unwrap()).unwrap();
            let e = load_scene(path.to_str().unwrap()).unwrap_err().to_string();
            assert!(e.contains(expected), "{e}");
            assert!(!e.contains('\n'), "{e}");
        }
    }

    #[test]
    fn the_container_follows_the_file_name() {
        use std::path::Path;
        assert_eq!(
            GltfContainer::for_path(Path::new("a.GLB")).unwrap(),
            GltfContainer::Glb
        );
        assert_eq!(
            GltfContainer::for_path(Path::new("a.gltf")).unwrap(),
            GltfContainer::Embedded
        );
        let e = GltfContainer::for_path(Path::new("a.png")).unwrap_err();
        assert!(e.to_string().contains("must end in .glb or .gltf"), "{e}");
    }
}
