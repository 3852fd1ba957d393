#define_import_path strata::tiled::lists
#import strata::raster::items::{ITEM_WORDS, items}
#import strata::raster::records::{records_written}
#import strata::tiled::params::{TiledParams}
#import strata::color::{Resolved}
#import strata::composite::{Composite, composite_new, view_distance}
#import strata::tail::{TailParams}

// tiled's bindings (group 1): each 8×8-pixel tile's list of (primitive, fan triangle) codes,
// each pixel's compositing state between rounds, the counters the frame reads back, and the
// resolved output.

@group(1) @binding(0) var<uniform> tp: TiledParams;
// Items per tile: counted, then (after the scan set them to zero) counted again as the scatter
// fills each list, ending equal to the count. After the tiles' counts (at tp.tiles + tile):
// each tile's work, the pixel centers its items cover (`tile_work`).
@group(1) @binding(1) var<storage, read_write> tile_counts: array<atomic<u32>>;
// Where each tile's list starts in `tile_codes`; after the starts (at tp.tiles + i), the order
// the one-pass kernel's workgroups take the tiles in, most work first (`tile_in_order`).
@group(1) @binding(2) var<storage, read_write> tile_starts: array<u32>;
// The items that cover a pixel center of their tile, grouped by tile: each item's index in the
// rasterizer's items (which hold its setup record and its coverage).
@group(1) @binding(3) var<storage, read_write> tile_codes: array<u32>;
// Counter words at the COUNTER_ indices (strata::tiled::constants).
@group(1) @binding(4) var<storage, read_write> tiled_counters: array<atomic<u32>>;
// Each pixel's result.
@group(1) @binding(5) var<storage, read_write> output: array<Resolved>;
// Each pixel's progress word (the first tp.pixels words; all zero, FRESH, before the one-pass
// kernel), then its compositing state, tp.state_words words, valid where the progress says a
// round left fragments to composite (only the progress words are cleared). Single-sampled the
// state is one composite; multisampled (`samples.wgsl`) the bound and account of the pixel's
// rounds and a composite per sample.
@group(1) @binding(6) var<storage, read_write> pixel_state: array<u32>;
// Rounds each tile ran.
@group(1) @binding(7) var<storage, read_write> tile_rounds: array<u32>;

// A pixel's state: the front-to-back composite so far (color, RGB transmittance, count, the
// last fragment's depth and tag: the bound of the next round; its view distance is recomputed
// from the depth) and its progress.
// Progress: nothing composited yet, done (its result is the state's, which `cs_finish`
// resolves), resolved (the one-pass kernel wrote its result and accounted for it: the rounds
// and `cs_finish` pass it by), or 3 + the fragments left behind the last one composited.
const PROGRESS_FRESH: u32 = 0u;
const PROGRESS_DONE: u32 = 1u;
const PROGRESS_RESOLVED: u32 = 2u;
const PROGRESS_LEFT: u32 = 3u;

struct PixelState {
    s: Composite,
    progress: u32,
}

fn state_float(w: u32) -> f32 {
    return bitcast<f32>(pixel_state[w]);
}

fn progress_of(p: u32) -> u32 {
    return pixel_state[p];
}

fn set_progress(p: u32, progress: u32) {
    pixel_state[p] = progress;
}

// Where pixel p's state words start, after every pixel's progress word.
fn state_at(p: u32) -> u32 {
    return tp.pixels + p * tp.state_words;
}

// Words of a composite in the state.
const COMPOSITE_WORDS: u32 = 9u;

// The composite stored at word w of the state (its view distance recomputed from its depth).
fn load_composite(w: u32) -> Composite {
    let depth = state_float(w + 7u);
    return Composite(
        vec3<f32>(state_float(w), state_float(w + 1u), state_float(w + 2u)),
        pixel_state[w + 6u],
        vec3<f32>(state_float(w + 3u), state_float(w + 4u), state_float(w + 5u)),
        pixel_state[w + 8u],
        depth,
        view_distance(depth),
    );
}

fn store_composite(w: u32, s: Composite) {
    pixel_state[w] = bitcast<u32>(s.color.r);
    pixel_state[w + 1u] = bitcast<u32>(s.color.g);
    pixel_state[w + 2u] = bitcast<u32>(s.color.b);
    pixel_state[w + 3u] = bitcast<u32>(s.transmittance.r);
    pixel_state[w + 4u] = bitcast<u32>(s.transmittance.g);
    pixel_state[w + 5u] = bitcast<u32>(s.transmittance.b);
    pixel_state[w + 6u] = s.count;
    pixel_state[w + 7u] = bitcast<u32>(s.last_depth);
    pixel_state[w + 8u] = s.last_tag;
}

fn load_state(p: u32) -> PixelState {
    let progress = progress_of(p);
    if progress == PROGRESS_FRESH || progress == PROGRESS_RESOLVED {
        return PixelState(composite_new(), progress);
    }
    return PixelState(load_composite(state_at(p)), progress);
}

fn store_state(p: u32, state: PixelState) {
    store_composite(state_at(p), state.s);
    set_progress(p, state.progress);
}

// Fragments left behind the last one composited.
fn fragments_left(progress: u32) -> u32 {
    return select(0u, progress - PROGRESS_LEFT, progress >= PROGRESS_LEFT);
}

// Adds `n` to the 64-bit work counter at words (at, at + 1): the low word carries into the
// high one, so counts of a large frame never wrap.
fn work_add(at: u32, n: u32) {
    if n == 0u {
        return;
    }
    let old = atomicAdd(&tiled_counters[at], n);
    if old > 0xffffffffu - n {
        atomicAdd(&tiled_counters[at + 1u], 1u);
    }
}

// The pixel centers of its tile that item `item` covers (the count pass's mask: bit y·8 + x,
// low word first).
fn item_mask(item: u32) -> vec2<u32> {
    let at = ITEM_WORDS * item;
    return vec2<u32>(items[at + 2u], items[at + 3u]);
}

// A list entry: its triangle's setup record, and the tile's pixel centers it covers within
// `region` (none where the entry names no item or record: poisoned or stale memory).
struct ListEntry {
    setup: u32,
    mask: vec2<u32>,
}

fn list_entry(index: u32, region: vec2<u32>) -> ListEntry {
    let item = tile_codes[index];
    if item >= tp.capacity {
        return ListEntry(0u, vec2<u32>(0u));
    }
    let setup = items[ITEM_WORDS * item];
    var mask = item_mask(item) & region;
    if setup >= records_written() {
        mask = vec2<u32>(0u);
    }
    return ListEntry(setup, mask);
}

// The frame's tail parameters (--tail with --k; mode 0 without).
fn tiled_tail() -> TailParams {
    return TailParams(tp.tail_mode, tp.tail_weight, tp.tail_depth_p, tp.tail_depth_q);
}

// Adds `centers` covered pixel centers to tile `tile`'s work.
fn add_tile_work(tile: u32, centers: u32) {
    atomicAdd(&tile_counts[tp.tiles + tile], centers);
}

fn tile_work(tile: u32) -> u32 {
    return atomicLoad(&tile_counts[tp.tiles + tile]);
}

// The tile the i-th workgroup of the one-pass kernel takes.
fn tile_in_order(i: u32) -> u32 {
    return tile_starts[tp.tiles + i];
}

fn set_tile_order(i: u32, tile: u32) {
    tile_starts[tp.tiles + i] = tile;
}

fn tile_of(tile: vec2<i32>) -> u32 {
    return u32(tile.y) * tp.tiles_x + u32(tile.x);
}
