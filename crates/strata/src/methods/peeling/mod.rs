//! Depth peeling: `f2b` (front-to-back, Everitt 2001) and `dual` (Bavoil & Myers 2008).
//!
//! **f2b** passes: init (compute: empty running composite per pixel); then per layer a *peel*
//! geometry pass — fragments not strictly after the pixel's last captured (depth, primitive) are
//! discarded and a LESS depth test keeps the nearest of the rest (the first drawn among equal
//! depths, so ties follow primitive order exactly) — and an *accumulate* compute pass that
//! composites the layer and counts capturing pixels; peeling stops after a pass that captured
//! nothing (N layers → N+1 geometry passes); finish (compute: over the background).
//! Memory per pixel: 32 B running composite, 8 B color, 4 B tag, 4 B depth copy, 4 B depth
//! buffer = 52·W·H. Exact, including ties.
//!
//! **dual** passes: init; *bounds* (one geometry pass: nearest and farthest depth per pixel with
//! atomicMin/atomicMax on the depth bits); then per pair of layers a *peel* geometry pass that
//! stores the fragment at the nearest depth in a front slot and the one at the farthest in a back
//! slot while the fragments between them compute the next bounds, and an *advance* compute pass
//! that composites the front slot front-to-back and the back slot back-to-front (the over
//! operator, with the same absorption rule) and counts pixels with layers left; finish joins the
//! two. N layers → ⌈N/2⌉+1 geometry passes. Memory per pixel: 16 B bounds, 64 B two composites,
//! 32 B two slots, 8 B hit counters = 120·W·H. Limit: fragments at exactly the same depth in one
//! pixel share a slot; one is kept, the others are counted in `fragments_dropped` (never
//! silently lost). Classic dual peeling's min/max blending needs RG32F blending, which core
//! WebGPU lacks, hence the storage atomics.

use crate::error::{Error, Result};
use crate::gpu::binding::{self, Slot};
use crate::gpu::{readback, shader, Gpu, ResourceCache};
use crate::methods::{
    attachment, capture_pipeline, compute_pipeline, dispatch_pixels, storage_geometry_pass,
    submit_pixels, Method, MethodStats, NullTarget,
};
use crate::render::{FrameContext, SceneGpu};

/// Peeling gives up past this many geometry passes (a runaway scene, not a real depth).
pub const MAX_PEEL_PASSES: u32 = 4096;

fn too_many_passes(method: &str) -> Error {
    Error::runtime(format!(
        "{method}: still capturing after {MAX_PEEL_PASSES} geometry passes"
    ))
}

fn read_counter(gpu: &Gpu, buffer: &wgpu::Buffer, count: u64) -> Result<Vec<u32>> {
    readback::read_u32s(gpu, buffer, count)
}

const COLOR_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba16Float;
const TAG_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::R32Uint;
const DEPTH_COPY_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::R32Float;

pub struct FrontToBack {
    peel_layout: wgpu::BindGroupLayout,
    accumulate_layout: wgpu::BindGroupLayout,
    peel: wgpu::RenderPipeline,
    init: wgpu::ComputePipeline,
    accumulate: wgpu::ComputePipeline,
    finish: wgpu::ComputePipeline,
    cache: ResourceCache,
}

impl FrontToBack {
    pub fn new(gpu: &Gpu, scene: &SceneGpu) -> FrontToBack {
        let device = &gpu.device;
        let peel_layout = binding::layout(device, "strata.f2b.peel.layout", &[Slot::Storage]);
        let accumulate_layout = binding::layout(
            device,
            "strata.f2b.accumulate.layout",
            &[
                Slot::StorageRw,
                Slot::TextureFloat,
                Slot::TextureUint,
                Slot::TextureFloat,
                Slot::StorageRw,
                Slot::StorageRw,
            ],
        );
        let module = shader::module(device, "strata.f2b.peel", include_str!("f2b_peel.wgsl"));
        let target = |format| {
            Some(wgpu::ColorTargetState {
                format,
                blend: None,
                write_mask: wgpu::ColorWrites::ALL,
            })
        };
        let peel = capture_pipeline(
            gpu,
            "strata.f2b.peel",
            &module,
            "fs_peel",
            &[&scene.frame_layout, &peel_layout],
            &[
                target(COLOR_FORMAT),
                target(TAG_FORMAT),
                target(DEPTH_COPY_FORMAT),
            ],
            Some(wgpu::DepthStencilState {
                format: wgpu::TextureFormat::Depth32Float,
                depth_write_enabled: Some(true),
                depth_compare: Some(wgpu::CompareFunction::Less),
                stencil: Default::default(),
                bias: Default::default(),
            }),
        );
        let module = shader::module(
            device,
            "strata.f2b.accumulate",
            include_str!("f2b_accumulate.wgsl"),
        );
        let layouts = [&scene.frame_layout, &accumulate_layout];
        FrontToBack {
            init: compute_pipeline(gpu, "strata.f2b.init", &module, "cs_init", &layouts),
            accumulate: compute_pipeline(
                gpu,
                "strata.f2b.accumulate",
                &module,
                "cs_accumulate",
                &layouts,
            ),
            finish: compute_pipeline(gpu, "strata.f2b.finish", &module, "cs_finish", &layouts),
            peel,
            peel_layout,
            accumulate_layout,
            cache: ResourceCache::default(),
        }
    }
}

impl Method for FrontToBack {
    fn render(&mut self, ctx: &mut FrameContext<'_>) -> Result<MethodStats> {
        let gpu = ctx.gpu;
        let (w, h) = (ctx.options.width, ctx.options.height);
        let usage = wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::TEXTURE_BINDING;
        let color = self
            .cache
            .texture(gpu, "strata.f2b.layer.color", (w, h), COLOR_FORMAT, usage)
            .create_view(&Default::default());
        let tag = self
            .cache
            .texture(gpu, "strata.f2b.layer.tag", (w, h), TAG_FORMAT, usage)
            .create_view(&Default::default());
        let depth_copy = self
            .cache
            .texture(
                gpu,
                "strata.f2b.layer.depth",
                (w, h),
                DEPTH_COPY_FORMAT,
                usage,
            )
            .create_view(&Default::default());
        let depth = self
            .cache
            .texture(
                gpu,
                "strata.f2b.depth",
                (w, h),
                wgpu::TextureFormat::Depth32Float,
                wgpu::TextureUsages::RENDER_ATTACHMENT,
            )
            .create_view(&Default::default());
        let state = self.cache.storage(
            gpu,
            "strata.f2b.state",
            ctx.pixels() * 32,
            wgpu::BufferUsages::empty(),
        )?;
        let captured =
            self.cache
                .storage(gpu, "strata.f2b.captured", 4, wgpu::BufferUsages::COPY_SRC)?;
        let peel_group = binding::group(
            &gpu.device,
            "strata.f2b.peel.group",
            &self.peel_layout,
            &[state.as_entire_binding()],
        );
        let acc_group = binding::group(
            &gpu.device,
            "strata.f2b.accumulate.group",
            &self.accumulate_layout,
            &[
                state.as_entire_binding(),
                wgpu::BindingResource::TextureView(&color),
                wgpu::BindingResource::TextureView(&tag),
                wgpu::BindingResource::TextureView(&depth_copy),
                captured.as_entire_binding(),
                ctx.output.as_entire_binding(),
            ],
        );
        let frame_group = ctx.frame_group;

        let mut enc = gpu.device.create_command_encoder(&Default::default());
        dispatch_pixels(
            ctx,
            &mut enc,
            "init",
            &self.init,
            &[frame_group, &acc_group],
        );
        gpu.queue.submit([enc.finish()]);

        let mut passes = 0;
        loop {
            if passes == MAX_PEEL_PASSES {
                return Err(too_many_passes("f2b"));
            }
            passes += 1;
            let mut enc = gpu.device.create_command_encoder(&Default::default());
            enc.clear_buffer(&captured, 0, None);
            {
                let mut pass = enc.begin_render_pass(&wgpu::RenderPassDescriptor {
                    label: Some("strata.f2b.peel"),
                    color_attachments: &[
                        attachment(&color, wgpu::Color::TRANSPARENT),
                        attachment(
                            &tag,
                            wgpu::Color {
                                r: u32::MAX as f64,
                                g: 0.0,
                                b: 0.0,
                                a: 0.0,
                            },
                        ),
                        attachment(&depth_copy, wgpu::Color::TRANSPARENT),
                    ],
                    depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
                        view: &depth,
                        depth_ops: Some(wgpu::Operations {
                            load: wgpu::LoadOp::Clear(1.0),
                            store: wgpu::StoreOp::Discard,
                        }),
                        stencil_ops: None,
                    }),
                    timestamp_writes: ctx.timer.render_pass("peel"),
                    occlusion_query_set: None,
                    multiview_mask: None,
                });
                pass.set_pipeline(&self.peel);
                pass.set_bind_group(0, Some(frame_group), &[]);
                pass.set_bind_group(1, Some(&peel_group), &[]);
                ctx.draw_geometry(&mut pass);
            }
            dispatch_pixels(
                ctx,
                &mut enc,
                "accumulate",
                &self.accumulate,
                &[frame_group, &acc_group],
            );
            gpu.queue.submit([enc.finish()]);
            if read_counter(gpu, &captured, 1)?[0] == 0 {
                break;
            }
        }

        submit_pixels(ctx, "finish", &self.finish, &[frame_group, &acc_group]);
        Ok(MethodStats {
            geometry_passes: passes,
            fragments_dropped: Some(0),
            bytes_allocated: ctx.pixels() * 52,
            ..Default::default()
        })
    }
}

pub struct Dual {
    peel_layout: wgpu::BindGroupLayout,
    advance_layout: wgpu::BindGroupLayout,
    bounds: wgpu::RenderPipeline,
    peel: wgpu::RenderPipeline,
    init: wgpu::ComputePipeline,
    advance: wgpu::ComputePipeline,
    finish: wgpu::ComputePipeline,
    null_target: Option<NullTarget>,
    cache: ResourceCache,
}

impl Dual {
    pub fn new(gpu: &Gpu, scene: &SceneGpu) -> Dual {
        let device = &gpu.device;
        let peel_layout = binding::layout(
            device,
            "strata.dual.peel.layout",
            &[
                Slot::Storage,
                Slot::StorageRw,
                Slot::StorageRw,
                Slot::StorageRw,
            ],
        );
        let advance_layout =
            binding::layout(device, "strata.dual.advance.layout", &[Slot::StorageRw; 8]);
        let module = shader::module(device, "strata.dual.peel", include_str!("dual_peel.wgsl"));
        let layouts = [&scene.frame_layout, &peel_layout];
        let targets = [NullTarget::target_state()];
        let bounds = capture_pipeline(
            gpu,
            "strata.dual.bounds",
            &module,
            "fs_bounds",
            &layouts,
            &targets,
            None,
        );
        let peel = capture_pipeline(
            gpu,
            "strata.dual.peel",
            &module,
            "fs_peel",
            &layouts,
            &targets,
            None,
        );
        let module = shader::module(
            device,
            "strata.dual.advance",
            include_str!("dual_advance.wgsl"),
        );
        let layouts = [&scene.frame_layout, &advance_layout];
        Dual {
            init: compute_pipeline(gpu, "strata.dual.init", &module, "cs_init", &layouts),
            advance: compute_pipeline(gpu, "strata.dual.advance", &module, "cs_advance", &layouts),
            finish: compute_pipeline(gpu, "strata.dual.finish", &module, "cs_finish", &layouts),
            bounds,
            peel,
            peel_layout,
            advance_layout,
            null_target: None,
            cache: ResourceCache::default(),
        }
    }
}

impl Method for Dual {
    fn render(&mut self, ctx: &mut FrameContext<'_>) -> Result<MethodStats> {
        let gpu = ctx.gpu;
        let (w, h) = (ctx.options.width, ctx.options.height);
        let null_target =
            NullTarget::ensure(&mut self.null_target, gpu, "strata.dual.null_target", w, h);
        let px = ctx.pixels();
        let none = wgpu::BufferUsages::empty();
        let bounds = self
            .cache
            .storage(gpu, "strata.dual.bounds", px * 8, none)?;
        let next_bounds = self
            .cache
            .storage(gpu, "strata.dual.next_bounds", px * 8, none)?;
        let layers = self
            .cache
            .storage(gpu, "strata.dual.layers", px * 32, none)?;
        let hits = self.cache.storage(gpu, "strata.dual.hits", px * 8, none)?;
        let front = self
            .cache
            .storage(gpu, "strata.dual.front", px * 32, none)?;
        let back = self.cache.storage(gpu, "strata.dual.back", px * 32, none)?;
        let counters =
            self.cache
                .storage(gpu, "strata.dual.counters", 8, wgpu::BufferUsages::COPY_SRC)?;
        let peel_group = binding::group(
            &gpu.device,
            "strata.dual.peel.group",
            &self.peel_layout,
            &[
                bounds.as_entire_binding(),
                next_bounds.as_entire_binding(),
                layers.as_entire_binding(),
                hits.as_entire_binding(),
            ],
        );
        let advance_group = binding::group(
            &gpu.device,
            "strata.dual.advance.group",
            &self.advance_layout,
            &[
                bounds.as_entire_binding(),
                next_bounds.as_entire_binding(),
                layers.as_entire_binding(),
                hits.as_entire_binding(),
                front.as_entire_binding(),
                back.as_entire_binding(),
                counters.as_entire_binding(),
                ctx.output.as_entire_binding(),
            ],
        );
        let frame_group = ctx.frame_group;

        let mut enc = gpu.device.create_command_encoder(&Default::default());
        dispatch_pixels(
            ctx,
            &mut enc,
            "init",
            &self.init,
            &[frame_group, &advance_group],
        );
        storage_geometry_pass(
            ctx,
            &mut enc,
            "bounds",
            null_target,
            &self.bounds,
            &[frame_group, &peel_group],
        );
        gpu.queue.submit([enc.finish()]);
        let mut passes = 1;
        let mut dropped = 0u64;
        loop {
            // Promote the bounds just computed; the slots are empty on the first round.
            let mut enc = gpu.device.create_command_encoder(&Default::default());
            enc.clear_buffer(&counters, 0, None);
            dispatch_pixels(
                ctx,
                &mut enc,
                "advance",
                &self.advance,
                &[frame_group, &advance_group],
            );
            gpu.queue.submit([enc.finish()]);
            let c = read_counter(gpu, &counters, 2)?;
            dropped += c[1] as u64;
            if c[0] == 0 {
                break;
            }
            if passes == MAX_PEEL_PASSES {
                return Err(too_many_passes("dual"));
            }
            passes += 1;
            let mut enc = gpu.device.create_command_encoder(&Default::default());
            storage_geometry_pass(
                ctx,
                &mut enc,
                "peel",
                null_target,
                &self.peel,
                &[frame_group, &peel_group],
            );
            gpu.queue.submit([enc.finish()]);
        }

        submit_pixels(ctx, "finish", &self.finish, &[frame_group, &advance_group]);
        Ok(MethodStats {
            geometry_passes: passes,
            fragments_dropped: Some(dropped),
            bytes_allocated: px * 120,
            ..Default::default()
        })
    }
}
