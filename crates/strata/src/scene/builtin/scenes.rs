//! The built-in scene generators.

use std::f32::consts::TAU;
use std::sync::Arc;

use glam::{Mat4, Quat, Vec3};

use super::models::model_mesh;
use super::params::Params;
use super::primitives::{cube, uv_sphere, uv_sphere_triangles};
use crate::error::{Error, Result};
use crate::scene::hsv;
use crate::scene::rng::SplitMix64;
use crate::scene::{
    Camera, Light, LightKind, Material, Mesh, Object, ObjectMotion, Orbit, Projection,
    RenderDefaults, Scene, Shading,
};

fn point_light(position: Vec3, color: [f32; 3], intensity: f32, range: f32) -> Light {
    Light {
        kind: LightKind::Point,
        position,
        color,
        intensity,
        range,
        ..Light::default()
    }
}

fn material(name: String, color: [f32; 3], opacity: f32) -> Material {
    Material {
        name,
        color,
        opacity,
        ..Material::default()
    }
}

// ---------------------------------------------------------------------------------------------
// layers

/// Half-size of the `layers` quads beyond the view: each quad spans y ∈ [−E, E] and
/// x ∈ [−E, −1 + 2·coverage], so it covers the view whatever its aspect (up to E).
pub const LAYERS_EXTENT: f32 = 100.0;

/// World z of layer `i` of `n` in `builtin:layers`: layer 0 is nearest the camera (z = 0, the
/// camera is at z = 10 looking down −Z), the others step back by min(0.5, 9/(n−1)) so every
/// layer stays inside the far plane.
pub fn layer_depth(i: usize, n: usize) -> f32 {
    let step = if n > 1 {
        (9.0 / (n - 1) as f32).min(0.5)
    } else {
        0.5
    };
    -(i as f32) * step
}

/// Color (linear RGB) and opacity of the layers of `builtin:layers?n=N`, nearest first: hues
/// evenly spaced around the color wheel (saturation 0.75, value 0.9), opacities cycling through
/// 0.25, 0.4167, 0.5833, 0.75. A pixel inside the covered part of the view composites them front
/// to back over the background: C = Σ_i (Π_{j<i} (1−α_j)) α_i c_i + (Π_i (1−α_i)) · background.
pub fn layer_colors(n: usize) -> Vec<([f32; 3], f32)> {
    (0..n)
        .map(|i| {
            let color = hsv(i as f32 / n as f32, 0.75, 0.9);
            let opacity = 0.25 + 0.5 * (i % 4) as f32 / 3.0;
            (color, opacity)
        })
        .collect()
}

/// `layers?n=16&coverage=0.75&order=random&seed=1`: `n` unlit screen-aligned quads under an
/// orthographic camera (eye (0,0,10) looking at the origin, view height 2, near 0.1, far 20).
/// Each quad covers the full view height and, horizontally, everything left of
/// x = −1 + 2·coverage: for a square image that is exactly the left `coverage` of the columns
/// (for an aspect a the view spans x ∈ [−a, a], so the covered fraction is (a − 1 + 2·coverage)/2a).
/// Layer i sits at [`layer_depth`]`(i, n)`, with material i = [`layer_colors`]`(n)[i]`; objects
/// are named `layer i`. `order` is the submission order: `front` (nearest first), `back`
/// (farthest first) or `random` (a shuffle seeded by `seed`).
pub(super) fn layers(p: &Params) -> Result<Scene> {
    let n = p.int("n", 16, 1, 1024)? as usize;
    let coverage = p.float("coverage", 0.75, 0.0, 1.0)?;
    let order = p.choice("order", &["random", "front", "back"])?;
    let seed = p.int("seed", 1, 0, u64::MAX)?;

    let mut scene = Scene {
        camera: Some(Camera {
            eye: Vec3::new(0.0, 0.0, 10.0),
            target: Vec3::ZERO,
            up: Vec3::Y,
            projection: Projection::Orthographic { height: 2.0 },
            near: 0.1,
            far: 20.0,
        }),
        defaults: RenderDefaults {
            shading: Some(Shading::Unlit),
            ..RenderDefaults::default()
        },
        ..Scene::default()
    };
    for (i, (color, opacity)) in layer_colors(n).into_iter().enumerate() {
        scene.add_material(Material {
            shading: Shading::Unlit,
            ..material(format!("layer {i}"), color, opacity)
        });
    }
    let mut submission: Vec<usize> = (0..n).collect();
    match order {
        "back" => submission.reverse(),
        "random" => SplitMix64::new(seed).shuffle(&mut submission),
        _ => {}
    }
    let (e, right) = (LAYERS_EXTENT, -1.0 + 2.0 * coverage);
    for i in submission {
        let z = layer_depth(i, n);
        let mesh = Mesh {
            positions: vec![[-e, -e, z], [right, -e, z], [right, e, z], [-e, e, z]],
            normals: vec![[0.0, 0.0, 1.0]; 4],
            indices: vec![0, 1, 2, 0, 2, 3],
        };
        scene.objects.push(Object {
            name: format!("layer {i}"),
            mesh,
            material: i,
        });
    }
    Ok(scene)
}

// ---------------------------------------------------------------------------------------------
// spheres

/// The `layers` parameter (default 16, 2..=512) of a scene `name` of closed `shell`s, each of
/// which gives a pixel two layers: it must be even.
fn even_layers(p: &Params, name: &str, shell: &str) -> Result<u64> {
    let layers = p.int("layers", 16, 2, 512)?;
    if layers % 2 != 0 {
        return Err(Error::input(format!(
            "builtin:{name}: layers={layers} must be even (each {shell} gives 2 layers)"
        )));
    }
    Ok(layers)
}

/// `spheres?layers=16&segments=48`: `layers/2` concentric UV spheres, radii evenly spaced from
/// 0.3 to 1.0 (a single sphere has radius 1), innermost first; each its own hue, opacity 0.3,
/// lit by two point lights; perspective camera on +Z looking at the centre.
pub(super) fn spheres(p: &Params) -> Result<Scene> {
    let layers = even_layers(p, "spheres", "shell")?;
    let segments = p.int("segments", 48, 3, 4096)? as u32;
    let count = (layers / 2) as usize;
    crate::scene::check_triangle_estimate(
        &format!("builtin:spheres: layers={layers} × segments={segments}"),
        count as u64 * uv_sphere_triangles(segments),
    )?;
    let unit = uv_sphere(segments);
    let mut scene = Scene::default();
    for k in 0..count {
        let r = if count == 1 {
            1.0
        } else {
            0.3 + 0.7 * k as f32 / (count - 1) as f32
        };
        let color = hsv(k as f32 / count as f32, 0.7, 0.95);
        let m = scene.add_material(material(format!("shell {k}"), color, 0.3));
        scene.objects.push(Object {
            name: format!("shell {k}"),
            mesh: unit.transformed(Mat4::from_scale(Vec3::splat(r))),
            material: m,
        });
    }
    scene.camera = Some(Camera::toward_origin(Vec3::new(0.0, 0.0, 3.5), 10.0));
    scene.lights = vec![
        point_light(Vec3::new(2.0, 3.0, 4.0), [1.0, 1.0, 1.0], 1.0, 15.0),
        point_light(Vec3::new(-3.0, -1.0, 2.0), [0.7, 0.8, 1.0], 0.5, 15.0),
    ];
    Ok(scene)
}

// ---------------------------------------------------------------------------------------------
// stack

/// `stack?layers=16&columns=2&segments=200`: seed 001's layered-sphere scene (its Fig. 6): a
/// `columns`×`columns` square of columns of unit UV spheres, each column `layers/2` spheres deep
/// along the view axis (a sphere gives 2 layers), 2.5 apart, one hue per depth, opacity 0.25, lit
/// by two point lights; an orthographic camera on +Z looks down the columns. The defaults are the
/// paper's: 4 columns of 39,600-triangle spheres, 1,267,200 triangles at 16 layers.
pub(super) fn stack(p: &Params) -> Result<Scene> {
    let layers = even_layers(p, "stack", "sphere")?;
    let columns = p.int("columns", 2, 1, 64)? as usize;
    let segments = p.int("segments", 200, 3, 4096)? as u32;
    let depth = (layers / 2) as usize;
    crate::scene::check_triangle_estimate(
        &format!("builtin:stack: layers={layers} × columns={columns}² × segments={segments}"),
        (depth * columns * columns) as u64 * uv_sphere_triangles(segments),
    )?;
    const SPACING: f32 = 2.5;
    let unit = uv_sphere(segments);
    let mut scene = Scene::default();
    let materials: Vec<usize> = (0..depth)
        .map(|d| {
            let color = hsv(d as f32 / depth as f32, 0.7, 0.95);
            scene.add_material(material(format!("depth {d}"), color, 0.25))
        })
        .collect();
    let centre = (columns as f32 - 1.0) * 0.5;
    let front = (depth as f32 - 1.0) * 0.5 * SPACING;
    for row in 0..columns {
        for column in 0..columns {
            for (d, &m) in materials.iter().enumerate() {
                let at = Vec3::new(
                    (column as f32 - centre) * SPACING,
                    (row as f32 - centre) * SPACING,
                    front - d as f32 * SPACING,
                );
                scene.objects.push(Object {
                    name: format!("sphere {row},{column},{d}"),
                    mesh: unit.transformed(Mat4::from_translation(at)),
                    material: m,
                });
            }
        }
    }
    let half_width = centre * SPACING + 1.0;
    scene.camera = Some(Camera {
        eye: Vec3::new(0.0, 0.0, front + 5.0),
        target: Vec3::ZERO,
        up: Vec3::Y,
        projection: Projection::Orthographic {
            height: 2.0 * half_width * 1.05,
        },
        near: 1.0,
        far: 2.0 * front + 10.0,
    });
    scene.lights = vec![
        point_light(
            Vec3::new(3.0, 4.0, front + 4.0),
            [1.0, 1.0, 1.0],
            1.0,
            4.0 * front + 20.0,
        ),
        point_light(
            Vec3::new(-4.0, -2.0, front + 2.0),
            [0.7, 0.8, 1.0],
            0.5,
            4.0 * front + 20.0,
        ),
    ];
    Ok(scene)
}

// ---------------------------------------------------------------------------------------------
// nvpro

/// `nvpro?objects=1024&subdiv=16&seed=0`: `objects` UV spheres (`subdiv` segments) centred
/// uniformly in [-1,1]³, radius uniform in [0.05, 0.25)·∛(1024/objects) (so the density stays
/// alike), random linear colors in [0.05, 1)³ and opacity in [0.3, 0.8); one object and one
/// material per sphere; lit by two point lights; a perspective camera at (0, 1, 4.8) looking at the centre.
pub(super) fn nvpro(p: &Params) -> Result<Scene> {
    let objects = p.int("objects", 1024, 1, 100_000)? as usize;
    let subdiv = p.int("subdiv", 16, 3, 256)? as u32;
    let seed = p.int("seed", 0, 0, u64::MAX)?;
    crate::scene::check_triangle_estimate(
        &format!("builtin:nvpro: objects={objects} × subdiv={subdiv}"),
        objects as u64 * uv_sphere_triangles(subdiv),
    )?;
    let mut rng = SplitMix64::new(seed);
    let unit = uv_sphere(subdiv);
    let scale = (1024.0 / objects as f32).cbrt();
    let mut scene = Scene::default();
    for i in 0..objects {
        let centre = Vec3::new(
            rng.range(-1.0, 1.0),
            rng.range(-1.0, 1.0),
            rng.range(-1.0, 1.0),
        );
        let radius = rng.range(0.05, 0.25) * scale;
        let color = [0; 3].map(|_| rng.range(0.05, 1.0));
        let opacity = rng.range(0.3, 0.8);
        let m = scene.add_material(material(format!("sphere {i}"), color, opacity));
        scene.objects.push(Object {
            name: format!("sphere {i}"),
            mesh: unit.transformed(Mat4::from_scale_rotation_translation(
                Vec3::splat(radius),
                Quat::IDENTITY,
                centre,
            )),
            material: m,
        });
    }
    scene.camera = Some(Camera::toward_origin(Vec3::new(0.0, 1.0, 4.8), 20.0));
    scene.lights = vec![
        point_light(Vec3::new(3.0, 4.0, 5.0), [1.0, 1.0, 1.0], 1.0, 20.0),
        point_light(Vec3::new(-4.0, -2.0, 3.0), [0.8, 0.85, 1.0], 0.6, 20.0),
    ];
    Ok(scene)
}

// ---------------------------------------------------------------------------------------------
// balls

/// Frames per second of `builtin:balls` (its `frame` parameter counts these).
pub(crate) const BALLS_FPS: f32 = 30.0;

/// `balls?count=1000&frame=0&segments=12&radius=R`: `count` spheres (`segments` around, half as
/// many rings; radius R, default 0.04·∛(1000/count)) each on its own seeded circular orbit (centre
/// in [-0.7,0.7]³, orbit radius in [0.1, 0.5), random axis, angular speed ±[0.5, 2) rad/s at 30
/// frames per second, random phase), placed at time `frame`. Each ball is one object with an
/// [`ObjectMotion`] (the unit sphere, its radius, its orbit), so the GPU moves it without
/// rebuilding meshes. Random hue, opacity 0.5, lit; a fixed perspective camera at
/// (0, 0.7, 3.8) looking at the centre. `scene.time` = frame.
pub(super) fn balls(p: &Params) -> Result<Scene> {
    let count = p.int("count", 1000, 1, 1_000_000)? as usize;
    let frame = p.float("frame", 0.0, 0.0, 1.0e6)?;
    let segments = p.int("segments", 12, 3, 256)? as u32;
    let default_radius = 0.04 * (1000.0 / count as f32).cbrt();
    let radius = p.float("radius", default_radius, 1e-4, 10.0)?;
    crate::scene::check_triangle_estimate(
        "builtin:balls",
        count as u64 * uv_sphere_triangles(segments),
    )?;
    let mut rng = SplitMix64::new(0xBA11_5EED);
    let unit = Arc::new(uv_sphere(segments));
    let mut scene = Scene::default();
    for i in 0..count {
        let centre = Vec3::new(
            rng.range(-0.7, 0.7),
            rng.range(-0.7, 0.7),
            rng.range(-0.7, 0.7),
        );
        let orbit_radius = rng.range(0.1, 0.5);
        let axis = rng.unit_vector();
        let u = axis.any_orthonormal_vector();
        let v = axis.cross(u);
        let speed = rng.range(0.5, 2.0) * if rng.next_f32() < 0.5 { -1.0 } else { 1.0 };
        let phase = rng.range(0.0, TAU);
        let hue = rng.next_f32();
        let motion = ObjectMotion {
            local: unit.clone(),
            scale: radius,
            orbit: Orbit {
                centre,
                radius: orbit_radius,
                u,
                v,
                angular_speed: speed / BALLS_FPS,
                phase,
            },
        };
        let m = scene.add_material(material(format!("ball {i}"), hsv(hue, 0.65, 0.9), 0.5));
        scene.objects.push(Object {
            name: format!("ball {i}"),
            mesh: Mesh::default(),
            material: m,
        });
        scene.motions.push(Some(motion));
    }
    scene.camera = Some(Camera::toward_origin(Vec3::new(0.0, 0.7, 3.8), 20.0));
    scene.lights = vec![
        point_light(Vec3::new(3.0, 4.0, 5.0), [1.0, 0.95, 0.9], 1.0, 20.0),
        point_light(Vec3::new(-4.0, 1.0, -3.0), [0.7, 0.8, 1.0], 0.6, 20.0),
    ];
    scene.set_time(frame);
    Ok(scene)
}

// ---------------------------------------------------------------------------------------------
// models and demo

/// One embedded model (`?subdivide=N`: N Loop subdivision steps, 4^N times the triangles) with
/// the default material, auto-framed camera, no lights (headlight).
pub(super) fn model(name: &str, p: &Params) -> Result<Scene> {
    let steps = p.int("subdivide", 0, 0, 4)? as u32;
    let mut mesh = model_mesh(name)?;
    crate::scene::check_triangle_estimate(
        &format!("builtin:{name}: subdivide={steps}"),
        mesh.triangle_count() as u64 * 4u64.pow(steps),
    )?;
    for _ in 0..steps {
        mesh = crate::scene::subdivide::loop_subdivide(&mesh);
    }
    let mut scene = Scene::default();
    let m = scene.add_material(Material::default());
    scene.objects.push(Object {
        name: name.to_string(),
        mesh,
        material: m,
    });
    Ok(scene)
}

/// `mesh` scaled so its largest extent is `size`, turned by `yaw_deg` about Y, standing on y = 0
/// centred at (x, z).
fn place_on_floor(mesh: &Mesh, size: f32, yaw_deg: f32, x: f32, z: f32) -> Mesh {
    let (lo, hi) = mesh.bounds();
    let s = size / (hi - lo).max_element();
    let centre = (lo + hi) * 0.5;
    let m = Mat4::from_rotation_y(yaw_deg.to_radians())
        * Mat4::from_scale(Vec3::splat(s))
        * Mat4::from_translation(-centre);
    let turned = mesh.transformed(m);
    let (lo, _) = turned.bounds();
    turned.transformed(Mat4::from_translation(Vec3::new(x, -lo.y, z)))
}

/// A checkerboard floor at y = 0: `cells`×`cells` unit squares centred on the origin, as two
/// meshes (light cells, dark cells) facing +Y.
fn checker_floor(cells: i32) -> [Mesh; 2] {
    let mut out = [Mesh::default(), Mesh::default()];
    let h = cells as f32 / 2.0;
    for i in 0..cells {
        for j in 0..cells {
            let m = &mut out[((i + j) % 2) as usize];
            let (x0, z0) = (i as f32 - h, j as f32 - h);
            let base = m.positions.len() as u32;
            // CCW seen from +Y.
            m.positions.extend_from_slice(&[
                [x0, 0.0, z0 + 1.0],
                [x0 + 1.0, 0.0, z0 + 1.0],
                [x0 + 1.0, 0.0, z0],
                [x0, 0.0, z0],
            ]);
            m.normals.extend_from_slice(&[[0.0, 1.0, 0.0]; 4]);
            m.indices
                .extend_from_slice(&[base, base + 1, base + 2, base, base + 2, base + 3]);
        }
    }
    out
}

/// The default scene: spot (orange), the teapot (teal) and suzanne (magenta), translucent
/// (opacity 0.35–0.45, absorption 0.8, ior 1.5) and overlapping in view, standing on an opaque
/// checkerboard floor (12×12 unit cells at y = 0, so the see-through shows) with two opaque
/// objects behind them (a polished gold ball, a stone column); three point lights (warm key,
/// cool fill, rim) and a ring of twelve coloured point lights low over the floor; a perspective
/// camera looking slightly down. Meant for the deferred pipeline (its default). About 26K
/// triangles.
pub(super) fn demo() -> Result<Scene> {
    let mut scene = Scene::default();
    for (name, grey, mesh) in ["floor light", "floor dark"]
        .into_iter()
        .zip([0.5, 0.25])
        .zip(checker_floor(12))
        .map(|((n, g), m)| (n, g, m))
    {
        let m = scene.add_material(Material {
            name: name.into(),
            color: [grey; 3],
            opacity: 1.0,
            absorption: 0.0,
            ior: 1.5,
            shading: Shading::Lit,
            ..Material::default()
        });
        scene.objects.push(Object {
            name: name.into(),
            mesh,
            material: m,
        });
    }
    // (model, color, opacity, size, yaw, x, z)
    let models = [
        ("teapot", [0.1, 0.65, 0.7], 0.35, 1.5, 25.0, 0.1, -0.9),
        ("spot", [0.95, 0.45, 0.12], 0.4, 1.3, -140.0, -0.9, 0.25),
        ("suzanne", [0.75, 0.22, 0.65], 0.45, 1.2, -20.0, 0.9, 0.35),
    ];
    for (name, color, opacity, size, yaw, x, z) in models {
        let m = scene.add_material(Material {
            name: name.into(),
            color,
            opacity,
            absorption: 0.8,
            ior: 1.5,
            shading: Shading::Lit,
            ..Material::default()
        });
        scene.objects.push(Object {
            name: name.into(),
            mesh: place_on_floor(&model_mesh(name)?, size, yaw, x, z),
            material: m,
        });
    }
    scene.camera = Some(Camera {
        eye: Vec3::new(0.0, 1.8, 5.0),
        target: Vec3::new(0.0, 0.5, -0.1),
        up: Vec3::Y,
        projection: Projection::Perspective { fov_y_deg: 40.0 },
        near: 0.1,
        far: 30.0,
    });
    // (name, mesh, transform, color, shininess)
    let opaque = [
        (
            "gold ball",
            uv_sphere(48),
            Mat4::from_translation(Vec3::new(-0.7, 0.42, -2.4))
                * Mat4::from_scale(Vec3::splat(0.42)),
            [0.85, 0.62, 0.22],
            160.0,
        ),
        (
            "column",
            cube(),
            Mat4::from_translation(Vec3::new(1.55, 0.7, -2.1))
                * Mat4::from_rotation_y(0.6)
                * Mat4::from_scale(Vec3::new(0.25, 0.7, 0.25)),
            [0.72, 0.7, 0.66],
            12.0,
        ),
    ];
    for (name, mesh, transform, color, shininess) in opaque {
        let m = scene.add_material(Material {
            name: name.into(),
            color,
            opacity: 1.0,
            shininess,
            ..Material::default()
        });
        scene.objects.push(Object {
            name: name.into(),
            mesh: mesh.transformed(transform),
            material: m,
        });
    }
    scene.lights = vec![
        point_light(Vec3::new(3.0, 4.0, 4.0), [1.0, 0.95, 0.85], 0.6, 20.0),
        point_light(Vec3::new(-4.0, 2.5, 2.0), [0.6, 0.7, 1.0], 0.3, 20.0),
        point_light(Vec3::new(0.0, 3.0, -4.0), [1.0, 1.0, 1.0], 0.4, 20.0),
    ];
    // Coloured pools of light around the models: a ring low over the floor, hues evenly spaced.
    let ring = 12;
    for i in 0..ring {
        let a = i as f32 / ring as f32 * std::f32::consts::TAU;
        let hue = i as f32 / ring as f32;
        let channel = |offset: f32| {
            let x = ((hue + offset).fract() * 6.0 - 3.0).abs() - 1.0;
            0.2 + 0.8 * x.clamp(0.0, 1.0)
        };
        let range = 1.8;
        scene.lights.push(Light {
            attenuation: [1.0, 0.0, 12.0 / (range * range)],
            ..point_light(
                Vec3::new(2.6 * a.cos(), 0.3, -0.5 + 2.0 * a.sin()),
                [channel(0.0), channel(2.0 / 3.0), channel(1.0 / 3.0)],
                3.0,
                range,
            )
        });
    }
    scene.defaults.pipeline = Some(crate::scene::Pipeline::Deferred);
    // A dark backdrop so that the pools of light read; `--background` overrides it.
    scene.defaults.background = Some(crate::scene::Background::Color([0.018, 0.02, 0.026]));
    Ok(scene)
}

#[cfg(test)]
mod tests {
    use super::super::build;
    use super::*;

    fn built(spec: &str) -> Scene {
        let s = build(spec).unwrap_or_else(|e| panic!("{spec}: {e}"));
        s.validate().unwrap_or_else(|e| panic!("{spec}: {e}"));
        s
    }

    #[test]
    fn every_builtin_builds_and_validates() {
        for name in super::super::builtin_names() {
            let s = built(name);
            assert!(s.triangle_count() > 0, "{name}");
        }
    }

    #[test]
    fn demo_is_small_and_fits_the_view() {
        let s = built("demo");
        assert!(s.triangle_count() < 30_000, "{}", s.triangle_count());
        assert!(s.lights.len() >= 2);
        let cam = s.camera.unwrap();
        let vp = cam.view_projection(1.0);
        for o in &s.objects[2..] {
            let (lo, _) = o.mesh.bounds();
            assert!(lo.y.abs() < 1e-4, "{} floats: {lo}", o.name);
            // Every vertex inside the view of a square image, with a margin.
            for &p in &o.mesh.positions {
                let ndc = vp.project_point3(Vec3::from(p));
                assert!(
                    ndc.x.abs() < 0.95 && ndc.y.abs() < 0.95,
                    "{}: {ndc}",
                    o.name
                );
            }
        }
        assert_eq!(s.materials[s.objects[0].material].opacity, 1.0);
        assert_eq!(s.materials[s.objects[1].material].opacity, 1.0);
    }

    #[test]
    fn layers_orders_are_permutations() {
        let key = |s: &Scene| {
            let mut v: Vec<(String, usize, Vec<[f32; 3]>)> = s
                .objects
                .iter()
                .map(|o| (o.name.clone(), o.material, o.mesh.positions.clone()))
                .collect();
            v.sort_by(|a, b| a.0.cmp(&b.0));
            v
        };
        let front = built("layers?n=16&order=front");
        let back = built("layers?n=16&order=back");
        let random = built("layers?n=16&order=random&seed=1");
        assert_eq!(key(&front), key(&back));
        assert_eq!(key(&front), key(&random));
        assert_eq!(front.materials, random.materials);
        let z =
            |s: &Scene| -> Vec<f32> { s.objects.iter().map(|o| o.mesh.positions[0][2]).collect() };
        let zf = z(&front);
        assert!(
            zf.windows(2).all(|w| w[0] > w[1]),
            "front: nearest (largest z) first"
        );
        let mut zb = z(&back);
        zb.reverse();
        assert_eq!(zf, zb);
        let zr = z(&random);
        assert_ne!(zr, zf);
        assert_ne!(zr, z(&back));
        // Same seed, same shuffle; another seed, another one.
        assert_eq!(zr, z(&built("layers?n=16&seed=1")));
        assert_ne!(zr, z(&built("layers?n=16&seed=2")));
    }

    #[test]
    fn layers_geometry_matches_the_contract() {
        let s = built("layers?n=64&coverage=0.25&order=front");
        assert_eq!(s.defaults.shading, Some(Shading::Unlit));
        let cam = s.camera.unwrap();
        assert_eq!(cam.projection, Projection::Orthographic { height: 2.0 });
        let colors = layer_colors(64);
        let vp = cam.view_projection(1.0);
        for (i, o) in s.objects.iter().enumerate() {
            assert_eq!(o.material, i);
            let m = &s.materials[i];
            assert_eq!((m.color, m.opacity), colors[i]);
            assert_eq!(m.shading, Shading::Unlit);
            assert!(m.opacity > 0.0 && m.opacity < 1.0);
            let (lo, hi) = o.mesh.bounds();
            assert!((hi.x - (-0.5)).abs() < 1e-6);
            assert!(lo.x < -1.0 && lo.y < -1.0 && hi.y > 1.0);
            // Inside the depth range.
            let d = vp.project_point3(Vec3::new(0.0, 0.0, hi.z)).z;
            assert!(d > 0.0 && d < 1.0, "layer {i} depth {d}");
        }
        let distinct: std::collections::HashSet<_> =
            colors.iter().map(|(c, _)| c.map(f32::to_bits)).collect();
        assert_eq!(distinct.len(), 64);
    }

    #[test]
    fn spheres_give_layers_surfaces_along_the_axis() {
        let s = built("spheres?layers=6");
        assert_eq!(s.objects.len(), 3);
        let radii: Vec<f32> = s.objects.iter().map(|o| o.mesh.bounds().1.y).collect();
        assert!(
            (radii[0] - 0.3).abs() < 1e-5 && (radii[2] - 1.0).abs() < 1e-5,
            "{radii:?}"
        );
        assert_eq!(built("spheres").objects.len(), 8);
    }

    #[test]
    fn stack_is_the_papers_layered_spheres() {
        let s = built("stack?layers=6&columns=3&segments=8");
        assert_eq!(s.objects.len(), 3 * 3 * 3);
        let z: Vec<f32> = s.objects[..3].iter().map(|o| o.mesh.bounds().1.z).collect();
        assert!(z[0] > z[1] && z[1] > z[2], "{z:?}");
        // The paper's 16-layer scene: 32 spheres, 1,267,200 triangles.
        assert_eq!(4 * 8 * uv_sphere_triangles(200), 1_267_200);
        assert!(crate::scene::builtin::build("stack?layers=5").is_err());
    }

    #[test]
    fn nvpro_and_balls_are_seeded() {
        let a = built("nvpro?objects=32&subdiv=8&seed=3");
        let b = built("nvpro?objects=32&subdiv=8&seed=3");
        let c = built("nvpro?objects=32&subdiv=8&seed=4");
        assert_eq!(a.objects.len(), 32);
        assert_eq!(a.objects[5].mesh, b.objects[5].mesh);
        assert_ne!(a.objects[5].mesh, c.objects[5].mesh);
        for m in &a.materials {
            assert!((0.3..0.8).contains(&m.opacity));
        }
        let f0 = built("balls?count=20");
        let f0b = built("balls?count=20&frame=0");
        let f1 = built("balls?count=20&frame=10");
        assert_eq!(f0.objects[3].mesh, f0b.objects[3].mesh);
        assert_ne!(f0.objects[3].mesh, f1.objects[3].mesh);
        assert_eq!(f1.time, 10.0);
        assert_eq!(
            f0.camera, f1.camera,
            "the camera does not move with the balls"
        );
    }

    #[test]
    fn hsv_primaries() {
        assert_eq!(hsv(0.0, 1.0, 1.0), [1.0, 0.0, 0.0]);
        assert_eq!(hsv(1.0 / 3.0, 1.0, 1.0), [0.0, 1.0, 0.0]);
        assert_eq!(hsv(2.0 / 3.0, 1.0, 1.0), [0.0, 0.0, 1.0]);
    }
}
