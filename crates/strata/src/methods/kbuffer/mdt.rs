//! Multi-depth-test k-buffers (seed 002's MDTS, seed 003's KB-MDT): atomic cascades keep each
//! pixel's k nearest keys sorted with no lock.
//!
//! - `kb-mdt32`: a depth pass cascades 32-bit depth keys; a color pass (second geometry pass)
//!   finds each fragment's key and stores its color and tag. Memory: 20 bytes per slot (key,
//!   claim, 3 color words). Exact but for depth ties beyond k, which share keys.
//! - `kb-mdt64`: one pass, 64-bit keys of depth and 8-bit sRGB color + alpha
//!   (SHADER_INT64_ATOMIC_ALL_OPS). 8 bytes per slot. Color quantized to 8 bits; no primitive or
//!   facing survives, so translucency is unsupported.
//! - `kb-mdt-pack`: one pass, two 32-bit cascades sharing the top 20 bits of the depth mapped to
//!   [0.5, 1), each with 12 bits of color (6 bits per sRGB channel and alpha). 8 bytes per slot.
//!   Depth quantized to 2⁻¹⁹; fragments tied in the top 20 bits can swap colors between the two
//!   arrays. Translucency and `--tail blend` are unsupported (no facing; a displaced key carries
//!   half a color).
//!
//! Passes: clear; capture (1 or 2 geometry passes); the shared k resolve. Per pixel 16 bytes of
//! counters and 20 of tail sums with `--tail blend`, as the other k-buffers.

use super::{
    check_memory, group_layout, k_of, params_for, stats_from_counters, FrameBuffers, RESOLVE_WGSL,
    STORAGE_WGSL,
};
use crate::error::{Error, Result};
use crate::gpu::{shader, Gpu, ResourceCache};
use crate::methods::{
    capture_pipeline, compute_pipeline, storage_geometry_pass, submit_pixels, Method, MethodStats,
    NullTarget,
};
use crate::render::{Effect, FrameContext, SceneGpu, Tail};

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Mdt {
    Mdt32,
    Mdt64,
    Pack,
}

impl Mdt {
    pub fn from_id(id: &str) -> Option<Mdt> {
        Some(match id {
            "kb-mdt32" => Mdt::Mdt32,
            "kb-mdt64" => Mdt::Mdt64,
            "kb-mdt-pack" => Mdt::Pack,
            _ => return None,
        })
    }

    /// Bytes per slot.
    pub fn slot_bytes(self) -> u64 {
        match self {
            Mdt::Mdt32 => 20,
            Mdt::Mdt64 | Mdt::Pack => 8,
        }
    }
}

const MDT_WGSL: &str = include_str!("mdt.wgsl");
const MDT64_WGSL: &str = include_str!("mdt64.wgsl");

pub fn capture_source(mdt: Mdt) -> String {
    match mdt {
        Mdt::Mdt64 => [STORAGE_WGSL, MDT64_WGSL].join("\n"),
        _ => [STORAGE_WGSL, MDT_WGSL].join("\n"),
    }
}

pub fn resolve_source(mdt: Mdt) -> String {
    match mdt {
        Mdt::Mdt32 => [
            STORAGE_WGSL,
            MDT_WGSL,
            include_str!("mdt32_resolve.wgsl"),
            RESOLVE_WGSL,
        ]
        .join("\n"),
        Mdt::Mdt64 => [STORAGE_WGSL, MDT64_WGSL, RESOLVE_WGSL].join("\n"),
        Mdt::Pack => [
            STORAGE_WGSL,
            MDT_WGSL,
            include_str!("pack_resolve.wgsl"),
            RESOLVE_WGSL,
        ]
        .join("\n"),
    }
}

pub struct MdtKBuffer {
    id: &'static str,
    mdt: Mdt,
    layout: wgpu::BindGroupLayout,
    /// Geometry passes in order: (pass name, pipeline).
    passes: Vec<(&'static str, wgpu::RenderPipeline)>,
    resolve: wgpu::ComputePipeline,
    null_target: Option<NullTarget>,
    cache: ResourceCache,
}

impl MdtKBuffer {
    pub fn new(gpu: &Gpu, scene: &SceneGpu, id: &'static str, mdt: Mdt) -> Result<MdtKBuffer> {
        if mdt == Mdt::Mdt64 && !gpu.has(wgpu::Features::SHADER_INT64_ATOMIC_ALL_OPS) {
            return Err(Error::unsupported(format!(
                "kb-mdt64 needs 64-bit storage atomics (SHADER_INT64_ATOMIC_ALL_OPS), which '{}' lacks; use kb-mdt32 or kb-mdt-pack",
                gpu.info.name
            )));
        }
        let layout = group_layout(gpu);
        let module = shader::module(
            &gpu.device,
            &format!("strata.{id}.capture"),
            &capture_source(mdt),
        );
        let layouts = [&scene.frame_layout, &layout];
        let targets = [NullTarget::target_state()];
        let pipeline = |entry: &str| {
            capture_pipeline(
                gpu,
                &format!("strata.{id}.{entry}"),
                &module,
                entry,
                &layouts,
                &targets,
                None,
            )
        };
        let passes = match mdt {
            Mdt::Mdt32 => vec![
                ("capture_depth", pipeline("fs_mdt32_depth")),
                ("capture_color", pipeline("fs_mdt32_color")),
            ],
            Mdt::Mdt64 => vec![("capture", pipeline("fs_mdt64"))],
            Mdt::Pack => vec![("capture", pipeline("fs_mdt_pack"))],
        };
        let module = shader::module(
            &gpu.device,
            &format!("strata.{id}.resolve"),
            &resolve_source(mdt),
        );
        let resolve = compute_pipeline(
            gpu,
            &format!("strata.{id}.resolve"),
            &module,
            "cs_resolve",
            &layouts,
        );
        Ok(MdtKBuffer {
            id,
            mdt,
            layout,
            passes,
            resolve,
            null_target: None,
            cache: ResourceCache::default(),
        })
    }
}

impl Method for MdtKBuffer {
    fn render(&mut self, ctx: &mut FrameContext<'_>) -> Result<MethodStats> {
        if self.mdt != Mdt::Mdt32 && ctx.options.effect == Effect::Translucency {
            return Err(Error::unsupported(format!(
                "{} keeps no primitive or facing per fragment, which translucency needs; use kb-mdt32",
                self.id
            )));
        }
        if self.mdt == Mdt::Pack && ctx.options.tail == Tail::Blend {
            return Err(Error::unsupported("kb-mdt-pack cannot blend a tail: a displaced key carries half a color; use --tail drop"));
        }
        let k = k_of(ctx.options)?;
        let gpu = ctx.gpu;
        let key_bytes = ctx.pixels() * k as u64 * self.mdt.slot_bytes();
        let shared = FrameBuffers::new(ctx, &mut self.cache, params_for(ctx.options, k, k, false))?;
        let total = key_bytes + shared.bytes;
        check_memory(ctx, self.id, key_bytes, total)?;
        let keys = self.cache.storage(
            gpu,
            "strata.kbuffer.keys",
            key_bytes,
            wgpu::BufferUsages::empty(),
        )?;
        let group = shared.group(gpu, &self.layout, &keys, ctx.output);
        let target = NullTarget::ensure(
            &mut self.null_target,
            gpu,
            "strata.kbuffer.null_target",
            ctx.options.width,
            ctx.options.height,
        );
        let frame_group = ctx.frame_group;
        let mut enc = gpu.device.create_command_encoder(&Default::default());
        shared.clear(&mut enc);
        enc.clear_buffer(&keys, 0, None);
        for (name, pipeline) in &self.passes {
            storage_geometry_pass(
                ctx,
                &mut enc,
                name,
                target,
                pipeline,
                &[frame_group, &group],
            );
        }
        gpu.queue.submit([enc.finish()]);
        submit_pixels(ctx, "resolve", &self.resolve, &[frame_group, &group]);
        Ok(stats_from_counters(
            &shared.read_counters(gpu)?,
            k,
            self.passes.len() as u32,
            total,
        ))
    }
}
