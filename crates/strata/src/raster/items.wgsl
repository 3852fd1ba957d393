#define_import_path strata::raster::items
#import strata::raster::params::{RasterParams}

// The work items the bin stage wrote, as every stage after it reads them: the rasterizer's
// bindings at group RASTER_GROUP (the scene's vertices, binding 3, are setup.wgsl's; the setup
// records, binding 4, records.wgsl's) and an item's decoding.

@group(#{RASTER_GROUP}) @binding(0) var<uniform> rp: RasterParams;
#ifdef SETUP_RECORDS
// Writable: a pass after the bin stores each item's coverage in its last two words.
@group(#{RASTER_GROUP}) @binding(1) var<storage, read_write> items: array<u32>;
#else
@group(#{RASTER_GROUP}) @binding(1) var<storage, read> items: array<u32>;
#endif
@group(#{RASTER_GROUP}) @binding(2) var<storage, read> raster_counters: array<u32>;

const ITEM_WORDS: u32 = #{ITEM_WORDS}u;

// A fan triangle of a primitive's clipped polygon (with SETUP_RECORDS: its setup record, `prim`
// naming the record), and one 8×8-pixel tile its bounds meet.
struct Item {
    prim: u32,
    fan: u32,
    tile: vec2<i32>,
}

// Items written this frame that the buffer holds (the rest overflowed and are reported).
fn items_written() -> u32 {
    let written = raster_counters[0];
    if raster_counters[1] != 0u || written > rp.capacity {
        return rp.capacity;
    }
    return written;
}

fn item_at(index: u32) -> Item {
    let code = items[ITEM_WORDS * index + 1u];
    return Item(items[ITEM_WORDS * index], code & 7u, vec2<i32>(vec2<u32>((code >> 3u) & 0x3fffu, code >> 17u)));
}

// The item a thread of an indirect dispatch over the items owns (64-wide workgroups in a
// grid args.wgsl sized).
fn item_thread(id: vec3<u32>, groups: vec3<u32>) -> u32 {
    return id.x + id.y * groups.x * 64u;
}
