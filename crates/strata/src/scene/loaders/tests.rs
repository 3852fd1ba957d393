//! Loader tests over the small files in `tests/fixtures/` (binary ones come from
//! `tests/fixtures/make_binary_fixtures.py`).

use std::path::{Path, PathBuf};

use glam::Vec3;

use super::*;
use crate::scene::builtin::primitives::tests::signed_volume;
use crate::scene::{Background, LightKind, Projection, Shading};

fn fixture(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/fixtures")
        .join(name)
}

fn spec(name: &str) -> String {
    fixture(name).display().to_string()
}

fn model(name: &str) -> (Vec<Part>, Vec<String>) {
    let mut w = Vec::new();
    let parts =
        load_model_with_warnings(&fixture(name), &mut w).unwrap_or_else(|e| panic!("{name}: {e}"));
    (parts, w)
}

/// The error of loading `name` as a scene; asserts it is one line naming the file.
fn scene_error(name: &str) -> String {
    let e = load_scene(&spec(name)).unwrap_err().to_string();
    assert!(e.contains(name), "error does not name the file: {e}");
    assert!(!e.contains('\n'), "error is not one line: {e:?}");
    e
}

/// [`scene_error`], which says each of `says`.
fn assert_scene_error(name: &str, says: &[&str]) {
    let e = scene_error(name);
    for said in says {
        assert!(e.contains(said), "{e}");
    }
}

fn approx3(a: [f32; 3], b: [f32; 3]) -> bool {
    a.iter().zip(b).all(|(x, y)| (x - y).abs() < 1e-5)
}

// --- OBJ ---------------------------------------------------------------------------------------

#[test]
fn obj_with_missing_mtl_loads_with_a_warning() {
    let (parts, warnings) = model("cube_missing_mtl.obj");
    assert_eq!(parts.len(), 1);
    let (name, mesh, material) = &parts[0];
    assert_eq!(name, "cube");
    assert!(material.is_none());
    assert_eq!(mesh.triangle_count(), 12);
    assert_eq!(mesh.normals.len(), mesh.positions.len(), "normals computed");
    assert!((signed_volume(mesh) - 8.0).abs() < 1e-4);
    assert_eq!(warnings.len(), 1, "{warnings:?}");
    assert!(
        warnings[0].contains("cube_missing_mtl.obj") && warnings[0].contains("missing.mtl"),
        "{warnings:?}"
    );
    assert!(!warnings[0].contains('\n'));

    let scene = load_scene(&spec("cube_missing_mtl.obj")).unwrap();
    assert!(scene.camera.is_none());
    assert_eq!(scene.materials, vec![Material::default()]);
}

#[test]
fn obj_with_mtl_uses_kd_and_d_or_tr() {
    let (parts, warnings) = model("two_materials.obj");
    assert!(warnings.is_empty(), "{warnings:?}");
    assert_eq!(parts.len(), 2);
    let (name, mesh, red) = &parts[0];
    assert_eq!(name, "red_part");
    let red = red.as_ref().unwrap();
    assert_eq!(red.name, "red");
    assert_eq!(red.color, [0.9, 0.1, 0.1]);
    assert_eq!(red.opacity, 0.25);
    assert!(
        mesh.normals.iter().all(|n| *n == [0.0, 0.0, 1.0]),
        "file normals kept"
    );
    let blue = parts[1].2.as_ref().unwrap();
    assert_eq!(blue.color, [0.1, 0.2, 0.9]);
    assert!((blue.opacity - 0.3).abs() < 1e-6, "Tr 0.7 → opacity 0.3");

    let scene = load_scene(&spec("two_materials.obj")).unwrap();
    assert_eq!(scene.objects.len(), 2);
    assert_eq!(scene.materials.len(), 2);
    assert_eq!(scene.objects[1].material, 1);
}

#[test]
fn malformed_obj_is_a_one_line_error() {
    assert_scene_error("malformed.obj", &["line 3", "position parse error"]);
}

#[test]
fn obj_with_nan_is_rejected() {
    assert_scene_error("nan.obj", &["non-finite"]);
}

#[test]
fn obj_with_out_of_range_index_is_rejected() {
    assert_scene_error("out_of_range.obj", &["line 5", "index 9 is out of range"]);
}

#[test]
fn obj_face_with_two_vertices_is_skipped_with_a_warning() {
    let (parts, warnings) = model("two_vertex_face.obj");
    let triangles: usize = parts.iter().map(|p| p.1.triangle_count()).sum();
    assert_eq!(triangles, 1, "the good face stays");
    assert_eq!(warnings.len(), 1, "{warnings:?}");
    assert!(
        warnings[0].contains("skipped 1 face(s)") && warnings[0].contains("line 5"),
        "{warnings:?}"
    );
}

#[test]
fn obj_without_faces_is_rejected() {
    assert_scene_error("empty.obj", &["no triangles"]);
}

// --- PLY ---------------------------------------------------------------------------------------

#[test]
fn ply_ascii_and_binary_agree() {
    let (ascii, _) = model("tetra_ascii.ply");
    let (le, _) = model("tetra_binary_le.ply");
    let (be, _) = model("tetra_binary_be.ply");
    let (name, mesh, material) = &ascii[0];
    assert_eq!(name, "tetra_ascii");
    assert!(material.is_none());
    assert_eq!(mesh.triangle_count(), 4);
    assert!(signed_volume(mesh) > 0.0);
    assert_eq!(mesh.normals[1], [1.0, 0.0, 0.0], "file normals kept");
    for other in [&le[0].1, &be[0].1] {
        assert_eq!(other.positions, mesh.positions);
        assert_eq!(other.indices, mesh.indices);
        assert_eq!(other.normals.len(), 4, "computed");
    }
    // Big-endian file: doubles, and sRGB (255, 255, 0) vertex colors → material color.
    let yellow = be[0].2.as_ref().unwrap();
    assert!(approx3(yellow.color, [1.0, 1.0, 0.0]), "{:?}", yellow.color);
    let scene = load_scene(&spec("tetra_binary_le.ply")).unwrap();
    assert!(scene.camera.is_none());
}

#[test]
fn malformed_ply_is_a_one_line_error() {
    assert_scene_error(
        "malformed.ply",
        &["line 11: vertex 1: cannot read '1 0 zero' as x y z"],
    );
}

// --- glTF --------------------------------------------------------------------------------------

fn check_two_nodes(parts: &[Part]) {
    assert_eq!(parts.len(), 2);
    let (name, tetra, glass) = &parts[0];
    assert_eq!(name, "tetra");
    // Node "moved": translation (2, 0, 0).
    assert_eq!(tetra.positions[1], [3.0, 0.0, 0.0]);
    assert_eq!(tetra.triangle_count(), 4);
    assert!(signed_volume(tetra) > 0.0);
    let glass = glass.as_ref().unwrap();
    assert_eq!(glass.name, "glass");
    assert!(approx3(glass.color, [0.2, 0.4, 0.6]));
    assert!(
        (glass.opacity - 0.4).abs() < 1e-6,
        "BLEND: opacity = factor alpha"
    );

    let (name, tri, solid) = &parts[1];
    assert_eq!(name, "triangle");
    // Node "child" (translation (0,1,0)) under "parent" (scale 2): world = S · T.
    assert_eq!(tri.triangle_count(), 1);
    assert!(
        approx3(tri.positions[1], [2.0, 2.0, 0.0]),
        "{:?}",
        tri.positions
    );
    let solid = solid.as_ref().unwrap();
    assert_eq!(solid.opacity, 1.0, "OPAQUE ignores the factor alpha");
}

#[test]
fn gltf_and_glb_load_with_node_transforms_and_materials() {
    let (gltf_parts, w) = model("two_nodes.gltf");
    assert!(w.is_empty(), "{w:?}");
    check_two_nodes(&gltf_parts);
    let (glb_parts, _) = model("two_nodes.glb");
    check_two_nodes(&glb_parts);
    let scene = load_scene(&spec("two_nodes.glb")).unwrap();
    assert!(scene.camera.is_none());
    assert_eq!(scene.materials.len(), 2);
}

#[test]
fn gltf_mask_cutoff_and_mirroring() {
    let text = std::fs::read_to_string(fixture("two_nodes.gltf")).unwrap();
    let text = text
        .replace("\"BLEND\"", "\"MASK\"")
        .replace("\"scale\": [\n    2.0,", "\"scale\": [\n    -2.0,");
    assert!(text.contains("-2.0"), "fixture layout changed");
    let path = std::env::temp_dir().join(format!("strata-mask-{}.gltf", std::process::id()));
    std::fs::write(&path, text).unwrap();
    let mut w = Vec::new();
    let parts = load_model_with_warnings(&path, &mut w);
    std::fs::remove_file(&path).ok();
    let parts = parts.unwrap();
    // glass: MASK with alpha 0.4 < cutoff 0.5 → the tetrahedron is cut out.
    assert_eq!(parts.len(), 1);
    let tri = &parts[0].1;
    assert!(approx3(tri.positions[1], [-2.0, 2.0, 0.0]));
    // The mirrored triangle keeps facing where its (transformed) normal points.
    let [a, b, c] = [0, 1, 2].map(|i| Vec3::from(tri.positions[tri.indices[i] as usize]));
    let n = (b - a).cross(c - a);
    assert!(n.dot(Vec3::from(tri.normals[tri.indices[0] as usize])) > 0.0);
}

#[test]
fn malformed_gltf_is_a_one_line_error() {
    scene_error("malformed.gltf");
}

#[test]
fn gltf_node_with_a_zero_scale_draws_nothing_and_the_rest_draws() {
    let text = std::fs::read_to_string(fixture("zero_scale.gltf")).unwrap();
    let mut json: serde_json::Value = serde_json::from_str(&text).unwrap();
    json["nodes"]
        .as_array_mut()
        .unwrap()
        .push(serde_json::json!({"mesh": 0}));
    json["scenes"][0]["nodes"] = serde_json::json!([0, 1]);
    let dir = std::env::temp_dir().join(format!("strata-hidden-node-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("hidden.gltf");
    std::fs::write(&path, json.to_string()).unwrap();
    let mut warnings = Vec::new();
    let parts = load_model_with_warnings(&path, &mut warnings).unwrap();
    assert_eq!(parts.len(), 1, "the visible node's mesh only");
    assert_eq!(parts[0].1.triangle_count(), 1);
    assert!(
        warnings.len() == 1 && warnings[0].contains("1 mesh node(s) with a zero scale"),
        "{warnings:?}"
    );
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn gltf_that_would_draw_nothing_or_misread_is_rejected() {
    // A zero scale hides its node (valid glTF); a file of hidden nodes only draws nothing.
    assert_scene_error("zero_scale.gltf", &["no triangles"]);
    assert_scene_error(
        "alpha_over_one.gltf",
        &["baseColorFactor", "outside [0, 1]"],
    );
    assert_scene_error("lines_only.gltf", &["no TRIANGLES primitive"]);
}

// --- TOML --------------------------------------------------------------------------------------

#[test]
fn toml_scene_uses_every_field() {
    let s = load_scene(&spec("scene.toml")).unwrap();
    assert_eq!(s.defaults.size, Some([320, 240]));
    assert_eq!(
        s.defaults.background,
        Some("#336699".parse::<Background>().unwrap())
    );
    assert_eq!(s.defaults.shading, Some(Shading::Lit));

    let cam = s.camera.unwrap();
    assert_eq!(cam.eye, Vec3::new(0.0, 2.0, 6.0));
    assert_eq!(cam.target, Vec3::new(0.0, 0.5, 0.0));
    assert_eq!(cam.up, Vec3::Y);
    assert_eq!(cam.projection, Projection::Perspective { fov_y_deg: 50.0 });
    assert_eq!((cam.near, cam.far), (0.5, 50.0));

    let glass = &s.materials[0];
    assert_eq!(
        (
            glass.name.as_str(),
            glass.color,
            glass.opacity,
            glass.absorption,
            glass.ior
        ),
        ("glass", [0.9, 0.2, 0.1], 0.4, 0.5, 1.45)
    );
    let flat = &s.materials[1];
    assert_eq!((flat.opacity, flat.shading), (1.0, Shading::Unlit));
    assert_eq!(flat.absorption, Material::default().absorption);

    // 1 quad + 1 sphere + 2 parts + 2 parts + 1 cube.
    assert_eq!(s.objects.len(), 7);
    let floor = &s.objects[0];
    assert_eq!(floor.material, 1);
    let (lo, hi) = floor.mesh.bounds();
    assert!(
        (lo - Vec3::new(-4.0, 0.0, -4.0)).abs().max_element() < 1e-5,
        "{lo}"
    );
    assert!(
        (hi - Vec3::new(4.0, 0.0, 4.0)).abs().max_element() < 1e-5,
        "{hi}"
    );
    assert!(
        approx3(floor.mesh.normals[0], [0.0, 1.0, 0.0]),
        "quad turned to face +Y"
    );

    let sphere = &s.objects[1];
    let (lo, hi) = sphere.mesh.bounds();
    assert!(
        (lo - Vec3::new(0.0, -1.0, -1.0)).abs().max_element() < 1e-3,
        "{lo}"
    );
    assert!(
        (hi - Vec3::new(2.0, 3.0, 1.0)).abs().max_element() < 1e-3,
        "{hi}"
    );
    let m = &s.materials[sphere.material];
    assert_eq!(
        (m.color, m.opacity, m.absorption, m.ior, m.shading),
        ([0.2, 0.3, 0.9], 0.6, 1.0, 1.3, Shading::Lit)
    );
    assert_eq!(m.name, "object 2");

    // Object 3 keeps the model's own materials (translated by −2 in x).
    let (red, blue) = (&s.objects[2], &s.objects[3]);
    assert_eq!(s.materials[red.material].name, "red");
    assert_eq!(s.materials[blue.material].opacity, 0.3);
    assert!(approx3(red.mesh.positions[1], [-1.0, 0.0, 0.0]));

    // Object 4: the named material replaces both, with opacity 0.7; rotated 90° about Y.
    let (a, b) = (&s.objects[4], &s.objects[5]);
    assert_eq!(a.material, b.material);
    let m = &s.materials[a.material];
    assert_eq!((m.color, m.opacity, m.ior), ([0.9, 0.2, 0.1], 0.7, 1.45));
    assert_eq!(m.name, "glass (object 4)");
    assert!(
        approx3(a.mesh.positions[1], [0.0, 0.0, -1.0]),
        "{:?}",
        a.mesh.positions[1]
    );

    let cube = &s.objects[6];
    assert_eq!(cube.material, 0);
    assert_eq!(cube.mesh.bounds().1, Vec3::new(0.25, 3.25, 0.25));

    assert_eq!(s.lights.len(), 4);
    let l = &s.lights[0];
    assert_eq!(
        (l.kind, l.position, l.color, l.intensity, l.range),
        (
            LightKind::Point,
            Vec3::new(2.0, 3.0, 4.0),
            [1.0, 0.9, 0.8],
            1.5,
            12.0
        )
    );
    let spot = &s.lights[1];
    assert_eq!(
        (spot.kind, spot.direction, spot.angle_deg),
        (LightKind::Spot, Vec3::NEG_Y, 25.0)
    );
    assert_eq!(s.lights[2].kind, LightKind::Directional);
    assert!((s.lights[2].direction - Vec3::new(1.0, -1.0, 0.0).normalize()).length() < 1e-6);
    assert_eq!(s.lights[3].kind, LightKind::Ambient);
}

#[test]
fn malformed_toml_is_a_one_line_error_with_its_line() {
    let e = scene_error("malformed.toml");
    assert!(e.contains("line 2") || e.contains("line 3"), "{e}");
}

#[test]
fn toml_unknown_material_names_the_object() {
    assert_scene_error(
        "unknown_material.toml",
        &["object 2 (line 9): unknown material 'glas'"],
    );
}

#[test]
fn toml_unknown_field_is_an_error() {
    assert_scene_error(
        "unknown_field.toml",
        &["object 1", "unknown field `colour`"],
    );
}

fn toml_error(text: &str) -> String {
    let e = toml::parse(text, "t.toml", &fixture(""), &mut Vec::new())
        .unwrap_err()
        .to_string();
    assert!(e.starts_with("t.toml: "), "{e}");
    assert!(!e.contains('\n'), "{e:?}");
    e
}

#[test]
fn toml_errors_name_element_and_problem() {
    let cube = "[[object]]\nmesh = \"builtin:cube\"\n";
    for (text, needle) in [
        (
            "objects = 1\n".to_string(),
            "t.toml: line 1, column 1 (objects = 1): unknown field `objects`",
        ),
        (
            "[[object]]\nmesh = \"nowhere.obj\"\n".into(),
            "object 1 (line 1): model file",
        ),
        (
            "[[object]]\nmesh = \"builtin:cone\"\n".into(),
            "unknown builtin mesh 'cone'",
        ),
        (
            "[[object]]\nmesh = \"x.fbx\"\n".into(),
            "unsupported file type",
        ),
        (
            "[[object]]\ncolor = [1, 0, 0]\n".into(),
            "missing field `mesh`",
        ),
        (format!("{cube}scale = \"big\"\n"), "scale must be a number"),
        (format!("{cube}scale = [1, 0, 1]\n"), "non-zero"),
        (
            format!("{cube}opacity = 1.5\n"),
            "opacity 1.5 is outside [0, 1]",
        ),
        (
            format!("{cube}shading = \"glossy\"\n"),
            "unknown variant `glossy`",
        ),
        (
            format!("{cube}translate = [1, 2]\n"),
            "object 1: line 3, column 13 (translate = [1, 2]): invalid length 2",
        ),
        (
            format!("[[material]]\nname = \"m\"\n{cube}opacity = \"x\"\n[[light]]\n"),
            "object 1: line 5, column 11 (opacity = \"x\"): invalid type: string \"x\", expected f32",
        ),
        (
            format!("[render]\nbackground = \"blue\"\n{cube}"),
            "render (line 1): background 'blue'",
        ),
        (
            format!("[render]\nsize = [0, 10]\n{cube}"),
            "render (line 1): size [0, 10] must be 1..16384 per side",
        ),
        (
            format!("[render]\nsize = [100000, 10]\n{cube}"),
            "render (line 1): size [100000, 10] must be 1..16384 per side",
        ),
        (
            format!("[camera]\neye = [0, 0, 5]\nnear = 2.0\nfar = 1.0\n{cube}"),
            "camera (line 1): near 2 and far 1",
        ),
        (format!("[camera]\neye = [0, 0, 0]\n{cube}"), "same point"),
        (
            format!("[camera]\ntarget = [0, 0, 0]\n{cube}"),
            "missing field `eye`",
        ),
        (
            format!("[camera]\neye = [0, 0, 5]\nprojection = \"fisheye\"\n{cube}"),
            "fisheye",
        ),
        (
            format!("[[material]]\nname = \"a\"\n[[material]]\nname = \"a\"\n{cube}"),
            "material 2 (line 3): material 'a' is defined twice",
        ),
        (
            format!("[[material]]\nname = \"a\"\nior = 0.5\n{cube}"),
            "material 1 (line 1): ior 0.5",
        ),
        (
            format!("{cube}[[light]]\nkind = \"laser\"\n"),
            "light 1: line 4, column 8 (kind = \"laser\"): unknown variant `laser`",
        ),
        (
            format!("{cube}[[light]]\nkind = \"spot\"\ndirection = [0, 0, 0]\n"),
            "direction must be non-zero",
        ),
        (
            format!("{cube}[[light]]\nrange = -1\n"),
            "range -1 must be positive",
        ),
        ("[render]\nsize = [64, 64]\n".into(), "no [[object]]"),
    ] {
        let e = toml_error(&text);
        assert!(
            e.contains(needle),
            "{text:?}\n  expected '{needle}' in: {e}"
        );
    }
}

#[test]
fn toml_rotation_order_is_x_then_y_then_z() {
    // A point at +X: X rotation keeps it, Y by 90° sends it to −Z, Z by 90° keeps −Z.
    // Were Z applied first, +X would go to +Y and stay there under Y.
    let text =
        "[[object]]\nmesh = \"builtin:quad\"\nrotate_deg = [0, 90, 90]\ntranslate = [0, 0, 5]\n";
    let s = toml::parse(text, "t.toml", Path::new("."), &mut Vec::new()).unwrap();
    let q = &s.objects[0].mesh;
    let m = glam::Mat4::from_translation(Vec3::new(0.0, 0.0, 5.0))
        * glam::Mat4::from_rotation_z(90f32.to_radians())
        * glam::Mat4::from_rotation_y(90f32.to_radians());
    for (p, orig) in q
        .positions
        .iter()
        .zip(crate::scene::builtin::quad().positions)
    {
        assert!(approx3(*p, m.transform_point3(Vec3::from(orig)).to_array()));
    }
    let r = m.transform_point3(Vec3::X);
    assert!((r - Vec3::new(0.0, 0.0, 4.0)).length() < 1e-5, "{r}");
}

#[test]
fn toml_negative_scale_keeps_outward_winding() {
    let text = "[[object]]\nmesh = \"builtin:cube\"\nscale = [-1, 1, 1]\n";
    let s = toml::parse(text, "t.toml", Path::new("."), &mut Vec::new()).unwrap();
    assert!(signed_volume(&s.objects[0].mesh) > 0.0);
}

// --- load_scene dispatch ----------------------------------------------------------------------

#[test]
fn load_scene_rejects_unknown_and_missing() {
    let e = load_scene("nowhere/scene.obj").unwrap_err().to_string();
    assert_eq!(e, "scene file 'nowhere/scene.obj' not found");
    let e = load_scene("model.fbx").unwrap_err().to_string();
    assert!(
        e.contains("'model.fbx'") && e.contains("unsupported file type"),
        "{e}"
    );
    let e = load_scene("README").unwrap_err().to_string();
    assert!(e.contains("'README'"), "{e}");
    let e = load_scene(&spec("")).unwrap_err().to_string();
    assert!(e.contains("unsupported") || e.contains("not a file"), "{e}");
    let e = load_scene("builtin:nope").unwrap_err().to_string();
    assert!(e.contains("unknown builtin scene 'nope'"), "{e}");
    let e = load_model(Path::new("scene.toml")).unwrap_err().to_string();
    assert!(e.contains("unsupported file type"), "{e}");
}

#[test]
fn load_scene_builds_builtins() {
    let s = load_scene("builtin:layers?n=4&order=front").unwrap();
    assert_eq!(s.objects.len(), 4);
}

// --- robustness: no input makes a loader panic --------------------------------------------------

mod never_panic {
    use super::*;
    use proptest::prelude::*;

    fn pick(options: &'static [&'static str]) -> impl Strategy<Value = &'static str> + Clone {
        prop::sample::select(options)
    }

    fn obj_line() -> impl Strategy<Value = String> {
        let number = pick(&["0", "1", "-1", "0.5", "nan", "inf", "1e40", "x", ""]);
        let index = pick(&[
            "1",
            "2",
            "3",
            "-1",
            "-4",
            "0",
            "3/1",
            "1//1",
            "2/0/1",
            "1/1/1/1",
            "99999999999999999999",
            "a",
            "/",
            "//",
        ]);
        prop_oneof![
            prop::collection::vec(number.clone(), 0..5).prop_map(|v| format!("v {}", v.join(" "))),
            prop::collection::vec(index.clone(), 0..6).prop_map(|v| format!("f {}", v.join(" "))),
            prop::collection::vec(index, 0..3).prop_map(|v| format!("l {}", v.join(" "))),
            prop::collection::vec(number.clone(), 0..4).prop_map(|v| format!("vt {}", v.join(" "))),
            prop::collection::vec(number, 0..4).prop_map(|v| format!("vn {}", v.join(" "))),
            pick(&[
                "o",
                "o part",
                "g",
                "usemtl",
                "usemtl m",
                "mtllib x.mtl",
                "mtllib",
                "p 1",
                "#"
            ])
            .prop_map(str::to_string),
        ]
    }

    fn mtl_line() -> impl Strategy<Value = &'static str> {
        pick(&[
            "newmtl m",
            "newmtl",
            "Kd 1 0",
            "Kd 1 0 0",
            "Kd x y z",
            "Ka",
            "d 2",
            "d -1",
            "d nan",
            "Tr x",
            "Tr 0.5",
            "Ni 1.5",
            "illum 2",
            "map_Kd",
            "map_Kd t.png",
        ])
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(400))]

        #[test]
        fn obj(lines in prop::collection::vec(obj_line(), 0..14),
               mtl in prop::collection::vec(mtl_line(), 0..6)) {
            let text = lines.join("\n");
            let mtl = mtl.join("\n");
            let lookup = |_: &Path| obj::MtlLookup::Text(mtl.clone());
            if let Err(e) = obj::parse_obj_text(&text, "f.obj", &lookup, &mut Vec::new()) {
                let e = e.to_string();
                prop_assert!(e.starts_with("f.obj: ") && !e.contains('\n'), "{}", e);
            }
        }

        #[test]
        fn ply(binary in any::<bool>(), count in 0u32..5, data in prop::collection::vec(any::<u8>(), 0..80),
               text in prop::collection::vec(pick(&["0", "1", "3", "-1", "2.5", "x", "\n", " "]), 0..40)) {
            let format = if binary { "binary_little_endian" } else { "ascii" };
            let mut bytes = format!(
                "ply\nformat {format} 1.0\nelement vertex {count}\nproperty float x\nproperty float y\n\
                 property float z\nelement face {count}\nproperty list uchar int vertex_indices\nend_header\n"
            ).into_bytes();
            if binary {
                bytes.extend_from_slice(&data);
            } else {
                bytes.extend_from_slice(text.join(" ").as_bytes());
            }
            if let Err(e) = ply::parse(&bytes, "f.ply", "f") {
                let e = e.to_string();
                prop_assert!(e.starts_with("f.ply: ") && !e.contains('\n'), "{}", e);
            }
        }

        #[test]
        fn gltf(mutations in prop::collection::vec((0usize..7, 0usize..100), 0..3)) {
            let mut text = std::fs::read_to_string(fixture("two_nodes.gltf")).unwrap();
            for (what, v) in mutations {
                let (from, to) = match what {
                    0 => ("\"count\": 12", format!("\"count\": {}", v % 16)),
                    1 => ("\"count\": 4", format!("\"count\": {}", v % 8)),
                    2 => ("\"byteOffset\": 48", format!("\"byteOffset\": {v}")),
                    3 => ("\"componentType\": 5123", format!("\"componentType\": {}", [5121, 5123, 5125, 5126, 5120][v % 5])),
                    4 => (
                        "\"type\": \"SCALAR\"",
                        format!("\"type\": \"{}\"", ["VEC2", "VEC3", "MAT4", "SCALAR"][v % 4]),
                    ),
                    5 => ("\"target\": 34962", format!("\"byteStride\": {}", v % 24)),
                    _ => ("\"byteLength\": 24", format!("\"byteLength\": {}", v % 32)),
                };
                text = text.replacen(from, &to, 1);
            }
            if let Err(e) = gltf::parse(text.as_bytes(), Path::new("."), "f.gltf", &mut Vec::new()) {
                let e = e.to_string();
                prop_assert!(e.starts_with("f.gltf: ") && !e.contains('\n'), "{}", e);
            }
        }

        #[test]
        fn toml(lines in prop::collection::vec(pick(&[
            "[[object]]", "mesh = \"builtin:cube\"", "mesh = \"builtin:sphere?segments=1\"", "mesh = 3",
            "[camera]", "eye = [0, 0, 5]", "eye = [0, 0]", "up = [0, 0, 0]", "near = 0", "far = -1",
            "[[material]]", "name = \"a\"", "material = \"a\"", "opacity = 2", "scale = [1, 2]",
            "scale = 0", "rotate_deg = [1e39, 0, 0]", "[render]", "size = [1, -1]", "[[light]]",
            "kind = \"spot\"", "direction = [0, 0, 0]", "x = ", "]", "[", "\"",
        ]), 0..12)) {
            let text = lines.join("\n");
            if let Err(e) = toml::parse(&text, "f.toml", Path::new("."), &mut Vec::new()) {
                let e = e.to_string();
                prop_assert!(e.starts_with("f.toml: ") && !e.contains('\n'), "{}", e);
            }
        }
    }
}

#[test]
fn toml_camera_keys_make_a_path_over_the_camera() {
    let text = r#"
[camera]
eye = [0.0, 0.0, 5.0]
fov_y_deg = 30.0

[[object]]
mesh = "builtin:cube"

[[camera_key]]
time = 0.0
eye = [0.0, 0.0, 5.0]

[[camera_key]]
time = 30.0
eye = [5.0, 0.0, 0.0]
target = [0.0, 1.0, 0.0]
"#;
    let mut s = toml::parse(text, "t.toml", Path::new("."), &mut Vec::new()).unwrap();
    assert_eq!(s.camera.unwrap().eye, Vec3::new(0.0, 0.0, 5.0));
    s.set_time(15.0);
    let c = s.camera.unwrap();
    assert!((c.eye - Vec3::new(2.5, 0.0, 2.5)).length() < 1e-6, "{c:?}");
    assert!(
        (c.target - Vec3::new(0.0, 0.5, 0.0)).length() < 1e-6,
        "{c:?}"
    );
    assert_eq!(
        c.projection,
        Projection::Perspective { fov_y_deg: 30.0 },
        "the keys keep the [camera]'s projection"
    );
    let e = toml_error(
        "[[object]]\nmesh = \"builtin:cube\"\n[[camera_key]]\ntime = 2.0\neye = [0.0, 0.0, 4.0]\n[[camera_key]]\ntime = 1.0\neye = [0.0, 0.0, 3.0]\n",
    );
    assert!(
        e.contains("camera_key 2 (line 6)") && e.contains("does not come after"),
        "{e}"
    );
    let e =
        toml_error("[[object]]\nmesh = \"builtin:cube\"\n[[camera_key]]\neye = [0.0, 0.0, 4.0]\n");
    assert!(e.contains("time"), "{e}");
}
