#define_import_path strata::tiled::sort
#import strata::raster::items::{ITEM_WORDS, Item, item_at, item_thread, items, items_written, rp}
#import strata::raster::records::{recorded_triangle, records_written}
#import strata::tiled::samples::{tile_samples_coverage}
#import strata::tiled::constants::{COUNTER_EMPTY_ITEMS}
#import strata::tiled::lists::{add_tile_work, item_mask, set_tile_order, tile_codes, tile_counts, tile_of, tile_starts, tile_work, tp, work_add}

// Sorts the rasterizer's work items into one list per tile: the count pass computes each
// item's coverage once — the 64-bit mask of the tile's pixel centers its set-up triangle (the
// bin's record) covers, by the raster stage's rule — stores it in the item and counts the items
// that cover a center per tile; an exclusive prefix sum over the tiles; the scatter lists
// those items' indices. An item that covers no center is dropped before it is counted. The
// order inside a list is the scatter's arrival order; nothing depends on it, as the tile pass
// orders each pixel's fragments by (depth, primitive).

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
    // `prim` names the item's setup record.
    return ListedItem(item, tile, tile < tp.tiles && item.prim < records_written());
}

// Covered pixel centers summed per workgroup: one atomic per workgroup on the frame's counter.
var<workgroup> empty_items: atomic<u32>;

@compute @workgroup_size(64)
fn cs_count(
    @builtin(global_invocation_id) id: vec3<u32>,
    @builtin(num_workgroups) groups: vec3<u32>,
    @builtin(local_invocation_index) lid: u32,
) {
    if lid == 0u {
        atomicStore(&empty_items, 0u);
    }
    workgroupBarrier();
    let listed = listed_item(id, groups);
    var mask = vec2<u32>(0u);
    if listed.valid {
        mask = tile_samples_coverage(recorded_triangle(listed.item.prim).t, listed.item.tile);
        if any(mask != vec2<u32>(0u)) {
            atomicAdd(&tile_counts[listed.tile], 1u);
            add_tile_work(listed.tile, countOneBits(mask.x) + countOneBits(mask.y));
        } else {
            atomicAdd(&empty_items, 1u);
        }
    }
    if item_thread(id, groups) < items_written() {
        let at = ITEM_WORDS * item_thread(id, groups);
        items[at + 2u] = mask.x;
        items[at + 3u] = mask.y;
    }
    workgroupBarrier();
    if lid == 0u {
        work_add(COUNTER_EMPTY_ITEMS, atomicLoad(&empty_items));
    }
}

// The scan's one workgroup: as many threads as the device runs in one (at most 1024: the
// serial loops over each thread's run of tiles set its time), a power of two.
const SCAN_THREADS: u32 = #{SCAN_THREADS}u;
var<workgroup> partial: array<u32, SCAN_THREADS>;
// Tiles by their work's power of two (class c: work in [2^(c−1), 2^c), class 0: none), and where
// each class starts in the order, most work first.
const WORK_CLASSES: u32 = 16u;
var<workgroup> class_counts: array<atomic<u32>, WORK_CLASSES>;
var<workgroup> class_starts: array<u32, WORK_CLASSES>;

fn work_class(work: u32) -> u32 {
    return min(WORK_CLASSES - 1u, select(0u, firstLeadingBit(work) + 1u, work > 0u));
}

// One workgroup: each thread sums a run of consecutive tiles and counts them by work class, the
// runs' sums are scanned in workgroup memory (the classes' starts meanwhile, most work first),
// and each thread writes its run's starts, zeroes its counts and places its tiles in the order
// the one-pass kernel's workgroups take them (within a class in any order): the heaviest tiles
// start first instead of setting the frame's end. Which workgroup takes which tile changes no
// byte of the frame. Two passes over the tiles in all.
@compute @workgroup_size(#{SCAN_THREADS})
fn cs_scan(@builtin(local_invocation_index) lid: u32) {
    if lid < WORK_CLASSES {
        atomicStore(&class_counts[lid], 0u);
    }
    workgroupBarrier();
    let run = (tp.tiles + SCAN_THREADS - 1u) / SCAN_THREADS;
    let first = lid * run;
    let last = min(first + run, tp.tiles);
    var sum = 0u;
    for (var t = first; t < last; t++) {
        sum += atomicLoad(&tile_counts[t]);
        atomicAdd(&class_counts[work_class(tile_work(t))], 1u);
    }
    partial[lid] = sum;
    workgroupBarrier();
    if lid == 0u {
        var start = 0u;
        for (var c = WORK_CLASSES; c > 0u; c--) {
            class_starts[c - 1u] = start;
            start += atomicLoad(&class_counts[c - 1u]);
            atomicStore(&class_counts[c - 1u], 0u);
        }
    }
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
        let c = work_class(tile_work(t));
        set_tile_order(class_starts[c] + atomicAdd(&class_counts[c], 1u), t);
    }
}

@compute @workgroup_size(64)
fn cs_scatter(@builtin(global_invocation_id) id: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let listed = listed_item(id, groups);
    let index = item_thread(id, groups);
    // Only the items the count pass counted: valid, and covering a pixel center.
    if !listed.valid || all(item_mask(index) == vec2<u32>(0u)) {
        return;
    }
    let tile = listed.tile;
    // The count pass saw this item, so the tile's list has room for it.
    let slot = tile_starts[tile] + atomicAdd(&tile_counts[tile], 1u);
    if slot >= tp.capacity {
        return;
    }
    tile_codes[slot] = index;
}
