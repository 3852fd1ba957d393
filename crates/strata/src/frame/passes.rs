//! Passes of a frame: capture pipelines over the scene's vertices, geometry passes into the
//! frame's encoder, and timed pixel dispatches. The pipeline builders that need no frame are in
//! [`crate::frame::passes`] (re-exported here, so a method imports its passes from one place).

use crate::frame::FrameContext;
pub use crate::gpu::passes::{
    attachment, blend_add, clear_depth_pass, color_target, compute_pipeline, compute_pipelines,
    fullscreen_pass, kept_attachment, render_pipeline, scratch_depth, screen_pipeline, NullTarget,
    Rasterization,
};
use crate::gpu::Gpu;

/// A render pipeline drawing the scene with `vs_scene` ([`Gpu::scene_vertex_module`]) and the
/// fragment entry point `(module, entry)` (a stage's module, or its passthrough twin), with no
/// culling (every surface layer counts), rasterizing `samples` samples per pixel (`--msaa`; the
/// targets must have as many).
pub fn capture_pipeline(
    gpu: &Gpu,
    label: &str,
    fragment: (&wgpu::ShaderModule, &str),
    layouts: &[&wgpu::BindGroupLayout],
    targets: &[Option<wgpu::ColorTargetState>],
    depth: Option<wgpu::DepthStencilState>,
    samples: u32,
) -> wgpu::RenderPipeline {
    let vertex = wgpu::VertexState {
        module: gpu.scene_vertex_module(),
        entry_point: Some("vs_scene"),
        compilation_options: Default::default(),
        buffers: &[Some(crate::scene::GpuVertex::layout())],
    };
    let raster = Rasterization {
        cull_mode: None,
        depth,
        samples,
    };
    render_pipeline(gpu, label, vertex, fragment, layouts, targets, raster)
}

/// The render pipeline of a geometry pass whose fragment stage is `stage`'s `entry` (a colour
/// step's made entry, [`crate::gpu::shader::color_entries`]): strata's vertex stage over the
/// scene ([`capture_pipeline`]), or for an application's recorder its shader calling the step
/// ([`crate::frame::application`]).
#[allow(clippy::too_many_arguments)]
pub fn geometry_pipeline(
    gpu: &Gpu,
    scene: &crate::frame::SceneGpu,
    (stage, entry): (&crate::gpu::shader::Stage, &str),
    layouts: &[&wgpu::BindGroupLayout],
    targets: &[Option<wgpu::ColorTargetState>],
    depth: Option<wgpu::DepthStencilState>,
    samples: u32,
) -> crate::error::Result<wgpu::RenderPipeline> {
    let label = format!("{}.{entry}", stage.label);
    match &scene.application {
        Some(app) => {
            let capture = crate::frame::application::capture_stage(stage, entry)?;
            let pass = crate::frame::application::PassPipeline {
                label: &label,
                layouts,
                ordered: false,
                targets,
                depth,
                samples,
            };
            crate::frame::application::pipeline(gpu, app, &capture, &pass)
        }
        None => Ok(capture_pipeline(
            gpu,
            &label,
            (&stage.module(&gpu.device), entry),
            layouts,
            targets,
            depth,
            samples,
        )),
    }
}

/// Records a geometry pass of `pipeline` with `groups` bound from index 0 (after an
/// application's groups) into color `targets`, each cleared to its color first, drawing the
/// frame's geometry.
pub fn color_geometry_pass(
    ctx: &mut FrameContext<'_>,
    name: &'static str,
    pipeline: &wgpu::RenderPipeline,
    groups: &[&wgpu::BindGroup],
    targets: &[(&wgpu::TextureView, wgpu::Color)],
) {
    let (scene, draw) = (ctx.scene, ctx.draw);
    let first = scene.first_group();
    color_pass(ctx, name, (pipeline, groups, first), targets, &|pass| {
        scene.draw(pass, draw)
    });
}

/// [`color_geometry_pass`] with the method's own draws (`draw` binds what it reads; strata's
/// groups from index 0: its own pipelines, not the application's).
pub fn color_pass_drawing(
    ctx: &mut FrameContext<'_>,
    name: &'static str,
    pipeline: &wgpu::RenderPipeline,
    groups: &[&wgpu::BindGroup],
    targets: &[(&wgpu::TextureView, wgpu::Color)],
    draw: &dyn Fn(&mut wgpu::RenderPass<'_>),
) {
    color_pass(ctx, name, (pipeline, groups, 0), targets, draw);
}

/// A timed pass into colour `targets`, each cleared first, strata's `groups` bound from `first`.
fn color_pass(
    ctx: &mut FrameContext<'_>,
    name: &'static str,
    bound: (&wgpu::RenderPipeline, &[&wgpu::BindGroup], u32),
    targets: &[(&wgpu::TextureView, wgpu::Color)],
    draw: &dyn Fn(&mut wgpu::RenderPass<'_>),
) {
    let attachments: Vec<_> = targets
        .iter()
        .map(|(view, clear)| attachment(view, *clear))
        .collect();
    render_pass(ctx, name, bound, &attachments, None, draw);
}

/// Records a timed geometry pass of `pipeline` with `groups` bound from index 0 (after an
/// application's groups), drawing the frame's geometry into `colors` (each loaded or cleared as
/// its operations say) and `depth`, a depth target loaded or cleared by its `LoadOp` and kept.
pub fn depth_geometry_pass(
    ctx: &mut FrameContext<'_>,
    name: &'static str,
    (pipeline, groups): (&wgpu::RenderPipeline, &[&wgpu::BindGroup]),
    colors: &[(&wgpu::TextureView, wgpu::LoadOp<wgpu::Color>)],
    (depth, depth_load): (&wgpu::TextureView, wgpu::LoadOp<f32>),
) {
    let attachments: Vec<_> = colors
        .iter()
        .map(|&(view, load)| {
            Some(wgpu::RenderPassColorAttachment {
                view,
                depth_slice: None,
                resolve_target: None,
                ops: wgpu::Operations {
                    load,
                    store: wgpu::StoreOp::Store,
                },
            })
        })
        .collect();
    let depth = wgpu::RenderPassDepthStencilAttachment {
        view: depth,
        depth_ops: Some(wgpu::Operations {
            load: depth_load,
            store: wgpu::StoreOp::Store,
        }),
        stencil_ops: None,
    };
    let (scene, draw) = (ctx.scene, ctx.draw);
    let first = scene.first_group();
    render_pass(
        ctx,
        name,
        (pipeline, groups, first),
        &attachments,
        Some(depth),
        &|pass| scene.draw(pass, draw),
    );
}

fn render_pass(
    ctx: &mut FrameContext<'_>,
    name: &'static str,
    (pipeline, groups, first): (&wgpu::RenderPipeline, &[&wgpu::BindGroup], u32),
    attachments: &[Option<wgpu::RenderPassColorAttachment<'_>>],
    depth: Option<wgpu::RenderPassDepthStencilAttachment<'_>>,
    draw: &dyn Fn(&mut wgpu::RenderPass<'_>),
) {
    let label = ctx.label(name);
    let mut pass = ctx.encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
        label: Some(&label),
        color_attachments: attachments,
        depth_stencil_attachment: depth,
        timestamp_writes: ctx.timer.render_pass(name),
        occlusion_query_set: None,
        multiview_mask: None,
    });
    pass.set_pipeline(pipeline);
    // An application's geometry passes bind its groups first (in its draw callback): strata's
    // start at `first`.
    for (i, group) in groups.iter().enumerate() {
        pass.set_bind_group(first + i as u32, Some(*group), &[]);
    }
    draw(&mut pass);
}

/// Runs a compute pipeline over every pixel (8×8 workgroups) in its own timed pass.
pub fn dispatch_pixels(
    ctx: &mut FrameContext<'_>,
    name: &'static str,
    pipeline: &wgpu::ComputePipeline,
    groups: &[&wgpu::BindGroup],
) {
    let workgroups = ctx.pixel_workgroups();
    dispatch(ctx, name, pipeline, groups, workgroups);
}

/// Runs a compute pipeline over `(x, y)` workgroups in its own timed pass.
pub fn dispatch(
    ctx: &mut FrameContext<'_>,
    name: &'static str,
    pipeline: &wgpu::ComputePipeline,
    groups: &[&wgpu::BindGroup],
    (x, y): (u32, u32),
) {
    dispatch_with(ctx, name, pipeline, groups, Workgroups::Direct(x, y));
}

/// How many workgroups a compute pass runs.
pub enum Workgroups<'a> {
    /// (x, y) workgroups; a pass with x = 0 dispatches nothing.
    Direct(u32, u32),
    /// From the first three words of a buffer written on the GPU.
    Indirect(&'a wgpu::Buffer),
}

/// Runs a compute pipeline over `workgroups` in its own timed pass.
pub fn dispatch_with(
    ctx: &mut FrameContext<'_>,
    name: &'static str,
    pipeline: &wgpu::ComputePipeline,
    groups: &[&wgpu::BindGroup],
    workgroups: Workgroups<'_>,
) {
    let label = ctx.label(name);
    let mut pass = ctx
        .encoder
        .begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some(&label),
            timestamp_writes: ctx.timer.compute_pass(name),
        });
    pass.set_pipeline(pipeline);
    for (i, g) in groups.iter().enumerate() {
        pass.set_bind_group(i as u32, Some(*g), &[]);
    }
    match workgroups {
        Workgroups::Direct(0, _) => {}
        Workgroups::Direct(x, y) => pass.dispatch_workgroups(x, y, 1),
        Workgroups::Indirect(args) => pass.dispatch_workgroups_indirect(args, 0),
    }
}

/// A geometry stage that writes only storage buffers, on the scene's rasterizer: a render
/// pipeline (the GPU's rasterizer) or the compute rasterizer's capture
/// ([`crate::raster::storage_stage`]).
pub enum GeometryStage {
    /// A render pipeline: the GPU's rasterizer, over a [`NullTarget`].
    Hw(wgpu::RenderPipeline),
    /// The compute rasterizer's capture pipeline.
    Compute(wgpu::ComputePipeline),
}

/// Records a timed geometry pass drawing into storage buffers only: over a [`NullTarget`] with
/// the GPU's rasterizer, or through the frame's compute rasterizer.
pub fn storage_geometry_pass(
    ctx: &mut FrameContext<'_>,
    name: &'static str,
    target: &NullTarget,
    stage: &GeometryStage,
    groups: &[&wgpu::BindGroup],
) {
    let pipeline = match stage {
        GeometryStage::Hw(pipeline) => pipeline,
        GeometryStage::Compute(pipeline) => {
            if let Some(raster) = ctx.raster.take() {
                raster.capture(ctx, name, pipeline, groups);
                ctx.raster = Some(raster);
            }
            return;
        }
    };
    let (scene, draw) = (ctx.scene, ctx.draw);
    render_pass(
        ctx,
        name,
        (pipeline, groups, scene.first_group()),
        &[target.attachment()],
        None,
        &|pass| scene.draw(pass, draw),
    );
}
