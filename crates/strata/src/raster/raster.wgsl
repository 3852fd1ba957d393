#define_import_path strata::raster::raster
#import strata::scene::{SceneVarying, behind_opaque, triangle_materials}
#import strata::raster::capture::{raster_capture}
#import strata::raster::setup::{HALF_SUBPIXEL, TILE, clipped_triangle, fan_triangle, scene_vertex, wide_add, wide_mul, wide_negate, wide_negative, wide_zero}

// Raster stage of the compute rasterizer: one thread per work item (a fan triangle and an
// 8×8-pixel tile) sets the triangle up again, tests the tile's pixel centers against its edges,
// interpolates what `vs_scene` passes the fragment stage and hands each covered fragment in
// front of the opaque depth to the method's capture, `raster_capture` (the module
// strata::raster::capture, made per method). The bindings' group is the one after the method's
// groups (the definition RASTER_GROUP).

// Keep in sync with `RasterParams` in crates/strata/src/raster/mod.rs.
struct RasterParams {
    triangles: u32,
    capacity: u32,
    guard: f32,
    _pad: u32,
}

@group(#{RASTER_GROUP}) @binding(0) var<uniform> rp: RasterParams;
@group(#{RASTER_GROUP}) @binding(1) var<storage, read> items: array<u32>;
@group(#{RASTER_GROUP}) @binding(2) var<storage, read> raster_counters: array<u32>;

@compute @workgroup_size(64)
fn cs_raster(@builtin(global_invocation_id) id: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let item = id.x + id.y * groups.x * 64u;
    var items_written = raster_counters[0];
    if raster_counters[1] != 0u || items_written > rp.capacity {
        items_written = rp.capacity;
    }
    if item >= items_written {
        return;
    }
    let prim = items[2u * item];
    let code = items[2u * item + 1u];
    if prim >= rp.triangles {
        return;
    }
    let j = code & 7u;
    let tile = vec2<i32>(vec2<u32>((code >> 3u) & 0x3fffu, code >> 17u));
    let t = fan_triangle(clipped_triangle(prim, rp.guard), j);
    if !t.valid {
        return;
    }
    let lo = max(t.min, tile * TILE);
    let hi = min(t.max, tile * TILE + vec2<i32>(TILE - 1));
    if any(lo > hi) {
        return;
    }
    let front_facing = wide_negative(t.doubled_area);
    // Orient the edges so the interior is where all three edge functions are positive; a pixel
    // center exactly on an edge counts only for top edges (horizontal, interior below) and left
    // edges (going up the screen, y down): the others get a bias of −1.
    var order = array<u32, 3>(0u, 1u, 2u);
    if wide_negative(t.doubled_area) {
        order = array<u32, 3>(0u, 2u, 1u);
    }
    var corners = t.corners;
    var edge: array<vec2<u32>, 3>;
    var step_x: array<vec2<u32>, 3>;
    var step_y: array<vec2<u32>, 3>;
    var strict: array<bool, 3>;
    let start = vec2<i32>(lo * 256 + vec2<i32>(HALF_SUBPIXEL));
    for (var i = 0u; i < 3u; i++) {
        let a = corners[order[i]].snapped;
        let b = corners[order[(i + 1u) % 3u]].snapped;
        let d = b - a;
        strict[i] = !(d.y < 0 || (d.y == 0 && d.x > 0));
        // e(x, y) = dx·(y − ay) − dy·(x − ax), stepped by whole pixels.
        edge[i] = wide_add(wide_mul(d.x, start.y - a.y), wide_negate(wide_mul(d.y, start.x - a.x)));
        step_x[i] = wide_mul(-d.y, 256);
        step_y[i] = wide_mul(d.x, 256);
    }
    // Barycentric plane of the unsnapped window positions, relative to corner 0.
    let w0 = corners[0].window;
    let e1 = corners[1].window - w0;
    let e2 = corners[2].window - w0;
    let area = e1.x * e2.y - e2.x * e1.y;
    let v0 = scene_vertex(prim, 0u);
    let v1 = scene_vertex(prim, 1u);
    let v2 = scene_vertex(prim, 2u);
    for (var y = lo.y; y <= hi.y; y++) {
        var row = edge;
        for (var x = lo.x; x <= hi.x; x++) {
            var inside = true;
            for (var i = 0u; i < 3u; i++) {
                if wide_negative(row[i]) || (strict[i] && wide_zero(row[i])) {
                    inside = false;
                }
                row[i] = wide_add(row[i], step_x[i]);
            }
            if !inside {
                continue;
            }
            let p = vec2<f32>(f32(x) + 0.5, f32(y) + 0.5) - w0;
            let l1 = (p.x * e2.y - e2.x * p.y) / area;
            let l2 = (e1.x * p.y - p.x * e1.y) / area;
            let l = vec3<f32>(1.0 - l1 - l2, l1, l2);
            // A centre on a near-clipped edge can interpolate to just below 0 (or to -0.0), which
            // keys made of a depth's bits (kpeel, MDT, dual) would sort last; the GPU's path
            // clamps depth to the viewport's range, and so does this one.
            let interpolated = dot(l, vec3<f32>(corners[0].z, corners[1].z, corners[2].z));
            let depth = select(interpolated, 0.0, !(interpolated > 0.0));
            let pw = l * vec3<f32>(corners[0].inv_w, corners[1].inv_w, corners[2].inv_w);
            let inv_w = pw.x + pw.y + pw.z;
            let weights = (corners[0].weights * pw.x + corners[1].weights * pw.y + corners[2].weights * pw.z) / inv_w;
            var v: SceneVarying;
            v.position = vec4<f32>(f32(x) + 0.5, f32(y) + 0.5, depth, inv_w);
            v.world = v0.position * weights.x + v1.position * weights.y + v2.position * weights.z;
            v.normal = v0.normal * weights.x + v1.normal * weights.y + v2.normal * weights.z;
            v.prim = prim;
            v.material = triangle_materials[prim];
            // The GPU path clips at the far plane and tests the opaque depth with LESS.
            if depth > 1.0 || behind_opaque(v.position) {
                continue;
            }
            raster_capture(v, front_facing);
        }
        for (var i = 0u; i < 3u; i++) {
            edge[i] = wide_add(edge[i], step_y[i]);
        }
    }
}
