#define_import_path strata::tiled::sort
#import strata::raster::items::{Item, item_at, item_thread, items_written, rp}
#import strata::raster::setup::{clipped_triangle, fan_triangle, tile_coverage}
#import strata::tiled::constants::{CODE_WORDS, COUNTER_EMPTY_ITEMS, COUNTER_SETUPS}
#import strata::tiled::lists::{tile_codes, tile_counts, tile_of, tile_starts, tp, work_add}

// Sorts the rasterizer's work items into one list per tile: a count per tile, an exclusive
// prefix sum over the tiles, a scatter that stores each item's code with the 64-bit mask of the
// tile's pixel centers its triangle covers (the raster stage's rule, evaluated once here so
// that the tile pass tests a bit per pixel). The order inside a list is the scatter's arrival order;
// nothing depends on it, as the tile pass orders each pixel's fragments by (depth, primitive).

// The work item a thread of the count and scatter passes owns, and its tile's index; `valid`
// is false past the items written or for an item no tile list takes.
struct ListedItem {
    item: Item,
    tile: u32,
    valid: bool,
}

fn listed_item(id: vec3<u32>, groups: vec3<u32>) -> ListedItem {
    let index = item_thread(id, groups);
    if index >= items_written() {
        return ListedItem(Item(0u, 0u, vec2<i32>(0)), 0u, false);
    }
    let item = item_at(index);
    let tile = tile_of(item.tile);
    return ListedItem(item, tile, tile < tp.tiles && item.prim < rp.triangles);
}

@compute @workgroup_size(64)
fn cs_count(@builtin(global_invocation_id) id: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let listed = listed_item(id, groups);
    if listed.valid {
        atomicAdd(&tile_counts[listed.tile], 1u);
    }
}

const SCAN_THREADS: u32 = 256u;
var<workgroup> partial: array<u32, SCAN_THREADS>;

// One workgroup: each thread sums a run of consecutive tiles, the runs' sums are scanned in
// workgroup memory, and each thread writes its run's starts and zeroes its counts.
@compute @workgroup_size(256)
fn cs_scan(@builtin(local_invocation_index) lid: u32) {
    let run = (tp.tiles + SCAN_THREADS - 1u) / SCAN_THREADS;
    let first = lid * run;
    let last = min(first + run, tp.tiles);
    var sum = 0u;
    for (var t = first; t < last; t++) {
        sum += atomicLoad(&tile_counts[t]);
    }
    partial[lid] = sum;
    workgroupBarrier();
    for (var step = 1u; step < SCAN_THREADS; step <<= 1u) {
        var before = 0u;
        if lid >= step {
            before = partial[lid - step];
        }
        workgroupBarrier();
        partial[lid] += before;
        workgroupBarrier();
    }
    var at = partial[lid] - sum;
    for (var t = first; t < last; t++) {
        let count = atomicLoad(&tile_counts[t]);
        tile_starts[t] = at;
        at += count;
        atomicStore(&tile_counts[t], 0u);
    }
}

@compute @workgroup_size(64)
fn cs_scatter(@builtin(global_invocation_id) id: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let listed = listed_item(id, groups);
    if !listed.valid {
        return;
    }
    let item = listed.item;
    let tile = listed.tile;
    // The count pass saw this item, so the tile's list has room for it.
    let slot = tile_starts[tile] + atomicAdd(&tile_counts[tile], 1u);
    if slot >= tp.capacity {
        return;
    }
    let mask = tile_coverage(fan_triangle(clipped_triangle(item.prim, rp.guard), item.fan), item.tile);
    work_add(COUNTER_SETUPS, 1u);
    if all(mask == vec2<u32>(0u)) {
        work_add(COUNTER_EMPTY_ITEMS, 1u);
    }
    let at = slot * CODE_WORDS;
    tile_codes[at] = (item.prim << 3u) | item.fan;
    tile_codes[at + 1u] = mask.x;
    tile_codes[at + 2u] = mask.y;
}
