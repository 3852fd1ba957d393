//! Baselines without order independence: `unsorted` (alpha blending in submission order) and
//! `sorted` (the same after sorting triangles back to front by centroid view depth on the CPU).
//!
//! Passes: blend (1 geometry pass, premultiplied over-blending into an Rgba16Float target, with an
//! atomic per-pixel fragment count), finish (compute: over the background, into the output).
//! With `--msaa 4|8` the target is multisampled: each fragment, shaded once, blends into the
//! samples it covers, and finish averages the samples (anti-aliased edges, as engines blend).
//! Memory: 8 bytes (Rgba16Float) per sample + 4 bytes (count) per pixel, plus 12 bytes per
//! triangle for `sorted`'s index buffer (the sorted triangles' vertex numbers). `sorted` draws every triangle
//! of the scene, so it refuses an application's draw callback. Limits: wrong wherever triangles overlap out of order (that is the
//! point); translucency gets Fresnel opacity but no absorption, which needs ordered neighbours.

pub mod descriptor;

use crate::error::{Error, Result};
use crate::frame::passes::{
    color_geometry_pass, color_pass_drawing, compute_pipeline, dispatch_pixels, geometry_pipeline,
};
use crate::frame::{FrameContext, Recorded, SceneGpu};
use crate::gpu::binding::{self, Slot};
use crate::gpu::shader::{self, Stage};
use crate::gpu::{Gpu, ResourceCache};
use crate::methods::Method;

const BLEND_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba16Float;
/// Bytes of the blend target per sample, and of the fragment count per pixel.
pub const SAMPLE_BYTES: u64 = 8;
/// Bytes of the fragment count per pixel.
pub const COUNT_BYTES: u64 = 4;

/// `unsorted` and `sorted`: one geometry pass blending into a half-float target, in submission or centroid order.
pub struct Blend {
    sort: bool,
    blend_layout: wgpu::BindGroupLayout,
    finish_layout: wgpu::BindGroupLayout,
    blend: wgpu::RenderPipeline,
    finish: wgpu::ComputePipeline,
    order: Option<wgpu::Buffer>,
    cache: ResourceCache,
    samples: u32,
}

impl Blend {
    /// The blend pipelines; `sort` orders the triangles back to front by centroid every frame.
    pub fn new(gpu: &Gpu, scene: &SceneGpu, sort: bool) -> crate::error::Result<Blend> {
        let samples = scene.samples;
        let target = Slot::target(samples);
        let blend_layout = binding::layout(&gpu.device, "strata.blend.layout", &[Slot::StorageRw]);
        let finish_layout = binding::layout(
            &gpu.device,
            "strata.blend.finish.layout",
            &[Slot::StorageRw, target, Slot::StorageRw],
        );
        let blend = geometry_pipeline(
            gpu,
            scene,
            (&blend_stage(), "fs_blend"),
            &[&scene.frame_layout, &blend_layout],
            &[Some(wgpu::ColorTargetState {
                format: BLEND_FORMAT,
                blend: Some(wgpu::BlendState::PREMULTIPLIED_ALPHA_BLENDING),
                write_mask: wgpu::ColorWrites::ALL,
            })],
            None,
            samples,
        )?;
        let module = finish_stage(samples).module(&gpu.device);
        let finish = compute_pipeline(
            gpu,
            "strata.blend.finish",
            (&module, "cs_finish"),
            &[&scene.frame_layout, &finish_layout],
        );
        Ok(Blend {
            sort,
            blend_layout,
            finish_layout,
            blend,
            finish,
            order: None,
            cache: ResourceCache::default(),
            samples,
        })
    }

    /// The vertex numbers of the triangles from farthest to nearest centroid along the view
    /// axis, an index buffer's contents.
    fn back_to_front(scene: &SceneGpu) -> Vec<u32> {
        let view = scene.camera.view();
        let depth: Vec<f32> = scene
            .centroids
            .iter()
            .map(|&c| view.transform_point3(c).z)
            .collect();
        let mut order: Vec<u32> = (0..depth.len() as u32).collect();
        // View space looks down −z: the farthest centroid has the most negative z.
        order.sort_by(|&a, &b| depth[a as usize].total_cmp(&depth[b as usize]));
        order
            .iter()
            .flat_map(|&t| [3 * t, 3 * t + 1, 3 * t + 2])
            .collect()
    }
}

/// The finish stage, reading the multisampled target with `--msaa`.
pub fn finish_stage(samples: u32) -> Stage {
    Stage::new("strata.blend.finish", include_str!("finish.wgsl"))
        .defs(&shader::target_samples(samples))
}

/// The blended capture (its own stage: it writes a color).
pub fn blend_stage() -> Stage {
    Stage::new("strata.blend", BLEND_WGSL).with(LIBRARY)
}

const BLEND_WGSL: &str = include_str!("blend.wgsl");

/// The baselines' WGSL modules (`strata::baseline::…`): the blend stage, which an
/// application's capture imports.
pub const LIBRARY: crate::gpu::shader::Library = &[BLEND_WGSL];

impl Method for Blend {
    fn record(&mut self, ctx: &mut FrameContext<'_>) -> Result<Recorded> {
        let gpu = ctx.gpu;
        let (w, h) = (ctx.options.frame.width, ctx.options.frame.height);
        if let (true, Some(order)) = (self.sort, ctx.options.frame.order) {
            return Err(Error::unsupported(format!(
                "sorted submits triangles back to front itself; --order {} applies to the other methods",
                order.name()
            )));
        }
        let order_bytes = if self.sort {
            ctx.scene.triangle_count as u64 * 12
        } else {
            0
        };
        let pixel_bytes = SAMPLE_BYTES * self.samples as u64 + COUNT_BYTES;
        ctx.check_budget(ctx.pixels() * pixel_bytes + order_bytes)?;
        let target = self.cache.texture_samples(
            gpu,
            "strata.blend.target",
            (w, h),
            BLEND_FORMAT,
            wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::TEXTURE_BINDING,
            self.samples,
        );
        let target_view = target.create_view(&Default::default());
        let counts = self
            .cache
            .storage(gpu, "strata.blend.counts", ctx.pixels() * 4)?;
        let mut bytes = ctx.pixels() * pixel_bytes;
        let order = if self.sort {
            let order = Self::back_to_front(ctx.scene);
            let buffer = self.order.get_or_insert_with(|| {
                gpu.device.create_buffer(&wgpu::BufferDescriptor {
                    label: Some("strata.sorted.order"),
                    size: (order.len() as u64 * 4).max(4),
                    usage: wgpu::BufferUsages::INDEX | wgpu::BufferUsages::COPY_DST,
                    mapped_at_creation: false,
                })
            });
            gpu.queue
                .write_buffer(buffer, 0, bytemuck::cast_slice(&order));
            bytes += order.len() as u64 * 4;
            Some((buffer.clone(), order.len() as u32))
        } else {
            None
        };
        let frame_group = ctx.frame_group;
        let blend_group = binding::group(
            &gpu.device,
            "strata.blend.group",
            &self.blend_layout,
            &[counts.as_entire_binding()],
        );
        let finish_group = binding::group(
            &gpu.device,
            "strata.blend.finish.group",
            &self.finish_layout,
            &[
                counts.as_entire_binding(),
                wgpu::BindingResource::TextureView(&target_view),
                ctx.output.as_entire_binding(),
            ],
        );
        ctx.encoder.clear_buffer(&counts, 0, None);
        let groups = [frame_group, &blend_group];
        let targets = [(&target_view, wgpu::Color::TRANSPARENT)];
        match order {
            Some((indices, count)) => {
                let scene = ctx.scene;
                color_pass_drawing(ctx, "blend", &self.blend, &groups, &targets, &|pass| {
                    scene.bind(pass);
                    pass.set_index_buffer(indices.slice(..), wgpu::IndexFormat::Uint32);
                    pass.draw_indexed(0..count, 0, 0..1);
                })
            }
            None => color_geometry_pass(ctx, "blend", &self.blend, &groups, &targets),
        }
        let frame_group = ctx.frame_group;
        dispatch_pixels(ctx, "finish", &self.finish, &[frame_group, &finish_group]);
        Ok(Recorded::passes(1, bytes))
    }

    fn resources(&self) -> Vec<&ResourceCache> {
        vec![&self.cache]
    }
}

/// The family's stages as its methods build them, for the test that validates every stage.
#[cfg(test)]
pub(crate) fn stages() -> Vec<Stage> {
    let mut stages = vec![blend_stage()];
    stages.extend([1, 4].map(finish_stage));
    stages
}
