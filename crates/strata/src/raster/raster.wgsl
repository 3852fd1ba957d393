#define_import_path strata::raster::raster
#import strata::scene::{behind_opaque}
#import strata::raster::capture::{raster_capture}
#import strata::raster::items::{item_at, items_written, rp}
#import strata::raster::setup::{clipped_triangle, fan_triangle, tile_coverage, tile_pixel, varying_at, wide_negative}

// Raster stage of the compute rasterizer: one thread per work item (a fan triangle and an
// 8×8-pixel tile) sets the triangle up again, tests the tile's pixel centers against its edges
// (`tile_coverage`),
// interpolates what `vs_scene` passes the fragment stage and hands each covered fragment in
// front of the opaque depth to the method's capture, `raster_capture` (the module
// strata::raster::capture, made per method). The bindings' group is the one after the method's
// groups (the definition RASTER_GROUP).

// A workgroup owns the 64 items args.wgsl counts it, however few invocations it has:
// RASTER_WORKGROUP is 64 except for ordered captures on lavapipe before Mesa 22.3.7, which
// needs workgroups of one SIMD vector (`gpu::ordered::workgroup_limit`); each invocation then
// rasterizes 64 / RASTER_WORKGROUP items, strided so that a workgroup's items stay the same.
@compute @workgroup_size(#{RASTER_WORKGROUP})
fn cs_raster(
    @builtin(workgroup_id) group: vec3<u32>,
    @builtin(local_invocation_index) lane: u32,
    @builtin(num_workgroups) groups: vec3<u32>,
) {
    let first = (group.x + group.y * groups.x) * 64u + lane;
    for (var i = 0u; i < 64u / #{RASTER_WORKGROUP}; i++) {
        rasterize_item(first + i * #{RASTER_WORKGROUP});
    }
}

// One work item: its fragments go to the method's capture.
fn rasterize_item(item: u32) {
    if item >= items_written() {
        return;
    }
    let work = item_at(item);
    let prim = work.prim;
    if prim >= rp.triangles {
        return;
    }
    let tile = work.tile;
    let t = fan_triangle(clipped_triangle(prim, rp.guard), work.fan);
    if !t.valid {
        return;
    }
    let front_facing = wide_negative(t.doubled_area);
    // Covered centers in row order, as the bits of the tile's mask.
    let mask = tile_coverage(t, tile);
    for (var word = 0u; word < 2u; word++) {
        var bits = mask[word];
        while bits != 0u {
            let bit = word * 32u + firstTrailingBit(bits);
            bits &= bits - 1u;
            let v = varying_at(t, prim, tile_pixel(tile, bit));
            // The GPU path clips at the far plane and tests the opaque depth with LESS.
            if v.position.z > 1.0 || behind_opaque(v.position) {
                continue;
            }
            raster_capture(v, front_facing);
        }
    }
}
