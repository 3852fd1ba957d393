//! The lit pipelines' per-pixel targets.

use crate::frame::{GbufferView, Pipeline, RenderOptions};
use crate::gpu::Gpu;

use super::{
    ALBEDO_FORMAT, AO_FORMAT, DEPTH_FORMAT, EXACT_NORMAL_FORMAT, HDR_FORMAT, LIGHT_FORMAT,
    NORMAL_FORMAT,
};

/// Per-pixel targets, re-made when the size changes.
pub(super) struct Targets {
    pub(super) size: (u32, u32),
    pub(super) hdr: wgpu::Texture,
    pub(super) depth: wgpu::Texture,
    pub(super) albedo: wgpu::Texture,
    pub(super) normal: wgpu::Texture,
    pub(super) exact_normal: wgpu::Texture,
    pub(super) diffuse: wgpu::Texture,
    pub(super) specular: wgpu::Texture,
    pub(super) ao_raw: wgpu::Texture,
    pub(super) ao: wgpu::Texture,
    pub(super) bytes: u64,
}

pub(super) fn view(t: &wgpu::Texture) -> wgpu::TextureView {
    t.create_view(&Default::default())
}

impl Targets {
    pub(super) fn new(gpu: &Gpu, pipeline: Pipeline, options: &RenderOptions) -> Targets {
        let size = (options.frame.width, options.frame.height);
        let deferred = pipeline == Pipeline::Deferred;
        // Targets a pipeline does not use stay 1×1 (bind groups still name them).
        let sized = |used: bool| if used { size } else { (1, 1) };
        let usage = wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::TEXTURE_BINDING;
        let make = |label: &str, format, used| {
            gpu.texture_2d(
                label,
                sized(used),
                format,
                usage | wgpu::TextureUsages::COPY_SRC,
            )
        };
        let debug_normals = options.build.lighting.gbuffer_debug == Some(GbufferView::NormalError);
        let targets = Targets {
            size,
            hdr: make("strata.lit.hdr", HDR_FORMAT, true),
            depth: make("strata.lit.depth", DEPTH_FORMAT, true),
            albedo: make("strata.deferred.gbuffer.albedo", ALBEDO_FORMAT, deferred),
            normal: make("strata.deferred.gbuffer.normal", NORMAL_FORMAT, deferred),
            exact_normal: make(
                "strata.deferred.gbuffer.exact_normal",
                EXACT_NORMAL_FORMAT,
                deferred && debug_normals,
            ),
            diffuse: make("strata.deferred.light.diffuse", LIGHT_FORMAT, deferred),
            specular: make("strata.deferred.light.specular", LIGHT_FORMAT, deferred),
            ao_raw: make(
                "strata.deferred.ssao.raw",
                AO_FORMAT,
                deferred && options.build.lighting.ssao,
            ),
            ao: make(
                "strata.deferred.ssao",
                AO_FORMAT,
                deferred && options.build.lighting.ssao,
            ),
            bytes: 0,
        };
        let bytes = [
            (&targets.hdr, 8),
            (&targets.depth, 4),
            (&targets.albedo, 4),
            (&targets.normal, 4),
            (&targets.exact_normal, 16),
            (&targets.diffuse, 8),
            (&targets.specular, 8),
            (&targets.ao_raw, 2),
            (&targets.ao, 2),
        ]
        .iter()
        .map(|(t, b)| t.width() as u64 * t.height() as u64 * b)
        .sum();
        Targets { bytes, ..targets }
    }
}
