#define_import_path strata::raster::bin
#import strata::raster::setup::{MAX_CORNERS, SETUP_RECORD_WORDS, TILE, clipped_triangle, fan_triangle, setup_record}
#import strata::raster::params::{RasterParams}

// Bin stage of the compute rasterizer: one thread per triangle sets it up and appends one work
// item per 8×8-pixel tile its clipped triangles' bounding boxes touch, so that no thread of the
// raster stage walks more than 64 pixels, however large the triangle. With SETUP_RECORDS
// (tiled) each set-up fan triangle is also stored as a record, and its items name the record
// instead of the primitive: the passes after the bin read the setup instead of redoing it.

@group(1) @binding(0) var<uniform> rp: RasterParams;
// ITEM_WORDS words per item: the primitive (or, with SETUP_RECORDS, the setup record), then
// fan triangle | tile x << 3 | tile y << 17; with SETUP_RECORDS two more words, the tile's
// covered pixel centers, which a later pass fills in.
@group(1) @binding(1) var<storage, read_write> items: array<u32>;
// Keep the COUNTER_ indices in sync with `ComputeRaster` in mod.rs.
@group(1) @binding(2) var<storage, read_write> raster_counters: array<atomic<u32>>;
#ifdef SETUP_RECORDS
// SETUP_RECORD_WORDS words per set-up fan triangle (`setup_record`), rp.setup_capacity of them.
@group(1) @binding(4) var<storage, read_write> setup_records: array<u32>;
#endif

const COUNTER_ITEMS: u32 = 0u;
const COUNTER_TRIANGLES: u32 = 2u;
const ITEM_WORDS: u32 = #{ITEM_WORDS}u;

// Adds n to the 64-bit counter at (at, at + 1); returns the low word before the add and whether
// it wrapped (the items it reserved are then not written: the frame reports the overflow).
fn reserve(at: u32, n: u32) -> vec2<u32> {
    let old = atomicAdd(&raster_counters[at], n);
    let wrapped = old > 0xffffffffu - n;
    if wrapped {
        atomicAdd(&raster_counters[at + 1u], 1u);
    }
    return vec2<u32>(old, select(0u, 1u, wrapped));
}

@compute @workgroup_size(64)
fn cs_bin(@builtin(global_invocation_id) id: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let draw = id.x + id.y * groups.x * 64u;
    if draw >= rp.triangles {
        return;
    }
    let prim = draw;
    let polygon = clipped_triangle(prim, rp.guard);
    for (var j = 0u; j + 2u < min(polygon.count, MAX_CORNERS); j++) {
        let t = fan_triangle(polygon, j);
        if !t.valid {
            continue;
        }
        // Every set-up fan triangle is counted (the records' need); one without a record (past
        // the buffer: the frame reports the overflow) lists no items.
        let setup = reserve(COUNTER_TRIANGLES, 1u);
        var named = prim;
#ifdef SETUP_RECORDS
        if setup.y != 0u || atomicLoad(&raster_counters[COUNTER_TRIANGLES + 1u]) != 0u || setup.x >= rp.setup_capacity {
            continue;
        }
        let record = setup_record(prim, t);
        for (var w = 0u; w < SETUP_RECORD_WORDS; w++) {
            setup_records[setup.x * SETUP_RECORD_WORDS + w] = record[w];
        }
        named = setup.x;
#endif
        let first = t.min / TILE;
        let last = t.max / TILE;
        let span = vec2<u32>(last - first + vec2<i32>(1));
        let n = span.x * span.y;
        let start = reserve(COUNTER_ITEMS, n);
        if start.y != 0u || atomicLoad(&raster_counters[COUNTER_ITEMS + 1u]) != 0u {
            continue;
        }
        // Bounded by the viewport's tiles.
        for (var k = 0u; k < n; k++) {
            let at = start.x + k;
            if at >= rp.capacity {
                break;
            }
            let tile = vec2<u32>(first) + vec2<u32>(k % span.x, k / span.x);
            items[ITEM_WORDS * at] = named;
            items[ITEM_WORDS * at + 1u] = j | (tile.x << 3u) | (tile.y << 17u);
        }
    }
}
