#define_import_path strata::raster::raster
#import strata::scene::{behind_opaque}
#import strata::raster::capture::{raster_capture}
#import strata::raster::items::{item_at, item_thread, items_written, rp}
#import strata::raster::setup::{HALF_SUBPIXEL, TILE, clipped_triangle, edge_value, fan_triangle, oriented_edges, varying_at, wide_add, wide_mul, wide_negative, wide_zero}

// Raster stage of the compute rasterizer: one thread per work item (a fan triangle and an
// 8×8-pixel tile) sets the triangle up again, tests the tile's pixel centers against its edges,
// interpolates what `vs_scene` passes the fragment stage and hands each covered fragment in
// front of the opaque depth to the method's capture, `raster_capture` (the module
// strata::raster::capture, made per method). The bindings' group is the one after the method's
// groups (the definition RASTER_GROUP).

@compute @workgroup_size(64)
fn cs_raster(@builtin(global_invocation_id) id: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let item = item_thread(id, groups);
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
    let lo = max(t.min, tile * TILE);
    let hi = min(t.max, tile * TILE + vec2<i32>(TILE - 1));
    if any(lo > hi) {
        return;
    }
    let front_facing = wide_negative(t.doubled_area);
    let edges = oriented_edges(t);
    var edge: array<vec2<u32>, 3>;
    var step_x: array<vec2<u32>, 3>;
    var step_y: array<vec2<u32>, 3>;
    let start = vec2<i32>(lo * 256 + vec2<i32>(HALF_SUBPIXEL));
    for (var i = 0u; i < 3u; i++) {
        let d = edges.delta[i];
        // Stepped by whole pixels from the first center: exact, so equal to `edge_value` there.
        edge[i] = edge_value(edges, i, start);
        step_x[i] = wide_mul(-d.y, 256);
        step_y[i] = wide_mul(d.x, 256);
    }
    for (var y = lo.y; y <= hi.y; y++) {
        var row = edge;
        for (var x = lo.x; x <= hi.x; x++) {
            var inside = true;
            for (var i = 0u; i < 3u; i++) {
                if wide_negative(row[i]) || (edges.strict[i] && wide_zero(row[i])) {
                    inside = false;
                }
                row[i] = wide_add(row[i], step_x[i]);
            }
            if !inside {
                continue;
            }
            let v = varying_at(t, prim, vec2<i32>(x, y));
            // The GPU path clips at the far plane and tests the opaque depth with LESS.
            if v.position.z > 1.0 || behind_opaque(v.position) {
                continue;
            }
            raster_capture(v, front_facing);
        }
        for (var i = 0u; i < 3u; i++) {
            edge[i] = wide_add(edge[i], step_y[i]);
        }
    }
}
