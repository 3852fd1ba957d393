//! The lit pipelines on lavapipe: deferred against forward (the G-buffer's quantization is the
//! only difference), light volumes against the per-fragment loop, and the full frame against
//! the reference.

use crate::frame::{BuildOptions, FrameOptions, Lighting};
use glam::{Mat4, Vec3};

use super::*;
use crate::frame::{Effect, RenderOptions};
use crate::gpu::readback;
use crate::render::LinearImage;
use crate::scene::builtin::{cube, quad, uv_sphere};
use crate::scene::{Light, LightKind, Material, Object, Projection, Shading};
use crate::testing::{
    assert_close, assert_exact, gpu, render_gpu, render_reference, Expected, EXACT_MAX_DIFF,
    EXACT_MAX_FRACTION,
};

/// Deferred against forward: at most 3/255 per sRGB channel on every pixel, and 2/255 on all but
/// 0.5% of them. What differs is the G-buffer: albedo in 8-bit sRGB (≤ 0.5/255 after encoding),
/// the normal in 10 bits (≤ 0.25°, which moves a specular highlight of exponent 64 by up to
/// ~2/255 on its flank), and positions rebuilt from f32 depth. Measured on these scenes: max
/// 2/255, under 0.1% of pixels over 1/255.
const DEFERRED_MAX_DIFF: u8 = 3;
const DEFERRED_NEAR_DIFF: u8 = 2;
const DEFERRED_NEAR_FRACTION: f64 = 0.005;
// Forward and the full frame against the reference: the exact methods' tolerance
// (`EXACT_MAX_DIFF`, `EXACT_MAX_FRACTION`: see methods/tests.rs), the HDR image's f16 adding
// ≤ 0.3/255.

fn material(name: &str, color: [f32; 3], opacity: f32, shininess: f32) -> Material {
    Material {
        name: name.into(),
        color,
        opacity,
        shininess,
        ..Material::default()
    }
}

fn object(scene: &mut Scene, name: &str, mesh: crate::scene::Mesh, m: Mat4, material: usize) {
    scene.objects.push(Object {
        name: name.into(),
        mesh: mesh.transformed(m),
        material,
    });
}

/// A lit room corner: a floor, a back wall, an opaque cube and sphere, a transparent sphere in
/// front; `lights` lights. No two surfaces share an edge or a plane (the wall stands just off the
/// floor, the cube just above it), so the exact comparisons do not hinge on f32 ties.
fn room(lights: Vec<Light>) -> Scene {
    let mut s = Scene::default();
    let floor = s.add_material(material("floor", [0.7, 0.7, 0.65], 1.0, 16.0));
    let wall = s.add_material(material("wall", [0.5, 0.6, 0.8], 1.0, 8.0));
    let red = s.add_material(material("red", [0.8, 0.2, 0.15], 1.0, 64.0));
    let gold = s.add_material(material("gold", [0.9, 0.7, 0.2], 1.0, 200.0));
    let glass = s.add_material(material("glass", [0.3, 0.8, 0.5], 0.4, 48.0));
    object(
        &mut s,
        "floor",
        quad(),
        Mat4::from_rotation_x(-std::f32::consts::FRAC_PI_2) * Mat4::from_scale(Vec3::splat(3.0)),
        floor,
    );
    object(
        &mut s,
        "wall",
        quad(),
        Mat4::from_translation(Vec3::new(0.0, 3.05, -3.05)) * Mat4::from_scale(Vec3::splat(3.0)),
        wall,
    );
    object(
        &mut s,
        "cube",
        cube(),
        Mat4::from_translation(Vec3::new(-1.0, 0.52, -0.5))
            * Mat4::from_rotation_y(0.5)
            * Mat4::from_scale(Vec3::splat(0.5)),
        red,
    );
    object(
        &mut s,
        "ball",
        uv_sphere(32),
        Mat4::from_translation(Vec3::new(1.0, 0.62, -0.8)) * Mat4::from_scale(Vec3::splat(0.6)),
        gold,
    );
    object(
        &mut s,
        "glass",
        uv_sphere(24),
        Mat4::from_translation(Vec3::new(0.0, 0.8, 0.8)) * Mat4::from_scale(Vec3::splat(0.7)),
        glass,
    );
    s.camera = Some(Camera {
        eye: Vec3::new(0.5, 2.5, 5.0),
        target: Vec3::new(0.0, 0.6, 0.0),
        up: Vec3::Y,
        projection: Projection::Perspective { fov_y_deg: 50.0 },
        near: 0.1,
        far: 30.0,
    });
    s.lights = lights;
    s
}

fn point(position: [f32; 3], color: [f32; 3], range: f32) -> Light {
    Light {
        kind: LightKind::Point,
        position: Vec3::from(position),
        color,
        intensity: 1.5,
        range,
        attenuation: [1.0, 0.2, 0.3],
        ..Light::default()
    }
}

fn spot(position: [f32; 3], target: [f32; 3], angle_deg: f32) -> Light {
    Light {
        kind: LightKind::Spot,
        position: Vec3::from(position),
        direction: (Vec3::from(target) - Vec3::from(position)).normalize(),
        angle_deg,
        color: [1.0, 0.9, 0.7],
        intensity: 2.0,
        range: 8.0,
        attenuation: [1.0, 0.0, 0.05],
    }
}

fn mixed_lights() -> Vec<Light> {
    vec![
        point([-1.5, 1.2, 1.0], [1.0, 0.4, 0.3], 3.0),
        point([1.8, 0.8, 0.2], [0.3, 0.6, 1.0], 2.5),
        point([0.0, 2.5, -2.0], [0.5, 1.0, 0.4], 4.0),
        spot([2.5, 3.5, 2.0], [0.0, 0.0, 0.0], 25.0),
        Light {
            kind: LightKind::Directional,
            direction: Vec3::new(-0.3, -1.0, -0.5).normalize(),
            color: [0.3, 0.3, 0.35],
            ..Light::default()
        },
        Light {
            kind: LightKind::Ambient,
            color: [0.05, 0.05, 0.06],
            ..Light::default()
        },
    ]
}

fn options(pipeline: Option<Pipeline>, size: u32) -> RenderOptions {
    RenderOptions {
        build: BuildOptions {
            lighting: Lighting {
                pipeline,
                ..Default::default()
            },
            ..Default::default()
        },
        frame: FrameOptions {
            width: size,
            height: size,
            ..Default::default()
        },
    }
}

fn render(scene: &Scene, options: &RenderOptions, method: &str) -> (LinearImage, FrameStats) {
    render_gpu(scene, options, method)
}

/// abuffer-ll's frame: the pipeline's pictures are compared on it.
fn abuffer_ll(scene: &Scene, options: &RenderOptions) -> (LinearImage, FrameStats) {
    render(scene, options, "abuffer-ll")
}

/// [`options`] changed by `change`.
fn options_with(
    pipeline: Option<Pipeline>,
    size: u32,
    change: impl FnOnce(&mut RenderOptions),
) -> RenderOptions {
    let mut options = options(pipeline, size);
    change(&mut options);
    options
}

use crate::frame::FrameStats;

fn assert_deferred_matches_forward(name: &str, scene: &Scene, size: u32) -> FrameStats {
    let (forward, _) = abuffer_ll(scene, &options(Some(Pipeline::Forward), size));
    let (deferred, stats) = abuffer_ll(scene, &options(Some(Pipeline::Deferred), size));
    assert_close(
        &format!("{name}-deferred-vs-forward"),
        &deferred,
        &forward,
        Effect::Transparency,
        DEFERRED_NEAR_DIFF,
        DEFERRED_NEAR_FRACTION,
    );
    assert_close(
        &format!("{name}-deferred-vs-forward-max"),
        &deferred,
        &forward,
        Effect::Transparency,
        DEFERRED_MAX_DIFF,
        0.0,
    );
    stats
}

#[test]
fn every_stage_and_the_uniforms_validate() {
    crate::gpu::twin::assert_twin::<DeferredParams>();
    for index in 0..STAGES.len() {
        crate::gpu::shader::validate(&stage(index));
    }
}

#[test]
fn deferred_equals_forward_with_every_kind_of_light() {
    let scene = room(mixed_lights());
    let stats = assert_deferred_matches_forward("room", &scene, 96);
    let lighting = stats.lighting.expect("lighting stats");
    assert_eq!(lighting.lights, 5);
    assert_eq!(lighting.cone_volumes, Some(1));
    assert_eq!(lighting.full_screen_lights, Some(1));
    assert_eq!(lighting.gbuffer_bytes_per_pixel, Some(12));
}

#[test]
fn deferred_equals_forward_with_the_octahedral_encoding_and_many_lights() {
    let mut scene = room(Vec::new());
    scene.add_light_field(200, 7);
    let size = 80;
    let forward = abuffer_ll(&scene, &options(Some(Pipeline::Forward), size)).0;
    let opts = options_with(Some(Pipeline::Deferred), size, |o| {
        o.build.lighting.normal_encoding = NormalEncoding::Octahedral
    });
    let (deferred, stats) = abuffer_ll(&scene, &opts);
    assert_close(
        "field-octahedral",
        &deferred,
        &forward,
        Effect::Transparency,
        DEFERRED_NEAR_DIFF,
        DEFERRED_NEAR_FRACTION,
    );
    let l = stats.lighting.unwrap();
    assert_eq!(l.lights, 200);
    assert!(l.culled_lights.unwrap() > 0, "{l:?}");
}

#[test]
fn spot_cones_match_forward_narrow_and_wide() {
    // 15° and 40° draw cones; 80° is wider than a cone volume takes and draws a sphere.
    let scene = room(vec![
        spot([-2.0, 3.0, 1.5], [-1.0, 0.0, -0.5], 15.0),
        spot([2.0, 3.0, 1.0], [1.0, 0.0, -0.5], 40.0),
        spot([0.0, 2.0, 2.5], [0.0, 0.0, 0.0], 80.0),
    ]);
    let stats = assert_deferred_matches_forward("spots", &scene, 96);
    let l = stats.lighting.unwrap();
    assert_eq!((l.cone_volumes, l.sphere_volumes), (Some(2), Some(1)));
}

#[test]
fn a_light_whose_volume_is_off_screen_changes_nothing() {
    let base = room(mixed_lights());
    let opts = options(Some(Pipeline::Deferred), 64);
    let (before, _) = abuffer_ll(&base, &opts);
    let mut with = base.clone();
    // Behind the camera (culled), and in view but out of reach of every surface (drawn, its
    // window zero on every pixel it covers).
    with.lights.push(point([0.5, 4.0, 9.0], [1.0; 3], 2.0));
    with.lights.push(point([0.0, 2.6, 1.0], [1.0; 3], 0.4));
    let (after, stats) = abuffer_ll(&with, &opts);
    let l = stats.lighting.unwrap();
    assert_eq!(l.culled_lights, Some(1));
    assert_eq!(before.pixels, after.pixels);
}

#[test]
fn the_camera_inside_a_point_lights_volume_is_lit_correctly() {
    let mut scene = room(Vec::new());
    let camera = scene.camera.unwrap();
    scene.lights.push(Light {
        attenuation: [1.0, 0.0, 0.0],
        ..point(camera.eye.to_array(), [1.0, 0.9, 0.8], 9.0)
    });
    let stats = assert_deferred_matches_forward("inside", &scene, 80);
    assert_eq!(stats.lighting.unwrap().sphere_volumes, Some(1));
    // And the light shows: the picture is brighter than with the ambient term alone.
    let mut dark = scene.clone();
    dark.lights.clear();
    dark.lights.push(Light {
        kind: LightKind::Ambient,
        color: [0.1; 3],
        ..Light::default()
    });
    let opts = options(Some(Pipeline::Deferred), 80);
    let lit = abuffer_ll(&scene, &opts).0;
    let unlit = abuffer_ll(&dark, &opts).0;
    let sum = |img: &LinearImage| img.pixels.iter().map(|p| p[0] + p[1] + p[2]).sum::<f32>();
    assert!(sum(&lit) > 1.5 * sum(&unlit));
}

#[test]
fn forward_pipeline_with_exact_methods_equals_the_reference() {
    let scene = room(mixed_lights());
    for pipeline in [Pipeline::Forward, Pipeline::Deferred] {
        let opts = options(Some(pipeline), 80);
        let (image, stats) = abuffer_ll(&scene, &opts);
        // Only the transparent sphere goes through the method.
        assert!(stats.max_depth_complexity.unwrap() <= 2, "{stats:?}");
        if pipeline == Pipeline::Forward {
            let expected = render_reference(&scene, &opts);
            assert_exact("room-forward", &image, &expected, Effect::Transparency);
        }
    }
    for (method, k) in [("f2b", None), ("kplus-heap", Some(1))] {
        let opts = options_with(Some(Pipeline::Forward), 64, |o| o.frame.k = k);
        let (image, _) = render(&scene, &opts, method);
        let expected = render_reference(&scene, &opts);
        assert_exact(
            &format!("room-forward-{method}"),
            &image,
            &expected,
            Effect::Transparency,
        );
    }
}

/// The expected full frame: the deferred image of the opaque objects alone (through the GPU's
/// own path, single-sampled), and over it, per sample, the reference's transparent fragments in
/// front of the opaque depth at the pixel center (each sample's `k` nearest), the samples
/// averaged; and how many pixels hold a fragment covering only some samples.
fn composite_over_deferred(scene: &Scene, opts: &RenderOptions) -> (LinearImage, u32) {
    let (opaque, transparent) = scene.split_by_opacity();
    let (lit_opaque, _) = abuffer_ll(&opaque, opts);
    let single = {
        let mut options = opts.clone();
        options.build.msaa = 1;
        options
    };
    let opaque_fragments = crate::reference::fragments(&opaque, &single).unwrap();
    let transparent_fragments = crate::reference::fragments(&transparent, opts).unwrap();
    let samples = opts.build.msaa.max(1);
    let full = ((1u32 << samples) - 1) as u8;
    let keep = opts.frame.k.map_or(usize::MAX, |k| k as usize);
    let mut partly_covered = 0;
    let pixels = transparent_fragments
        .iter()
        .zip(&opaque_fragments)
        .zip(&lit_opaque.pixels)
        .map(|((list, opaque), under)| {
            let in_front: Vec<_> = match opaque.first() {
                Some(o) => list.iter().filter(|f| f.depth < o.depth).cloned().collect(),
                None => list.clone(),
            };
            partly_covered += in_front.iter().any(|f| f.coverage != full) as u32;
            let under = [under[0] as f64, under[1] as f64, under[2] as f64];
            let mut sum = [0.0; 3];
            for sample in 0..samples {
                let own: Vec<_> = in_front
                    .iter()
                    .filter(|f| f.coverage & (1 << sample) != 0)
                    .take(keep)
                    .cloned()
                    .collect();
                let c = crate::resolve::composite(&own, under, false);
                sum = std::array::from_fn(|i| sum[i] + c[i] / samples as f64);
            }
            [
                sum[0] as f32,
                sum[1] as f32,
                sum[2] as f32,
                in_front.len() as f32,
            ]
        })
        .collect();
    let (width, height) = (opts.frame.width, opts.frame.height);
    (
        LinearImage {
            width,
            height,
            pixels,
        },
        partly_covered,
    )
}

/// The full frame's options: deferred at 80×80, no tone mapping, a dark background; changed by
/// `change`.
fn full_frame_options(change: impl FnOnce(&mut RenderOptions)) -> RenderOptions {
    options_with(Some(Pipeline::Deferred), 80, |o| {
        o.build.lighting.tonemap = Tonemap::None;
        o.frame.background = crate::scene::Background::Color([0.02, 0.03, 0.05]);
        change(o);
    })
}

/// The full frame: the transparent method over the deferred image equals the reference's
/// transparent fragments (those in front of the opaque depth) composited over that same
/// deferred image.
#[test]
fn the_transparent_method_over_the_deferred_image_equals_the_reference_composite() {
    let scene = room(mixed_lights());
    let opts = full_frame_options(|_| {});
    let expected = Expected {
        image: composite_over_deferred(&scene, &opts).0,
        effect: Effect::Transparency,
    };
    for method in ["abuffer-ll", "dual", "kplus-array"] {
        let opts = {
            let mut options = opts.clone();
            options.frame.k = Some(4);
            options
        };
        let (actual, _) = render(&scene, &opts, method);
        expected.assert_exact(&format!("full-frame-{method}"), &actual);
    }
}

/// --msaa 4 with the pipeline: the lit opaque frame stays single-sampled, the transparent
/// fragments in front of its depth at the pixel center are composited per sample over the lit
/// pixel and averaged — for the methods that keep every fragment, each sample's k nearest, and
/// peel — and the reference agrees.
#[test]
fn multisampled_transparency_over_the_single_sampled_deferred_image() {
    let scene = room(mixed_lights());
    let opts = full_frame_options(|o| {
        o.build.msaa = 4;
        o.frame.k = Some(4);
    });
    let (expected, partly_covered) = composite_over_deferred(&scene, &opts);
    assert!(partly_covered > 20, "{partly_covered} edge pixels");
    let expected = Expected {
        image: expected,
        effect: Effect::Transparency,
    };
    let reference = crate::reference::render(&scene, &opts).unwrap().0;
    expected.assert_exact("msaa-deferred-reference", &reference);
    for method in ["abuffer-ll", "kplus-heap", "f2b"] {
        let (actual, _) = render(&scene, &opts, method);
        expected.assert_exact(&format!("msaa-deferred-{method}"), &actual);
    }
}

#[test]
fn a_scene_without_opaque_or_without_transparent_objects_renders_with_a_pipeline() {
    let all_transparent = {
        let mut s = room(mixed_lights());
        s.override_alpha(0.5);
        s
    };
    let all_opaque = {
        let mut s = room(mixed_lights());
        s.override_alpha(1.0);
        s
    };
    for (name, scene) in [("transparent", all_transparent), ("opaque", all_opaque)] {
        check_both_pipelines(&format!("only-{name}"), &scene, |_| {});
    }
}

/// `scene` through abuffer-ll with each pipeline (48², `adjust` applied to the options) equals
/// the reference: forward within the exact methods' bound, deferred within the G-buffer's.
fn check_both_pipelines(name: &str, scene: &Scene, adjust: impl Fn(&mut RenderOptions)) {
    for pipeline in [Pipeline::Forward, Pipeline::Deferred] {
        let mut opts = options(Some(pipeline), 48);
        adjust(&mut opts);
        let (image, _) = abuffer_ll(scene, &opts);
        let expected = render_reference(scene, &opts);
        let (max_diff, fraction) = match pipeline {
            Pipeline::Forward => (EXACT_MAX_DIFF, EXACT_MAX_FRACTION),
            Pipeline::Deferred => (DEFERRED_MAX_DIFF, DEFERRED_NEAR_FRACTION),
        };
        assert_close(
            &format!("{name}-{pipeline:?}"),
            &image,
            &expected,
            Effect::Transparency,
            max_diff,
            fraction,
        );
    }
}

/// Multiply and add materials over the lit image and over the background: a multiply pane in
/// front of the whole view tints the room and the background by channel (the background is
/// drawn under the lit image first), the room's glass adds its light.
#[test]
fn blend_modes_over_the_lit_image_and_the_background_equal_the_reference() {
    let mut scene = room(mixed_lights());
    let glass = scene
        .materials
        .iter()
        .position(|m| m.name == "glass")
        .unwrap();
    scene.materials[glass].blend = crate::scene::Blend::Add;
    let mut tint = material("tint", [0.9, 0.35, 0.2], 0.6, 16.0);
    tint.shading = Shading::Unlit;
    tint.blend = crate::scene::Blend::Multiply;
    let tint = scene.add_material(tint);
    object(
        &mut scene,
        "pane",
        quad(),
        Mat4::from_translation(Vec3::new(0.5, 2.0, 3.0)) * Mat4::from_scale(Vec3::splat(6.0)),
        tint,
    );
    check_both_pipelines("blend-modes", &scene, |opts| {
        opts.build.lighting.tonemap = Tonemap::None;
        opts.frame.background = crate::scene::Background::Color([0.1, 0.6, 0.9]);
    });
}

#[test]
fn the_headlight_and_unlit_materials_match_forward() {
    let mut scene = room(Vec::new());
    scene.materials[1].shading = Shading::Unlit;
    assert_deferred_matches_forward("headlight", &scene, 64);
}

/// The G-buffer's normal error measured on the GPU (the debug view compares the decoded normal
/// with the one before encoding). Bounds: the CPU twin's maxima for this 50° view (spheremap
/// 0.32° for z ≥ −0.55, octahedral 0.24°) times 1.5, because Vulkan lets an implementation
/// convert floats to unorm by rounding toward zero, which doubles the worst step error; lavapipe
/// measured 0.26° for both.
#[test]
fn the_normal_error_view_measures_the_encoding_within_its_bound() {
    let scene = room(mixed_lights());
    for (encoding, bound) in [
        (NormalEncoding::Spheremap, 0.48),
        (NormalEncoding::Octahedral, 0.36),
    ] {
        let opts = options_with(Some(Pipeline::Deferred), 64, |o| {
            o.build.lighting.normal_encoding = encoding;
            o.build.lighting.gbuffer_debug = Some(GbufferView::NormalError);
        });
        let mut renderer = crate::Renderer::new(gpu(), &scene, &opts).unwrap();
        renderer.render("abuffer-ll").unwrap();
        let lit = renderer.recorder().unwrap().lit().unwrap();
        let errors = readback::read_rgba16f(gpu(), lit.hdr()).unwrap();
        let max = errors.iter().map(|p| p[0]).fold(0.0f32, f32::max);
        let covered = errors.iter().filter(|p| p[0] > 0.0).count();
        assert!(max < bound, "{encoding:?}: {max}°");
        // The view measures something: most covered pixels carry some quantization error.
        assert!(
            covered > 64 * 64 / 4,
            "{encoding:?}: {covered} pixels with an error"
        );
    }
}

#[test]
fn every_gbuffer_view_renders_and_differs_from_the_picture() {
    let scene = room(mixed_lights());
    let picture = abuffer_ll(&scene, &options(Some(Pipeline::Deferred), 48)).0;
    let mut views = Vec::new();
    for view in [
        GbufferView::Albedo,
        GbufferView::Normal,
        GbufferView::Specular,
        GbufferView::Material,
        GbufferView::Depth,
        GbufferView::Lights,
        GbufferView::NormalError,
        GbufferView::Occlusion,
    ] {
        let opts = options_with(Some(Pipeline::Deferred), 48, |o| {
            o.build.lighting.gbuffer_debug = Some(view)
        });
        let image = abuffer_ll(&scene, &opts).0;
        assert_ne!(image.pixels, picture.pixels, "{view:?}");
        views.push(image.pixels);
    }
    for i in 0..views.len() {
        for j in i + 1..views.len() {
            assert_ne!(views[i], views[j], "views {i} and {j}");
        }
    }
}

#[test]
fn ssao_darkens_the_floor_by_the_cube_and_not_the_open_floor() {
    let scene = room(vec![Light {
        kind: LightKind::Ambient,
        color: [0.8; 3],
        ..Light::default()
    }]);
    let size = 96;
    let plain = abuffer_ll(&scene, &options(Some(Pipeline::Deferred), size)).0;
    let opts = options_with(Some(Pipeline::Deferred), size, |o| {
        o.build.lighting.ssao = true
    });
    let (occluded, stats) = abuffer_ll(&scene, &opts);
    assert!(stats.gpu_ms.unwrap().contains_key("deferred.ssao"));
    let camera = scene.camera.unwrap();
    let view_proj = camera.view_projection(1.0);
    let pixel_of = |p: Vec3| {
        let c = view_proj.project_point3(p);
        let x = ((c.x * 0.5 + 0.5) * size as f32) as u32;
        let y = ((0.5 - c.y * 0.5) * size as f32) as u32;
        (y * size + x) as usize
    };
    let luminance =
        |img: &LinearImage, i: usize| img.pixels[i][0] + img.pixels[i][1] + img.pixels[i][2];
    // The floor just in front of the cube, and a floor point far from everything.
    let by_the_cube = pixel_of(Vec3::new(-1.0, 0.0, 0.35));
    let open = pixel_of(Vec3::new(2.2, 0.0, 2.0));
    let (near_with, near_without) = (
        luminance(&occluded, by_the_cube),
        luminance(&plain, by_the_cube),
    );
    assert!(
        near_with < 0.95 * near_without,
        "by the cube: {near_with} vs {near_without}"
    );
    assert!(luminance(&occluded, open) > 0.98 * luminance(&plain, open));
    let total = |img: &LinearImage| {
        (0..img.pixels.len())
            .map(|i| luminance(img, i))
            .sum::<f32>()
    };
    assert!(total(&occluded) < 0.99 * total(&plain));
}

#[test]
fn the_light_field_is_deterministic_and_reaches_the_scene() {
    let mut a = room(Vec::new());
    let mut b = room(Vec::new());
    a.add_light_field(50, 3);
    b.add_light_field(50, 3);
    assert_eq!(a.lights, b.lights);
    assert_eq!(a.lights.len(), 50);
    let (lo, hi) = a.bounds();
    for l in &a.lights {
        assert!(
            l.position.cmpge(lo - 1e-3).all() && l.position.y <= hi.y + 0.2 * (hi - lo).length()
        );
        assert!(l.range > 0.0 && l.attenuation[2] > 0.0);
    }
    let mut c = room(Vec::new());
    c.add_light_field(50, 4);
    assert_ne!(a.lights, c.lights);
}

#[test]
fn splitting_by_opacity_keeps_order_materials_and_camera() {
    let scene = room(mixed_lights());
    let (opaque, transparent) = scene.split_by_opacity();
    let names = |s: &Scene| s.objects.iter().map(|o| o.name.clone()).collect::<Vec<_>>();
    assert_eq!(names(&opaque), ["floor", "wall", "cube", "ball"]);
    assert_eq!(names(&transparent), ["glass"]);
    assert_eq!(transparent.materials.len(), 1);
    assert_eq!(transparent.materials[0].name, "glass");
    assert_eq!(opaque.camera, scene.camera);
    assert_eq!(opaque.lights, scene.lights);
}

#[test]
fn options_that_need_the_deferred_pipeline_say_so() {
    for opts in [
        options_with(Some(Pipeline::Forward), 16, |o| {
            o.build.lighting.ssao = true
        }),
        options_with(None, 16, |o| {
            o.build.lighting.gbuffer_debug = Some(GbufferView::Normal)
        }),
    ] {
        let e = opts.validate().unwrap_err().to_string();
        assert!(e.contains("--pipeline deferred"), "{e}");
    }
}
