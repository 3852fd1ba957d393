//! The CPU reference: an exact multi-fragment renderer, the ground truth of every test.
//!
//! Every fragment of every pixel is generated with the GPU's coverage rule ([`raster`]), shaded
//! with the same formulas as `shaders/shared/scene.wgsl` in f64, sorted by depth with ties by
//! primitive index, optionally cut to the `k` nearest, and composited in f64 by
//! [`crate::resolve::composite`]. With `--msaa` each fragment covers some of its pixel's samples
//! (shaded at the center, as the GPU does); every sample composites its own fragments (its k
//! nearest) and the pixel is their average. Rows are split into bands rendered in parallel with
//! rayon.
//! Memory: every fragment is held at once (about 80 bytes each).

pub mod raster;

use glam::{DVec3, Vec3};
use rayon::prelude::*;

use crate::error::Result;
use crate::frame::uniforms::{self, GpuLight, LightingSetup};
use crate::frame::{Effect, FrameStats, RenderOptions};
use crate::metrics::LinearImage;
use crate::resolve::{composite, RefFragment};
use crate::scene::{Camera, Material, Projection, Scene, Shading};

const BAND_ROWS: u32 = 8;
/// Shading constant shared with scene.wgsl.
const SPECULAR: f64 = 0.3;

struct Shader<'a> {
    materials: &'a [Material],
    setup: LightingSetup,
    eye: DVec3,
    to_camera: DVec3,
    orthographic: bool,
    translucency: bool,
}

fn v3(a: [f32; 3]) -> DVec3 {
    DVec3::new(a[0] as f64, a[1] as f64, a[2] as f64)
}

/// Diffuse (times the albedo) and specular from direction `l` with unit radiance; the twin of
/// `blinn_phong_terms` in scene.wgsl.
fn blinn_phong(n: DVec3, v: DVec3, l: DVec3, shininess: f64) -> (f64, f64) {
    let hv = l + v;
    let h = hv / hv.length().max(1e-6);
    (
        n.dot(l).max(0.0),
        SPECULAR * n.dot(h).max(0.0).powf(shininess),
    )
}

/// Direction to the light and the light's attenuation at `world` (window, 1 / (a + b·d + c·d²),
/// spot cone); the twin of `light_terms` in scene.wgsl.
fn light_direction(light: &GpuLight, world: DVec3) -> (DVec3, f64) {
    let dir = v3(light.direction);
    if light.kind == 2 {
        return (-dir.normalize(), 1.0);
    }
    let to_light = v3(light.position) - world;
    let d = to_light.length();
    let l = to_light / d.max(1e-12);
    let r = d / light.range as f64;
    let window = (1.0 - r * r).clamp(0.0, 1.0);
    let [a, b, c] = light.attenuation.map(|x| x as f64);
    let mut attenuation = window * window / (a + d * (b + d * c));
    if light.kind == 1 {
        let cos = (-l).dot(dir.normalize());
        let (outer, inner) = (light.cos_outer as f64, light.cos_inner as f64);
        attenuation *= ((cos - outer) / (inner - outer).max(1e-6)).clamp(0.0, 1.0);
    }
    (l, attenuation)
}

impl Shader<'_> {
    /// Color and opacity; the twin of `shade` in scene.wgsl.
    fn shade(&self, world: DVec3, normal: DVec3, material: usize) -> (DVec3, f64) {
        let m = &self.materials[material];
        let v = if self.orthographic {
            self.to_camera
        } else {
            (self.eye - world).normalize()
        };
        let mut n = normal / normal.length().max(1e-12);
        if n.dot(v) < 0.0 {
            n = -n;
        }
        let albedo = v3(m.color);
        let mut color = albedo;
        if m.shading != Shading::Unlit {
            let shininess = m.exponent() as f64;
            let mut diffuse = v3(self.setup.ambient);
            let mut specular = DVec3::ZERO;
            if self.setup.headlight {
                let (d, s) = blinn_phong(n, v, v, shininess);
                diffuse += DVec3::splat(d);
                specular += DVec3::splat(s);
            }
            for light in &self.setup.lights {
                let (l, attenuation) = light_direction(light, world);
                let (d, s) = blinn_phong(n, v, l, shininess);
                let radiance = v3(light.radiance) * attenuation;
                diffuse += radiance * d;
                specular += radiance * s;
            }
            color = albedo * diffuse + specular;
        }
        let mut alpha = m.opacity as f64;
        if self.translucency {
            let ior = m.ior as f64;
            let f0 = ((ior - 1.0) / (ior + 1.0)).powi(2);
            let fresnel = f0 + (1.0 - f0) * (1.0 - n.dot(v).abs().clamp(0.0, 1.0)).powi(5);
            alpha = fresnel + (1.0 - fresnel) * alpha;
        }
        (color, alpha)
    }
}

/// View-space distance of a window depth; the twin of `view_distance` in composite.wgsl.
pub fn view_distance(camera: &Camera, depth: f64) -> f64 {
    let (n, f) = (camera.near as f64, camera.far as f64);
    match camera.projection {
        Projection::Orthographic { .. } => n + depth * (f - n),
        Projection::Perspective { .. } => n * f / (f - depth * (f - n)),
    }
}

/// Every pixel's fragments in depth order (depth, then primitive index), row-major.
pub fn fragments(scene: &Scene, options: &RenderOptions) -> Result<Vec<Vec<RefFragment>>> {
    shaded_fragments(scene, options, false)
}

/// [`fragments`] with depth and attributes interpolated from the triangles' corners snapped to
/// the subpixel grid ([`raster::SetupTriangle::snap_planes`]), as the H100's rasterizer makes
/// them: the same fragments and coverage, depths and shading that differ on near edge-on
/// triangles. Tests use it to tell that convention from a fault.
pub fn fragments_on_snapped_planes(
    scene: &Scene,
    options: &RenderOptions,
) -> Result<Vec<Vec<RefFragment>>> {
    shaded_fragments(scene, options, true)
}

fn shaded_fragments(
    scene: &Scene,
    options: &RenderOptions,
    snapped_planes: bool,
) -> Result<Vec<Vec<RefFragment>>> {
    scene.validate()?;
    options.validate()?;
    let (w, h) = (options.frame.width, options.frame.height);
    let camera = scene.camera_or_framing();
    let view_proj = camera.view_projection(w as f32 / h as f32).as_dmat4();
    let tris = scene.triangles();
    let shader = Shader {
        materials: &scene.materials,
        setup: uniforms::lighting(scene),
        eye: camera.eye.as_dvec3(),
        to_camera: (camera.eye - camera.target)
            .normalize_or(Vec3::Z)
            .as_dvec3(),
        orthographic: matches!(camera.projection, Projection::Orthographic { .. }),
        translucency: options.frame.effect == Effect::Translucency,
    };

    let mut setups = setup_triangles(&tris, &view_proj, options);
    if snapped_planes {
        setups
            .iter_mut()
            .for_each(raster::SetupTriangle::snap_planes);
    }
    let band_count = h.div_ceil(BAND_ROWS) as usize;
    let mut bands: Vec<Vec<u32>> = vec![Vec::new(); band_count];
    for (i, t) in setups.iter().enumerate() {
        for band in bands
            .iter_mut()
            .take((t.max[1] / BAND_ROWS) as usize + 1)
            .skip((t.min[1] / BAND_ROWS) as usize)
        {
            band.push(i as u32);
        }
    }

    let absorption: Vec<f64> = scene
        .materials
        .iter()
        .map(|m| m.absorption as f64)
        .collect();
    let blends: Vec<crate::scene::Blend> = scene.materials.iter().map(|m| m.blend).collect();
    let rows: Vec<Vec<Vec<RefFragment>>> = bands
        .par_iter()
        .enumerate()
        .map(|(b, members)| {
            let y0 = b as u32 * BAND_ROWS;
            let y1 = (y0 + BAND_ROWS).min(h);
            let mut pixels: Vec<Vec<RefFragment>> = vec![Vec::new(); ((y1 - y0) * w) as usize];
            // Setups are in primitive order, so each pixel's list starts in primitive order.
            for &i in members {
                let t = &setups[i as usize];
                let prim = t.prim as usize;
                let corners = &tris.vertices[prim * 3..prim * 3 + 3];
                let material = tris.materials[prim] as usize;
                cover_samples(t, y0..y1, options.build.msaa, |s| {
                    // Depth clipping (multisampled: per sample, in `cover_samples`), and the
                    // opaque test against the cleared depth (1.0) at the center.
                    let clipped = if options.build.msaa > 1 {
                        s.depth.is_nan() || s.depth >= 1.0
                    } else {
                        !(0.0..1.0).contains(&s.depth)
                    };
                    if clipped {
                        return;
                    }
                    let world = v3(corners[0].position) * s.weights.x
                        + v3(corners[1].position) * s.weights.y
                        + v3(corners[2].position) * s.weights.z;
                    let normal = v3(corners[0].normal) * s.weights.x
                        + v3(corners[1].normal) * s.weights.y
                        + v3(corners[2].normal) * s.weights.z;
                    let (color, alpha) = shader.shade(world, normal, material);
                    pixels[((s.y - y0) * w + s.x) as usize].push(RefFragment {
                        depth: s.depth,
                        prim: t.prim,
                        front_facing: t.area2 < 0,
                        color: color.to_array(),
                        alpha,
                        absorption: absorption[material],
                        distance: view_distance(&camera, s.depth),
                        coverage: s.coverage as u8,
                        blend: blends[material],
                    });
                });
            }
            for p in &mut pixels {
                p.sort_by(RefFragment::order);
            }
            pixels
        })
        .collect();
    Ok(rows.into_iter().flatten().collect())
}

use raster::cover_samples;

/// Every triangle of `tris` projected by `view_proj`, clipped and set up for coverage at the
/// options' size and samples, in primitive order.
fn setup_triangles(
    tris: &crate::scene::TriangleList,
    view_proj: &glam::DMat4,
    options: &RenderOptions,
) -> Vec<raster::SetupTriangle> {
    let (w, h) = (options.frame.width, options.frame.height);
    tris.vertices
        .par_chunks_exact(3)
        .enumerate()
        .fold(Vec::new, |mut out, (prim, t)| {
            let corners = [v3(t[0].position), v3(t[1].position), v3(t[2].position)];
            raster::setup(
                prim as u32,
                corners,
                view_proj,
                w,
                h,
                options.build.msaa,
                &mut out,
            );
            out
        })
        .flatten()
        .collect()
}

/// Renders the exact picture. `options.frame.k` keeps each pixel's k nearest fragments.
///
/// With `options.pipeline` the scene splits by opacity as the GPU pipelines split it: each
/// pixel's nearest opaque surface, shaded, replaces the background, the transparent fragments in
/// front of it (strictly nearer) are composited over it, and the result is tone-mapped.
pub fn render(scene: &Scene, options: &RenderOptions) -> Result<(LinearImage, FrameStats)> {
    if options.frame.k_auto.is_some() {
        return Err(crate::Error::input(
            "the reference takes --k N, not --k auto (a GPU frame's stats name the k it chose)",
        ));
    }
    if options.build.lighting.ssao || options.build.lighting.gbuffer_debug.is_some() {
        return Err(crate::Error::input(
            "the reference has no G-buffer: --ssao and --gbuffer-debug are GPU-only",
        ));
    }
    let (lists, opaque) = match options.build.lighting.pipeline {
        None => (fragments(scene, options)?, None),
        Some(_) => {
            scene.validate()?;
            let (opaque, transparent) = scene.split_by_opacity();
            let part = |s: &Scene, o: &RenderOptions| -> Result<Vec<Vec<RefFragment>>> {
                if s.objects.is_empty() {
                    Ok(vec![Vec::new(); o.pixels() as usize])
                } else {
                    fragments(s, o)
                }
            };
            // The pipeline's lit opaque frame is single-sampled (frame::msaa): its nearest
            // surface at the pixel center.
            let mut single = options.clone();
            single.build.msaa = 1;
            let nearest: Vec<Option<RefFragment>> = part(&opaque, &single)?
                .into_iter()
                .map(|l| l.into_iter().next())
                .collect();
            let lists = part(&transparent, options)?
                .into_iter()
                .zip(&nearest)
                .map(|(list, o)| match o {
                    Some(o) => list.into_iter().filter(|f| f.depth < o.depth).collect(),
                    None => list,
                })
                .collect();
            (lists, Some(nearest))
        }
    };
    Ok(render_lists(&lists, opaque.as_deref(), options))
}

/// The picture of every pixel's fragments `lists` (depth order) as [`render`] makes it: each
/// sample composites its k nearest over the background (or the pixel's `opaque` surface, then
/// tone-mapped). Tests also give it the reference's fragments at the depths a device's
/// rasterizer gave them.
pub fn render_lists(
    lists: &[Vec<RefFragment>],
    opaque: Option<&[Option<RefFragment>]>,
    options: &RenderOptions,
) -> (LinearImage, FrameStats) {
    let (w, h) = (options.frame.width, options.frame.height);
    let translucency = options.frame.effect == Effect::Translucency;
    let keep = options.frame.k.map(|k| k as usize).unwrap_or(usize::MAX);
    let samples = options.build.msaa.max(1);
    // Per pixel: the color, averaged over samples that each composite their own k nearest,
    // and the fragments some sample kept.
    let resolved: Vec<([f32; 4], u64)> = lists
        .par_iter()
        .enumerate()
        .map(|(i, list)| {
            let (x, y) = (i as u32 % w, i as u32 / w);
            let mut bg = options.frame.background.at(x, y).map(|c| c as f64);
            if let Some(Some(o)) = opaque.map(|o| &o[i]) {
                bg = o.color;
            }
            let mut kept_by_any = vec![false; list.len()];
            let mut sum = [0.0f64; 3];
            for sample in 0..samples {
                let own: Vec<RefFragment> = list
                    .iter()
                    .enumerate()
                    .filter(|(_, f)| f.coverage & (1 << sample) != 0)
                    .take(keep)
                    .map(|(j, f)| {
                        kept_by_any[j] = true;
                        *f
                    })
                    .collect();
                let c = composite(&own, bg, translucency);
                sum = std::array::from_fn(|k| sum[k] + c[k]);
            }
            let mut c = sum.map(|s| s / samples as f64);
            if opaque.is_some() {
                c = crate::deferred::encoding::tone_map(options.build.lighting.tonemap, c);
            }
            let kept = kept_by_any.iter().filter(|k| **k).count();
            (
                [c[0] as f32, c[1] as f32, c[2] as f32, kept as f32],
                kept as u64,
            )
        })
        .collect();
    let generated: u64 = lists.iter().map(|l| l.len() as u64).sum();
    let stored: u64 = resolved.iter().map(|r| r.1).sum();
    let pixels: Vec<[f32; 4]> = resolved.into_iter().map(|r| r.0).collect();
    let stats = FrameStats {
        method: "reference".into(),
        method_choice: None,
        width: w,
        height: h,
        k: options.frame.k,
        effect: options.frame.effect.name().into(),
        geometry_passes: 0,
        // With --k N the picture is each pixel's N nearest: the whole scene's only when no pixel
        // has more.
        exact: Some(generated == stored),
        exact_k_nearest: options.frame.k.map(|_| true),
        gpu_ms: None,
        gpu_ms_total: None,
        fragments_generated: Some(generated),
        fragments_stored: Some(stored),
        fragments_dropped: Some(generated - stored),
        max_depth_complexity: lists.iter().map(|l| l.len() as u32).max(),
        bytes_allocated: generated * std::mem::size_of::<RefFragment>() as u64,
        overflow: None,
        lock_failures: None,
        memory_ordering: None,
        bands: None,
        depth_histogram: None,
        depth_histogram_clipped: None,
        k_auto: None,
        lighting: None,
        raster: "cpu".to_string(),
        compute_raster: None,
        culled_temporal: None,
        order: None,
        kendall_tau: None,
        family: None,
        blocking_readbacks: 0,
        submits: 0,
        frame: 0,
        adapter: Some("cpu".into()),
        backend: Some("cpu".into()),
    };
    (
        LinearImage {
            width: w,
            height: h,
            pixels,
        },
        stats,
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::frame::{BuildOptions, FrameOptions};
    use crate::scene::loaders::load_scene;

    fn opts(k: Option<u32>) -> RenderOptions {
        RenderOptions {
            frame: FrameOptions {
                width: 48,
                height: 48,
                k,
                ..Default::default()
            },
            ..Default::default()
        }
    }

    #[test]
    fn k_at_depth_complexity_changes_nothing_and_smaller_k_keeps_the_nearest() {
        let scene = load_scene("builtin:spheres?layers=8").unwrap();
        let (all, stats) = render(&scene, &opts(None)).unwrap();
        let n = stats.max_depth_complexity.unwrap();
        assert_eq!(n, 8);
        let (same, _) = render(&scene, &opts(Some(n))).unwrap();
        assert_eq!(all, same);
        let (two, s2) = render(&scene, &opts(Some(2))).unwrap();
        assert_eq!(two.max_count(), 2);
        assert_eq!(
            s2.fragments_dropped.unwrap() + s2.fragments_stored.unwrap(),
            s2.fragments_generated.unwrap()
        );
        // k = 2 composites exactly the two nearest fragments of each pixel.
        let lists = fragments(&scene, &opts(None)).unwrap();
        let center = (24 * 48 + 24) as usize;
        let bg = RenderOptions::default()
            .frame
            .background
            .at(24, 24)
            .map(|c| c as f64);
        let expect = composite(&lists[center][..2], bg, false);
        for (got, want) in two.pixels[center].iter().zip(expect) {
            assert!((*got as f64 - want).abs() < 1e-6);
        }
    }

    #[test]
    fn fragments_are_in_depth_then_primitive_order() {
        let scene = load_scene("builtin:nvpro?objects=40&subdiv=8").unwrap();
        for list in fragments(&scene, &opts(None)).unwrap() {
            assert!(list
                .windows(2)
                .all(|w| RefFragment::order(&w[0], &w[1]).is_lt()));
        }
    }

    /// A layer's edge through a column of pixel centers covers half the samples there at 4×
    /// and 8×: those pixels get half its contribution, and its fragments say which samples.
    #[test]
    fn multisampled_edges_cover_half_the_samples() {
        let scene = load_scene("builtin:layers?n=1&coverage=0.515625").unwrap();
        for msaa in [4, 8] {
            let o = RenderOptions {
                build: BuildOptions {
                    msaa,
                    ..Default::default()
                },
                frame: FrameOptions {
                    width: 32,
                    height: 32,
                    background: crate::scene::Background::Color([0.2, 0.3, 0.4]),
                    ..Default::default()
                },
            };
            let lists = fragments(&scene, &o).unwrap();
            let (img, _) = render(&scene, &o).unwrap();
            let full = ((1u32 << msaa) - 1) as u8;
            for y in 0..32 {
                let at = |x: u32| (y * 32 + x) as usize;
                assert_eq!(lists[at(15)][0].coverage, full);
                let edge = lists[at(16)][0].coverage;
                assert_eq!(edge.count_ones(), msaa / 2, "{msaa}x row {y}: {edge:b}");
                assert!(lists[at(17)].is_empty());
                for c in 0..3 {
                    let half = 0.5 * (img.pixels[at(15)][c] + img.pixels[at(17)][c]);
                    assert!((img.pixels[at(16)][c] - half).abs() < 1e-6);
                }
            }
        }
    }

    #[test]
    fn closed_spheres_are_entered_front_facing_and_left_back_facing() {
        let scene = load_scene("builtin:spheres?layers=6").unwrap();
        let lists = fragments(&scene, &opts(None)).unwrap();
        let center = &lists[24 * 48 + 24];
        assert_eq!(center.len(), 6);
        let facing: Vec<bool> = center.iter().map(|f| f.front_facing).collect();
        assert_eq!(facing, [true, true, true, false, false, false]);
    }
}
