//! `convex` — single-read multi-fragment rendering with convex polyhedra (seed 001: Xie & Wang,
//! 2011): the geometry is ordered in object space so that each triangle is drawn once per frame
//! in visibility order, and a pixel never holds more than one group's layers at a time.
//!
//! Preprocess (once per geometry, the last few kept in memory by [`decomposition_of`], and on
//! disk with `--cache-dir` ([`cache`]);
//! [`decompose`]): convex parts by region growing, inseparable neighbours paired into groups of
//! two, nesting found, a separating plane per pair of groups whose boxes overlap.
//!
//! Per frame ([`order`], on the CPU when the view changed): the groups' screen footprints
//! (rectangles and projected hulls), the visibility order of every pair that can meet in a pixel
//! (their plane, or nesting), a topological sort into passes whose groups cannot share a pixel;
//! the plan's triangles are then written into one index buffer, pass by pass and cap by cap.
//! Passes, each recorded into the caller's encoder:
//! - init (compute): every pixel's compositing state, counters.
//! - per pass: capture (one geometry pass of at most three draws, one per cap; a container's
//!   front cap before what it holds, its back cap after): each fragment appended to its pixel's
//!   slots behind an atomic claim counter, and a pixel's first claim lists it; then merge
//!   (compute, dispatched indirectly over the listed pixels only, so a pass costs what its groups
//!   cover, not the screen): the pixel sorts its at most `layers` fragments (2 per convex part;
//!   4 for a paired group — the paper's slab), composites them front to back behind what earlier
//!   passes merged, and counts an order violation when the pass's nearest fragment lies in front
//!   of the last merged one.
//! - finish (compute): the pixel's [`crate::frame::Resolved`] and its account.
//!
//! Every triangle is drawn once per frame (containers' twice, each fragment kept once).
//! Memory: (16·layers + 60)·W·H + 12 bytes per triangle (the index buffer; a container's
//! twice) + 64 — two layers' worth when no group is paired, whatever the depth complexity.
//!
//! With `--msaa S` a pixel has S sample entries with their own claims, slots and state: a
//! fragment, shaded once, is captured at each sample it covers (a pixel on a part's edge gets
//! one fragment per triangle touching it, each covering only its samples, so a per-pixel array
//! of `layers` would overflow there), every entry merges its own, finish averages them.
//! Violations and overflows count sample entries; a fragment counts as dropped when some
//! sample it covers was full (never fewer than the fragments no sample kept). At a curved
//! silhouette a partly covering fragment carries its triangle's plane depth at the pixel
//! center, which for a steep triangle lies far from the triangle: the reference orders each
//! sample by those depths, convex by object space, and where they disagree the merge counts a
//! violation (nested spheres at 48², 4×: 25 per thousand pixels; 0.04% of pixels over 2/255
//! with transparency, 1.1% with translucency's absorption).
//! On planar layers it equals the reference.
//! Memory: ((16·layers + 60)·S + 8)·W·H + the rest as above.
//!
//! The paper captures a piece's two layers with 32-bit MAX blending into two zero-cleared
//! targets; WebGPU has no MAX blending on 32-bit float targets everywhere, so the capture writes
//! storage behind a per-pixel counter, which also keeps a paired group's four layers and counts
//! (as dropped) what a non-convex configuration would put past them. Which fragments an
//! overflowing entry keeps is the order they arrived in: on a GPU that runs a pixel's fragments
//! at once, such pixels (counted in `overflowing_pixels`) may differ from run to run.
//!
//! Exact where every overlapping pair has a plane or nests: then the passes follow depth order in
//! every pixel and the result equals the reference. Coincident surfaces (parts lying in one
//! plane: decals, doubled faces) are such pairs: a part never holds two faces of one plane
//! over each other, and coplanar groups are ordered by their lowest primitive from either
//! side, as the reference orders equal depths. A frame that broke the order or dropped a
//! fragment says `exact: false`. Pairs without either (adjacent parts on a
//! curved scanned surface whose shared boundary is not planar, once each has a partner) are
//! ordered by centroid distance: the frame counts the pixels where that broke the order
//! (`order_violations`), and the error against the reference is measured, not hidden. Limits:
//! static geometry (a scene whose objects move is refused; camera motion is free), the GPU's
//! rasterizer only, no application draw callback, no `--order`.

pub mod cache;
pub mod decompose;
pub mod descriptor;
pub mod order;
pub mod stats;

use std::path::Path;
use std::sync::{Arc, Mutex};

use glam::Vec3;

use crate::error::{Error, Result};
use crate::frame::passes::{capture_pipeline, compute_pipelines, dispatch_pixels, NullTarget};
use crate::frame::{FrameContext, MethodStats, Recorded, RenderOptions, SceneGpu, Totals};
use crate::gpu::binding::{self, Slot};
use crate::gpu::shader::{Defs, Stage};
use crate::gpu::{Gpu, ResourceCache};
use crate::methods::Method;
use crate::scene::GpuVertex;
use decompose::Decomposition;
use order::{Cap, FramePlan};
pub use stats::ConvexStats;

/// Per pass, the cap drawn and its range of the plan's index buffer.
type PassDraws = Vec<Vec<(Cap, std::ops::Range<u32>)>>;

/// The last plan, the view-projection and size it was made for, and its draws (at most three
/// a pass).
struct CurrentPlan {
    view_proj: [f32; 16],
    size: (u32, u32),
    plan: FramePlan,
    draws: PassDraws,
}

/// Per-pixel bytes besides the slots: compositing state, claim counter, generated count, the
/// pass's list of touched pixels.
const PIXEL_BYTES: u64 = crate::resolve::COMPOSITE_BYTES + 12;
/// Bytes besides the per-pixel ones and the index buffer: counters, the touched count, the
/// merge's indirect arguments and their reset value.
const FIXED_BYTES: u64 = 16 + 16 + 16 + 16;
/// Invocations per merge workgroup; the merge dispatch grows by one workgroup per this many
/// touched pixels.
const MERGE_WORKGROUP: u32 = 64;
/// Above this many passes a frame is timed as one span ("passes") instead of per pass, so the
/// timestamp query set does not run out.
const MAX_TIMED_PASSES: usize = 500;

/// `convex`: the decomposition, made once per geometry, and the per-frame order, passes and merge.
pub struct Convex {
    decomposition: Arc<Decomposition>,
    layers: u32,
    /// The current plan's triangles, pass by pass and cap by cap (vertex numbers 3t + i, so the
    /// vertex stage still names the primitive), rewritten when the plan changes; sized for
    /// every group with containers twice.
    indices: wgpu::Buffer,
    capture_layout: wgpu::BindGroupLayout,
    merge_layout: wgpu::BindGroupLayout,
    whole: wgpu::RenderPipeline,
    front: wgpu::RenderPipeline,
    back: wgpu::RenderPipeline,
    init: wgpu::ComputePipeline,
    merge: wgpu::ComputePipeline,
    finish: wgpu::ComputePipeline,
    null_target: Option<NullTarget>,
    /// The merge's indirect arguments before a pass: no workgroups, y = z = 1.
    merge_args_reset: wgpu::Buffer,
    plan: Option<CurrentPlan>,
    cache: ResourceCache,
}

/// Decompositions made or read in this process, newest last, by their geometry: a method made
/// again for the same geometry — the viewer changing an option, a benchmark's next
/// configuration — reuses the preprocess instead of repeating it.
static DECOMPOSITIONS: Mutex<Vec<(cache::Key, Arc<Decomposition>)>> = Mutex::new(Vec::new());
/// How many decompositions stay cached in memory.
const CACHED_DECOMPOSITIONS: usize = 4;

/// The decomposition of `triangles`: from memory, else from `cache_dir` (see [`cache`]), else
/// made (told to `progress` as the fraction done) and stored in both. A cache file that cannot
/// be read or written is reported as a warning; the decomposition is made regardless.
pub fn decomposition_of(
    triangles: &[[Vec3; 3]],
    cache_dir: Option<&Path>,
    progress: &dyn Fn(f32),
) -> Arc<Decomposition> {
    let key = cache::Key::of(triangles);
    let mut memory = DECOMPOSITIONS.lock().unwrap_or_else(|e| e.into_inner());
    if let Some(i) = memory.iter().position(|(k, _)| *k == key) {
        let entry = memory.remove(i);
        let found = entry.1.clone();
        memory.push(entry);
        return found;
    }
    // Made outside the lock: other threads' lookups need not wait for a long preprocess.
    drop(memory);
    let made = Arc::new(read_or_make(triangles, key, cache_dir, progress));
    let mut memory = DECOMPOSITIONS.lock().unwrap_or_else(|e| e.into_inner());
    memory.push((key, made.clone()));
    if memory.len() > CACHED_DECOMPOSITIONS {
        memory.remove(0);
    }
    made
}

fn read_or_make(
    triangles: &[[Vec3; 3]],
    key: cache::Key,
    cache_dir: Option<&Path>,
    progress: &dyn Fn(f32),
) -> Decomposition {
    let Some(dir) = cache_dir else {
        return Decomposition::new(triangles, progress);
    };
    let start = std::time::Instant::now();
    match cache::read(dir, key) {
        Ok(Some(mut d)) => {
            d.stats.read_from_cache_ms = Some(start.elapsed().as_secs_f64() * 1e3);
            progress(1.0);
            return d;
        }
        Ok(None) => {}
        Err(why) => log::warn!("convex: remaking an unusable cached decomposition ({why})"),
    }
    let d = Decomposition::new(triangles, progress);
    if let Err(why) = cache::write(dir, key, &d) {
        log::warn!("convex: could not cache the decomposition ({why})");
    }
    d
}

/// The convex stages (capture.wgsl, merge.wgsl) for `layers` fragments per pixel and pass.
pub fn stages(layers: u32) -> [Stage; 2] {
    let defs = Defs::default()
        .value("CONVEX_LAYERS", layers)
        .value("MERGE_WORKGROUP", MERGE_WORKGROUP);
    [
        Stage::new("strata.convex.capture", include_str!("capture.wgsl")).defs(&defs),
        Stage::new("strata.convex.merge", include_str!("merge.wgsl")).defs(&defs),
    ]
}

/// The scene's triangles read back from its vertex buffer (setup, not steady state).
fn scene_triangles(gpu: &Gpu, scene: &SceneGpu) -> Result<Vec<[Vec3; 3]>> {
    let bytes = scene.triangle_count as u64 * 3 * std::mem::size_of::<GpuVertex>() as u64;
    if bytes == 0 {
        return Ok(Vec::new());
    }
    let raw = crate::gpu::readback::read_buffer(gpu, &scene.vertices, bytes)?;
    Ok(positions(bytemuck::cast_slice(&raw)))
}

/// Each triangle's corners from three [`GpuVertex`] per triangle.
fn positions(vertices: &[GpuVertex]) -> Vec<[Vec3; 3]> {
    vertices
        .chunks_exact(3)
        .map(|t| [0, 1, 2].map(|i| Vec3::from(t[i].position)))
        .collect()
}

impl Convex {
    /// Decomposes `scene` (or reads the decomposition from `--cache-dir`) and makes the pipelines.
    pub fn new(gpu: &Gpu, scene: &SceneGpu, options: &RenderOptions) -> Result<Convex> {
        if scene.animation.is_some() {
            return Err(Error::unsupported(
                "convex orders static geometry decomposed once; this scene's objects move (use --frame T to render one time, or another method)",
            ));
        }
        let triangles = scene_triangles(gpu, scene)?;
        Ok(Self::with_decomposition(
            gpu,
            scene,
            decomposition_of(&triangles, options.build.cache_dir.as_deref(), &|_| {}),
        ))
    }

    /// The method over a decomposition already made (of the scene's triangles).
    pub fn with_decomposition(
        gpu: &Gpu,
        scene: &SceneGpu,
        decomposition: Arc<Decomposition>,
    ) -> Convex {
        let device = &gpu.device;
        let layers = decomposition.stats.layers_per_group;
        let most: u64 = decomposition
            .groups
            .iter()
            .zip(&decomposition.container)
            .map(|(g, &container)| g.triangles.len() as u64 * if container { 2 } else { 1 })
            .sum();
        let indices = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("strata.convex.indices"),
            size: (12 * most).max(16),
            usage: wgpu::BufferUsages::INDEX | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let capture_layout = binding::layout(
            device,
            "strata.convex.capture.layout",
            &[
                Slot::StorageRw,
                Slot::StorageRw,
                Slot::StorageRw,
                Slot::StorageRw,
                Slot::StorageRw,
            ],
        );
        let merge_layout = binding::layout(
            device,
            "strata.convex.merge.layout",
            &[
                Slot::StorageRw,
                Slot::StorageRw,
                Slot::Storage,
                Slot::StorageRw,
                Slot::StorageRw,
                Slot::StorageRw,
                Slot::Storage,
                Slot::Storage,
            ],
        );
        let merge_args_reset = gpu.buffer_with(
            "strata.convex.merge_args_reset",
            &[0u32, 1, 1, 0],
            wgpu::BufferUsages::COPY_SRC,
        );
        let [capture_stage, merge_stage] = stages(layers);
        let module = capture_stage.module(device);
        let capture = |entry: &str| {
            capture_pipeline(
                gpu,
                &format!("strata.convex.{entry}"),
                (&module, entry),
                &[&scene.frame_layout, &capture_layout],
                &[NullTarget::target_state()],
                None,
                scene.samples,
            )
        };
        let (whole, front, back) = (capture("fs_whole"), capture("fs_front"), capture("fs_back"));
        let [init, merge, finish] = compute_pipelines(
            gpu,
            "strata.convex",
            &merge_stage.module(device),
            ["cs_init", "cs_merge", "cs_finish"],
            &[&scene.frame_layout, &merge_layout],
        );
        Convex {
            init,
            merge,
            finish,
            whole,
            front,
            back,
            capture_layout,
            merge_layout,
            decomposition,
            layers,
            indices,
            null_target: None,
            merge_args_reset,
            plan: None,
            cache: ResourceCache::default(),
        }
    }

    /// The groups, planes and statistics of the preprocess.
    pub fn decomposition(&self) -> &Decomposition {
        &self.decomposition
    }

    /// Bytes per pixel at `samples` per pixel: every per-pixel array per sample entry with
    /// `--msaa`, and two counts per pixel.
    fn pixel_bytes(&self, samples: u32) -> u64 {
        let entry = 16 * self.layers as u64 + PIXEL_BYTES;
        if samples > 1 {
            entry * samples as u64 + 8
        } else {
            entry
        }
    }

    /// The plan for the frame's view, made again only when the view or size changed (its
    /// triangles then written to the index buffer, pass by pass and cap by cap); returns its
    /// CPU milliseconds this frame.
    fn update_plan(&mut self, ctx: &FrameContext<'_>) -> f64 {
        let view_proj = crate::frame::uniforms::band_projection(&ctx.scene.camera, ctx.options);
        let key = view_proj.to_cols_array();
        let size = ctx.size();
        if let Some(current) = &self.plan {
            if current.view_proj == key && current.size == size {
                return 0.0;
            }
        }
        let plan = order::plan(
            &self.decomposition,
            &ctx.scene.camera,
            view_proj,
            size.0,
            size.1,
            ctx.scene.samples,
        );
        let mut indices: Vec<u32> = Vec::new();
        let draws: PassDraws = plan
            .passes
            .iter()
            .map(|pass| {
                let mut draws: Vec<(Cap, std::ops::Range<u32>)> = Vec::new();
                for &(g, cap) in pass {
                    let start = indices.len() as u32;
                    let triangles = &self.decomposition.groups[g as usize].triangles;
                    indices.extend(
                        triangles
                            .iter()
                            .flat_map(|&t| [3 * t, 3 * t + 1, 3 * t + 2]),
                    );
                    match draws.last_mut() {
                        // The pass is sorted by cap: its groups of one cap are one draw.
                        Some((last, range)) if *last == cap => range.end = indices.len() as u32,
                        _ => draws.push((cap, start..indices.len() as u32)),
                    }
                }
                draws
            })
            .collect();
        if !indices.is_empty() {
            ctx.gpu
                .queue
                .write_buffer(&self.indices, 0, bytemuck::cast_slice(&indices));
        }
        let ms = plan.order_ms;
        self.plan = Some(CurrentPlan {
            view_proj: key,
            size,
            plan,
            draws,
        });
        ms
    }
}

impl Method for Convex {
    fn record(&mut self, ctx: &mut FrameContext<'_>) -> Result<Recorded> {
        if let Some(order) = ctx.options.frame.order {
            return Err(Error::unsupported(format!(
                "convex submits its groups in visibility order itself; --order {} applies to the other methods",
                order.name()
            )));
        }
        let gpu = ctx.gpu;
        let px = ctx.pixels();
        let samples = ctx.scene.samples;
        let bytes = px * self.pixel_bytes(samples) + self.indices.size() + FIXED_BYTES;
        ctx.check_budget(bytes)?;
        let order_ms = self.update_plan(ctx);
        let layers = self.layers as u64;
        // Sample entries (one per pixel single-sampled); with --msaa the claims are followed by
        // per-pixel counts of fragments and drops.
        let entries = px * samples as u64;
        let pixel_counts = if samples > 1 { px * 8 } else { 0 };
        let state = self.cache.storage(
            gpu,
            "strata.convex.state",
            entries * crate::resolve::COMPOSITE_BYTES,
        )?;
        let claims = self
            .cache
            .storage(gpu, "strata.convex.claims", entries * 4 + pixel_counts)?;
        let slots = self
            .cache
            .storage(gpu, "strata.convex.slots", entries * 16 * layers)?;
        let generated = self
            .cache
            .storage(gpu, "strata.convex.generated", entries * 4)?;
        let counters = self.cache.readable(gpu, "strata.convex.counters", 16)?;
        let touched = self
            .cache
            .storage(gpu, "strata.convex.touched", entries * 4)?;
        let touched_count = self.cache.storage(gpu, "strata.convex.touched_count", 4)?;
        let merge_args = self.cache.storage_with(
            gpu,
            "strata.convex.merge_args",
            16,
            wgpu::BufferUsages::INDIRECT,
        )?;
        let capture_group = binding::group(
            &gpu.device,
            "strata.convex.capture.group",
            &self.capture_layout,
            &[
                claims.as_entire_binding(),
                slots.as_entire_binding(),
                touched.as_entire_binding(),
                touched_count.as_entire_binding(),
                merge_args.as_entire_binding(),
            ],
        );
        let merge_group = binding::group(
            &gpu.device,
            "strata.convex.merge.group",
            &self.merge_layout,
            &[
                state.as_entire_binding(),
                claims.as_entire_binding(),
                slots.as_entire_binding(),
                generated.as_entire_binding(),
                counters.as_entire_binding(),
                ctx.output.as_entire_binding(),
                touched.as_entire_binding(),
                touched_count.as_entire_binding(),
            ],
        );
        let null_target = ctx.null_target(&mut self.null_target, "strata.convex.null_target");
        let frame_group = ctx.frame_group;
        ctx.encoder.clear_buffer(&counters, 0, None);
        dispatch_pixels(ctx, "init", &self.init, &[frame_group, &merge_group]);
        let CurrentPlan {
            plan,
            draws: pass_draws,
            ..
        } = self.plan.as_ref().expect("made above");
        let mut draws = 0;
        let span = (plan.passes.len() > MAX_TIMED_PASSES).then(|| ctx.timer.span("passes"));
        let last_pass = plan.passes.len().saturating_sub(1);
        for (p, cap_draws) in pass_draws.iter().enumerate() {
            ctx.encoder
                .copy_buffer_to_buffer(&self.merge_args_reset, 0, &merge_args, 0, 16);
            ctx.encoder.clear_buffer(&touched_count, 0, None);
            let label = ctx.label("capture");
            let timestamps = match span {
                Some(span) => ctx.timer.render_pass_in_span(span, p == 0, false),
                None => ctx.timer.render_pass("capture"),
            };
            let scene = ctx.scene;
            let mut pass = ctx.encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
                label: Some(&label),
                color_attachments: &[null_target.attachment()],
                depth_stencil_attachment: None,
                timestamp_writes: timestamps,
                occlusion_query_set: None,
                multiview_mask: None,
            });
            pass.set_bind_group(0, Some(frame_group), &[]);
            pass.set_bind_group(1, Some(&capture_group), &[]);
            scene.bind(&mut pass);
            pass.set_index_buffer(self.indices.slice(..), wgpu::IndexFormat::Uint32);
            for (cap, range) in cap_draws {
                pass.set_pipeline(match cap {
                    Cap::Whole => &self.whole,
                    Cap::Front => &self.front,
                    Cap::Back => &self.back,
                });
                pass.draw_indexed(range.clone(), 0, 0..1);
                draws += 1;
            }
            drop(pass);
            let label = ctx.label("merge");
            let timestamps = match span {
                Some(span) => ctx.timer.compute_pass_in_span(span, false, p == last_pass),
                None => ctx.timer.compute_pass("merge"),
            };
            let mut pass = ctx
                .encoder
                .begin_compute_pass(&wgpu::ComputePassDescriptor {
                    label: Some(&label),
                    timestamp_writes: timestamps,
                });
            pass.set_pipeline(&self.merge);
            pass.set_bind_group(0, Some(frame_group), &[]);
            pass.set_bind_group(1, Some(&merge_group), &[]);
            pass.dispatch_workgroups_indirect(&merge_args, 0);
        }
        dispatch_pixels(ctx, "finish", &self.finish, &[frame_group, &merge_group]);
        ctx.readback.words(&counters, 0, 4);
        let d = &self.decomposition.stats;
        Ok(Recorded {
            geometry_passes: plan.passes.len() as u32,
            bytes_allocated: bytes,
            capacity: layers,
            family: Some(crate::frame::FamilyStats::new(ConvexStats {
                parts: d.parts,
                groups: d.groups,
                culled: plan.culled,
                passes: plan.passes.len() as u32,
                draws,
                overlapping_pairs: plan.overlapping,
                unseparated_pairs: plan.unseparated,
                cycles_broken: plan.cycles_broken,
                layers: self.layers,
                order_ms,
                preprocess_ms: d.preprocess_ms,
                order_violations: None,
                overflowing_pixels: None,
            })),
            ..Default::default()
        })
    }

    fn stats(&mut self, recorded: &Recorded, _totals: &Totals, words: &[u32]) -> MethodStats {
        let family = recorded
            .family
            .as_ref()
            .and_then(|f| f.get::<ConvexStats>())
            .map(|c| {
                crate::frame::FamilyStats::new(ConvexStats {
                    order_violations: Some(crate::frame::wide(words, 0)),
                    overflowing_pixels: Some(crate::frame::wide(words, 2)),
                    ..c.clone()
                })
            });
        MethodStats {
            family,
            ..Default::default()
        }
    }

    fn resources(&self) -> Vec<&ResourceCache> {
        vec![&self.cache]
    }
}

/// Every triangle of `scene` (at its current time), in primitive order.
pub fn triangles_of(scene: &crate::scene::Scene) -> Vec<[Vec3; 3]> {
    positions(&scene.triangles().vertices)
}

/// `scene` redrawn as its decomposition: one opaque object per group, each its own color
/// (golden-ratio hues, paired groups darker), with the scene's camera and lights — what
/// `strata convex --out` renders.
pub fn pieces_scene(
    scene: &crate::scene::Scene,
    triangles: &[[Vec3; 3]],
    decomposition: &Decomposition,
) -> crate::scene::Scene {
    use crate::scene::{Material, Mesh, Object, Scene};
    let mut pieces = Scene {
        camera: Some(scene.camera_or_framing()),
        lights: scene.lights.clone(),
        ..Scene::default()
    };
    for (i, g) in decomposition.groups.iter().enumerate() {
        let hue = (i as f32 * 0.618_034).fract();
        let value = if g.parts > 1 { 0.55 } else { 0.95 };
        let material = pieces.add_material(Material {
            name: format!("group {i}"),
            color: crate::scene::hsv(hue, 0.65, value),
            opacity: 1.0,
            ..Material::default()
        });
        let positions: Vec<[f32; 3]> = g
            .triangles
            .iter()
            .flat_map(|&t| triangles[t as usize].map(|p| p.to_array()))
            .collect();
        let mut mesh = Mesh {
            indices: (0..positions.len() as u32).collect(),
            normals: Vec::new(),
            positions,
        };
        mesh.compute_normals();
        pieces.objects.push(Object {
            name: format!("group {i}"),
            mesh,
            material,
        });
    }
    pieces
}

#[cfg(test)]
mod tests;
