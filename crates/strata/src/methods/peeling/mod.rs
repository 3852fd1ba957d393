//! Depth peeling: `f2b` (front-to-back, Everitt 2001) and `dual` (Bavoil & Myers 2008) here;
//! `bucket` (bucket depth peeling, Liu et al. 2009) in [`bucket`].
//!
//! The number of layers L a frame peels is fixed when it is recorded: `--layers N`, else the
//! depth complexity the previous frame measured (8 for a first frame). Each frame counts every
//! pixel's fragments on the GPU, so a frame with fewer layers than its depth complexity knows
//! it: its missing fragments are reported as dropped, the next frame peels enough, and exact
//! mode renders such a frame again. Nothing waits on the GPU between passes.
//!
//! **f2b** passes: init (compute: empty running composite per pixel); then L times a *peel*
//! geometry pass — fragments not strictly after the pixel's last captured (depth, primitive) are
//! discarded and a LESS depth test keeps the nearest of the rest (the first drawn among equal
//! depths, so ties follow primitive order exactly); the first one also counts every fragment of
//! the pixel — and an *accumulate* compute pass that composites the layer; finish (compute).
//! Because ties follow the draw order, f2b refuses `--order front|back|random`.
//! N layers → N geometry passes. Memory per pixel: 48 B running composite (RGB transmittance),
//! 8 B color, 4 B tag, 4 B depth copy, 4 B depth buffer, 4 B count = 72·W·H. Exact, including
//! ties.
//!
//! **dual** passes: init; *bounds* (one geometry pass: nearest and farthest depth per pixel with
//! atomicMin/atomicMax on the depth bits); then per pair of layers a *peel* geometry pass that
//! stores the fragment at the nearest depth in a front slot and the one at the farthest in a back
//! slot while the fragments between them compute the next bounds, and an *advance* compute pass
//! that composites the front slot front-to-back and the back slot back-to-front (the over
//! operator, with the same absorption rule) and counts pixels with layers left; finish joins the
//! two. N layers → ⌈N/2⌉+1 geometry passes. Keys: with 64-bit atomic min/max
//! (SHADER_INT64_ATOMIC_MIN_MAX) a fragment's key is its depth bits above its tag (primitive and
//! facing), unique per pixel, so fragments at exactly equal depth peel one by one in primitive
//! order and dual is exact with ties; without it the key is the depth alone, and fragments at
//! exactly the same depth in one pixel share a slot — one is kept, the others are counted in
//! `fragments_dropped` (never silently lost). Memory per pixel: bounds 16 B (32 B with 64-bit
//! keys), 96 B two composites, 32 B two slots, 12 B hit counters and count = 156·W·H
//! (172·W·H). Classic dual peeling's min/max blending needs RG32F blending, which core
//! WebGPU lacks, hence the storage atomics.

pub mod bucket;
pub mod descriptor;
pub mod options;

pub use options::{BucketSplit, PeelingOptions, MAX_LAYERS};

use crate::error::{Error, Result};
use crate::frame::passes::{
    attachment, color_target, compute_pipelines, dispatch_pixels, geometry_pipeline, scratch_depth,
    storage_geometry_pass, GeometryStage, NullTarget,
};
use crate::frame::{FrameContext, MethodStats, Recorded, SceneGpu, Totals};
use crate::gpu::binding::{self, Slot};
use crate::gpu::shader::{self, Defs, Library, Stage};
use crate::gpu::{Gpu, ResourceCache};
use crate::resolve::COMPOSITE_BYTES;

/// The peeling family's WGSL modules (`strata::peeling::…`).
pub const LIBRARY: Library = &[
    include_str!("f2b_peel.wgsl"),
    include_str!("f2b_accumulate.wgsl"),
    include_str!("dual_key32.wgsl"),
    include_str!("dual_key64.wgsl"),
    DUAL_PEEL_WGSL,
    DUAL_ADVANCE_WGSL,
    bucket::PARAMS_WGSL,
    include_str!("bucket_common.wgsl"),
    include_str!("bucket_bounds.wgsl"),
    include_str!("bucket_reduce.wgsl"),
    include_str!("bucket_histogram.wgsl"),
    include_str!("bucket_sort.wgsl"),
    include_str!("bucket_color.wgsl"),
    include_str!("bucket_resolve.wgsl"),
];
use crate::methods::Method;

/// Layers a first frame peels before it has measured its depth complexity.
pub const FIRST_GUESS_LAYERS: u32 = 8;

/// Layers for the next frame: fixed by the options, else the last measured depth complexity.
pub(crate) fn layers_for(ctx: &FrameContext<'_>, measured: Option<u32>) -> u32 {
    ctx.options
        .frame
        .family::<PeelingOptions>()
        .layers
        .or(measured)
        .unwrap_or(FIRST_GUESS_LAYERS)
        .clamp(1, MAX_LAYERS)
}

/// Whether the options fix the layers (`--layers`), so that a frame peeling them is complete.
pub(crate) fn layers_fixed(ctx: &FrameContext<'_>) -> bool {
    ctx.options
        .frame
        .family::<PeelingOptions>()
        .layers
        .is_some()
}

/// Feedback of a peeling frame: the depth complexity it measured, and whether it peeled enough
/// (a frame that peeled the `--layers` asked for is complete: what lies deeper is counted as
/// dropped, and peeling the same count again would not change it).
pub(crate) fn peel_feedback(
    measured: &mut Option<u32>,
    recorded: &Recorded,
    totals: &Totals,
    layers_fixed: bool,
) -> MethodStats {
    *measured = Some(totals.max_depth.max(1));
    MethodStats {
        incomplete: !layers_fixed && totals.max_depth as u64 > recorded.capacity,
        ..Default::default()
    }
}

/// f2b's bytes per pixel (see the module docs); with `--msaa S`, 72·S + 8.
fn f2b_pixel_bytes(samples: u32) -> u64 {
    let per_sample = COMPOSITE_BYTES + 24;
    if samples > 1 {
        per_sample * samples as u64 + 8
    } else {
        per_sample
    }
}

const COLOR_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba16Float;
const TAG_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::R32Uint;

/// `f2b`: one geometry pass per layer, each peeling the nearest fragment behind the last.
pub struct FrontToBack {
    peel_layout: wgpu::BindGroupLayout,
    accumulate_layout: wgpu::BindGroupLayout,
    peel_first: wgpu::RenderPipeline,
    peel: wgpu::RenderPipeline,
    /// `--msaa`: samples per pixel, and the account pass after the last layer.
    samples: u32,
    account: Option<GeometryStage>,
    null_target: Option<NullTarget>,
    init: wgpu::ComputePipeline,
    accumulate: wgpu::ComputePipeline,
    finish: wgpu::ComputePipeline,
    measured: Option<u32>,
    /// The last frame peeled `--layers` layers, not a measured count.
    layers_fixed: bool,
    cache: ResourceCache,
}

impl FrontToBack {
    /// The peel and accumulate pipelines for `scene`.
    pub fn new(gpu: &Gpu, scene: &SceneGpu) -> crate::error::Result<FrontToBack> {
        let device = &gpu.device;
        let samples = scene.samples;
        let multisampled = samples > 1;
        let peel_layout = binding::layout(
            device,
            "strata.f2b.peel.layout",
            &[Slot::Storage, Slot::StorageRw],
        );
        let layer_texture = Slot::target(samples);
        let tag_texture = if multisampled {
            Slot::TextureFloatMultisampled
        } else {
            Slot::TextureUint
        };
        let accumulate_layout = binding::layout(
            device,
            "strata.f2b.accumulate.layout",
            &[
                Slot::StorageRw,
                layer_texture,
                tag_texture,
                tag_texture,
                Slot::StorageRw,
                Slot::StorageRw,
            ],
        );
        let peel_stage = Stage::new("strata.f2b.peel", include_str!("f2b_peel.wgsl"))
            .with(LIBRARY)
            .defs(&shader::target_samples(samples));
        let module = peel_stage.module(device);
        let target = |format| color_target(format, None);
        let peel_pipeline = |entry: &str| {
            geometry_pipeline(
                gpu,
                scene,
                (&peel_stage, entry),
                &[&scene.frame_layout, &peel_layout],
                &[
                    target(COLOR_FORMAT),
                    target(tag_format(samples)),
                    target(tag_format(samples)),
                ],
                Some(wgpu::DepthStencilState {
                    format: wgpu::TextureFormat::Depth32Float,
                    depth_write_enabled: Some(true),
                    depth_compare: Some(wgpu::CompareFunction::Less),
                    stencil: Default::default(),
                    bias: Default::default(),
                }),
                samples,
            )
        };
        // Multisampled, the account pass counts instead of the first peel.
        let (peel_first, peel) = (peel_pipeline("fs_peel_first")?, peel_pipeline("fs_peel")?);
        let account = multisampled
            .then(|| {
                crate::raster::storage_stage(
                    gpu,
                    scene,
                    "strata.f2b.account",
                    &peel_stage,
                    (&module, false),
                    "fs_account",
                    &[&scene.frame_layout, &peel_layout],
                )
            })
            .transpose()?;
        let module = Stage::new("strata.f2b.accumulate", include_str!("f2b_accumulate.wgsl"))
            .with(LIBRARY)
            .defs(&shader::target_samples(samples))
            .module(device);
        let [init, accumulate, finish] = compute_pipelines(
            gpu,
            "strata.f2b",
            &module,
            ["cs_init", "cs_accumulate", "cs_finish"],
            &[&scene.frame_layout, &accumulate_layout],
        );
        Ok(FrontToBack {
            init,
            accumulate,
            finish,
            peel_first,
            peel,
            samples,
            account,
            null_target: None,
            peel_layout,
            accumulate_layout,
            measured: None,
            layers_fixed: false,
            cache: ResourceCache::default(),
        })
    }
}

/// The layer's tag and depth targets: the tag itself and the depth's bits (32-bit float targets
/// are not renderable on GL), or with `--msaa` the tag as an exact float and the depth itself
/// (32-bit integer formats cannot be multisampled in WebGPU; primitives stay below 2^23).
fn tag_format(samples: u32) -> wgpu::TextureFormat {
    if samples > 1 {
        wgpu::TextureFormat::R32Float
    } else {
        TAG_FORMAT
    }
}

/// The most triangles f2b takes with `--msaa` (its tags travel as exact floats).
pub const F2B_MSAA_MAX_TRIANGLES: u64 = 1 << 23;

impl Method for FrontToBack {
    fn record(&mut self, ctx: &mut FrameContext<'_>) -> Result<Recorded> {
        if let Some(order) = ctx
            .options
            .frame
            .order
            .filter(|o| *o != crate::order::Order::Scene)
        {
            return Err(Error::unsupported(format!(
                "f2b takes no --order {}: its LESS depth test keeps the first fragment drawn at an equal depth, and its peel relies on that being the lowest primitive; dual and kpeel peel by (depth, primitive) in any order",
                order.name()
            )));
        }
        let gpu = ctx.gpu;
        let (w, h) = ctx.size();
        let layers = layers_for(ctx, self.measured);
        self.layers_fixed = layers_fixed(ctx);
        let samples = self.samples;
        ctx.check_budget(ctx.pixels() * f2b_pixel_bytes(samples))?;
        let usage = wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::TEXTURE_BINDING;
        let mut view = |label, format, usage| {
            self.cache
                .texture_samples(gpu, label, (w, h), format, usage, samples)
                .create_view(&Default::default())
        };
        let color = view("strata.f2b.layer.color", COLOR_FORMAT, usage);
        let tag = view("strata.f2b.layer.tag", tag_format(samples), usage);
        let depth_copy = view("strata.f2b.layer.depth", tag_format(samples), usage);
        let depth = view(
            "strata.f2b.depth",
            wgpu::TextureFormat::Depth32Float,
            wgpu::TextureUsages::RENDER_ATTACHMENT,
        );
        let state = self.cache.storage(
            gpu,
            "strata.f2b.state",
            ctx.pixels() * COMPOSITE_BYTES * samples as u64,
        )?;
        // Multisampled: per pixel fragments and composited ones, per sample fragments.
        let count_words = if samples > 1 { 2 + samples as u64 } else { 1 };
        let counts =
            self.cache
                .storage(gpu, "strata.f2b.counts", ctx.pixels() * 4 * count_words)?;
        let peel_group = binding::group(
            &gpu.device,
            "strata.f2b.peel.group",
            &self.peel_layout,
            &[state.as_entire_binding(), counts.as_entire_binding()],
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
                counts.as_entire_binding(),
                ctx.output.as_entire_binding(),
            ],
        );
        let frame_group = ctx.frame_group;
        ctx.encoder.clear_buffer(&counts, 0, None);
        dispatch_pixels(ctx, "init", &self.init, &[frame_group, &acc_group]);
        for layer in 0..layers {
            let label = ctx.label("peel");
            let (scene, draw) = (ctx.scene, ctx.draw);
            let mut pass = ctx.encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
                label: Some(&label),
                color_attachments: &[
                    attachment(&color, wgpu::Color::TRANSPARENT),
                    attachment(
                        &tag,
                        wgpu::Color {
                            // No fragment: u32::MAX, or the float tag's -1.
                            r: if samples > 1 { -1.0 } else { u32::MAX as f64 },
                            g: 0.0,
                            b: 0.0,
                            a: 0.0,
                        },
                    ),
                    attachment(&depth_copy, wgpu::Color::TRANSPARENT),
                ],
                depth_stencil_attachment: scratch_depth(&depth),
                timestamp_writes: ctx.timer.render_pass("peel"),
                occlusion_query_set: None,
                multiview_mask: None,
            });
            pass.set_pipeline(if layer == 0 {
                &self.peel_first
            } else {
                &self.peel
            });
            let first = scene.first_group();
            pass.set_bind_group(first, Some(frame_group), &[]);
            pass.set_bind_group(first + 1, Some(&peel_group), &[]);
            scene.draw(&mut pass, draw);
            drop(pass);
            dispatch_pixels(
                ctx,
                "accumulate",
                &self.accumulate,
                &[frame_group, &acc_group],
            );
        }
        let mut account_passes = 0;
        if let Some(account) = &self.account {
            let target = ctx.null_target(&mut self.null_target, "strata.f2b.null_target");
            storage_geometry_pass(ctx, "account", target, account, &[frame_group, &peel_group]);
            account_passes = 1;
        }
        dispatch_pixels(ctx, "finish", &self.finish, &[frame_group, &acc_group]);
        Ok(Recorded {
            geometry_passes: layers + account_passes,
            bytes_allocated: ctx.pixels() * f2b_pixel_bytes(samples),
            capacity: layers as u64,
            ..Default::default()
        })
    }

    fn stats(&mut self, recorded: &Recorded, totals: &Totals, _: &[u32]) -> MethodStats {
        peel_feedback(&mut self.measured, recorded, totals, self.layers_fixed)
    }

    fn resources(&self) -> Vec<&ResourceCache> {
        vec![&self.cache]
    }
}

/// `dual`: the nearest and the farthest layer per geometry pass, composited from both ends.
pub struct Dual {
    peel_layout: wgpu::BindGroupLayout,
    advance_layout: wgpu::BindGroupLayout,
    bounds: GeometryStage,
    peel: GeometryStage,
    /// `--msaa`'s account pass after the last peel.
    account: Option<GeometryStage>,
    init: wgpu::ComputePipeline,
    advance: wgpu::ComputePipeline,
    finish: wgpu::ComputePipeline,
    null_target: Option<NullTarget>,
    measured: Option<u32>,
    /// The last frame peeled `--layers` layers, not a measured count.
    layers_fixed: bool,
    /// Bytes per key: 8 with 64-bit atomics (exact with ties), else 4.
    key_bytes: u64,
    cache: ResourceCache,
}

/// dual's bytes for `px` pixels at `samples` per pixel and `key_bytes` per key (module docs).
fn dual_bytes(px: u64, samples: u32, key_bytes: u64) -> u64 {
    // Two composites, two 16-byte layer slots, 12 bytes of hits, four keys of bounds.
    let per_entry = 2 * COMPOSITE_BYTES + 32 + 12 + 4 * key_bytes;
    if samples > 1 {
        px * (per_entry * samples as u64 + 8)
    } else {
        px * per_entry
    }
}

/// `dual`'s peel stage.
pub const DUAL_PEEL_WGSL: &str = include_str!("dual_peel.wgsl");
/// `dual`'s stage between passes: composites the peeled layers and makes the next bounds current.
pub const DUAL_ADVANCE_WGSL: &str = include_str!("dual_advance.wgsl");

/// A dual-peeling stage over 64-bit keys (`wide`, exact) or 32-bit ones (dual_key*.wgsl).
pub fn dual_stage(label: &str, source: &'static str, wide: bool) -> Stage {
    Stage::new(label, source)
        .with(LIBRARY)
        .defs(&Defs::default().flag_if("WIDE_KEYS", wide))
}

/// Whether the adapter has the 64-bit atomic min/max dual peeling's exact keys need.
pub fn has_wide_keys(gpu: &Gpu) -> bool {
    gpu.has(wgpu::Features::SHADER_INT64_ATOMIC_MIN_MAX)
        || gpu.has(wgpu::Features::SHADER_INT64_ATOMIC_ALL_OPS)
}

impl Dual {
    /// The peel and advance pipelines for `scene`.
    pub fn new(gpu: &Gpu, scene: &SceneGpu) -> crate::error::Result<Dual> {
        let device = &gpu.device;
        let wide = has_wide_keys(gpu);
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
        let stage = dual_stage("strata.dual.peel", DUAL_PEEL_WGSL, wide);
        let module = stage.module(device);
        let layouts = [&scene.frame_layout, &peel_layout];
        let geometry_stage = |label, entry| {
            crate::raster::storage_stage(
                gpu,
                scene,
                label,
                &stage,
                (&module, false),
                entry,
                &layouts,
            )
        };
        let bounds = geometry_stage("strata.dual.bounds", "fs_bounds")?;
        let peel = geometry_stage("strata.dual.peel", "fs_peel")?;
        let account = (scene.samples > 1)
            .then(|| geometry_stage("strata.dual.account", "fs_account"))
            .transpose()?;
        let [init, advance, finish] = compute_pipelines(
            gpu,
            "strata.dual",
            &dual_stage("strata.dual.advance", DUAL_ADVANCE_WGSL, wide).module(device),
            ["cs_init", "cs_advance", "cs_finish"],
            &[&scene.frame_layout, &advance_layout],
        );
        Ok(Dual {
            init,
            advance,
            finish,
            bounds,
            peel,
            account,
            peel_layout,
            advance_layout,
            null_target: None,
            measured: None,
            layers_fixed: false,
            key_bytes: if wide { 8 } else { 4 },
            cache: ResourceCache::default(),
        })
    }
}

impl Method for Dual {
    fn record(&mut self, ctx: &mut FrameContext<'_>) -> Result<Recorded> {
        let gpu = ctx.gpu;
        let layers = layers_for(ctx, self.measured);
        self.layers_fixed = layers_fixed(ctx);
        let samples = ctx.scene.samples;
        if samples > 1 && self.key_bytes < 8 {
            return Err(Error::unsupported(format!(
                "dual --msaa {samples} needs 64-bit atomic min/max (SHADER_INT64_ATOMIC_MIN_MAX), which '{}' lacks: with depth-only keys its account could not tell fragments lost to a shared key; use f2b or kpeel",
                gpu.info.name
            )));
        }
        let null_target = ctx.null_target(&mut self.null_target, "strata.dual.null_target");
        let px = ctx.pixels();
        let bytes = dual_bytes(px, samples, self.key_bytes);
        ctx.check_budget(bytes)?;
        let key_bytes = self.key_bytes;
        // Per sample entry (one per pixel single-sampled).
        let entries = px * samples as u64;
        let bounds = self
            .cache
            .storage(gpu, "strata.dual.bounds", entries * 2 * key_bytes)?;
        let next_bounds =
            self.cache
                .storage(gpu, "strata.dual.next_bounds", entries * 2 * key_bytes)?;
        let layers_buffer = self
            .cache
            .storage(gpu, "strata.dual.layers", entries * 32)?;
        // --msaa: per pixel its fragments and those composited, after the entries' words.
        let pixel_counts = if samples > 1 { px * 8 } else { 0 };
        let hits = self
            .cache
            .storage(gpu, "strata.dual.hits", entries * 12 + pixel_counts)?;
        let front = self
            .cache
            .storage(gpu, "strata.dual.front", entries * COMPOSITE_BYTES)?;
        let back = self
            .cache
            .storage(gpu, "strata.dual.back", entries * COMPOSITE_BYTES)?;
        let counters = self.cache.readable(gpu, "strata.dual.counters", 8)?;
        let peel_group = binding::group(
            &gpu.device,
            "strata.dual.peel.group",
            &self.peel_layout,
            &[
                bounds.as_entire_binding(),
                next_bounds.as_entire_binding(),
                layers_buffer.as_entire_binding(),
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
                layers_buffer.as_entire_binding(),
                hits.as_entire_binding(),
                front.as_entire_binding(),
                back.as_entire_binding(),
                counters.as_entire_binding(),
                ctx.output.as_entire_binding(),
            ],
        );
        let frame_group = ctx.frame_group;
        dispatch_pixels(ctx, "init", &self.init, &[frame_group, &advance_group]);
        storage_geometry_pass(
            ctx,
            "bounds",
            null_target,
            &self.bounds,
            &[frame_group, &peel_group],
        );
        // Promote the bounds just computed (the slots are empty on the first round), then peel a
        // front and a back layer per pass.
        let peel_passes = layers.div_ceil(2);
        for pass in 0..=peel_passes {
            if pass > 0 {
                storage_geometry_pass(
                    ctx,
                    "peel",
                    null_target,
                    &self.peel,
                    &[frame_group, &peel_group],
                );
            }
            ctx.encoder.clear_buffer(&counters, 0, None);
            dispatch_pixels(
                ctx,
                "advance",
                &self.advance,
                &[frame_group, &advance_group],
            );
        }
        let mut account_passes = 0;
        if let Some(account) = &self.account {
            storage_geometry_pass(
                ctx,
                "account",
                null_target,
                account,
                &[frame_group, &peel_group],
            );
            account_passes = 1;
        }
        dispatch_pixels(ctx, "finish", &self.finish, &[frame_group, &advance_group]);
        ctx.readback.words(&counters, 0, 1);
        Ok(Recorded {
            geometry_passes: peel_passes + 1 + account_passes,
            bytes_allocated: bytes,
            capacity: layers as u64,
            ..Default::default()
        })
    }

    fn stats(&mut self, recorded: &Recorded, totals: &Totals, words: &[u32]) -> MethodStats {
        let mut stats = peel_feedback(&mut self.measured, recorded, totals, self.layers_fixed);
        // Pixels with layers left after the last pass (beyond `--layers`: dropped, as asked).
        stats.incomplete |= !self.layers_fixed && words[0] > 0;
        stats
    }

    fn resources(&self) -> Vec<&ResourceCache> {
        vec![&self.cache]
    }
}

/// The family's f2b and dual stages as its methods build them, for the test that validates
/// every stage (bucket's are validated by its own tests).
#[cfg(test)]
pub(crate) fn stages() -> Vec<Stage> {
    let mut stages = Vec::new();
    for samples in [1, 4] {
        for (label, source) in [
            ("f2b.peel", include_str!("f2b_peel.wgsl")),
            ("f2b.accumulate", include_str!("f2b_accumulate.wgsl")),
        ] {
            stages.push(
                Stage::new(label, source)
                    .with(LIBRARY)
                    .defs(&crate::gpu::shader::target_samples(samples)),
            );
        }
    }
    for wide in [false, true] {
        stages.push(dual_stage("dual.peel", DUAL_PEEL_WGSL, wide));
        stages.push(dual_stage("dual.advance", DUAL_ADVANCE_WGSL, wide));
    }
    stages
}
