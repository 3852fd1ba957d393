//! `tiled`: exact transparency in compute, each 8×8-pixel tile's fragments sorted inside one
//! workgroup, with no per-pixel global atomics and no locks — race-free by construction.
//!
//! Passes (all compute; the scene's triangles are read from its vertex buffer):
//! - **bin** (the compute rasterizer's, [`crate::raster`]): each triangle is transformed,
//!   clipped and snapped; every (fan triangle, 8×8 tile its bounds meet) pair becomes a work
//!   item. The item buffer is sized from the last frame's need; after an overflow it grows, the
//!   frame reports itself incomplete and exact mode renders it again.
//! - **count**, **scan**, **scatter**: the items are counted per tile, the counts scanned (one
//!   workgroup) into list starts, and each item's (primitive, fan triangle) code is scattered
//!   into its tile's list.
//! - **tile** (one workgroup of 64 threads per tile, a thread per pixel): the tile's list is
//!   walked in chunks of 64 triangles, set up once per chunk in workgroup memory; each thread
//!   keeps its pixel's 16 nearest fragments behind a bound in registers, sorted by (depth,
//!   primitive), and composites them front to back at the end of the round. A pixel with more
//!   sets its bound to the last fragment it composited and the tile walks its list again, so
//!   only deep tiles pay more rounds (⌈f/16⌉ for a tile whose deepest pixel has f fragments),
//!   nothing is lost at equal depths, and the result is exact at any depth complexity. The
//!   resolved pixel is written directly. Coverage, depth and attributes are the compute
//!   rasterizer's (`strata::raster::setup`), so its pictures equal the other compute-rasterized
//!   exact methods' bit for bit.
//!
//! Deterministic: a pixel's fragments are composited in (depth, primitive) order whatever the
//! order the scatter filled a list in, so a frame gives the same bytes every run.
//!
//! Memory: the rasterizer's 8 bytes per item and 48 of constants, 4 bytes per item for the tile
//! lists, 8 per tile (count, start), 68 of counters and 16 of parameters. Limits: triangles
//! < 2²⁹ (a list code holds the primitive and 3 bits of fan triangle); `--msaa`, temporal culling,
//! `--order` and an application's draw callback are not supported (it reads the scene's
//! triangles itself).

pub mod descriptor;

use bytemuck::{Pod, Zeroable};

use crate::error::{Error, Result};
use crate::frame::passes::{compute_pipeline, dispatch};
use crate::frame::{FrameContext, MethodStats, Recorded, SceneGpu, TiledStats, Totals};
use crate::gpu::binding::{self, Slot};
use crate::gpu::shader::{Defs, Library, Stage};
use crate::gpu::{Gpu, ResourceCache};
use crate::methods::Method;
use crate::raster::{ComputeRaster, TILE};

/// tiled's WGSL modules (`strata::tiled::…`): its bindings, the list sort and the tile pass.
pub const LIBRARY: Library = &[LISTS_WGSL, SORT_WGSL, TILE_WGSL];
const LISTS_WGSL: &str = include_str!("lists.wgsl");
const SORT_WGSL: &str = include_str!("sort.wgsl");
const TILE_WGSL: &str = include_str!("tile.wgsl");

/// Fragments a pixel keeps per round (KEEP in tile.wgsl).
pub const KEEP: u32 = 16;
/// Bytes of one list code.
pub const CODE_BYTES: u64 = 4;
/// Bytes per tile: its item count and its list's start.
pub const TILE_BYTES: u64 = 8;
/// Counter words (COUNTER_ in lists.wgsl): tiles by rounds, then the deepest pixel.
pub const COUNTER_WORDS: u64 = 17;
const ROUND_BINS: usize = 16;
const COUNTER_DEEPEST: usize = 16;
/// The most triangles a list code can name.
pub const MAX_TRIANGLES: u32 = 1 << 29;

/// Keep in sync with `TiledParams` in lists.wgsl.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable, PartialEq)]
pub struct TiledParams {
    /// Tiles per row.
    pub tiles_x: u32,
    /// Tiles of the viewport.
    pub tiles: u32,
    /// Codes the list buffer holds.
    pub capacity: u32,
    /// Padding to 16 bytes.
    pub _pad: u32,
}

/// The stages, with the rasterizer's bindings in group 2 (after the frame's and tiled's).
pub fn stage(label: &str, source: &'static str) -> Stage {
    Stage::new(label, source)
        .with(crate::raster::LIBRARY)
        .with(LIBRARY)
        .defs(&Defs::default().value("RASTER_GROUP", 2))
}

/// The list sort's stage (entries `cs_count`, `cs_scan`, `cs_scatter`).
pub fn sort_stage() -> Stage {
    stage("strata.tiled.sort", SORT_WGSL)
}

/// The tile pass's stage (entry `cs_tile`).
pub fn tile_stage() -> Stage {
    stage("strata.tiled.tile", TILE_WGSL)
}

/// `tiled`'s pipelines, its rasterizer and its buffers.
pub struct Tiled {
    gpu: Gpu,
    raster: ComputeRaster,
    layout: wgpu::BindGroupLayout,
    count: wgpu::ComputePipeline,
    scan: wgpu::ComputePipeline,
    scatter: wgpu::ComputePipeline,
    tile: wgpu::ComputePipeline,
    cache: ResourceCache,
}

impl Tiled {
    /// The pipelines for `scene`.
    pub fn new(
        gpu: &Gpu,
        scene: &SceneGpu,
        options: &crate::frame::RenderOptions,
    ) -> Result<Tiled> {
        if scene.triangle_count >= MAX_TRIANGLES {
            return Err(Error::unsupported(format!(
                "tiled takes fewer than {MAX_TRIANGLES} triangles (a tile list's code holds the primitive in 29 bits); the scene has {}",
                scene.triangle_count
            )));
        }
        let layout = binding::layout(
            &gpu.device,
            "strata.tiled.layout",
            &[
                Slot::Uniform,
                Slot::StorageRw,
                Slot::StorageRw,
                Slot::StorageRw,
                Slot::StorageRw,
                Slot::StorageRw,
            ],
        );
        let raster_layout = crate::raster::raster_layout(gpu);
        let layouts = [&scene.frame_layout, &layout, &raster_layout];
        let sort = sort_stage().module(&gpu.device);
        let tile = tile_stage().module(&gpu.device);
        let pipeline = |label, module, entry| compute_pipeline(gpu, label, module, entry, &layouts);
        Ok(Tiled {
            gpu: gpu.clone(),
            raster: ComputeRaster::new(gpu, scene, options),
            count: pipeline("strata.tiled.count", &sort, "cs_count"),
            scan: pipeline("strata.tiled.scan", &sort, "cs_scan"),
            scatter: pipeline("strata.tiled.scatter", &sort, "cs_scatter"),
            tile: pipeline("strata.tiled.tile", &tile, "cs_tile"),
            layout,
            cache: ResourceCache::default(),
        })
    }
}

/// Bytes of the lists and tile words for `capacity` items and `tiles` tiles.
fn list_bytes(capacity: u64, tiles: u64) -> u64 {
    capacity * CODE_BYTES + tiles * TILE_BYTES
}

impl Method for Tiled {
    fn record(&mut self, ctx: &mut FrameContext<'_>) -> Result<Recorded> {
        let gpu = ctx.gpu;
        let (w, h) = ctx.size();
        let (tiles_x, tiles_y) = (w.div_ceil(TILE), h.div_ceil(TILE));
        let tiles = tiles_x as u64 * tiles_y as u64;
        self.raster.prepare(gpu, ctx.options, ctx.scene)?;
        let capacity = self.raster.frame_capacity();
        let bytes = self.raster.bytes()
            + list_bytes(capacity, tiles)
            + COUNTER_WORDS * 4
            + std::mem::size_of::<TiledParams>() as u64;
        ctx.check_budget(bytes)?;
        let params = TiledParams {
            tiles_x,
            tiles: tiles as u32,
            capacity: capacity as u32,
            _pad: 0,
        };
        let cache = &mut self.cache;
        let params = cache.uniform(gpu, "strata.tiled.params", bytemuck::bytes_of(&params));
        let none = wgpu::BufferUsages::empty();
        let counts = cache.storage(gpu, "strata.tiled.counts", tiles * 4, none)?;
        let starts = cache.storage(gpu, "strata.tiled.starts", tiles * 4, none)?;
        let codes = cache.storage(gpu, "strata.tiled.codes", capacity * CODE_BYTES, none)?;
        let counters = cache.storage(
            gpu,
            "strata.tiled.counters",
            COUNTER_WORDS * 4,
            wgpu::BufferUsages::COPY_SRC,
        )?;
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
            ],
        );
        ctx.encoder.clear_buffer(&counts, 0, None);
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
        dispatch(
            ctx,
            "tile",
            &self.tile,
            &[frame_group, &group, &raster_group],
            (tiles_x, tiles_y),
        );
        self.raster.read_counters(ctx.readback);
        ctx.readback.words(&counters, 0, COUNTER_WORDS);
        Ok(Recorded {
            capacity,
            ..Recorded::passes(1, bytes)
        })
    }

    fn stats(&mut self, recorded: &Recorded, _: &Totals, words: &[u32]) -> MethodStats {
        let raster_words = crate::raster::COUNTER_WORDS as usize;
        let report = self
            .raster
            .feedback(&self.gpu, &words[..raster_words], recorded.capacity);
        let counters = &words[raster_words..raster_words + COUNTER_WORDS as usize];
        let mut tile_rounds: Vec<u64> = counters[..ROUND_BINS].iter().map(|&n| n as u64).collect();
        while tile_rounds.len() > 1 && tile_rounds.last() == Some(&0) {
            tile_rounds.pop();
        }
        let tiles = self
            .cache
            .get("strata.tiled.counts")
            .map_or(0, |b| b.size() / 4);
        MethodStats {
            overflow: Some(report.stats.overflow),
            incomplete: report.incomplete,
            cannot_complete: report.cannot_complete,
            tiled: Some(TiledStats {
                tile_rounds,
                deepest_pixel: counters[COUNTER_DEEPEST],
                list_bytes: list_bytes(recorded.capacity, tiles),
            }),
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
