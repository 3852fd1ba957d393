//! `tiled`: exact transparency in compute, each 8×8-pixel tile's fragments sorted inside one
//! workgroup, with no per-pixel global atomics and no locks — race-free by construction.
//!
//! Passes (all compute; the scene's triangles are read from its vertex buffer):
//! - **bin** (the compute rasterizer's, [`crate::raster`], with [`Binning::SetupRecords`]):
//!   each triangle is transformed, clipped and snapped once; each fan triangle of its clipped
//!   polygon is stored as a setup record (88 bytes), and every (record, 8×8 tile its bounds
//!   meet) pair becomes a work item. The item and record buffers are sized from the last
//!   frame's need; after an overflow they grow, the frame reports itself incomplete and exact
//!   mode renders it again.
//! - **count**, **scan**, **scatter**: each item's coverage — the 64-bit mask of its tile's
//!   pixel centers inside the record's triangle — is computed once and stored in the item; the
//!   items that cover a center are counted per tile with the centers they cover (the others are
//!   dropped here), the counts scanned (one workgroup of up to 1024 threads) into list starts and the tiles ordered by
//!   their covered centers, most first (a counting sort by power of two), and each kept item's
//!   index scattered into its tile's list.
//! - **fast** (`fast.wgsl`, four workgroups of 64 threads per tile, taking the tiles in the
//!   scan's order on a GPU so that the heaviest start first, in raster order on a CPU device):
//!   where the tile's list
//!   covers at most `fast_fragments` pixel centers (what the device's workgroup memory holds:
//!   1152 on lavapipe, 2048 at most), the first workgroup takes the whole tile, else each takes
//!   a 4×4 quarter: its items' records are loaded once per chunk, its fragments spread one per
//!   thread (a prefix sum over the items' coverage), each evaluated and shaded once into
//!   workgroup memory, then gathered per pixel, sorted by (depth, primitive) by the pixel's
//!   thread, composited and resolved — the finish folded in: the pixel's result is written and
//!   the workgroup adds its pixels to the frame's totals with one atomic per total. A quarter
//!   past the store is left to the rounds and counted, and so is a pixel of more than 128
//!   fragments (its thread's insertion sort stays within 8128 steps).
//! - **round** × R, for the pixels the fast pass left (one workgroup of 64 threads per tile, a
//!   thread per pixel): the tile's list is walked in chunks of 64 triangles, their records
//!   loaded once per chunk into workgroup memory; each thread tests its bit of each triangle's
//!   mask and keeps its pixel's 16 nearest fragments behind its bound (the last fragment it
//!   composited) in registers, sorted by (depth, primitive), and composites them front to back
//!   onto its state. Tiles whose pixels have nothing left skip the round. R is ⌈f/16⌉ of the
//!   deepest pixel last frame's rounds ran on (2 for a first frame, at least 1); pixels with
//!   fragments left after R rounds make the frame incomplete (counted as dropped; exact mode
//!   renders again with enough rounds). R is at most `MAX_ROUNDS` (4096, 65,536 fragments a
//!   pixel): a frame is one submission, and a deeper pixel says the frame cannot complete.
//! - **finish**: the result of each pixel the fast pass left, from its state (summed per
//!   workgroup into the frame's totals), and the rounds per tile.
//!
//! Work counters (`TiledStats`): triangle setups (the bin's), setup records loaded, fragment
//! evaluations and shadings, items kept and dropped as empty, quarters past the store, and the
//! lane occupancy of the evaluation loops — what a CPU device can count of the work a GPU does,
//! for a cost model of the frame. Each is summed per workgroup and added once per workgroup.
//!
//! Coverage, depth and attributes are the compute rasterizer's (`strata::raster::setup`; a
//! record holds exactly the values its setup computed), so its pictures equal the other
//! compute-rasterized exact methods' bit for bit. Deterministic: a pixel's fragments are
//! composited in (depth, primitive) order whatever order the scatter filled a list in, so a
//! frame gives the same bytes every run. `--k N` composites each pixel's N nearest and counts
//! the rest as dropped; with `--tail blend|weighted` the rest are composited behind them as one
//! term (`strata::tail`, the k-buffers' tail): by the one-pass kernel from its sorted run, by
//! the round that reaches k from every fragment behind its bound (each joins the tail as it is
//! shaded, and the ones composited leave it: integer sums, so no per-pixel atomics and no
//! dependence on order).
//!
//! `--msaa 4|8` (`samples.wgsl`), as the reference samples: the bin's bounds take every pixel
//! whose square meets the triangle, an item's coverage is the tile's pixels with a sample inside
//! (the exact top-left rule at each standard position, [`sample_grid`]), and a fragment — one
//! per (fan triangle, pixel) — is evaluated and shaded at the pixel center once, its tag
//! carrying the samples it covers (those in front of the far plane). The one-pass kernel
//! composites each sample's fragments from the pixel's sorted run (its own k nearest and tail)
//! and writes the samples' mean. The rounds take the pixel's KEEP nearest in its (depth, tag)
//! order — which, restricted to a sample, is the sample's order — and composite each into the
//! samples it covers that have room, keeping a composite per sample; a sample that may fill in
//! a round joins every fragment behind the bound that covers it to its own tail. A fragment
//! counts once however many samples composited it. It needs no multisampled target, so it runs
//! 8× on devices whose targets take 4 (lavapipe) and on GL, whose shaders cannot read the
//! sample mask.
//!
//! Memory: the fast pass's store is workgroup memory (24 bytes a fragment); in buffers, the
//! rasterizer's 16 bytes per item (record, tile, coverage), 88 per set-up fan triangle and 48
//! of constants, 4 bytes per listed item, 20 per tile (count, work, start, order, rounds), 40 per pixel
//! (state: its progress word, then its composite; with `--msaa S`, [`state_bytes`]: 20 + 36·S),
//! 144 of counters and 64 of parameters.
//! Limits: the scene's vertices in one storage binding; temporal culling, `--order`
//! and an application's draw callback are not supported (it reads the scene's triangles
//! itself). On lavapipe, whose invocations stop looping after 65535 iterations in all, a round
//! can walk a list of a few thousand chunks of triangles at most; a walk cut short is counted
//! and the frame refused with the reason.

pub mod cost;
pub mod descriptor;
pub mod stats;

use bytemuck::Zeroable;

use crate::gpu::twin::{gpu_struct, wgsl_constants, wgsl_module};

use crate::error::{Error, Result};
use crate::frame::passes::{compute_pipeline, dispatch};
use crate::frame::{FamilyStats, FrameContext, MethodStats, Recorded, SceneGpu, Totals};
use crate::gpu::binding::{self, Slot};
use crate::gpu::shader::{Defs, Library, Stage};
use crate::gpu::{Gpu, ResourceCache};
use crate::methods::Method;
use crate::raster::{Binning, ComputeRaster, TILE};
pub use stats::TiledStats;

/// tiled's WGSL modules (`strata::tiled::…`): its bindings, the list sort and the tile pass.
pub const LIBRARY: Library = &[
    PARAMS_WGSL,
    CONSTANTS_WGSL,
    LISTS_WGSL,
    SORT_WGSL,
    SAMPLES_WGSL,
    TILE_WGSL,
    FAST_WGSL,
];
const PARAMS_WGSL: &str = wgsl_module!("strata::tiled::params", TiledParams);
/// `strata::tiled::constants`: the sizes and counter words below, for the shaders.
const CONSTANTS_WGSL: &str = wgsl_constants!(
    "strata::tiled::constants",
    KEEP = KEEP,
    COUNTER_WORDS = COUNTER_WORDS,
    COUNTER_ROUNDS = COUNTER_ROUNDS,
    ROUND_BINS = ROUND_BINS,
    COUNTER_DEEPEST = COUNTER_DEEPEST,
    COUNTER_UNFINISHED = COUNTER_UNFINISHED,
    COUNTER_LONGEST_LIST = COUNTER_LONGEST_LIST,
    COUNTER_CUT_SHORT = COUNTER_CUT_SHORT,
    COUNTER_ROUNDS_RECORDED = COUNTER_ROUNDS_RECORDED,
    COUNTER_RECORD_LOADS = COUNTER_RECORD_LOADS,
    COUNTER_EVALUATIONS = COUNTER_EVALUATIONS,
    COUNTER_SHADINGS = COUNTER_SHADINGS,
    COUNTER_EMPTY_ITEMS = COUNTER_EMPTY_ITEMS,
    COUNTER_WARP_STEPS = COUNTER_WARP_STEPS,
    COUNTER_PAST_CAPACITY = COUNTER_PAST_CAPACITY,
    COUNTER_DEEPEST_IN_ROUNDS = COUNTER_DEEPEST_IN_ROUNDS,
    COUNTER_SORT_STEPS = COUNTER_SORT_STEPS,
    COUNTER_ONE_PASS_PIXELS = COUNTER_ONE_PASS_PIXELS,
);
const LISTS_WGSL: &str = include_str!("lists.wgsl");
const SORT_WGSL: &str = include_str!("sort.wgsl");
const SAMPLES_WGSL: &str = include_str!("samples.wgsl");
const TILE_WGSL: &str = include_str!("tile.wgsl");
const FAST_WGSL: &str = include_str!("fast.wgsl");

/// Fragments a pixel keeps per round.
pub const KEEP: u32 = 16;
/// Bytes of one list entry: the index of a rasterizer item (which holds its setup record and
/// coverage mask, [`crate::raster::RECORD_ITEM_BYTES`]).
pub const LIST_ENTRY_BYTES: u64 = 4;
/// Bytes per tile: its item count, its work, its list's start, its place in the one-pass
/// kernel's order and its rounds.
pub const TILE_BYTES: u64 = 20;
/// Bytes per pixel of compositing state between rounds, single-sampled: its progress word and
/// its composite ([`state_bytes`]).
pub const STATE_BYTES: u64 = 40;
/// Bytes of one composite in a pixel's state: color, transmittance, count, the last fragment's
/// depth and tag.
const COMPOSITE_BYTES: u64 = 36;
/// Bytes of a multisampled pixel's state besides its samples' composites: its progress word,
/// the last fragment a round took (depth and tag: the next round's bound), the fragments the
/// rounds took and those some sample composited.
const SAMPLES_STATE_BYTES: u64 = 20;

/// Bytes per pixel of compositing state between rounds at `samples` per pixel: single-sampled
/// the progress word and one composite, with `--msaa` a composite per sample besides
/// the pixel's bound and account.
pub fn state_bytes(samples: u32) -> u64 {
    match samples {
        0 | 1 => STATE_BYTES,
        s => SAMPLES_STATE_BYTES + s as u64 * COMPOSITE_BYTES,
    }
}

/// `--msaa`'s sample positions ([`crate::frame::msaa::positions`]) for the shaders: sample s's
/// position in sixteenths of a pixel in byte s % 4 of word s / 4, x in its low four bits and y
/// in its high four (every standard position lies on that grid, strictly inside the pixel).
pub fn sample_grid(samples: u32) -> [u32; 2] {
    let mut grid = [0u32; 2];
    if samples <= 1 {
        return grid;
    }
    for (s, p) in crate::frame::msaa::positions(samples).iter().enumerate() {
        let [x, y] = p.map(|c| (c * 16.0) as u32);
        grid[s / 4] |= (x | y << 4) << (8 * (s % 4));
    }
    grid
}
/// Counter words.
pub const COUNTER_WORDS: u64 = 36;
/// Tiles by the rounds they ran: bin r for r rounds, the last bin for ROUND_BINS − 1 or more.
const COUNTER_ROUNDS: usize = 0;
const ROUND_BINS: usize = 16;
/// The most fragments one pixel had.
const COUNTER_DEEPEST: usize = 16;
/// Pixels with fragments left behind their last round.
const COUNTER_UNFINISHED: usize = 17;
/// The longest tile list.
const COUNTER_LONGEST_LIST: usize = 18;
/// Pixel rounds whose walk of the list ended early (a loop cut short by the adapter).
const COUNTER_CUT_SHORT: usize = 19;
/// The rounds the frame recorded.
const COUNTER_ROUNDS_RECORDED: usize = 20;
// The work, each a 64-bit count in two words (low first), so that the cost of the frame can be
// modelled from what a CPU device counts (issue 64):
/// Setup records loaded into workgroup memory: one per list entry covering a pixel of the
/// one-pass kernel's region, one per chunk entry covering a working pixel in each round.
const COUNTER_RECORD_LOADS: usize = 21;
/// Fragment evaluations (barycentrics and depth at a covered pixel center) in the rounds.
const COUNTER_EVALUATIONS: usize = 23;
/// Fragments shaded (attributes and lighting) in the rounds, kept or later displaced.
const COUNTER_SHADINGS: usize = 25;
/// Items whose triangle covers no pixel center of their tile (listed, but never evaluated).
const COUNTER_EMPTY_ITEMS: usize = 27;
/// Steps of the rounds' evaluation loop summed over 32-lane warps (two per tile), so that
/// evaluations / (32 · steps) is the loop's lane occupancy.
const COUNTER_WARP_STEPS: usize = 29;
/// 4×4 quarters of tiles that the one-pass kernel left to the rounds: their covered pixel
/// centers outgrew its store, as the whole tile's did.
const COUNTER_PAST_CAPACITY: usize = 31;
/// The most fragments one pixel of a tile some round ran in had (the next frame's rounds).
const COUNTER_DEEPEST_IN_ROUNDS: usize = 32;
/// Steps of the one-pass kernel's per-pixel insertion sorts (compares), each 32-lane warp
/// counted as its longest sort: the sort's time on a GPU, whose warp waits for its last lane.
const COUNTER_SORT_STEPS: usize = 33;
/// Pixels the one-pass kernel resolved, in tiles with a list or none (the rest: the rounds').
const COUNTER_ONE_PASS_PIXELS: usize = 35;
/// Bytes of workgroup memory the one-pass kernel keeps besides its fragment store: the chunk
/// of 16 set-up triangles (176 bytes each), their primitives, masks and prefix sums, the
/// per-pixel counts and starts, and a few counts and sums (the work, the warps' sorts, the
/// resolved pixels' account).
const FAST_FIXED_BYTES: u32 = 16 * (176 + 4 + 8 + 4) + 64 * 8 + 64;
/// Bytes of workgroup memory per stored fragment: the fragment, its pixel, its place in the
/// pixels' runs.
const FAST_FRAGMENT_BYTES: u32 = 16 + 4 + 4;

/// Fragments the one-pass kernel's store holds on `gpu`: what its workgroup memory takes, at
/// most 2048 (32 a pixel) and at least 64.
pub fn fast_fragments(gpu: &Gpu) -> u32 {
    let memory = gpu.limits.max_compute_workgroup_storage_size;
    (memory.saturating_sub(FAST_FIXED_BYTES) / FAST_FRAGMENT_BYTES).clamp(64, 2048) / 64 * 64
}
/// Whether the one-pass kernel takes the tiles most work first on `gpu`: on a GPU, so that the
/// heaviest tiles start early instead of setting the frame's end; on a CPU device (lavapipe) in
/// raster order, whose neighbouring tiles share triangles in its caches — lavapipe took 9.3 s
/// for nvpro at 1024² in work order and 5.3 s in raster order (2026-12-06). Strata's own unit
/// tests take work order everywhere, so that lavapipe runs that path too; its integration tests
/// and the CLI run raster order there.
pub fn orders_tiles_by_work(gpu: &Gpu) -> bool {
    crate::methods::choice::compute_is_faster(&gpu.info) || cfg!(test)
}

/// Rounds of a first frame, before any depth complexity was measured.
pub const FIRST_ROUNDS: u32 = 2;

gpu_struct! {
    /// tiled's uniforms (`strata::tiled::params`).
    #[derive(PartialEq)]
    pub struct TiledParams {
        /// Tiles per row.
        pub tiles_x: u32,
        /// Tiles of the viewport.
        pub tiles: u32,
        /// Codes the list buffer holds (the rasterizer's item capacity).
        pub capacity: u32,
        /// Fragments a pixel composites at most (`--k`); 0: all of them.
        pub k: u32,
        /// Rounds recorded this frame.
        pub rounds: u32,
        /// Pixels of the frame (its band): the state buffer's progress words come first.
        pub pixels: u32,
        /// `--tail` with `--k` (`TailParams::mode` of `strata::tail`): what becomes of a
        /// pixel's fragments past its k nearest.
        pub tail_mode: u32,
        /// `TailParams::weight`: `--weight`, and the view's projection.
        pub tail_weight: u32,
        /// `TailParams::depth_p`.
        pub tail_depth_p: f32,
        /// `TailParams::depth_q`.
        pub tail_depth_q: f32,
        /// 1: the one-pass kernel's workgroups take the tiles most work first (the scan's
        /// order); 0: in raster order ([`orders_tiles_by_work`]).
        pub order_by_work: u32,
        /// Words of a pixel's state after its progress word ([`state_bytes`]).
        pub state_words: u32,
        /// With `--msaa`, the sample positions ([`sample_grid`]).
        pub sample_grid: [u32; 2],
        pad_b: [u32; 2],
    }
}

/// The stages at `samples` per pixel, with the rasterizer's bindings in group 2 (after the
/// frame's and tiled's). Multisampled, they are composed with `MULTISAMPLED`, which compiles the
/// samples' paths (`samples.wgsl`) in: a single-sampled frame's kernels carry none of their
/// registers.
pub fn stage(label: &str, source: &'static str, samples: u32) -> Stage {
    Stage::new(label, source)
        .with(crate::raster::LIBRARY)
        .with(LIBRARY)
        .defs(&Defs::default().value("RASTER_GROUP", 2))
        .defs(&Binning::SetupRecords.defs())
        .defs(&crate::gpu::shader::target_samples(samples))
}

/// Rounds that composite `fragments` per pixel (at least one).
pub fn rounds_for(fragments: u32) -> u32 {
    fragments.div_ceil(KEEP).max(1)
}

/// The most round dispatches one frame records (docs/watchdog.md, T1): 65,536 fragments in a
/// pixel. A frame is one submission, which a driver may time as one job: past this the rounds
/// would be thousands of dispatches each walking whole tile lists. Pixels deeper than this are
/// left unfinished and the frame says it cannot complete.
pub const MAX_ROUNDS: u32 = 4096;

/// The rounds the next frame needs (before [`MAX_ROUNDS`]): enough for the deepest pixel the
/// one-pass kernel left to the rounds (at least one: a tile past its capacity must run one to
/// be counted); after an item overflow the deepest pixel seen is only a lower bound, so the
/// rounds do not shrink.
fn next_rounds(rounds: u32, overflow: bool, deepest: u32, deepest_in_rounds: u32) -> u32 {
    match overflow {
        true => rounds.max(rounds_for(deepest)),
        false => rounds_for(deepest_in_rounds),
    }
}

/// The list sort's stage (entries `cs_count`, `cs_scan`, `cs_scatter`), its scan of
/// `scan_threads` threads.
pub fn sort_stage(scan_threads: u32, samples: u32) -> Stage {
    stage("strata.tiled.sort", SORT_WGSL, samples)
        .defs(&Defs::default().value("SCAN_THREADS", scan_threads))
}

/// Threads of the scan's one workgroup on `gpu`: as many as it runs in a workgroup, at most
/// 1024, a power of two (each thread walks ⌈tiles / threads⌉ tiles twice, one after another).
pub fn scan_threads(gpu: &Gpu) -> u32 {
    let limits = &gpu.limits;
    let most = limits
        .max_compute_invocations_per_workgroup
        .min(limits.max_compute_workgroup_size_x)
        .clamp(64, 1024);
    1 << most.ilog2()
}

/// The tile pass's stage (entries `cs_round`, `cs_round_samples`, `cs_finish`).
pub fn tile_stage(samples: u32) -> Stage {
    stage("strata.tiled.tile", TILE_WGSL, samples)
}

/// The one-pass kernel's stage (entry `cs_fast`), its store of `fragments`.
pub fn fast_stage(fragments: u32, samples: u32) -> Stage {
    stage("strata.tiled.fast", FAST_WGSL, samples)
        .defs(&Defs::default().value("FAST_FRAGMENTS", fragments))
}

/// `tiled`'s pipelines, its rasterizer and its buffers.
pub struct Tiled {
    gpu: Gpu,
    raster: ComputeRaster,
    layout: wgpu::BindGroupLayout,
    count: wgpu::ComputePipeline,
    scan: wgpu::ComputePipeline,
    scatter: wgpu::ComputePipeline,
    round: wgpu::ComputePipeline,
    fast: wgpu::ComputePipeline,
    finish: wgpu::ComputePipeline,
    cache: ResourceCache,
    /// Rounds the next frame records: from the last frame's deepest pixel.
    rounds: u32,
    /// Samples per pixel (`--msaa`; 1 single-sampled).
    samples: u32,
}

impl Tiled {
    /// The pipelines for `scene`.
    pub fn new(
        gpu: &Gpu,
        scene: &SceneGpu,
        options: &crate::frame::RenderOptions,
    ) -> Result<Tiled> {
        let (vertex_bytes, binding) = (scene.vertices.size(), gpu.max_storage_binding());
        if vertex_bytes > binding {
            let mib = |b: u64| b as f64 / 1048576.0;
            return Err(Error::unsupported(format!(
                "tiled reads the scene's vertices from one storage binding: {} triangles take {:.0} MiB, more than the device's {:.0} MiB; use an exact method on the GPU's rasterizer (abuffer-ll, kpeel)",
                scene.triangle_count,
                mib(vertex_bytes),
                mib(binding)
            )));
        }
        // Parameters, then the counts, starts, lists, counters, output, state and rounds.
        let slots: Vec<Slot> = std::iter::once(Slot::Uniform)
            .chain([Slot::StorageRw; 7])
            .collect();
        let layout = binding::layout(&gpu.device, "strata.tiled.layout", &slots);
        let raster = ComputeRaster::with_binning(gpu, scene, options, Binning::SetupRecords);
        let raster_layout = raster.layout().clone();
        let layouts = [&scene.frame_layout, &layout, &raster_layout];
        let samples = options.build.msaa.max(1);
        let sort = sort_stage(scan_threads(gpu), samples).module(&gpu.device);
        let tile = tile_stage(samples).module(&gpu.device);
        let fast = fast_stage(fast_fragments(gpu), samples).module(&gpu.device);
        let pipeline =
            |label, module, entry| compute_pipeline(gpu, label, (module, entry), &layouts);
        Ok(Tiled {
            gpu: gpu.clone(),
            raster,
            count: pipeline("strata.tiled.count", &sort, "cs_count"),
            scan: pipeline("strata.tiled.scan", &sort, "cs_scan"),
            scatter: pipeline("strata.tiled.scatter", &sort, "cs_scatter"),
            // Multisampled, the rounds keep a composite per sample.
            round: match samples > 1 {
                false => pipeline("strata.tiled.round", &tile, "cs_round"),
                true => pipeline("strata.tiled.round", &tile, "cs_round_samples"),
            },
            fast: pipeline("strata.tiled.fast", &fast, "cs_fast"),
            finish: pipeline("strata.tiled.finish", &tile, "cs_finish"),
            layout,
            cache: ResourceCache::default(),
            rounds: FIRST_ROUNDS,
            samples,
        })
    }
}

impl Tiled {
    /// Pixels the state buffer holds.
    fn state_pixels(&self) -> u64 {
        self.cache
            .get("strata.tiled.state")
            .map_or(0, |b| b.size() / state_bytes(self.samples))
    }
}

/// Bytes of the lists, the tile words and the pixels' state for `capacity` items, `tiles` tiles
/// and `pixels` pixels of `samples` each.
fn list_bytes(capacity: u64, tiles: u64, pixels: u64, samples: u32) -> u64 {
    capacity * LIST_ENTRY_BYTES + tiles * TILE_BYTES + pixels * state_bytes(samples)
}

impl Method for Tiled {
    fn record(&mut self, ctx: &mut FrameContext<'_>) -> Result<Recorded> {
        let gpu = ctx.gpu;
        let (w, h) = ctx.size();
        let (tiles_x, tiles_y) = (w.div_ceil(TILE), h.div_ceil(TILE));
        let tiles = tiles_x as u64 * tiles_y as u64;
        self.raster.prepare(gpu, ctx.options, ctx.scene)?;
        let capacity = self.raster.frame_capacity();
        let pixels = ctx.pixels();
        let bytes = self.raster.bytes()
            + list_bytes(capacity, tiles, pixels, self.samples)
            + COUNTER_WORDS * 4
            + std::mem::size_of::<TiledParams>() as u64;
        ctx.check_budget(bytes)?;
        let k = ctx.k.unwrap_or(0);
        // With --k the rounds need not go past the k nearest; multisampled they take a pixel's
        // fragments in its order, and a sample may reach its k nearest only later.
        let rounds = match k {
            0 => self.rounds,
            _ if self.samples > 1 => self.rounds,
            k => self.rounds.min(rounds_for(k)),
        };
        // The tail matters only where --k leaves fragments past the k nearest.
        let mut tail = crate::methods::kbuffer::tail_settings(ctx.options, ctx.scene);
        if k == 0 {
            tail.mode = 0;
        }
        let params = TiledParams {
            tiles_x,
            tiles: tiles as u32,
            capacity: capacity as u32,
            k,
            rounds,
            pixels: pixels as u32,
            tail_mode: tail.mode,
            tail_weight: tail.weight,
            tail_depth_p: tail.depth_p,
            tail_depth_q: tail.depth_q,
            order_by_work: orders_tiles_by_work(gpu) as u32,
            state_words: ((state_bytes(self.samples) - 4) / 4) as u32,
            sample_grid: sample_grid(self.samples),
            ..Zeroable::zeroed()
        };
        let cache = &mut self.cache;
        let params = cache.uniform(gpu, "strata.tiled.params", bytemuck::bytes_of(&params));
        // Counts then work, starts then the order.
        let counts = cache.storage(gpu, "strata.tiled.counts", tiles * 8)?;
        let starts = cache.storage(gpu, "strata.tiled.starts", tiles * 8)?;
        let codes = cache.storage(gpu, "strata.tiled.codes", capacity * LIST_ENTRY_BYTES)?;
        let state = cache.storage(
            gpu,
            "strata.tiled.state",
            pixels * state_bytes(self.samples),
        )?;
        let tile_rounds = cache.storage(gpu, "strata.tiled.rounds", tiles * 4)?;
        let counters = cache.readable(gpu, "strata.tiled.counters", COUNTER_WORDS * 4)?;
        let group = binding::group(
            &gpu.device,
            "strata.tiled.group",
            &self.layout,
            &[
                params.as_entire_binding(),
                counts.as_entire_binding(),
                starts.as_entire_binding(),
                codes.as_entire_binding(),
                counters.as_entire_binding(),
                ctx.output.as_entire_binding(),
                state.as_entire_binding(),
                tile_rounds.as_entire_binding(),
            ],
        );
        ctx.encoder.clear_buffer(&counts, 0, None);
        // Only the progress words: a pixel's composite is read where its progress says it was
        // written this frame.
        ctx.encoder.clear_buffer(&state, 0, Some(pixels * 4));
        ctx.encoder.clear_buffer(&tile_rounds, 0, None);
        ctx.encoder.clear_buffer(&counters, 0, None);
        let frame_group = ctx.frame_group;
        // The first capture bins the scene's triangles into the rasterizer's items.
        self.raster
            .capture(ctx, "count", &self.count, &[frame_group, &group]);
        let raster_group = self.raster.frame_group().expect("prepared above").clone();
        dispatch(
            ctx,
            "scan",
            &self.scan,
            &[frame_group, &group, &raster_group],
            (1, 1),
        );
        self.raster
            .capture(ctx, "scatter", &self.scatter, &[frame_group, &group]);
        let groups = [frame_group, &group, &raster_group];
        // Four workgroups a tile: the whole tile in the first, or a 4×4 quarter in each.
        dispatch(ctx, "fast", &self.fast, &groups, (4 * tiles_x, tiles_y));
        for _ in 0..rounds {
            dispatch(ctx, "round", &self.round, &groups, (tiles_x, tiles_y));
        }
        dispatch(ctx, "finish", &self.finish, &groups, (tiles_x, tiles_y));
        self.raster.read_counters(ctx.readback);
        ctx.readback.words(&counters, 0, COUNTER_WORDS);
        Ok(Recorded {
            capacity,
            setup_capacity: self.raster.frame_setup_capacity(),
            k: (k > 0).then_some(k),
            ..Recorded::passes(1, bytes)
        })
    }

    fn stats(&mut self, recorded: &Recorded, _: &Totals, words: &[u32]) -> MethodStats {
        let raster_words = crate::raster::COUNTER_WORDS as usize;
        let report = self.raster.feedback(
            &self.gpu,
            &words[..raster_words],
            recorded.capacity,
            recorded.setup_capacity,
        );
        let counters = &words[raster_words..raster_words + COUNTER_WORDS as usize];
        let mut tile_rounds: Vec<u64> = counters[COUNTER_ROUNDS..ROUND_BINS]
            .iter()
            .map(|&n| n as u64)
            .collect();
        while tile_rounds.len() > 1 && tile_rounds.last() == Some(&0) {
            tile_rounds.pop();
        }
        let tiles: u64 = counters[COUNTER_ROUNDS..ROUND_BINS]
            .iter()
            .map(|&n| n as u64)
            .sum();
        let deepest = counters[COUNTER_DEEPEST];
        let deepest_in_rounds = counters[COUNTER_DEEPEST_IN_ROUNDS];
        let unfinished = counters[COUNTER_UNFINISHED] as u64;
        let longest_list = counters[COUNTER_LONGEST_LIST];
        let needed = next_rounds(
            self.rounds,
            report.stats.overflow,
            deepest,
            deepest_in_rounds,
        );
        self.rounds = needed.min(MAX_ROUNDS);
        let cut_short = counters[COUNTER_CUT_SHORT];
        let cannot_complete = report.cannot_complete.or_else(|| {
            if cut_short > 0 {
                return Some(crate::frame::Shortfall {
                    why: format!(
                        "tiled: {cut_short} pixels' walks of their tile lists ended early (the longest list holds {longest_list} triangles): a round walks at most 1048576 entries (a display watchdog), and lavapipe stops a shader invocation's loops after 65535 iterations in all: render smaller or use another exact method here"
                    ),
                    binding: None,
                });
            }
            (unfinished > 0 && needed > MAX_ROUNDS).then(|| crate::frame::Shortfall {
                why: format!(
                    "tiled: a pixel holds {deepest} fragments, more than the {MAX_ROUNDS} rounds a frame records composite ({}): a frame of more rounds risks a display watchdog; use another exact method here",
                    MAX_ROUNDS * KEEP
                ),
                binding: None,
            })
        });
        let work = |at: usize| crate::frame::wide(counters, at);
        let warp_steps = work(COUNTER_WARP_STEPS);
        let evaluations = work(COUNTER_EVALUATIONS);
        MethodStats {
            overflow: Some(report.stats.overflow),
            incomplete: report.incomplete || unfinished > 0 || cut_short > 0,
            cannot_complete,
            family: Some(FamilyStats::new(TiledStats {
                triangle_setups: report.stats.triangles_set_up,
                record_loads: work(COUNTER_RECORD_LOADS),
                sort_steps: work(COUNTER_SORT_STEPS),
                one_pass_pixels: counters[COUNTER_ONE_PASS_PIXELS] as u64,
                warp_steps,
                fragment_evaluations: evaluations,
                shadings: work(COUNTER_SHADINGS),
                items_kept: report
                    .stats
                    .tile_items
                    .saturating_sub(work(COUNTER_EMPTY_ITEMS)),
                items_empty: work(COUNTER_EMPTY_ITEMS),
                tiles_past_capacity: counters[COUNTER_PAST_CAPACITY] as u64,
                evaluation_occupancy: match warp_steps {
                    0 => 0.0,
                    steps => evaluations as f64 / (32 * steps) as f64,
                },
                rounds: counters[COUNTER_ROUNDS_RECORDED],
                tile_rounds,
                deepest_pixel: deepest,
                unfinished_pixels: unfinished,
                longest_list,
                list_bytes: list_bytes(recorded.capacity, tiles, self.state_pixels(), self.samples),
            })),
            compute_raster: Some(report.stats),
            ..Default::default()
        }
    }

    fn resources(&self) -> Vec<&ResourceCache> {
        vec![&self.cache, self.raster.resources()]
    }
}

#[cfg(test)]
mod tests;
