#define_import_path strata::raster::bin
#import strata::raster::setup::{MAX_CORNERS, TILE, clipped_triangle, fan_triangle}
#import strata::raster::params::{RasterParams}

// Bin stage of the compute rasterizer: one thread per triangle sets it up and appends one work
// item per 8×8-pixel tile its clipped triangles' bounding boxes touch, so that no thread of the
// raster stage walks more than 64 pixels, however large the triangle.

@group(1) @binding(0) var<uniform> rp: RasterParams;
// Two words per item: the primitive, then fan triangle | tile x << 3 | tile y << 17.
@group(1) @binding(1) var<storage, read_write> items: array<u32>;
// Keep the COUNTER_ indices in sync with `ComputeRaster` in mod.rs.
@group(1) @binding(2) var<storage, read_write> raster_counters: array<atomic<u32>>;

const COUNTER_ITEMS: u32 = 0u;
const COUNTER_TRIANGLES: u32 = 2u;

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
    var set_up = 0u;
    for (var j = 0u; j + 2u < min(polygon.count, MAX_CORNERS); j++) {
        let t = fan_triangle(polygon, j);
        if !t.valid {
            continue;
        }
        set_up += 1u;
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
            items[2u * at] = prim;
            items[2u * at + 1u] = j | (tile.x << 3u) | (tile.y << 17u);
        }
    }
    if set_up > 0u {
        reserve(COUNTER_TRIANGLES, set_up);
    }
}
