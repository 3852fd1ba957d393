#define_import_path strata::tiled::lists
#import strata::color::{Resolved}

// tiled's bindings (group 1): each 8×8-pixel tile's list of (primitive, fan triangle) codes,
// the counters the frame reads back, and the resolved output.

// Keep in sync with `TiledParams` in crates/strata/src/methods/tiled/mod.rs.
struct TiledParams {
    tiles_x: u32,
    tiles: u32,
    // Codes the list buffer holds (the rasterizer's item capacity).
    capacity: u32,
    _pad: u32,
}

@group(1) @binding(0) var<uniform> tp: TiledParams;
// Items per tile: counted, then (after the scan set them to zero) counted again as the scatter
// fills each list, ending equal to the count.
@group(1) @binding(1) var<storage, read_write> tile_counts: array<atomic<u32>>;
// Where each tile's list starts in `tile_codes`.
@group(1) @binding(2) var<storage, read_write> tile_starts: array<u32>;
// primitive << 3 | fan triangle, grouped by tile.
@group(1) @binding(3) var<storage, read_write> tile_codes: array<u32>;
// Keep the COUNTER_ indices in sync with mod.rs.
@group(1) @binding(4) var<storage, read_write> tiled_counters: array<atomic<u32>>;
// Each pixel's result.
@group(1) @binding(5) var<storage, read_write> output: array<Resolved>;

// Tiles by the rounds their tile pass ran: bin r for r rounds, the last bin for ROUND_BINS − 1
// or more (a tile without items runs none).
const COUNTER_ROUNDS: u32 = 0u;
const ROUND_BINS: u32 = 16u;
// The most fragments one pixel had.
const COUNTER_DEEPEST: u32 = 16u;
const COUNTER_WORDS: u32 = 17u;

fn tile_of(tile: vec2<i32>) -> u32 {
    return u32(tile.y) * tp.tiles_x + u32(tile.x);
}
