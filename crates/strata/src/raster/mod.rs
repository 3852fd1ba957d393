//! The compute rasterizer (seed 002's programmable pipeline, `--raster compute`): the scene's
//! triangles become fragments in compute shaders instead of the GPU's fixed-function rasterizer,
//! and each fragment goes straight into the method's capture.
//!
//! Passes, recorded before a frame's first geometry pass and reused by the others:
//! - **bin** (one thread per triangle): the vertex transform of `vs_scene`, clipping at the near
//!   plane z ≥ 0 and at a guard band |x|, |y| ≤ g·w (g = 2²²/max(width, height) − 1, so window
//!   coordinates stay within ±2²¹ pixels), the viewport transform, snapping to 1/256 pixel, and
//!   the bounding box of each triangle of the clipped polygon's fan. Each (fan triangle, 8×8
//!   tile of its bounding box) pair is appended as a work item. Seed 002 runs one thread per
//!   triangle over its whole bounding box; that serializes a large triangle over thousands of
//!   pixels, so large triangles are split here into tiles, and no thread walks more than 64
//!   pixel centers. A triangle larger than the screen costs its binning thread one store per
//!   tile of the screen. With [`Binning::SetupRecords`] (tiled) each set-up fan triangle is
//!   also stored as a record (its primitive and, per corner, window position, depth, 1/w and
//!   weights: 88 bytes, from which `triangle_of` derives the snapped corners, area and bounds
//!   exactly), and the items name records and leave room for their tile's coverage mask
//!   (16 bytes each), so that the passes after the bin never set a triangle up again.
//! - **args** (one thread): the item count becomes an indirect dispatch.
//! - **capture** (one thread per item, each of the method's geometry passes): the item's
//!   triangle is set up again (recomputing beats storing ~100 bytes of setup per triangle), its
//!   edge functions are evaluated exactly in 64-bit integers (two 32-bit words) at the tile's
//!   pixel centers with the top-left rule, depth is interpolated linearly in the window and the
//!   world position and normal perspective-correctly from the unsnapped window positions, the
//!   fragment is tested against the far plane and the opaque depth as the GPU path does, shaded
//!   with the same material model and handed to the method's fragment stage, compiled as a
//!   function (`discard` becomes `return`: the stages write only storage).
//!
//! Coverage is the GPU path's rule as the CPU reference implements it
//! (`crate::reference::raster`): pixel centers, top-left rule, 8 subpixel bits (lavapipe's
//! and NVIDIA's `subPixelPrecisionBits`). Depth and attributes are computed in f32 from the same
//! inputs as the GPU's, so they agree to rounding, not bit for bit.
//!
//! Memory: 8 bytes per work item (the primitive and a packed fan-triangle and tile index; with
//! setup records 16, and 88 per record, sized like the items), 16 of counters, 16 of dispatch
//! arguments. The item buffer starts at twice the triangle count plus four
//! items per screen tile, grows to the measured need + 25% after a frame that overflowed (that
//! frame reports itself incomplete, and exact mode renders it again), shrinks when more than
//! twice too large, and is bounded by the device's largest storage binding.
//!
//! Methods: those whose geometry passes store only into storage buffers —
//! the MDT cascades (`kb-mdt32`, `kb-mdt64`, `kb-mdt-pack`: seed 002's MDTS; `kb-keys`' exact
//! (depth, primitive) keys), the fixed arrays
//! (`abuffer-fixed`, `kb-ab-fixed`: its FABS), the linked lists `abuffer-ll` and `kb-ab-ll`, the
//! S-buffers `sbuffer` and `kb-sbuffer`, `dual`'s atomic min/max, `kb` (whose unlocked
//! read-modify-writes race by design on either path), `kpeel` — seed 002's multi-layer
//! peeling, `--layers-per-pass` — which on this path captures through its own lock-free
//! cascade of 64-bit (depth, tag) keys and a colors pass (kpeel_cascade.wgsl; two geometry
//! passes per layer group, SHADER_INT64_ATOMIC_ALL_OPS), and the captures that order memory:
//! the spin locks (`kplus-array`, `kplus-heap`, `kplus-array-r`, `kplus-semiheap`, `kb-ps`,
//! `mlab`, `kplus-sbuffer`) and `kb-ll`'s compare-exchange links. Those get acquire/release
//! atomics as their fragment stages do (`compute_stage`, `gpu::ordered`: SPIR-V passthrough on
//! Vulkan; refused with one line where the adapter has none, as on the GPU's rasterizer). On
//! lavapipe before Mesa 22.3.7 their workgroups hold one SIMD vector (8 invocations, each
//! rasterizing 8 items): that Mesa compiles an ordered atomic's memory barrier in a compute
//! shader as a workgroup barrier, and in larger workgroups stops running some invocations
//! (`gpu::ordered::workgroup_limit`) — with 64, `kb-ps` lost fragments on 784 of 2304 pixels.
//! Not supported: the methods that write color targets through the GPU's blending or depth test
//! (`unsorted`, `sorted`, `f2b`, `bucket`, `wboit`, `mboit`), which a compute shader could only
//! emulate with per-pixel locks.
//!
//! They refuse `--raster compute` with one clear error.

pub mod wide;

use crate::gpu::twin::{gpu_struct, wgsl_module};

use crate::error::{Error, Result};
use crate::frame::passes::{
    capture_pipeline, dispatch_with, GeometryStage, NullTarget, Workgroups,
};
pub use crate::frame::{ComputeRasterStats, Raster};
use crate::frame::{FrameContext, ReadbackList, RenderOptions, SceneGpu};
use crate::gpu::binding::{self, Slot};
use crate::gpu::shader::{capture_entries, Defs, Library, Stage};
use crate::gpu::{Gpu, ResourceCache};

/// The rasterizer's WGSL modules (`strata::raster::…`): setup, the work items, bin, args and the
/// raster stage.
pub const LIBRARY: Library = &[
    PARAMS_WGSL,
    SETUP_WGSL,
    ITEMS_WGSL,
    BIN_WGSL,
    ARGS_WGSL,
    RASTER_WGSL,
    RECORDS_WGSL,
];
/// `strata::raster::params`: [`RasterParams`] for the stages that bind them.
const PARAMS_WGSL: &str = wgsl_module!("strata::raster::params", RasterParams);
const SETUP_WGSL: &str = include_str!("setup.wgsl");
const ITEMS_WGSL: &str = include_str!("items.wgsl");
const BIN_WGSL: &str = include_str!("bin.wgsl");
const ARGS_WGSL: &str = include_str!("args.wgsl");
const RASTER_WGSL: &str = include_str!("raster.wgsl");
const RECORDS_WGSL: &str = include_str!("records.wgsl");

/// Pixels per side of a bin tile (TILE in setup.wgsl).
pub const TILE: u32 = 8;
/// Bytes of one (triangle, tile) work item.
pub const ITEM_BYTES: u64 = 8;
/// Bytes of one work item with setup records ([`Binning::SetupRecords`]): the record, the
/// packed fan triangle and tile, and the tile's covered pixel centers (64 bits).
pub const RECORD_ITEM_BYTES: u64 = 16;
/// Bytes of one setup record (SETUP_RECORD_WORDS in setup.wgsl): the primitive, and per corner
/// the window position, depth, 1/w and weights.
pub const SETUP_RECORD_BYTES: u64 = 22 * 4;

/// What the bin stage leaves for the passes after it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Binning {
    /// Items naming (primitive, fan triangle): each later pass sets its triangle up again.
    Items,
    /// A setup record per set-up fan triangle, and items naming records with room for their
    /// coverage (tiled): the triangle is set up once.
    SetupRecords,
}

impl Binning {
    /// Bytes of one work item.
    pub fn item_bytes(self) -> u64 {
        match self {
            Binning::Items => ITEM_BYTES,
            Binning::SetupRecords => RECORD_ITEM_BYTES,
        }
    }

    /// The definitions of the stages that read the items: their words and, with records,
    /// the records' binding.
    pub fn defs(self) -> Defs {
        Defs::default()
            .value("ITEM_WORDS", (self.item_bytes() / 4) as u32)
            .flag_if("SETUP_RECORDS", self == Binning::SetupRecords)
    }
}
/// Counter words (COUNTER_ in bin.wgsl): work items (64-bit), fan triangles set up (64-bit).
pub const COUNTER_WORDS: u64 = 4;
const COUNTER_ITEMS: usize = 0;
const COUNTER_TRIANGLES: usize = 2;
/// Bytes of counters, dispatch arguments and parameters.
pub const CONSTANT_BYTES: u64 = 16 + 16 + 16;

gpu_struct! {
    /// The compute rasterizer's parameters (`strata::raster::params`), one struct for every
    /// stage that binds them.
    #[derive(PartialEq)]
    pub struct RasterParams {
        /// Triangles of the scene.
        pub triangles: u32,
        /// Work items the item buffer holds.
        pub capacity: u32,
        /// Clipping guard band: |x|, |y| ≤ guard·w keeps window coordinates inside the edge
        /// functions' range.
        pub guard: f32,
        /// Setup records the record buffer holds ([`Binning::SetupRecords`]; else 0).
        pub setup_capacity: u32,
    }
}

/// The guard band in clip-space units of w: window coordinates stay within ±2²¹ pixels, so
/// snapped coordinates and their differences fit the edge functions' 32-bit inputs.
pub fn guard_band(width: u32, height: u32) -> f32 {
    ((1u32 << 22) / width.max(height).max(1)) as f32 - 1.0
}

/// The bin stage: setup's raster bindings are its group 1.
pub fn bin_stage(binning: Binning) -> Stage {
    Stage::new("strata.raster.bin", BIN_WGSL)
        .with(LIBRARY)
        .defs(&Defs::default().value("RASTER_GROUP", 1))
        .defs(&binning.defs())
}

/// The args stage (no scene bindings).
pub fn args_stage() -> Stage {
    Stage::new("strata.raster.args", ARGS_WGSL).with(LIBRARY)
}

/// The layout of the raster stage's bindings (params, items, counters, the scene's vertices), which every method's
/// compute capture places after its own groups.
pub fn raster_layout(gpu: &Gpu) -> wgpu::BindGroupLayout {
    binding_layout(gpu, Binning::Items)
}

/// The raster bindings' layout for `binning`: with setup records the items are writable (a
/// later pass stores their coverage) and the records follow the scene's vertices.
fn binding_layout(gpu: &Gpu, binning: Binning) -> wgpu::BindGroupLayout {
    let slots: &[Slot] = match binning {
        Binning::Items => &[Slot::Uniform, Slot::Storage, Slot::Storage, Slot::Storage],
        Binning::SetupRecords => &[
            Slot::Uniform,
            Slot::StorageRw,
            Slot::Storage,
            Slot::Storage,
            Slot::Storage,
        ],
    };
    binding::layout(&gpu.device, "strata.raster.layout", slots)
}

/// The compute capture of a method's storage-only fragment stage `entry`: its `stage` (a
/// library module, named by its `#define_import_path`) declares the entry's capture step
/// `{entry}_capture(v: SceneVarying, front_facing: bool, mask: u32)`, which its made `@fragment`
/// stage calls (`shader::capture_entries`). The raster stage calls it through a module made here
/// (`strata::raster::capture`) with full coverage (the compute rasterizer samples pixel
/// centers; `--msaa` refuses it). The raster bindings are at group `raster_group`; a workgroup
/// of `workgroup` invocations (a divisor of 64) rasterizes 64 items. An error when the stage
/// declares no such step.
pub fn capture_stage(
    stage: &Stage,
    entry: &str,
    raster_group: usize,
    workgroup: u32,
) -> Result<Stage> {
    let step = format!("{entry}_capture");
    if !capture_entries(stage.source()).any(|e| e == entry) {
        return Err(Error::unsupported(format!(
            "{entry} declares no capture step ({step}) the compute rasterizer can call"
        )));
    }
    let module = stage.module_name().ok_or_else(|| {
        Error::unsupported(format!(
            "{}: the stage names no module to import {step} from",
            stage.label
        ))
    })?;
    let bridge = format!(
        "#define_import_path strata::raster::capture
#import strata::scene::SceneVarying
#import {module}::{step}

fn raster_capture(v: SceneVarying, front_facing: bool) {{
    {step}(v, front_facing, 0xffffffffu);
}}
"
    );
    let raster = Stage::new(format!("{}.compute", stage.label), RASTER_WGSL)
        .with(LIBRARY)
        .with_module(bridge)
        .defs(stage.definitions())
        .defs(
            &Defs::default()
                .value("RASTER_GROUP", raster_group as u32)
                .value("RASTER_WORKGROUP", workgroup),
        )
        .defs(&Binning::Items.defs());
    Ok(stage
        .libraries()
        .iter()
        .fold(raster, |raster, library| raster.with(library)))
}

/// A storage-only geometry stage of a method on the scene's rasterizer: a render pipeline of
/// `module`'s fragment `entry` (the module of `stage`, or its passthrough twin with ordered
/// atomics), or the compute rasterizer's capture composed from `stage` with relaxed atomics
/// (a capture that needs ordering calls [`compute_stage`] itself). For an application's
/// recorder it is the application's shader calling the step (`frame::application`), its
/// atomics ordered where `ordered` (the fragment module is then `module`'s passthrough twin).
pub fn storage_stage(
    gpu: &Gpu,
    scene: &SceneGpu,
    label: &str,
    stage: &Stage,
    (module, ordered): (&wgpu::ShaderModule, bool),
    entry: &str,
    layouts: &[&wgpu::BindGroupLayout],
) -> Result<GeometryStage> {
    if let Some(app) = &scene.application {
        let capture = crate::frame::application::capture_stage(stage, entry)?;
        let pass = crate::frame::application::PassPipeline {
            label,
            layouts,
            ordered,
            targets: &[NullTarget::target_state()],
            depth: None,
            samples: scene.samples,
        };
        return crate::frame::application::pipeline(gpu, app, &capture, &pass)
            .map(GeometryStage::Hw);
    }
    if scene.raster_layout.is_none() {
        return Ok(GeometryStage::Hw(capture_pipeline(
            gpu,
            label,
            (module, entry),
            layouts,
            &[NullTarget::target_state()],
            None,
            scene.samples,
        )));
    }
    Ok(compute_stage(
        gpu,
        scene,
        &format!("{label}.compute"),
        stage,
        entry,
        layouts,
        false,
    ))
}

/// The compute rasterizer's capture of `stage`'s fragment `entry` (see [`capture_stage`]) with
/// the method's `layouts`, the rasterizer's group after them. Only for scenes on the compute
/// rasterizer. With `ordered` its `acquire_*` and `release_*` atomics get that ordering where
/// the adapter takes SPIR-V passthrough ([`crate::gpu::ordered`], as fragment captures do), in
/// workgroups no larger than the adapter runs such atomics in correctly
/// ([`crate::gpu::ordered::workgroup_limit`]: one SIMD vector on lavapipe before Mesa 22.3.7).
pub fn compute_stage(
    gpu: &Gpu,
    scene: &SceneGpu,
    label: &str,
    stage: &Stage,
    entry: &str,
    layouts: &[&wgpu::BindGroupLayout],
    ordered: bool,
) -> GeometryStage {
    let raster_layout = scene
        .raster_layout
        .as_ref()
        .expect("a compute stage is made for a scene on the compute rasterizer");
    let ordered = ordered && crate::gpu::ordered::available(gpu);
    let workgroup = match ordered {
        true => crate::gpu::ordered::ordered_workgroup(gpu, 64),
        false => 64,
    };
    let mut raster = capture_stage(stage, entry, layouts.len(), workgroup)
        .expect("strata's storage stages have the capture signature (tested)");
    raster.label = label.to_owned();
    let module = ordered
        .then(|| crate::gpu::ordered::module(gpu, &raster))
        .flatten()
        .unwrap_or_else(|| raster.module(&gpu.device));
    let mut all = layouts.to_vec();
    all.push(raster_layout);
    GeometryStage::Compute(crate::frame::passes::compute_pipeline(
        gpu,
        label,
        (&module, "cs_raster"),
        &all,
    ))
}

/// The compute rasterizer's feedback on a frame.
pub struct RasterReport {
    /// The frame's statistics.
    pub stats: ComputeRasterStats,
    /// Work items overflowed: the frame lost fragments and exact mode renders it again.
    pub incomplete: bool,
    /// Why no later frame can be complete either.
    pub cannot_complete: Option<crate::frame::Shortfall>,
}

/// This frame's binding of the rasterizer's buffers.
struct FrameBinding {
    bin_group: wgpu::BindGroup,
    args_group: wgpu::BindGroup,
    raster_group: wgpu::BindGroup,
    counters: wgpu::Buffer,
    args: wgpu::Buffer,
    capacity: u64,
    setup_capacity: u64,
    binned: bool,
}

/// The compute rasterizer's passes and buffers, kept between frames.
pub struct ComputeRaster {
    bin: wgpu::ComputePipeline,
    args: wgpu::ComputePipeline,
    bin_layout: wgpu::BindGroupLayout,
    args_layout: wgpu::BindGroupLayout,
    raster_layout: wgpu::BindGroupLayout,
    cache: ResourceCache,
    binning: Binning,
    /// Work items the next frame's buffer holds.
    capacity: u64,
    /// Setup records the next frame's buffer holds ([`Binning::SetupRecords`]).
    setup_capacity: u64,
    /// Triangles of the scene the last prepared frame bins.
    triangles: u64,
    frame: Option<FrameBinding>,
}

impl crate::frame::ComputeCapture for ComputeRaster {
    fn capture(
        &mut self,
        ctx: &mut FrameContext<'_>,
        name: &'static str,
        pipeline: &wgpu::ComputePipeline,
        groups: &[&wgpu::BindGroup],
    ) {
        ComputeRaster::capture(self, ctx, name, pipeline, groups);
    }
}

impl ComputeRaster {
    /// The rasterizer's pipelines for `scene`.
    pub fn new(gpu: &Gpu, scene: &SceneGpu, options: &RenderOptions) -> ComputeRaster {
        Self::with_binning(gpu, scene, options, Binning::Items)
    }

    /// The rasterizer whose bin stage leaves `binning` (setup records: the method binds
    /// [`ComputeRaster::layout`], whose items it fills in).
    pub fn with_binning(
        gpu: &Gpu,
        scene: &SceneGpu,
        options: &RenderOptions,
        binning: Binning,
    ) -> ComputeRaster {
        let mut bin_slots = vec![
            Slot::Uniform,
            Slot::StorageRw,
            Slot::StorageRw,
            Slot::Storage,
        ];
        if binning == Binning::SetupRecords {
            bin_slots.push(Slot::StorageRw);
        }
        let bin_layout = binding::layout(&gpu.device, "strata.raster.bin.layout", &bin_slots);
        let args_layout = binding::layout(
            &gpu.device,
            "strata.raster.args.layout",
            &[Slot::Uniform, Slot::Storage, Slot::StorageRw],
        );
        let compute = crate::frame::passes::compute_pipeline;
        let tiles = screen_tiles(options.frame.width, options.frame.height);
        ComputeRaster {
            bin: compute(
                gpu,
                "strata.raster.bin",
                (&bin_stage(binning).module(&gpu.device), "cs_bin"),
                &[&scene.frame_layout, &bin_layout],
            ),
            args: compute(
                gpu,
                "strata.raster.args",
                (&args_stage().module(&gpu.device), "cs_args"),
                &[&args_layout],
            ),
            bin_layout,
            args_layout,
            raster_layout: match (binning, &scene.raster_layout) {
                (Binning::Items, Some(layout)) => layout.clone(),
                _ => binding_layout(gpu, binning),
            },
            cache: ResourceCache::default(),
            binning,
            capacity: 2 * scene.triangle_count as u64 + 4 * tiles,
            // Most triangles set up as one fan triangle; a clipped one takes a few.
            setup_capacity: scene.triangle_count as u64 + scene.triangle_count as u64 / 8 + 64,
            triangles: scene.triangle_count as u64,
            frame: None,
        }
    }

    /// The most work items one buffer binds.
    fn limit(&self, gpu: &Gpu) -> u64 {
        (gpu.max_storage_binding() / self.binning.item_bytes()).min(1 << 31)
    }

    /// The most setup records one buffer binds.
    fn setup_limit(gpu: &Gpu) -> u64 {
        (gpu.max_storage_binding() / SETUP_RECORD_BYTES).min(1 << 31)
    }

    /// Bytes of the item and record buffers for `capacity` items and `setup_capacity` records.
    fn buffer_bytes(&self, capacity: u64, setup_capacity: u64) -> u64 {
        capacity * self.binning.item_bytes() + setup_capacity * SETUP_RECORD_BYTES + CONSTANT_BYTES
    }

    /// The layout of this rasterizer's bindings, which a method's passes after the bin take
    /// as their last group ([`ComputeRaster::frame_group`]).
    pub fn layout(&self) -> &wgpu::BindGroupLayout {
        &self.raster_layout
    }

    /// What the bin stage leaves.
    pub fn binning(&self) -> Binning {
        self.binning
    }

    /// Allocates this frame's buffers (binning is recorded by the first geometry pass).
    pub fn prepare(&mut self, gpu: &Gpu, options: &RenderOptions, scene: &SceneGpu) -> Result<()> {
        let triangles = scene.triangle_count;
        self.triangles = triangles as u64;
        let capacity = self.capacity.clamp(1, self.limit(gpu));
        let setup_capacity = match self.binning {
            Binning::Items => 0,
            Binning::SetupRecords => self.setup_capacity.clamp(1, Self::setup_limit(gpu)),
        };
        let params = RasterParams {
            triangles,
            capacity: capacity as u32,
            guard: guard_band(options.frame.width, options.frame.height),
            setup_capacity: setup_capacity as u32,
        };
        let item_bytes = self.binning.item_bytes();
        let cache = &mut self.cache;
        let params_buffer = cache.uniform(gpu, "strata.raster.params", bytemuck::bytes_of(&params));
        let items = cache.storage(gpu, "strata.raster.items", capacity * item_bytes)?;
        let records = match self.binning {
            Binning::Items => None,
            Binning::SetupRecords => Some(cache.storage(
                gpu,
                "strata.raster.records",
                setup_capacity * SETUP_RECORD_BYTES,
            )?),
        };
        let counters = cache.readable(gpu, "strata.raster.counters", COUNTER_WORDS * 4)?;
        let args =
            cache.storage_with(gpu, "strata.raster.args", 16, wgpu::BufferUsages::INDIRECT)?;
        let group = |label, layout, buffers: &[&wgpu::Buffer]| {
            let resources: Vec<_> = buffers.iter().map(|b| b.as_entire_binding()).collect();
            binding::group(&gpu.device, label, layout, &resources)
        };
        let mut buffers = vec![&params_buffer, &items, &counters, &scene.vertices];
        buffers.extend(records.as_ref());
        self.frame = Some(FrameBinding {
            bin_group: group("strata.raster.bin.group", &self.bin_layout, &buffers),
            args_group: group(
                "strata.raster.args.group",
                &self.args_layout,
                &[&params_buffer, &counters, &args],
            ),
            raster_group: group("strata.raster.group", &self.raster_layout, &buffers),
            counters,
            args,
            capacity,
            setup_capacity,
            binned: false,
        });
        Ok(())
    }

    /// Bytes this frame's buffers take.
    pub fn bytes(&self) -> u64 {
        self.frame
            .as_ref()
            .map_or(0, |f| self.buffer_bytes(f.capacity, f.setup_capacity))
    }

    /// Records one of the method's geometry passes through `pipeline` (a compute capture made by
    /// [`storage_stage`]) with the method's `groups`; the first one of a frame bins first.
    pub fn capture(
        &mut self,
        ctx: &mut FrameContext<'_>,
        name: &'static str,
        pipeline: &wgpu::ComputePipeline,
        groups: &[&wgpu::BindGroup],
    ) {
        let Some(frame) = self.frame.as_mut() else {
            return;
        };
        if !frame.binned {
            frame.binned = true;
            ctx.encoder.clear_buffer(&frame.counters, 0, None);
            let triangles = ctx.scene.triangle_count;
            let workgroups = triangles.div_ceil(64);
            let x = workgroups.min(65535);
            let frame_group = ctx.frame_group;
            dispatch_with(
                ctx,
                "raster.bin",
                &self.bin,
                &[frame_group, &frame.bin_group],
                Workgroups::Direct(x, workgroups.div_ceil(x.max(1))),
            );
            dispatch_with(
                ctx,
                "raster.args",
                &self.args,
                &[&frame.args_group],
                Workgroups::Direct(1, 1),
            );
        }
        let mut all = groups.to_vec();
        all.push(&frame.raster_group);
        dispatch_with(ctx, name, pipeline, &all, Workgroups::Indirect(&frame.args));
    }

    /// Asks for the frame's counters.
    pub fn read_counters(&self, readback: &mut ReadbackList) -> bool {
        match &self.frame {
            Some(f) if f.binned => {
                readback.words(&f.counters, 0, COUNTER_WORDS);
                true
            }
            _ => false,
        }
    }

    /// Feedback from a frame's counters, recorded with `capacity` items (and, with setup
    /// records, `setup_capacity` records): grows a buffer after an overflow, shrinks one more
    /// than twice too large.
    pub fn feedback(
        &mut self,
        gpu: &Gpu,
        words: &[u32],
        capacity: u64,
        setup_capacity: u64,
    ) -> RasterReport {
        let needed = crate::frame::wide(words, COUNTER_ITEMS);
        let set_up = crate::frame::wide(words, COUNTER_TRIANGLES);
        let fit = |n: u64| (n + n / 4).max(1024);
        let items_overflow = needed > capacity;
        // Grow after an overflow; shrink when more than twice too large.
        if items_overflow || self.capacity > 2 * fit(needed) {
            self.capacity = fit(needed);
        }
        let records = self.binning == Binning::SetupRecords;
        let records_overflow = records && set_up > setup_capacity;
        if records && (records_overflow || self.setup_capacity > 2 * fit(set_up)) {
            self.setup_capacity = fit(set_up);
        }
        let overflow = items_overflow || records_overflow;
        let (limit, setup_limit) = (self.limit(gpu), Self::setup_limit(gpu));
        let mib = |n: u64, bytes: u64| (n * bytes) as f64 / 1048576.0;
        let items_shortfall = (needed > limit).then(|| crate::frame::Shortfall {
            why: format!(
                "--raster compute: the frame needs {needed} tile items ({:.1} MiB at {} bytes each), more than the device's largest storage buffer holds ({limit})",
                mib(needed, self.binning.item_bytes()),
                self.binning.item_bytes()
            ),
            binding: Some((needed, limit)),
        });
        let records_shortfall = (records && set_up > setup_limit).then(|| crate::frame::Shortfall {
            why: format!(
                "--raster compute: the frame sets up {set_up} triangles ({:.1} MiB of setup records at {SETUP_RECORD_BYTES} bytes each), more than the device's largest storage buffer holds ({setup_limit})",
                mib(set_up, SETUP_RECORD_BYTES)
            ),
            binding: Some((set_up, setup_limit)),
        });
        RasterReport {
            stats: ComputeRasterStats {
                triangles: self.triangles,
                triangles_set_up: set_up,
                tile_items: needed,
                item_capacity: capacity,
                overflow,
                bytes_allocated: self.buffer_bytes(capacity, setup_capacity),
            },
            incomplete: overflow,
            cannot_complete: items_shortfall.or(records_shortfall),
        }
    }

    /// This frame's raster bind group (params, items, counters, the scene's vertices), for a
    /// method's own passes over the items after [`ComputeRaster::capture`] binned them.
    pub fn frame_group(&self) -> Option<&wgpu::BindGroup> {
        self.frame.as_ref().map(|f| &f.raster_group)
    }

    /// Work items this frame's buffer holds.
    pub fn frame_capacity(&self) -> u64 {
        self.frame.as_ref().map_or(0, |f| f.capacity)
    }

    /// Setup records this frame's buffer holds (0 without [`Binning::SetupRecords`]).
    pub fn frame_setup_capacity(&self) -> u64 {
        self.frame.as_ref().map_or(0, |f| f.setup_capacity)
    }

    /// The rasterizer's buffers.
    pub fn resources(&self) -> &ResourceCache {
        &self.cache
    }
}

/// Tiles of the viewport.
pub fn screen_tiles(width: u32, height: u32) -> u64 {
    width.div_ceil(TILE) as u64 * height.div_ceil(TILE) as u64
}

#[cfg(test)]
mod tests;
