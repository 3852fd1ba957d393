#define_import_path strata::raster::items
#import strata::raster::params::{RasterParams}

// The work items the bin stage wrote, as every stage after it reads them: the rasterizer's
// bindings at group RASTER_GROUP (the scene's vertices, binding 3, are setup.wgsl's) and an
// item's decoding.

@group(#{RASTER_GROUP}) @binding(0) var<uniform> rp: RasterParams;
@group(#{RASTER_GROUP}) @binding(1) var<storage, read> items: array<u32>;
@group(#{RASTER_GROUP}) @binding(2) var<storage, read> raster_counters: array<u32>;

// A fan triangle of a primitive's clipped polygon, and one 8×8-pixel tile its bounds meet.
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
    let code = items[2u * index + 1u];
    return Item(items[2u * index], code & 7u, vec2<i32>(vec2<u32>((code >> 3u) & 0x3fffu, code >> 17u)));
}

// The item a thread of an indirect dispatch over the items owns (64-wide workgroups in a
// grid args.wgsl sized).
fn item_thread(id: vec3<u32>, groups: vec3<u32>) -> u32 {
    return id.x + id.y * groups.x * 64u;
}
