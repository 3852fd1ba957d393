//! Bucket depth peeling, `bucket` (Liu, Huang, Liu & Wu, HPG 2009): k layers' depths in one
//! geometry pass by a bucket sort of each pixel's fragments over its depth range, using render
//! targets as the bucket array and MAX blending as the concurrent update (no atomics, no locks).
//!
//! Passes:
//! 1. `bounds` — geometry pass into an Rg32Float target with MAX blending of (−z, z): each
//!    pixel's nearest and farthest depth (and, by a storage atomic, its fragment count). With
//!    `--msaa` the target is multisampled and a `reduce` screen pass joins the samples' bounds.
//! 2. `histogram` (only with `--buckets adaptive`) — geometry pass: each fragment sets the bit of
//!    its part of the pixel's range split into 1024 equal parts (one storage atomicOr: the paper
//!    ORs bits into render targets with logic-op blending, which WebGPU lacks).
//! 3. `sort` — geometry pass into ⌈k/4⌉ Rgba32Float targets with MAX blending. The pixel's
//!    range is split into B = k/2 buckets; a fragment of bucket b writes −z to slot 2b and z to
//!    slot 2b + 1, nothing (−2) elsewhere, so every bucket ends with its nearest and farthest
//!    depth: dual peeling inside each bucket (the paper's scheme against collisions), every
//!    bucket at once.
//! 4. `color` — geometry pass (storage only): the fragment whose depth is its bucket's nearest
//!    (farthest) claims that slot with one atomicOr on the pixel's claim word and stores its
//!    shaded record there. The paper's targets hold depths only; its attributes come from a
//!    later pass too, and WebGPU's blending cannot carry a color beside a max-blended depth.
//! 5. `resolve` — compute: the claimed slots in bucket order, composited front to back.
//!
//! The split (`--buckets`): **uniform** (default, the paper's method) — B equal parts of the
//! range; **adaptive** (the paper's second scheme) — the occupied parts of the histogram, in
//! depth order, share the B buckets (bucket = rank · B / occupied parts), so with at most B
//! occupied parts only fragments within one part (1/1024 of the range) can collide, and empty
//! depth costs no bucket. Either way the routing is exact integer arithmetic on depths clamped
//! to [0, 1] in fixed point with 31 fraction bits (`bucket_common.wgsl`), which the CPU twin
//! ([`select`], [`select_samples`]) repeats.
//!
//! **Approximate by design**: a bucket keeps two fragments, so a third routed to it — fragments
//! clustered in depth — is lost. Losses are counted in `fragments_dropped`; a frame without
//! drops equals the reference. Fragments at exactly one depth share a slot: two that are both a
//! bucket's nearest and farthest keep both slots (and composite in primitive order); otherwise
//! the first to claim the slot keeps it and the others are dropped — a race on a GPU, so which
//! of three coplanar faces shows may change from frame to frame (the count does not). The
//! paper's multi-pass refinement (peeling again behind what collided) is not built.
//!
//! `--msaa S`: the bounds and bucket targets are multisampled, so MAX blending gives every
//! sample its own buckets' nearest and farthest; the routing stays the pixel's (a fragment has
//! one bucket at all its samples); claims and records are per sample entry, a fragment that
//! claimed at some sample counts itself kept once (claims are never taken back), and the
//! resolve composites each sample and averages.
//!
//! Memory per pixel, S samples: 8 B bounds (+8·S B of sample bounds and a 4 B kept count with
//! S > 1), 4 B count,
//! 128 B of histogram with the adaptive split, and per sample 16·⌈k/4⌉ B of bucket targets,
//! 4 B of claims and 16·k B of records; plus a 16-byte uniform ([`frame_bytes`]). `--k` is
//! even, 2 ≤ k ≤ 32 (the claim word), and at most 4 × the targets the device blends at once:
//! k/4 ≤ `max_color_attachments` and 16·⌈k/4⌉ ≤ `max_color_attachment_bytes_per_sample` (32
//! layers with 8 targets, the paper's figure; WebGPU's defaults allow 8). Needs
//! FLOAT32_BLENDABLE. `--raster compute` and `--temporal` are refused.

use crate::gpu::twin::{gpu_struct, wgsl_module};
use crate::methods::peeling::PeelingOptions;

use crate::error::{Error, Result};
use crate::frame::passes::{
    color_geometry_pass, color_pass_drawing, compute_pipeline, dispatch_pixels, geometry_pipeline,
    screen_pipeline, storage_geometry_pass, GeometryStage, NullTarget,
};
use crate::frame::{FrameContext, Recorded, SceneGpu};
use crate::gpu::binding::{self, Slot};
use crate::gpu::shader::{self, Stage};
use crate::gpu::{Gpu, ResourceCache};
use crate::methods::kbuffer::DEFAULT_K;
use crate::methods::peeling::BucketSplit;
use crate::methods::Method;

/// The most slots a pixel has: two per bucket, one claim bit each.
pub const MAX_SLOTS: u32 = 32;

gpu_struct! {
    /// bucket's uniforms (`strata::peeling::bucket_params`).
    #[derive(PartialEq)]
    pub struct BucketParams {
        /// Buckets per pixel (k/2).
        pub buckets: u32,
        /// Slots per pixel: two per bucket.
        pub slots: u32,
        /// Target layers the slots take (four channels each).
        pub layers: u32,
        /// 1 with --buckets adaptive.
        pub adaptive: u32,
    }
}

/// The WGSL declaration of [`BucketParams`].
pub(crate) const PARAMS_WGSL: &str = wgsl_module!("strata::peeling::bucket_params", BucketParams);

const BOUNDS_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rg32Float;
const BUCKET_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba32Float;
/// What the targets are cleared to (`NO_DEPTH` in bucket_common.wgsl).
const NO_DEPTH: f64 = -2.0;

/// Target layers for `slots` slots (four channels each).
pub fn target_layers(slots: u32) -> u32 {
    slots.div_ceil(4)
}

/// Parts of the range the adaptive split's histogram tells apart (`SUBINTERVALS` in WGSL).
pub const SUBINTERVALS: u32 = 1024;
/// The histogram's bytes per pixel, one bit per part.
pub const HISTOGRAM_BYTES: u64 = SUBINTERVALS as u64 / 8;

/// Bytes a frame allocates at `slots` slots over `pixels` pixels (module docs).
pub fn frame_bytes(pixels: u64, slots: u32, split: BucketSplit, samples: u32) -> u64 {
    let histogram = match split {
        BucketSplit::Uniform => 0,
        BucketSplit::Adaptive => HISTOGRAM_BYTES,
    };
    let samples = samples as u64;
    // Per sample: bucket targets, claim word and records; with --msaa, the samples' bounds.
    let per_sample = 16 * target_layers(slots) as u64 + 4 + 16 * slots as u64;
    // --msaa: the samples' bounds and the kept count.
    let multisampled = if samples > 1 { 8 * samples + 4 } else { 0 };
    pixels * (8 + 4 + histogram + multisampled + samples * per_sample)
        + std::mem::size_of::<BucketParams>() as u64
}

/// The most slots the device's render targets hold: four per target it blends at once.
pub fn device_max_slots(limits: &wgpu::Limits) -> u32 {
    let targets = limits
        .max_color_attachments
        .min(limits.max_color_attachment_bytes_per_sample / 16);
    (4 * targets).min(MAX_SLOTS)
}

/// `--k` for bucket: an input error when it is odd or outside 2..=32, unsupported where the
/// device blends too few targets at once.
pub fn slots_of(k: Option<u32>, limits: &wgpu::Limits) -> Result<u32> {
    let k = k.unwrap_or(DEFAULT_K);
    if !(2..=MAX_SLOTS).contains(&k) || !k.is_multiple_of(2) {
        return Err(Error::input(format!(
            "--k {k}: bucket keeps two fragments per bucket and one claim bit per slot, so k must be even and within 2..{MAX_SLOTS}"
        )));
    }
    let max = device_max_slots(limits);
    if k > max {
        return Err(Error::unsupported(format!(
            "bucket --k {k} needs {} four-channel 32-bit targets blended at once, and this device takes {} color targets of at most {} bytes per sample in all: use --k {max} or less",
            target_layers(k),
            limits.max_color_attachments,
            limits.max_color_attachment_bytes_per_sample
        )));
    }
    Ok(k)
}

/// The sort stage for `layers` target layers: the routing (bucket_sort.wgsl) and a generated
/// output struct and entry point (one member per layer).
pub fn sort_stage(layers: u32) -> Stage {
    let members: Vec<String> = (0..layers)
        .map(|i| format!("    @location({i}) layer_{i}_range: vec4<f32>,"))
        .collect();
    let values: Vec<String> = (0..layers)
        .map(|i| format!("bucket_channels({i}u, b, z)"))
        .collect();
    let source = format!(
        "#define_import_path strata::peeling::bucket_sort_targets\n#import strata::scene::{{SceneVarying, behind_opaque}}\n#import strata::peeling::bucket_sort::{{bucket_channels, fragment_bucket}}\n\nstruct BucketTargets {{\n{}\n}}\n\nfn fs_sort_step(v: SceneVarying, front_facing: bool, mask: u32) -> BucketTargets {{\n    if behind_opaque(v.position) {{\n        discard;\n    }}\n    let b = fragment_bucket(v);\n    let z = v.position.z;\n    return BucketTargets({});\n}}\n",
        members.join("\n"),
        values.join(", ")
    );
    Stage::new("strata.bucket.sort", source).with(super::LIBRARY)
}

/// The bucket-depth-peeling stages besides the generated sort, the color stage's layer
/// textures multisampled at `samples` > 1.
pub fn stages(samples: u32) -> [Stage; 5] {
    let stage = |label: &str, source: &'static str| Stage::new(label, source).with(super::LIBRARY);
    [
        stage("strata.bucket.bounds", include_str!("bucket_bounds.wgsl")),
        stage("strata.bucket.reduce", include_str!("bucket_reduce.wgsl")),
        stage(
            "strata.bucket.histogram",
            include_str!("bucket_histogram.wgsl"),
        ),
        stage("strata.bucket.color", include_str!("bucket_color.wgsl"))
            .defs(&shader::target_samples(samples)),
        stage("strata.bucket.resolve", include_str!("bucket_resolve.wgsl")),
    ]
}

/// Fixed point with 31 fraction bits of a window depth, clamped to [0, 1] (`depth_fixed` in
/// WGSL).
fn depth_fixed(z: f32) -> u64 {
    (z.clamp(0.0, 1.0) * 2147483648.0) as u32 as u64
}

/// The part of `parts` equal parts of [lo, hi] (fixed point) that `q` falls in (`bucket_of`).
fn part_of(q: u64, lo: u64, hi: u64, parts: u64) -> u64 {
    let width = (hi.max(lo) - lo) / parts + 1;
    ((q.max(lo) - lo) / width).min(parts - 1)
}

/// The CPU twin of the routing and the claims: which of a pixel's fragment depths keep a slot,
/// given `slots` slots and the split. Depths are visited in the given order, which decides only
/// between fragments at exactly equal depth (on the GPU, whichever claims first).
pub fn select(depths: &[f32], slots: u32, split: BucketSplit) -> Vec<bool> {
    let everywhere = vec![1u32; depths.len()];
    select_samples(depths, &everywhere, 1, slots, split)
        .into_iter()
        .map(|kept| kept != 0)
        .collect()
}

/// [`select`] with `--msaa`: each fragment covers the samples of its mask in `coverage`; it is
/// routed over all the pixel's fragments (one bucket at every sample) and claims its slot at
/// each sample it covers among that sample's fragments. Returns, per fragment, the mask of the
/// samples that kept it.
pub fn select_samples(
    depths: &[f32],
    coverage: &[u32],
    samples: u32,
    slots: u32,
    split: BucketSplit,
) -> Vec<u32> {
    let buckets = (slots / 2).max(1) as u64;
    let Some(nearest) = depths.iter().copied().reduce(f32::min) else {
        return Vec::new();
    };
    let farthest = depths.iter().copied().fold(nearest, f32::max);
    let (lo, hi) = (depth_fixed(nearest), depth_fixed(farthest));
    let parts = SUBINTERVALS as u64;
    let mut occupied = vec![false; parts as usize];
    for &z in depths {
        occupied[part_of(depth_fixed(z), lo, hi, parts) as usize] = true;
    }
    let total = occupied.iter().filter(|o| **o).count() as u64;
    let bucket: Vec<usize> = depths
        .iter()
        .map(|&z| {
            let q = depth_fixed(z);
            match split {
                BucketSplit::Uniform => part_of(q, lo, hi, buckets) as usize,
                BucketSplit::Adaptive => {
                    let part = part_of(q, lo, hi, parts) as usize;
                    let below = occupied[..part].iter().filter(|o| **o).count() as u64;
                    (below * buckets / total).min(buckets - 1) as usize
                }
            }
        })
        .collect();
    let mut kept = vec![0u32; depths.len()];
    for s in 0..samples {
        let covers = |i: usize| coverage[i] >> s & 1 == 1;
        let mut bounds = vec![(f32::INFINITY, f32::NEG_INFINITY); buckets as usize];
        for (i, &z) in depths.iter().enumerate().filter(|(i, _)| covers(*i)) {
            let b = &mut bounds[bucket[i]];
            *b = (b.0.min(z), b.1.max(z));
        }
        let mut claimed = vec![[false; 2]; buckets as usize];
        for (i, &z) in depths.iter().enumerate().filter(|(i, _)| covers(*i)) {
            let b = bucket[i];
            let (near, far) = bounds[b];
            let mut take = |end: usize| !std::mem::replace(&mut claimed[b][end], true);
            if (z == near && take(0)) || (z == far && take(1)) {
                kept[i] |= 1 << s;
            }
        }
    }
    kept
}

/// `bucket`: the bounds, histogram, color and resolve pipelines and their targets.
pub struct Bucket {
    bounds_layout: wgpu::BindGroupLayout,
    reduce_layout: wgpu::BindGroupLayout,
    sort_layout: wgpu::BindGroupLayout,
    color_layout: wgpu::BindGroupLayout,
    resolve_layout: wgpu::BindGroupLayout,
    histogram_layout: wgpu::BindGroupLayout,
    frame_layout: wgpu::BindGroupLayout,
    samples: u32,
    bounds: wgpu::RenderPipeline,
    /// `--msaa`: the pass that joins the samples' bounds into the pixel's.
    reduce: Option<wgpu::RenderPipeline>,
    /// `--buckets adaptive`'s histogram pass.
    histogram: GeometryStage,
    /// The sort pipeline and the target layers it was built for.
    sort: Option<(u32, wgpu::RenderPipeline)>,
    color: GeometryStage,
    resolve: wgpu::ComputePipeline,
    null_target: Option<NullTarget>,
    cache: ResourceCache,
}

/// The bucket target layers' labels (one texture each: multisampled arrays are not core
/// WebGPU).
const LAYER_LABELS: [&str; 8] = [
    "strata.bucket.layer0",
    "strata.bucket.layer1",
    "strata.bucket.layer2",
    "strata.bucket.layer3",
    "strata.bucket.layer4",
    "strata.bucket.layer5",
    "strata.bucket.layer6",
    "strata.bucket.layer7",
];

/// The color pass's first layer binding (bucket_color.wgsl).
const FIRST_LAYER_BINDING: u32 = 6;

fn blend_max() -> wgpu::BlendState {
    let max = wgpu::BlendComponent {
        src_factor: wgpu::BlendFactor::One,
        dst_factor: wgpu::BlendFactor::One,
        operation: wgpu::BlendOperation::Max,
    };
    wgpu::BlendState {
        color: max,
        alpha: max,
    }
}

fn max_target(format: wgpu::TextureFormat) -> Option<wgpu::ColorTargetState> {
    Some(wgpu::ColorTargetState {
        format,
        blend: Some(blend_max()),
        write_mask: wgpu::ColorWrites::ALL,
    })
}

impl Bucket {
    /// Makes the pipelines for `scene` (on a device with FLOAT32_BLENDABLE: its descriptor's
    /// `needs`, which `methods::create` checks).
    pub fn new(gpu: &Gpu, scene: &SceneGpu) -> Result<Bucket> {
        let device = &gpu.device;
        let samples = scene.samples;
        let layer_slot = Slot::target(samples);
        let bounds_layout = binding::layout(
            device,
            "strata.bucket.bounds.layout",
            &[Slot::Uniform, Slot::StorageRw],
        );
        let reduce_layout = binding::layout_at(
            device,
            "strata.bucket.reduce.layout",
            &[(1, Slot::TextureFloatMultisampled)],
        );
        // The histogram (binding 5) is read wherever a fragment is routed.
        let sort_layout = binding::layout_at(
            device,
            "strata.bucket.sort.layout",
            &[
                (0, Slot::Uniform),
                (1, Slot::TextureFloat),
                (5, Slot::Storage),
            ],
        );
        let mut color_slots = vec![
            (0, Slot::Uniform),
            (1, Slot::TextureFloat),
            (3, Slot::StorageRw),
            (4, Slot::StorageRw),
            (5, Slot::Storage),
        ];
        color_slots
            .extend((0..LAYER_LABELS.len() as u32).map(|i| (FIRST_LAYER_BINDING + i, layer_slot)));
        let color_layout = binding::layout_at(device, "strata.bucket.color.layout", &color_slots);
        let histogram_layout = binding::layout(
            device,
            "strata.bucket.histogram.layout",
            &[Slot::Uniform, Slot::TextureFloat, Slot::StorageRw],
        );
        let resolve_layout = binding::layout(
            device,
            "strata.bucket.resolve.layout",
            &[
                Slot::Uniform,
                Slot::Storage,
                Slot::Storage,
                Slot::Storage,
                Slot::StorageRw,
            ],
        );
        let [bounds_stage, reduce_stage, histogram_stage, color_stage, resolve_stage] =
            stages(samples);
        let bounds = geometry_pipeline(
            gpu,
            scene,
            (&bounds_stage, "fs_bounds"),
            &[&scene.frame_layout, &bounds_layout],
            &[max_target(BOUNDS_FORMAT)],
            None,
            samples,
        )?;
        let reduce = (samples > 1).then(|| {
            let module = reduce_stage.module(device);
            screen_pipeline(
                gpu,
                "strata.bucket.reduce",
                (&module, "vs_reduce"),
                (&module, "fs_reduce"),
                &[&scene.frame_layout, &reduce_layout],
                &[Some(BOUNDS_FORMAT.into())],
                None,
                None,
            )
        });
        let storage_stage = |label, stage: &Stage, entry, layout| {
            let module = stage.module(device);
            let layouts = [&scene.frame_layout, layout];
            crate::raster::storage_stage(
                gpu,
                scene,
                label,
                stage,
                (&module, false),
                entry,
                &layouts,
            )
        };
        let histogram = storage_stage(
            "strata.bucket.histogram",
            &histogram_stage,
            "fs_histogram",
            &histogram_layout,
        )?;
        let color = storage_stage(
            "strata.bucket.color",
            &color_stage,
            "fs_color",
            &color_layout,
        )?;
        let resolve = compute_pipeline(
            gpu,
            "strata.bucket.resolve",
            (&resolve_stage.module(device), "cs_resolve"),
            &[&scene.frame_layout, &resolve_layout],
        );
        Ok(Bucket {
            bounds_layout,
            reduce_layout,
            sort_layout,
            color_layout,
            resolve_layout,
            histogram_layout,
            frame_layout: scene.frame_layout.clone(),
            samples,
            bounds,
            reduce,
            histogram,
            sort: None,
            color,
            resolve,
            null_target: None,
            cache: ResourceCache::default(),
        })
    }

    /// The sort pipeline for `layers` target layers, built when the layer count changes.
    fn sort_pipeline(
        &mut self,
        gpu: &Gpu,
        scene: &SceneGpu,
        layers: u32,
    ) -> Result<&wgpu::RenderPipeline> {
        if self.sort.as_ref().is_none_or(|(l, _)| *l != layers) {
            let stage = sort_stage(layers);
            let targets: Vec<_> = (0..layers).map(|_| max_target(BUCKET_FORMAT)).collect();
            let pipeline = geometry_pipeline(
                gpu,
                scene,
                (&stage, "fs_sort"),
                &[&self.frame_layout, &self.sort_layout],
                &targets,
                None,
                self.samples,
            )?;
            self.sort = Some((layers, pipeline));
        }
        Ok(&self.sort.as_ref().expect("built above").1)
    }
}

impl Method for Bucket {
    fn record(&mut self, ctx: &mut FrameContext<'_>) -> Result<Recorded> {
        let gpu = ctx.gpu;
        let slots = slots_of(ctx.k, &gpu.limits)?;
        let layers = target_layers(slots);
        let px = ctx.pixels();
        let split = ctx.options.frame.family::<PeelingOptions>().buckets;
        let adaptive = split == BucketSplit::Adaptive;
        let samples = self.samples;
        let bytes = frame_bytes(px, slots, split, samples);
        ctx.check_budget(bytes)?;
        let size = ctx.size();
        let params = BucketParams {
            buckets: slots / 2,
            slots,
            layers,
            adaptive: adaptive as u32,
        };
        let params = self
            .cache
            .uniform(gpu, "strata.bucket.params", bytemuck::bytes_of(&params));
        let usage = wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::TEXTURE_BINDING;
        let bounds = self
            .cache
            .texture(gpu, "strata.bucket.bounds", size, BOUNDS_FORMAT, usage)
            .create_view(&Default::default());
        // --msaa: the bounds pass writes each sample's, the reduce pass joins them into `bounds`.
        // (--msaa is fixed per renderer, so nothing to forget here.)
        let bounds_samples = (samples > 1).then(|| {
            self.cache
                .texture_samples(
                    gpu,
                    "strata.bucket.bounds_samples",
                    size,
                    BOUNDS_FORMAT,
                    usage,
                    samples,
                )
                .create_view(&Default::default())
        });
        for label in &LAYER_LABELS[layers as usize..] {
            self.cache.forget(label);
        }
        let layer_views: Vec<wgpu::TextureView> = LAYER_LABELS[..layers as usize]
            .iter()
            .map(|label| {
                self.cache
                    .texture_samples(gpu, label, size, BUCKET_FORMAT, usage, samples)
                    .create_view(&Default::default())
            })
            .collect();
        let entries = px * samples as u64;
        let counts = self.cache.storage(gpu, "strata.bucket.counts", px * 4)?;
        // --msaa: each pixel's kept count after the entries' claim words.
        let kept_words = if samples > 1 { px } else { 0 };
        let claims = self
            .cache
            .storage(gpu, "strata.bucket.claims", (entries + kept_words) * 4)?;
        let records =
            self.cache
                .storage(gpu, "strata.bucket.records", entries * 16 * slots as u64)?;
        // Uniform: the counts stand in at the histogram's bindings, never read there (and never
        // bound beside them).
        let histogram = if adaptive {
            self.cache
                .storage(gpu, "strata.bucket.histogram", px * HISTOGRAM_BYTES)?
        } else {
            self.cache.forget("strata.bucket.histogram");
            counts.clone()
        };
        let device = &gpu.device;
        let histogram_group = binding::group(
            device,
            "strata.bucket.histogram.group",
            &self.histogram_layout,
            &[
                params.as_entire_binding(),
                wgpu::BindingResource::TextureView(&bounds),
                histogram.as_entire_binding(),
            ],
        );
        let bounds_group = binding::group(
            device,
            "strata.bucket.bounds.group",
            &self.bounds_layout,
            &[params.as_entire_binding(), counts.as_entire_binding()],
        );
        let reduce_group = bounds_samples.as_ref().map(|view| {
            binding::group_at(
                device,
                "strata.bucket.reduce.group",
                &self.reduce_layout,
                &[(1, wgpu::BindingResource::TextureView(view))],
            )
        });
        let sort_group = binding::group_at(
            device,
            "strata.bucket.sort.group",
            &self.sort_layout,
            &[
                (0, params.as_entire_binding()),
                (1, wgpu::BindingResource::TextureView(&bounds)),
                (5, histogram.as_entire_binding()),
            ],
        );
        let mut color_entries = vec![
            (0, params.as_entire_binding()),
            (1, wgpu::BindingResource::TextureView(&bounds)),
            (3, claims.as_entire_binding()),
            (4, records.as_entire_binding()),
            (5, histogram.as_entire_binding()),
        ];
        // Layers past the frame's repeat its last (never read: routing stays below k/4).
        color_entries.extend((0..LAYER_LABELS.len()).map(|i| {
            let view = &layer_views[i.min(layer_views.len() - 1)];
            (
                FIRST_LAYER_BINDING + i as u32,
                wgpu::BindingResource::TextureView(view),
            )
        }));
        let color_group = binding::group_at(
            device,
            "strata.bucket.color.group",
            &self.color_layout,
            &color_entries,
        );
        let resolve_group = binding::group(
            device,
            "strata.bucket.resolve.group",
            &self.resolve_layout,
            &[
                params.as_entire_binding(),
                counts.as_entire_binding(),
                claims.as_entire_binding(),
                records.as_entire_binding(),
                ctx.output.as_entire_binding(),
            ],
        );
        let nothing = wgpu::Color {
            r: NO_DEPTH,
            g: NO_DEPTH,
            b: NO_DEPTH,
            a: NO_DEPTH,
        };
        let frame_group = ctx.frame_group;
        ctx.encoder.clear_buffer(&counts, 0, None);
        ctx.encoder.clear_buffer(&claims, 0, None);
        if adaptive {
            ctx.encoder.clear_buffer(&histogram, 0, None);
        }
        color_geometry_pass(
            ctx,
            "bounds",
            &self.bounds,
            &[frame_group, &bounds_group],
            &[(bounds_samples.as_ref().unwrap_or(&bounds), nothing)],
        );
        if let (Some(reduce), Some(group)) = (&self.reduce, &reduce_group) {
            color_pass_drawing(
                ctx,
                "reduce",
                reduce,
                &[frame_group, group],
                &[(&bounds, nothing)],
                &|pass| pass.draw(0..3, 0..1),
            );
        }
        let null_target = ctx.null_target(&mut self.null_target, "strata.bucket.null_target");
        if adaptive {
            storage_geometry_pass(
                ctx,
                "histogram",
                null_target,
                &self.histogram,
                &[frame_group, &histogram_group],
            );
        }
        let targets: Vec<_> = layer_views.iter().map(|v| (v, nothing)).collect();
        let sort = self.sort_pipeline(gpu, ctx.scene, layers)?;
        color_geometry_pass(ctx, "sort", sort, &[frame_group, &sort_group], &targets);
        let null_target = self.null_target.as_ref().expect("made above");
        storage_geometry_pass(
            ctx,
            "color",
            null_target,
            &self.color,
            &[frame_group, &color_group],
        );
        dispatch_pixels(
            ctx,
            "resolve",
            &self.resolve,
            &[frame_group, &resolve_group],
        );
        Ok(Recorded {
            geometry_passes: 3 + adaptive as u32,
            k: Some(slots),
            bytes_allocated: bytes,
            capacity: slots as u64,
            ..Default::default()
        })
    }

    fn resources(&self) -> Vec<&ResourceCache> {
        vec![&self.cache]
    }
}

#[cfg(test)]
mod tests;
