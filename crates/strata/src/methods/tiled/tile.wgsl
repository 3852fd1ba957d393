#define_import_path strata::tiled::tile
#import strata::scene::{behind_opaque, frame, pixel_index, report_pixel, scene_fragment}
#import strata::fragment::{Fragment, fragment_before}
#import strata::composite::{composite_finish, composite_front, composite_new}
#import strata::raster::items::{rp}
#import strata::raster::setup::{SetupTriangle, clipped_triangle, covers, fan_triangle, varying_at, wide_negative}
#import strata::tiled::lists::{COUNTER_DEEPEST, COUNTER_ROUNDS, ROUND_BINS, output, tile_codes, tile_counts, tile_starts, tiled_counters, tp}

// The tile pass: one workgroup per 8×8-pixel tile, one thread per pixel, no atomics on pixel
// data. Each round walks the tile's list in chunks of CHUNK triangles: the threads set one
// triangle each up into workgroup memory, then every thread tests its pixel against the chunk
// and keeps the KEEP nearest fragments strictly behind its bound, sorted by (depth, primitive)
// in its own registers. At the end of a round each thread composites what it kept, front to
// back; a pixel that had more than KEEP candidates moves its bound to the last one composited
// and the tile goes over its list again. Only tiles with a pixel deeper than KEEP pay another
// round, fragments at equal depths are told apart by their primitive, and the result does not
// depend on the order of the list: the same frame gives the same bytes.

const CHUNK: u32 = 64u;
// Keep in sync with `KEEP` in mod.rs.
const KEEP: u32 = 16u;

var<workgroup> chunk: array<SetupTriangle, CHUNK>;
var<workgroup> chunk_prims: array<u32, CHUNK>;
var<workgroup> list_length: u32;
var<workgroup> wants_more: atomic<u32>;
var<workgroup> another_round: u32;

// Inserts `f` into the `kept` fragments, nearest first; a full array drops its farthest (which
// the caller checked lies behind `f`).
fn keep(kept: ptr<function, array<Fragment, KEEP>>, count: ptr<function, u32>, f: Fragment) {
    var at = min(*count, KEEP - 1u);
    while at > 0u && fragment_before(f, (*kept)[at - 1u]) {
        (*kept)[at] = (*kept)[at - 1u];
        at -= 1u;
    }
    (*kept)[at] = f;
    *count = min(*count + 1u, KEEP);
}

@compute @workgroup_size(8, 8)
fn cs_tile(
    @builtin(workgroup_id) group: vec3<u32>,
    @builtin(local_invocation_id) local: vec3<u32>,
    @builtin(local_invocation_index) lid: u32,
) {
    let tile = group.y * tp.tiles_x + group.x;
    if lid == 0u {
        atomicStore(&wants_more, 0u);
        list_length = atomicLoad(&tile_counts[tile]);
    }
    let n = workgroupUniformLoad(&list_length);
    let start = tile_starts[tile];
    let pixel = vec2<i32>(group.xy * 8u + local.xy);
    let on_screen = all(vec2<u32>(pixel) < frame.size);
    var s = composite_new();
    var bound = Fragment(0.0, 0u, 0u, 0u);
    var bounded = false;
    var done = !on_screen;
    // A round that is not the pixel's last composites KEEP of its fragments, and a pixel has at
    // most one fragment per item: n / KEEP + 1 rounds finish every pixel.
    let rounds = select(0u, n / KEEP + 1u, n > 0u);
    var ran = 0u;
    for (var round = 0u; round < rounds; round++) {
        ran += 1u;
        var kept: array<Fragment, KEEP>;
        var count = 0u;
        var candidates = 0u;
        for (var base = 0u; base < n; base += CHUNK) {
            // Everyone is done with the previous chunk before it is overwritten.
            workgroupBarrier();
            if base + lid < n {
                let code = tile_codes[start + base + lid];
                let prim = code >> 3u;
                chunk_prims[lid] = prim;
                var t = fan_triangle(clipped_triangle(prim, rp.guard), code & 7u);
                t.valid = t.valid && prim < rp.triangles;
                chunk[lid] = t;
            }
            workgroupBarrier();
            // A thread that is done still takes part in the barriers above.
            if !done {
                let chunk_size = min(CHUNK, n - base);
                for (var j = 0u; j < chunk_size; j++) {
                    let t = chunk[j];
                    if !covers(t, pixel) {
                        continue;
                    }
                    let prim = chunk_prims[j];
                    let v = varying_at(t, prim, pixel);
                    // The GPU path clips at the far plane and tests the opaque depth with LESS.
                    if v.position.z > 1.0 || behind_opaque(v.position) {
                        continue;
                    }
                    let front_facing = wide_negative(t.doubled_area);
                    let key = Fragment(v.position.z, (prim << 1u) | select(0u, 1u, front_facing), 0u, 0u);
                    if bounded && !fragment_before(bound, key) {
                        continue;
                    }
                    candidates += 1u;
                    if count == KEEP && !fragment_before(key, kept[KEEP - 1u]) {
                        continue;
                    }
                    keep(&kept, &count, scene_fragment(v, front_facing));
                }
            }
        }
        if !done {
            for (var i = 0u; i < count; i++) {
                composite_front(&s, kept[i]);
            }
            if candidates > KEEP {
                bound = kept[KEEP - 1u];
                bounded = true;
                atomicOr(&wants_more, 1u);
            } else {
                done = true;
            }
        }
        workgroupBarrier();
        if lid == 0u {
            another_round = atomicExchange(&wants_more, 0u);
        }
        if workgroupUniformLoad(&another_round) == 0u {
            break;
        }
    }
    if lid == 0u {
        atomicAdd(&tiled_counters[COUNTER_ROUNDS + min(ran, ROUND_BINS - 1u)], 1u);
    }
    if !on_screen {
        return;
    }
    // Every fragment of the pixel was composited, once.
    let total = s.count;
    atomicMax(&tiled_counters[COUNTER_DEEPEST], total);
    output[pixel_index(vec2<u32>(pixel))] = composite_finish(s);
    report_pixel(total, total);
}
