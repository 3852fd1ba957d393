//! Scenes: meshes, materials, camera, lights and background, and the loaders and built-in
//! generators that produce them.
//!
//! A [`Scene`] keeps objects in world space. Rendering flattens it into one triangle list
//! ([`Scene::triangles`]) whose order is the *primitive index* every method and the CPU reference
//! use to break depth ties.

pub mod animation;
#[cfg(feature = "scenes")]
pub mod builtin;
#[cfg(feature = "scenes")]
pub mod export;
#[cfg(feature = "scenes")]
pub mod loaders;
pub mod pipeline;
pub(crate) mod rng;
pub mod subdivide;

pub use animation::{CameraKey, CameraPath, ObjectMotion, Orbit};
pub use pipeline::Pipeline;

use glam::{Mat4, Vec3};

use crate::error::{Error, Result};
use crate::keyword::keyword_enum;

/// The longest side of a picture, in pixels.
pub const MAX_SIDE: u32 = 16384;

/// The most triangles a scene may have, whatever its source: about 4 GiB of host memory at this
/// size (the objects' meshes and the flattened upload). Built-in scenes and loaders check their
/// estimate against it before allocating; the seeds' largest scenes (11.9M triangles) fit.
pub const MAX_SCENE_TRIANGLES: u64 = 1 << 25;

/// Host bytes one triangle costs while a scene is built and uploaded (meshes and flat vertices).
#[cfg(feature = "scenes")]
const HOST_BYTES_PER_TRIANGLE: u64 = 132;

/// Refuses `triangles` over [`MAX_SCENE_TRIANGLES`], naming `what` makes them.
#[cfg(feature = "scenes")]
pub(crate) fn check_triangle_estimate(what: &str, triangles: u64) -> Result<()> {
    if triangles <= MAX_SCENE_TRIANGLES {
        return Ok(());
    }
    Err(Error::input(format!(
        "{what} makes {triangles} triangles (about {:.1} GiB), more than the limit of {MAX_SCENE_TRIANGLES}",
        (triangles.saturating_mul(HOST_BYTES_PER_TRIANGLE)) as f64 / (1u64 << 30) as f64
    )))
}

keyword_enum! {
    /// How a fragment's color is computed from its material.
    #[derive(Default)]
    #[cfg_attr(feature = "serde", derive(serde::Deserialize))]
    pub enum Shading ("shading") {
        /// Fragment color = material color.
        Unlit = "unlit",
        /// Two-sided Blinn–Phong with the scene's lights (a headlight when there are none).
        #[default]
        Lit = "lit",
    }
}
pub use crate::resolve::Blend;

/// Surface appearance of one object.
#[derive(Clone, Debug, PartialEq)]
pub struct Material {
    /// The material's name in its scene file (for messages).
    pub name: String,
    /// Linear RGB.
    pub color: [f32; 3],
    /// Opacity α in [0, 1].
    pub opacity: f32,
    /// Beer–Lambert absorption σ per scene unit (translucency effect).
    pub absorption: f32,
    /// Index of refraction for Schlick Fresnel (translucency effect).
    pub ior: f32,
    /// Lit (Blinn–Phong under the scene's lights) or unlit (its color as is).
    pub shading: Shading,
    /// Blinn–Phong specular exponent, an integer in 1..=1023 (the deferred G-buffer stores it in
    /// 10 bits, so every pipeline uses the rounded value; see [`Material::exponent`]).
    pub shininess: f32,
    /// How its fragments combine with what lies behind them.
    pub blend: Blend,
}

/// Specular exponent of materials that do not set one.
pub const DEFAULT_SHININESS: f32 = 48.0;
/// Largest specular exponent: the G-buffer keeps it in 10 bits.
pub const MAX_SHININESS: f32 = 1023.0;

impl Material {
    /// Whether it hides what lies behind it: opacity 1 blending over (an add or multiply
    /// material at opacity 1 still shows what is behind it).
    pub fn is_opaque(&self) -> bool {
        self.opacity >= 1.0 && self.blend == Blend::Over
    }

    /// The specular exponent every pipeline shades with: `shininess` rounded into 1..=1023.
    pub fn exponent(&self) -> f32 {
        self.shininess.round().clamp(1.0, MAX_SHININESS)
    }
}

impl Default for Material {
    fn default() -> Self {
        Material {
            name: "default".into(),
            color: [0.8, 0.8, 0.8],
            opacity: 0.5,
            absorption: 0.0,
            ior: 1.5,
            shading: Shading::Lit,
            shininess: DEFAULT_SHININESS,
            blend: Blend::Over,
        }
    }
}

/// An indexed triangle mesh. Normals are per vertex; when a loader finds none they are computed.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Mesh {
    /// Vertex positions.
    pub positions: Vec<[f32; 3]>,
    /// Unit vertex normals, one per position.
    pub normals: Vec<[f32; 3]>,
    /// Three indices per triangle into `positions`.
    pub indices: Vec<u32>,
}

impl Mesh {
    /// Triangles of the mesh.
    pub fn triangle_count(&self) -> usize {
        self.indices.len() / 3
    }

    /// Checks what every renderer relies on: finite coordinates, indices in range, at least one
    /// triangle. `what` names the mesh in the error.
    pub fn validate(&self, what: &str) -> Result<()> {
        if self.indices.is_empty() {
            return Err(Error::input(format!("{what}: mesh has no triangles")));
        }
        if !self.indices.len().is_multiple_of(3) {
            return Err(Error::input(format!(
                "{what}: index count {} is not a multiple of 3",
                self.indices.len()
            )));
        }
        if let Some((i, p)) = self
            .positions
            .iter()
            .enumerate()
            .find(|(_, p)| !p.iter().all(|c| c.is_finite()))
        {
            return Err(Error::input(format!(
                "{what}: vertex {i} has a non-finite coordinate {p:?}"
            )));
        }
        let n = self.positions.len();
        if let Some((i, &idx)) = self
            .indices
            .iter()
            .enumerate()
            .find(|(_, &idx)| idx as usize >= n)
        {
            return Err(Error::input(format!(
                "{what}: index {idx} at position {i} is out of range ({n} vertices)"
            )));
        }
        if !self.normals.is_empty() && self.normals.len() != n {
            return Err(Error::input(format!(
                "{what}: {} normals for {n} vertices",
                self.normals.len()
            )));
        }
        Ok(())
    }

    /// Area-weighted vertex normals (replaces any existing ones).
    pub fn compute_normals(&mut self) {
        let mut acc = vec![Vec3::ZERO; self.positions.len()];
        for t in self.indices.chunks_exact(3) {
            let [a, b, c] = [t[0], t[1], t[2]].map(|i| Vec3::from(self.positions[i as usize]));
            let n = (b - a).cross(c - a);
            for &i in t {
                acc[i as usize] += n;
            }
        }
        self.normals = acc
            .into_iter()
            .map(|n| n.try_normalize().unwrap_or(Vec3::Z).to_array())
            .collect();
    }

    /// Returns the mesh transformed by `m` (normals by its inverse transpose).
    pub fn transformed(&self, m: Mat4) -> Mesh {
        let nm = m.inverse().transpose();
        Mesh {
            positions: self
                .positions
                .iter()
                .map(|&p| m.transform_point3(Vec3::from(p)).to_array())
                .collect(),
            normals: self
                .normals
                .iter()
                .map(|&n| {
                    nm.transform_vector3(Vec3::from(n))
                        .try_normalize()
                        .unwrap_or(Vec3::Z)
                        .to_array()
                })
                .collect(),
            indices: self.indices.clone(),
        }
    }

    /// Axis-aligned bounds (min, max).
    pub fn bounds(&self) -> (Vec3, Vec3) {
        self.positions.iter().fold(
            (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY)),
            |(lo, hi), &p| (lo.min(Vec3::from(p)), hi.max(Vec3::from(p))),
        )
    }
}

/// A mesh placed in the world with a material (index into [`Scene::materials`]).
#[derive(Clone, Debug)]
pub struct Object {
    /// The object's name in its scene file (for messages).
    pub name: String,
    /// World-space mesh.
    pub mesh: Mesh,
    /// Index into [`Scene::materials`].
    pub material: usize,
}

/// How a camera projects the view.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Projection {
    /// A perspective projection.
    Perspective {
        /// Vertical field of view in degrees.
        fov_y_deg: f32,
    },
    /// `height` is the world-space height of the view.
    Orthographic {
        /// World-space height of the view.
        height: f32,
    },
}

/// A right-handed camera looking from `eye` at `target`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Camera {
    /// Where the camera is, in world space.
    pub eye: Vec3,
    /// The point it looks at.
    pub target: Vec3,
    /// Which way is up (need not be orthogonal to the view direction).
    pub up: Vec3,
    /// Perspective or orthographic.
    pub projection: Projection,
    /// Distance of the near clipping plane.
    pub near: f32,
    /// Distance of the far clipping plane.
    pub far: f32,
}

impl Camera {
    /// World to view space.
    pub fn view(&self) -> Mat4 {
        Mat4::look_at_rh(self.eye, self.target, self.up)
    }

    /// wgpu convention: right-handed view space, depth in [0, 1].
    pub fn projection(&self, aspect: f32) -> Mat4 {
        match self.projection {
            Projection::Perspective { fov_y_deg } => {
                Mat4::perspective_rh(fov_y_deg.to_radians(), aspect, self.near, self.far)
            }
            Projection::Orthographic { height } => {
                let h = height * 0.5;
                let w = h * aspect;
                Mat4::orthographic_rh(-w, w, -h, h, self.near, self.far)
            }
        }
    }

    /// World to clip space for a view of `aspect` = width / height.
    pub fn view_projection(&self, aspect: f32) -> Mat4 {
        self.projection(aspect) * self.view()
    }

    /// A 45° perspective camera at `eye` looking at the origin, +Y up, seeing from 0.1 to `far`:
    /// the built-in scenes' camera.
    pub fn toward_origin(eye: Vec3, far: f32) -> Camera {
        Camera {
            eye,
            target: Vec3::ZERO,
            up: Vec3::Y,
            projection: Projection::Perspective { fov_y_deg: 45.0 },
            near: 0.1,
            far,
        }
    }

    /// A perspective camera looking at the bounding box from the front (+Z), slightly above,
    /// so that the whole box is in view.
    pub fn framing(lo: Vec3, hi: Vec3) -> Camera {
        let center = (lo + hi) * 0.5;
        let radius = ((hi - lo).length() * 0.5).max(1e-3);
        let fov_y_deg = 40.0f32;
        let dist = radius / (fov_y_deg.to_radians() * 0.5).sin() * 1.05;
        let dir = Vec3::new(0.0, 0.35, 1.0).normalize();
        Camera {
            eye: center + dir * dist,
            target: center,
            up: Vec3::Y,
            projection: Projection::Perspective { fov_y_deg },
            near: (dist - radius * 1.5).max(dist * 0.01),
            far: dist + radius * 1.5,
        }
    }
}

keyword_enum! {
    /// What kind of light a [`Light`] is.
    #[cfg_attr(feature = "serde", derive(serde::Deserialize))]
    pub enum LightKind ("light kind") {
        /// Light from a point, in every direction.
        Point = "point",
        /// Light from a point, inside a cone along `direction`.
        Spot = "spot",
        /// Parallel light along `direction` from infinitely far away.
        Directional = "directional",
        /// Light from everywhere: a constant term added to every lit surface.
        Ambient = "ambient",
    }
}

/// A light of the scene; the fields a kind does not use are ignored.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Light {
    /// What kind of light this is.
    pub kind: LightKind,
    /// World position (point and spot lights).
    pub position: Vec3,
    /// Direction the light travels (spot and directional lights).
    pub direction: Vec3,
    /// Spot lights: the cone's half-angle in degrees.
    pub angle_deg: f32,
    /// Linear RGB.
    pub color: [f32; 3],
    /// Multiplies `color`.
    pub intensity: f32,
    /// Radius of the light volume (point, spot); also where attenuation reaches zero.
    pub range: f32,
    /// Point and spot lights: the constant, linear and quadratic terms of the distance
    /// attenuation 1 / (a + b·d + c·d²) (seed 004's form), windowed to zero at `range`.
    pub attenuation: [f32; 3],
}

impl Default for Light {
    fn default() -> Self {
        Light {
            kind: LightKind::Point,
            position: Vec3::new(2.0, 3.0, 4.0),
            direction: Vec3::NEG_Y,
            angle_deg: 30.0,
            color: [1.0; 3],
            intensity: 1.0,
            range: 10.0,
            attenuation: [1.0, 0.0, 0.0],
        }
    }
}

/// What shows through where the fragments leave transmittance.
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub enum Background {
    /// 16-pixel cells of sRGB greys #cccccc and #999999.
    #[default]
    Checker,
    /// Linear RGB.
    Color([f32; 3]),
}

impl std::str::FromStr for Background {
    type Err = Error;
    /// `checker` or a CSS-like sRGB hex color `#rrggbb`.
    fn from_str(s: &str) -> Result<Self> {
        if s == "checker" {
            return Ok(Background::Checker);
        }
        let hex = s.strip_prefix('#').filter(|h| h.len() == 6);
        let parsed = hex.and_then(|h| {
            let v = u32::from_str_radix(h, 16).ok()?;
            Some(
                [(v >> 16) & 255, (v >> 8) & 255, v & 255]
                    .map(|c| srgb_to_linear(c as f32 / 255.0)),
            )
        });
        parsed.map(Background::Color).ok_or_else(|| {
            Error::input(format!(
                "background '{}' is neither 'checker' nor a color '#rrggbb'",
                crate::error::quoted(s)
            ))
        })
    }
}

impl Background {
    /// Linear RGB of the background at pixel (x, y).
    pub fn at(&self, x: u32, y: u32) -> [f32; 3] {
        match *self {
            Background::Color(c) => c,
            Background::Checker => {
                let light = ((x / 16) + (y / 16)).is_multiple_of(2);
                let g = if light { 0xcc } else { 0x99 };
                [srgb_to_linear(g as f32 / 255.0); 3]
            }
        }
    }
}

/// Linear RGB from hue (turns, [0,1)), saturation and value.
pub fn hsv(h: f32, s: f32, v: f32) -> [f32; 3] {
    let h6 = h.rem_euclid(1.0) * 6.0;
    let f = h6 - h6.floor();
    let (p, q, t) = (v * (1.0 - s), v * (1.0 - s * f), v * (1.0 - s * (1.0 - f)));
    match h6 as u32 {
        0 => [v, t, p],
        1 => [q, v, p],
        2 => [p, v, t],
        3 => [p, q, v],
        4 => [t, p, v],
        _ => [v, p, q],
    }
}

/// The sRGB transfer function's inverse: an encoded value in [0, 1] to linear.
pub fn srgb_to_linear(c: f32) -> f32 {
    if c <= 0.04045 {
        c / 12.92
    } else {
        ((c + 0.055) / 1.055).powf(2.4)
    }
}

/// The sRGB transfer function: a linear value in [0, 1] to its encoding.
pub fn linear_to_srgb(c: f32) -> f32 {
    let c = c.clamp(0.0, 1.0);
    if c <= 0.003_130_8 {
        c * 12.92
    } else {
        1.055 * c.powf(1.0 / 2.4) - 0.055
    }
}

/// Picture defaults a scene file may carry (`[render]`).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct RenderDefaults {
    /// Picture size in pixels (width, height).
    pub size: Option<[u32; 2]>,
    /// What lies behind the scene.
    pub background: Option<Background>,
    /// Shading of materials that do not set their own.
    pub shading: Option<Shading>,
    /// The pipeline the scene is meant for (`--pipeline` overrides it).
    pub pipeline: Option<crate::scene::Pipeline>,
}

/// Everything strata draws: objects, their materials, lights and camera, and how they move.
#[derive(Clone, Debug, Default)]
pub struct Scene {
    /// The meshes and their materials.
    pub objects: Vec<Object>,
    /// Materials the objects index.
    pub materials: Vec<Material>,
    /// `None`: auto-framed from the bounds.
    pub camera: Option<Camera>,
    /// The scene's lights; with none, a light at the eye shades it.
    pub lights: Vec<Light>,
    /// Picture defaults the scene carries.
    pub defaults: RenderDefaults,
    /// Animation time of the scene, in frames (see [`Scene::set_time`]).
    pub time: f32,
    /// How each object moves, index for index with `objects` (empty: nothing moves). Each
    /// moving object's `mesh` is its motion's mesh at `time`.
    pub motions: Vec<Option<ObjectMotion>>,
    /// A moving camera: `camera` is its camera at `time`.
    pub camera_path: Option<CameraPath>,
}

/// One vertex of the flattened triangle list: the scene's vertex buffer, which `vs_scene`
/// (`shaders/shared/scene.wgsl`) reads as locations 0 and 1 and the compute rasterizer as six
/// floats. Vertex 3t + i is corner i of triangle t.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct GpuVertex {
    /// World-space position.
    pub position: [f32; 3],
    /// Unit world-space normal.
    pub normal: [f32; 3],
}

impl GpuVertex {
    /// Locations 0 (position) and 1 (normal), as `vs_scene` reads them.
    pub const ATTRIBUTES: [wgpu::VertexAttribute; 2] =
        wgpu::vertex_attr_array![0 => Float32x3, 1 => Float32x3];

    /// The vertex-buffer layout of every scene pipeline.
    pub fn layout() -> wgpu::VertexBufferLayout<'static> {
        wgpu::VertexBufferLayout {
            array_stride: std::mem::size_of::<GpuVertex>() as u64,
            step_mode: wgpu::VertexStepMode::Vertex,
            attributes: &Self::ATTRIBUTES,
        }
    }
}

/// The scene flattened for the GPU: three vertices per triangle in primitive order, and each
/// triangle's material index.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct TriangleList {
    /// Three vertices per triangle, in primitive order.
    pub vertices: Vec<GpuVertex>,
    /// Each triangle's index into the materials buffer.
    pub materials: Vec<u32>,
}

/// Bytes per triangle of the flattened scene on the GPU: three vertices and a material index.
pub const GPU_TRIANGLE_BYTES: u64 = 3 * std::mem::size_of::<GpuVertex>() as u64 + 4;

/// A linear RGB color of full value with the given hue in [0, 1) and saturation.
fn hue_color(hue: f32, saturation: f32) -> [f32; 3] {
    let channel = |offset: f32| {
        let x = ((hue + offset).fract() * 6.0 - 3.0).abs() - 1.0;
        1.0 - saturation + saturation * x.clamp(0.0, 1.0)
    };
    [channel(0.0), channel(2.0 / 3.0), channel(1.0 / 3.0)]
}

impl Scene {
    /// Adds `m` and gives its index, for [`Object::material`].
    pub fn add_material(&mut self, m: Material) -> usize {
        self.materials.push(m);
        self.materials.len() - 1
    }

    /// The blend modes other than over that the scene's objects use, each once, in the order
    /// of [`Blend`] (empty: everything blends over).
    pub fn blend_modes(&self) -> Vec<Blend> {
        let used = |b: Blend| {
            self.objects
                .iter()
                .any(|o| self.materials.get(o.material).is_some_and(|m| m.blend == b))
        };
        [Blend::Add, Blend::Multiply]
            .into_iter()
            .filter(|&b| used(b))
            .collect()
    }

    /// Triangles over every object.
    pub fn triangle_count(&self) -> usize {
        self.objects.iter().map(|o| o.mesh.triangle_count()).sum()
    }

    /// The world-space bounding box (min, max) of every object; inverted (+∞, −∞) when there are none.
    pub fn bounds(&self) -> (Vec3, Vec3) {
        self.objects.iter().fold(
            (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY)),
            |(lo, hi), o| {
                let (a, b) = o.mesh.bounds();
                (lo.min(a), hi.max(b))
            },
        )
    }

    /// The scene's camera, or one framing its bounds.
    pub fn camera_or_framing(&self) -> Camera {
        self.camera.unwrap_or_else(|| {
            let (lo, hi) = self.bounds();
            Camera::framing(lo, hi)
        })
    }

    /// The opaque objects ([`Material::is_opaque`]) and the rest, as two scenes with the full scene's
    /// camera and lights, each with only the materials it uses. Objects keep their order, so
    /// depth ties among the transparent ones break as in the full scene.
    pub fn split_by_opacity(&self) -> (Scene, Scene) {
        let camera = Some(self.camera_or_framing());
        let part = |opaque: bool| {
            let mut out = Scene {
                objects: Vec::new(),
                materials: Vec::new(),
                camera,
                lights: self.lights.clone(),
                defaults: self.defaults.clone(),
                time: self.time,
                motions: Vec::new(),
                camera_path: self.camera_path.clone(),
            };
            let mut remap: Vec<Option<usize>> = vec![None; self.materials.len()];
            for (i, o) in self.objects.iter().enumerate() {
                if self.materials[o.material].is_opaque() != opaque {
                    continue;
                }
                if self.animated() {
                    out.motions.push(self.motions.get(i).cloned().flatten());
                }
                let material = *remap[o.material]
                    .get_or_insert_with(|| out.add_material(self.materials[o.material].clone()));
                out.objects.push(Object {
                    material,
                    ..o.clone()
                });
            }
            out
        };
        (part(true), part(false))
    }

    /// Adds `count` coloured point lights, a deterministic field for `seed`, spread over the
    /// scene's bounds (`--lights N`): ranges shrink as the field grows so that each point stays
    /// reached by a similar number of lights, and the intensity falls with that overlap so the
    /// picture keeps its brightness. Attenuation is 1 / (1 + 25 d² / range²), windowed to 0 at
    /// the range.
    pub fn add_light_field(&mut self, count: u32, seed: u64) {
        if count == 0 {
            return;
        }
        let (lo, hi) = self.bounds();
        let size = (hi - lo).max(Vec3::splat(1e-3));
        let diagonal = size.length();
        let range = diagonal * (0.5 / (count as f32).cbrt()).max(0.06);
        // Lights hover over the scene: the box grows upwards by a tenth of its diagonal.
        let (box_lo, box_hi) = (lo, hi + Vec3::new(0.0, 0.1 * diagonal, 0.0));
        let volume = (box_hi - box_lo)
            .max(Vec3::splat(range * 0.5))
            .element_product();
        let overlap = count as f32 * 4.0 / 3.0 * std::f32::consts::PI * range.powi(3) / volume;
        let intensity = 1.5 / overlap.max(1.0).sqrt();
        let mut rng = rng::SplitMix64::new(seed ^ 0x6c69_6768_7473);
        for _ in 0..count {
            let t = Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32());
            let hue = rng.next_f32();
            self.lights.push(Light {
                kind: LightKind::Point,
                position: box_lo + (box_hi - box_lo) * t,
                color: hue_color(hue, 0.75),
                intensity,
                range,
                attenuation: [1.0, 0.0, 25.0 / (range * range)],
                ..Light::default()
            });
        }
    }

    /// Sets every material's opacity (`--alpha`).
    pub fn override_alpha(&mut self, alpha: f32) {
        for m in &mut self.materials {
            m.opacity = alpha;
        }
    }

    /// Sets every material's shading (`--shading`).
    pub fn override_shading(&mut self, shading: Shading) {
        for m in &mut self.materials {
            m.shading = shading;
        }
    }

    /// Validates every object and material.
    pub fn validate(&self) -> Result<()> {
        if self.objects.is_empty() {
            return Err(Error::input("scene has no objects".to_string()));
        }
        for o in &self.objects {
            o.mesh.validate(&o.name)?;
            if o.material >= self.materials.len() {
                return Err(Error::input(format!(
                    "{}: material index {} out of range",
                    o.name, o.material
                )));
            }
        }
        if !self.motions.is_empty() && self.motions.len() != self.objects.len() {
            return Err(Error::input(format!(
                "scene has {} motions for {} objects",
                self.motions.len(),
                self.objects.len()
            )));
        }
        for (o, m) in self.objects.iter().zip(&self.motions) {
            let Some(m) = m else { continue };
            let orbit = &m.orbit;
            let finite = [orbit.radius, orbit.angular_speed, orbit.phase, m.scale]
                .iter()
                .all(|x| x.is_finite())
                && [orbit.centre, orbit.u, orbit.v]
                    .iter()
                    .all(|v| v.is_finite());
            if !(finite && m.scale > 0.0) {
                return Err(Error::input(format!(
                    "{}: its motion must be finite with a positive scale",
                    o.name
                )));
            }
            m.local.validate(&o.name)?;
        }
        for m in &self.materials {
            if !(0.0..=1.0).contains(&m.opacity) {
                return Err(Error::input(format!(
                    "material '{}': opacity {} is outside [0, 1]",
                    m.name, m.opacity
                )));
            }
            if !m.color.iter().all(|c| c.is_finite())
                || !m.absorption.is_finite()
                || m.absorption < 0.0
                || m.ior.is_nan()
                || m.ior < 1.0
                || !(m.shininess.is_finite() && m.shininess > 0.0)
            {
                return Err(Error::input(format!(
                    "material '{}': color must be finite, absorption ≥ 0, ior ≥ 1 and shininess positive",
                    m.name
                )));
            }
        }
        Ok(())
    }

    /// The flattened triangle list: three vertices per triangle in primitive order.
    pub fn triangles(&self) -> TriangleList {
        let mut out = TriangleList::with_capacity(self.triangle_count());
        for o in &self.objects {
            out.push_mesh(&o.mesh, o.material as u32);
        }
        out
    }

    /// The triangle list the GPU animates from: moving objects in object space (their motion's
    /// mesh), the others in world space as in [`Scene::triangles`]; and each triangle's object.
    pub fn rest_triangles(&self) -> (TriangleList, Vec<u32>) {
        let mut out = TriangleList::with_capacity(self.triangle_count());
        let mut objects = Vec::with_capacity(self.triangle_count());
        for (i, o) in self.objects.iter().enumerate() {
            let mesh = match self.motions.get(i) {
                Some(Some(m)) => &m.local,
                _ => &o.mesh,
            };
            out.push_mesh(mesh, o.material as u32);
            objects.resize(out.materials.len(), i as u32);
        }
        (out, objects)
    }
}

impl TriangleList {
    fn with_capacity(triangles: usize) -> TriangleList {
        TriangleList {
            vertices: Vec::with_capacity(triangles * 3),
            materials: Vec::with_capacity(triangles),
        }
    }

    /// Appends `mesh`'s triangles: its vertex normals, or each face's own when it has none.
    fn push_mesh(&mut self, mesh: &Mesh, material: u32) {
        let has_normals = mesh.normals.len() == mesh.positions.len();
        for t in mesh.indices.chunks_exact(3) {
            let flat = {
                let [a, b, c] = [t[0], t[1], t[2]].map(|i| Vec3::from(mesh.positions[i as usize]));
                (b - a)
                    .cross(c - a)
                    .try_normalize()
                    .unwrap_or(Vec3::Z)
                    .to_array()
            };
            for &i in t {
                self.vertices.push(GpuVertex {
                    position: mesh.positions[i as usize],
                    normal: if has_normals {
                        mesh.normals[i as usize]
                    } else {
                        flat
                    },
                });
            }
            self.materials.push(material);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn gpu_vertex_layout() {
        crate::testing::assert_layout!(GpuVertex, 24, normal: 12);
        let layout = GpuVertex::layout();
        assert_eq!(layout.array_stride, 24);
        assert_eq!(layout.attributes[1].offset, 12);
        assert_eq!(GPU_TRIANGLE_BYTES, 76);
    }

    #[test]
    fn background_parses_srgb_hex() {
        let b: Background = "#ffffff".parse().unwrap();
        assert_eq!(b, Background::Color([1.0; 3]));
        assert!("#12345".parse::<Background>().is_err());
        assert!("blue".parse::<Background>().is_err());
    }

    #[test]
    fn mesh_validation_names_the_problem() {
        let mut m = Mesh {
            positions: vec![[0.0; 3], [1.0, 0.0, 0.0], [0.0, f32::NAN, 0.0]],
            normals: vec![],
            indices: vec![0, 1, 2],
        };
        let e = m.validate("bad.obj").unwrap_err().to_string();
        assert!(e.contains("bad.obj") && e.contains("non-finite"), "{e}");
        m.positions[2] = [0.0, 1.0, 0.0];
        m.indices[2] = 7;
        let e = m.validate("bad.obj").unwrap_err().to_string();
        assert!(e.contains("out of range"), "{e}");
        m.indices.clear();
        assert!(m
            .validate("x")
            .unwrap_err()
            .to_string()
            .contains("no triangles"));
    }
}
