//! Rust twins of the GPU structs in `shaders/shared/scene.wgsl`. Keep in sync with it; the
//! layout tests below pin sizes and offsets.

use bytemuck::{Pod, Zeroable};
use glam::{Mat4, Vec3};

use crate::frame::{Effect, RenderOptions};
use crate::scene::{
    srgb_to_linear, Background, Camera, LightKind, Material, Projection, Scene, Shading,
};

/// Keep in sync with `Frame` in scene.wgsl.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub struct FrameUniforms {
    /// Clip from world, cropped to the frame's band.
    pub view_proj: [[f32; 4]; 4],
    /// View from world (the camera's).
    pub view: [[f32; 4]; 4],
    /// The camera's position (w unused).
    pub eye: [f32; 4],
    /// Unit direction from the scene towards the camera, for orthographic views (w unused).
    pub to_camera: [f32; 4],
    /// The background's linear RGB (w unused), for a plain background.
    pub background: [f32; 4],
    /// The checkerboard's light squares, linear RGB (w unused).
    pub checker_light: [f32; 4],
    /// The checkerboard's dark squares, linear RGB (w unused).
    pub checker_dark: [f32; 4],
    /// Ambient radiance, linear RGB (w unused).
    pub ambient: [f32; 4],
    /// Target size in pixels.
    pub size: [u32; 2],
    /// `Effect` as the shaders number it: 0 transparency, 1 translucency, 2 complexity.
    pub effect: u32,
    /// Lights in the lights buffer.
    pub light_count: u32,
    /// Near plane distance.
    pub near: f32,
    /// Far plane distance.
    pub far: f32,
    /// 1 for an orthographic camera.
    pub orthographic: u32,
    /// 1 when the scene has no lights and a light at the eye shades it.
    pub headlight: u32,
    /// 1 when the background is the checkerboard.
    pub checker: u32,
    /// Samples per pixel with `--msaa` (4 or 8), whose coverage mask each fragment's tag carries
    /// ([`crate::frame::msaa`]); 0 single-sampled.
    pub coverage_bits: u32,
    /// 1 when some material blends other than over: resolves then look up each fragment's
    /// blend mode ([`crate::scene::Blend`]); 0 spares them the lookup.
    pub blend_modes: u32,
    /// Padding to WGSL's 16-byte alignment.
    pub _pad: u32,
}

/// Keep in sync with `Material` in scene.wgsl.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub struct GpuMaterial {
    /// Linear RGB.
    pub color: [f32; 3],
    /// Alpha of the surface (0 clear, 1 opaque).
    pub opacity: f32,
    /// Absorption coefficient of the translucency effect, per unit of distance.
    pub absorption: f32,
    /// Index of refraction (translucency's Fresnel term).
    pub ior: f32,
    /// 0 unlit, 1 lit.
    pub shading: u32,
    /// The specular exponent ([`Material::exponent`]).
    pub shininess: f32,
    /// [`crate::scene::Blend::index`].
    pub blend: u32,
    /// Padding to WGSL's 16-byte alignment.
    pub _pad: [u32; 3],
}

/// Keep in sync with `Light` in scene.wgsl.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub struct GpuLight {
    /// World position (point and spot lights).
    pub position: [f32; 3],
    /// 0 point, 1 spot, 2 directional.
    pub kind: u32,
    /// Unit direction the light shines along (spot and directional lights).
    pub direction: [f32; 3],
    /// Cosine of the spot's outer half-angle.
    pub cos_outer: f32,
    /// Color times intensity, linear RGB.
    pub radiance: [f32; 3],
    /// Distance where the light's attenuation is windowed to zero.
    pub range: f32,
    /// Cosine of the angle where the spot starts to fade.
    pub cos_inner: f32,
    /// a, b, c of the attenuation 1 / (a + b·d + c·d²).
    pub attenuation: [f32; 3],
}

/// The shading parameters both the GPU and the CPU reference derive from a scene.
#[derive(Clone, Debug)]
pub struct LightingSetup {
    /// Ambient radiance, linear RGB (the scene's ambient lights summed, or the default).
    pub ambient: [f32; 3],
    /// A light at the eye shades the scene, which has no lights.
    pub headlight: bool,
    /// The scene's other lights as the shaders read them.
    pub lights: Vec<GpuLight>,
}

/// Ambient term when the scene has no ambient light of its own.
pub const DEFAULT_AMBIENT: f32 = 0.1;
/// Spot lights fade from full at this fraction of their angle to zero at the angle.
pub const SPOT_INNER_FRACTION: f32 = 0.8;

/// The ambient term and lights the GPU and the reference shade a scene with.
pub fn lighting(scene: &Scene) -> LightingSetup {
    let mut ambient = [0.0f32; 3];
    let mut has_ambient = false;
    let mut lights = Vec::new();
    for l in &scene.lights {
        let radiance = l.color.map(|c| c * l.intensity);
        if l.kind == LightKind::Ambient {
            has_ambient = true;
            for (a, r) in ambient.iter_mut().zip(radiance) {
                *a += r;
            }
            continue;
        }
        lights.push(GpuLight {
            position: l.position.to_array(),
            kind: match l.kind {
                LightKind::Point => 0,
                LightKind::Spot => 1,
                _ => 2,
            },
            direction: l.direction.normalize_or(Vec3::NEG_Y).to_array(),
            cos_outer: l.angle_deg.to_radians().cos(),
            radiance,
            range: l.range.max(1e-6),
            cos_inner: (l.angle_deg * SPOT_INNER_FRACTION).to_radians().cos(),
            attenuation: l.attenuation,
        });
    }
    if !has_ambient {
        ambient = [DEFAULT_AMBIENT; 3];
    }
    LightingSetup {
        ambient,
        headlight: scene.lights.is_empty(),
        lights,
    }
}

/// A material as the shaders read it.
pub fn gpu_material(m: &Material) -> GpuMaterial {
    GpuMaterial {
        color: m.color,
        opacity: m.opacity,
        absorption: m.absorption,
        ior: m.ior,
        shading: match m.shading {
            Shading::Unlit => 0,
            Shading::Lit => 1,
        },
        shininess: m.exponent(),
        blend: m.blend.index(),
        _pad: [0; 3],
    }
}

/// sRGB greys of the default checkerboard, in linear RGB.
pub fn checker_colors() -> ([f32; 3], [f32; 3]) {
    let light = srgb_to_linear(0xcc as f32 / 255.0);
    let dark = srgb_to_linear(0x99 as f32 / 255.0);
    ([light; 3], [dark; 3])
}

/// The camera's view-projection for the picture, cropped to its band: the full picture's
/// projection followed by the map that takes the band's rows to the whole of clip space.
pub fn band_projection(camera: &Camera, options: &RenderOptions) -> Mat4 {
    let Some(band) = options.frame.band else {
        return camera.view_projection(options.frame.width as f32 / options.frame.height as f32);
    };
    let full = band.full_height as f32;
    let full_projection = camera.view_projection(options.frame.width as f32 / full);
    // Clip-space y of the band's centre (y up, rows down) and how much the band is magnified.
    let centre = 1.0 - (2.0 * band.top as f32 + options.frame.height as f32) / full;
    let scale = full / options.frame.height as f32;
    let crop = Mat4::from_cols(
        glam::Vec4::X,
        glam::Vec4::new(0.0, scale, 0.0, 0.0),
        glam::Vec4::Z,
        glam::Vec4::new(0.0, -scale * centre, 0.0, 1.0),
    );
    crop * full_projection
}

/// The uniforms of a frame seen through `camera` with `options` and the lighting `setup`.
pub fn frame_uniforms(
    camera: &Camera,
    options: &RenderOptions,
    setup: &LightingSetup,
    blending: bool,
) -> FrameUniforms {
    let view = camera.view();
    let view_proj: Mat4 = band_projection(camera, options);
    let (light, dark) = checker_colors();
    let (checker, background) = match options.frame.background {
        Background::Checker => (1, [0.0; 3]),
        Background::Color(c) => (0, c),
    };
    let to_camera = (camera.eye - camera.target).normalize_or(Vec3::Z);
    FrameUniforms {
        view_proj: view_proj.to_cols_array_2d(),
        view: view.to_cols_array_2d(),
        eye: camera.eye.extend(1.0).to_array(),
        to_camera: to_camera.extend(0.0).to_array(),
        background: [background[0], background[1], background[2], 1.0],
        checker_light: [light[0], light[1], light[2], 1.0],
        checker_dark: [dark[0], dark[1], dark[2], 1.0],
        ambient: [setup.ambient[0], setup.ambient[1], setup.ambient[2], 0.0],
        size: [options.frame.width, options.frame.height],
        effect: match options.frame.effect {
            Effect::Transparency => 0,
            Effect::Translucency => 1,
            Effect::Complexity => 2,
        },
        light_count: setup.lights.len() as u32,
        near: camera.near,
        far: camera.far,
        orthographic: matches!(camera.projection, Projection::Orthographic { .. }) as u32,
        headlight: setup.headlight as u32,
        checker,
        coverage_bits: crate::frame::msaa::coverage_bits(options.build.msaa),
        blend_modes: blending as u32,
        _pad: 0,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testing::assert_layout;

    #[test]
    fn frame_uniforms_layout_matches_wgsl() {
        assert_layout!(FrameUniforms, 272, eye: 128, ambient: 208, size: 224, effect: 232,
            near: 240, checker: 256, coverage_bits: 260, blend_modes: 264);
    }

    #[test]
    fn material_and_light_layout_match_wgsl() {
        assert_layout!(GpuMaterial, 48, blend: 32, absorption: 16, shading: 24, shininess: 28);
        assert_layout!(GpuLight, 64, direction: 16, radiance: 32, cos_inner: 48, attenuation: 52);
    }
}
