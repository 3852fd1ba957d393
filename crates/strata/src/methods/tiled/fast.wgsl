#define_import_path strata::tiled::fast
#import strata::scene::{fragment_coverage, frame, pixel_index, report_pixels, scene_fragment_covering}
#import strata::color::{Resolved, resolved_mean, resolved_sum_add, resolved_sum_new}
#import strata::fragment::{Fragment, fragment_before}
#import strata::composite::{composite_finish, composite_front, composite_new}
#import strata::raster::records::{recorded_triangle}
#import strata::raster::setup::{SetupTriangle, barycentrics_at, varying_from, wide_negative}
#import strata::tiled::samples::{fragment_samples}
#import strata::tiled::constants::{COUNTER_DEEPEST, COUNTER_EVALUATIONS, COUNTER_LONGEST_LIST, COUNTER_ONE_PASS_PIXELS, COUNTER_PAST_CAPACITY, COUNTER_RECORD_LOADS, COUNTER_SHADINGS, COUNTER_SORT_STEPS, COUNTER_WARP_STEPS}
#import strata::tiled::lists::{PROGRESS_RESOLVED, list_entry, tile_in_order, output, set_progress, tile_counts, tile_starts, tiled_counters, tiled_tail, tp, work_add}
#import strata::tail::{composite_tail_of, tail_empty, tail_join}

// The one-pass tile kernel, before any round: four workgroups per 8×8-pixel tile, one thread
// per fragment. Where the tile's list covers at most FAST_FRAGMENTS pixel centers (the
// workgroup memory the device gives), the first workgroup takes the whole tile and the others
// leave; else each takes one 4×4 quarter, so that a deep tile's work is split four ways
// (balance: a hot tile does not set the frame's critical path alone). A quarter past the
// store too is left to the rounds (`tile.wgsl`), counted in COUNTER_PAST_CAPACITY: the
// rounds take every pixel whose state is still fresh.
// - The list is read FAST_CHUNK items at a time: one thread per item loads its triangle's
//   setup record (the bin's) into workgroup memory, and the chunk's covered pixel centers (the
//   bits of the items' masks) are numbered by a prefix sum.
// - Each thread takes fragments number lid, lid + 64, …: finds its item (a binary search of
//   the prefix sums) and pixel (the item mask's r-th set bit), evaluates the depth, the opaque
//   and far tests, and shades the fragment once, into the tile's fragment store.
// - Each pixel's fragments are gathered by a counting sort, and the pixel's thread sorts them
//   by (depth, primitive), composites them front to back and writes the pixel's result (the
//   finish folded in: the rounds and `cs_finish` pass the pixel by, and the workgroup adds its
//   pixels to the frame's totals with one atomic each). With --k it composites the k nearest
//   and counts the rest as dropped.
// The store's order depends on the threads' timing; nothing else does: a pixel's fragments are
// composited in (depth, primitive) order, so the frame's bytes equal the rounds' and every run's.

const LANES: u32 = 64u;
const FAST_CHUNK: u32 = 16u;
// Fragments the store holds: sized to the device's workgroup memory (`fast_fragments`).
const FAST_FRAGMENTS: u32 = #{FAST_FRAGMENTS}u;
// The most fragments a pixel's thread sorts here (an insertion sort: at most 8128 steps, within
// lavapipe's 65535 loop iterations an invocation and short on a GPU); a deeper pixel keeps its
// fresh state and the rounds take it.
const PIXEL_MAX: u32 = 128u;

var<workgroup> covered: atomic<u32>;
var<workgroup> stored: atomic<u32>;
var<workgroup> list_length: u32;
var<workgroup> chunk: array<SetupTriangle, FAST_CHUNK>;
var<workgroup> chunk_prims: array<u32, FAST_CHUNK>;
var<workgroup> chunk_masks: array<vec2<u32>, FAST_CHUNK>;
// Inclusive prefix sums of the chunk's items' covered pixel centers.
var<workgroup> chunk_ends: array<u32, FAST_CHUNK>;
var<workgroup> fragments: array<Fragment, FAST_FRAGMENTS>;
var<workgroup> fragment_lanes: array<u32, FAST_FRAGMENTS>;
// Fragment indices grouped by pixel (the counting sort's output), then sorted per pixel.
var<workgroup> by_pixel: array<u32, FAST_FRAGMENTS>;
var<workgroup> pixel_counts: array<atomic<u32>, LANES>;
var<workgroup> pixel_starts: array<u32, LANES>;
// The workgroup's record loads, evaluations and shadings, summed here first so that the frame's
// counters take one atomic per workgroup each, not one per thread.
var<workgroup> work_sums: array<atomic<u32>, 3>;
// The longest insertion sort of each 32-lane warp's pixels.
var<workgroup> warp_sorts: array<atomic<u32>, 2>;
// The resolved pixels' account: fragments generated, composited, dropped, the deepest, and
// the pixels.
var<workgroup> resolved: array<atomic<u32>, 5>;

fn bits(mask: vec2<u32>) -> u32 {
    return countOneBits(mask.x) + countOneBits(mask.y);
}

// The lane (bit index, 0..63) of the r-th set bit of `mask`, r < bits(mask).
fn nth_bit(mask: vec2<u32>, r: u32) -> u32 {
    var word = mask.x;
    var base = 0u;
    var rank = r;
    let low = countOneBits(mask.x);
    if rank >= low {
        word = mask.y;
        base = 32u;
        rank -= low;
    }
    // Clear the lowest set bit `rank` times; then the lowest set bit is the one.
    for (var i = 0u; i < 32u; i++) {
        if i >= rank {
            break;
        }
        word &= word - 1u;
    }
    return base + firstTrailingBit(word);
}

// The chunk item whose covered centers hold the chunk's fragment number `f`.
fn item_of(f: u32, items: u32) -> u32 {
    var lo = 0u;
    var hi = items - 1u;
    for (var step = 0u; step < 5u; step++) {
        if lo >= hi {
            break;
        }
        let mid = (lo + hi) / 2u;
        if chunk_ends[mid] > f {
            hi = mid;
        } else {
            lo = mid + 1u;
        }
    }
    return lo;
}

struct TileThread {
    @builtin(workgroup_id) group: vec3<u32>,
    @builtin(local_invocation_id) local: vec3<u32>,
    @builtin(local_invocation_index) lid: u32,
}

// The bits (lane y·8 + x) of quarter q's 4×4 pixels: left or right half of the rows of the low
// (rows 0–3) or high (rows 4–7) word.
fn quarter_mask(q: u32) -> vec2<u32> {
    let half = select(0x0f0f0f0fu, 0xf0f0f0f0u, (q & 1u) == 1u);
    return select(vec2<u32>(half, 0u), vec2<u32>(0u, half), q >= 2u);
}

// The covered pixel centers of `region` in the tile's list (every thread's share, summed).
fn covered_in(start: u32, n: u32, lid: u32, region: vec2<u32>) -> u32 {
    var mine = 0u;
    for (var i = lid; i < n; i += LANES) {
        mine += bits(list_entry(start + i, region).mask);
    }
    return mine;
}

@compute @workgroup_size(8, 8)
fn cs_fast(invocation: TileThread) {
    let lid = invocation.lid;
    // Four workgroups per tile along x, in the scan's order of the tiles (most work first) or in
    // raster order (`orders_tiles_by_work`).
    let quarter = invocation.group.x % 4u;
    var tile = invocation.group.y * tp.tiles_x + invocation.group.x / 4u;
    if tp.order_by_work != 0u {
        tile = tile_in_order(tile);
    }
    let tile_xy = vec2<u32>(tile % tp.tiles_x, tile / tp.tiles_x);
    let corner = vec2<i32>(tile_xy * 8u);
    if lid == 0u {
        atomicStore(&covered, 0u);
        atomicStore(&stored, 0u);
        list_length = atomicLoad(&tile_counts[tile]);
    }
    if lid < 3u {
        atomicStore(&work_sums[lid], 0u);
    }
    if lid < 2u {
        atomicStore(&warp_sorts[lid], 0u);
    }
    if lid < 5u {
        atomicStore(&resolved[lid], 0u);
    }
    atomicStore(&pixel_counts[lid], 0u);
    workgroupBarrier();
    let n = workgroupUniformLoad(&list_length);
    if n == 0u {
        // No triangle meets the tile: the first workgroup resolves its pixels as empty.
        let pixel = vec2<u32>(corner) + invocation.local.xy;
        if quarter == 0u && all(pixel < frame.size) {
            let p = pixel_index(pixel);
            output[p] = composite_finish(composite_new());
            set_progress(p, PROGRESS_RESOLVED);
        }
        if quarter == 0u && lid == 0u {
            let inside = min(vec2<u32>(8u), frame.size - vec2<u32>(corner));
            atomicAdd(&tiled_counters[COUNTER_ONE_PASS_PIXELS], inside.x * inside.y);
        }
        return;
    }
    let start = tile_starts[tile];
    // The covered pixel centers of the whole list: an upper bound of its fragments.
    atomicAdd(&covered, covered_in(start, n, lid, vec2<u32>(0xffffffffu)));
    workgroupBarrier();
    if lid == 0u {
        list_length = atomicLoad(&covered);
    }
    let whole = workgroupUniformLoad(&list_length);
    var region = vec2<u32>(0xffffffffu);
    var total = whole;
    if whole > FAST_FRAGMENTS {
        region = quarter_mask(quarter);
        workgroupBarrier();
        if lid == 0u {
            atomicStore(&covered, 0u);
        }
        workgroupBarrier();
        atomicAdd(&covered, covered_in(start, n, lid, region));
        workgroupBarrier();
        if lid == 0u {
            list_length = atomicLoad(&covered);
        }
        total = workgroupUniformLoad(&list_length);
    } else if quarter != 0u {
        // The first workgroup takes the whole tile.
        return;
    }
    if total > FAST_FRAGMENTS {
        // Left to the rounds.
        if lid == 0u {
            atomicAdd(&tiled_counters[COUNTER_PAST_CAPACITY], 1u);
        }
        return;
    }
    var loads = 0u;
    var evaluations = 0u;
    var shadings = 0u;
    for (var base = 0u; base < n; base += FAST_CHUNK) {
        let items = min(FAST_CHUNK, n - base);
        // Everyone is done with the previous chunk before it is overwritten.
        workgroupBarrier();
        if lid < items {
            let entry = list_entry(start + base + lid, region);
            chunk_masks[lid] = entry.mask;
            if any(entry.mask != vec2<u32>(0u)) {
                let recorded = recorded_triangle(entry.setup);
                chunk[lid] = recorded.t;
                chunk_prims[lid] = recorded.prim;
                loads += 1u;
            }
        }
        workgroupBarrier();
        if lid < items {
            var end = 0u;
            for (var j = 0u; j <= lid; j++) {
                end += bits(chunk_masks[j]);
            }
            chunk_ends[lid] = end;
        }
        workgroupBarrier();
        let chunk_fragments = chunk_ends[items - 1u];
        for (var f = lid; f < chunk_fragments; f += LANES) {
            let j = item_of(f, items);
            let first = select(0u, chunk_ends[j - 1u], j > 0u);
            let lane = nth_bit(chunk_masks[j], f - first);
            let pixel = corner + vec2<i32>(vec2<u32>(lane % 8u, lane / 8u));
            let t = chunk[j];
            let prim = chunk_prims[j];
            let b = barycentrics_at(t, pixel);
            evaluations += 1u;
            let covered = fragment_samples(t, pixel, b.depth);
            if covered == 0u {
                continue;
            }
            let front_facing = wide_negative(t.doubled_area);
            shadings += 1u;
            let slot = atomicAdd(&stored, 1u);
            fragments[slot] = scene_fragment_covering(varying_from(t, prim, pixel, b), front_facing, covered);
            fragment_lanes[slot] = lane;
            atomicAdd(&pixel_counts[lane], 1u);
        }
    }
    workgroupBarrier();
    // The counting sort: each pixel's start, then every fragment's index in its pixel's run.
    let count = atomicLoad(&pixel_counts[lid]);
    var begin = 0u;
    for (var j = 0u; j < lid; j++) {
        begin += atomicLoad(&pixel_counts[j]);
    }
    pixel_starts[lid] = begin;
    workgroupBarrier();
    atomicStore(&pixel_counts[lid], 0u);
    workgroupBarrier();
    let kept = atomicLoad(&stored);
    for (var f = lid; f < kept; f += LANES) {
        let lane = fragment_lanes[f];
        by_pixel[pixel_starts[lane] + atomicAdd(&pixel_counts[lane], 1u)] = f;
    }
    // Every pixel's run is gathered before any is sorted.
    workgroupBarrier();
    let pixel = corner + vec2<i32>(invocation.local.xy);
    // Only the region's pixels: another quarter's, or the rounds', are not this one's to write.
    let in_region = ((region[lid / 32u] >> (lid % 32u)) & 1u) == 1u;
    let resolves = in_region && all(vec2<u32>(pixel) < frame.size) && count <= PIXEL_MAX;
    var sort_steps = 0u;
    if resolves {
        sort_steps = resolve_pixel(vec2<u32>(pixel), begin, count);
    }
    // Each 32-lane warp sorts as long as its longest sort.
    atomicMax(&warp_sorts[lid / 32u], sort_steps);
    atomicAdd(&work_sums[0], loads);
    atomicAdd(&work_sums[1], evaluations);
    atomicAdd(&work_sums[2], shadings);
    workgroupBarrier();
    if lid == 0u {
        atomicMax(&tiled_counters[COUNTER_LONGEST_LIST], n);
        // Each of the two warps steps through its lanes' share of the fragments.
        work_add(COUNTER_WARP_STEPS, 2u * ((total + LANES - 1u) / LANES));
        work_add(COUNTER_RECORD_LOADS, atomicLoad(&work_sums[0]));
        work_add(COUNTER_EVALUATIONS, atomicLoad(&work_sums[1]));
        work_add(COUNTER_SHADINGS, atomicLoad(&work_sums[2]));
        work_add(COUNTER_SORT_STEPS, atomicLoad(&warp_sorts[0]) + atomicLoad(&warp_sorts[1]));
        atomicMax(&tiled_counters[COUNTER_DEEPEST], atomicLoad(&resolved[3]));
        atomicAdd(&tiled_counters[COUNTER_ONE_PASS_PIXELS], atomicLoad(&resolved[4]));
        report_pixels(atomicLoad(&resolved[0]), atomicLoad(&resolved[1]), atomicLoad(&resolved[2]), atomicLoad(&resolved[3]));
    }
}

// Writes pixel `pixel`'s result, marks it resolved (the rounds and `cs_finish` pass it by) and
// adds it to the workgroup's account: `count` fragments, `kept` of them composited.
fn write_resolved(pixel: vec2<u32>, result: Resolved, count: u32, kept: u32) {
    let p = pixel_index(pixel);
    output[p] = result;
    set_progress(p, PROGRESS_RESOLVED);
    atomicAdd(&resolved[0], count);
    atomicAdd(&resolved[1], kept);
    atomicAdd(&resolved[2], count - kept);
    atomicMax(&resolved[3], count);
    atomicAdd(&resolved[4], 1u);
}

// Sorts pixel `pixel`'s `count` fragments, run `begin` of `by_pixel`, by (depth, primitive),
// composites them front to back (with --k its k nearest; the rest are dropped, or with --tail
// composited behind them as one term) and writes its result: the rounds and `cs_finish` pass it by.
// Adds the pixel to the workgroup's account; returns the insertion sort's steps.
fn resolve_pixel(pixel: vec2<u32>, begin: u32, count: u32) -> u32 {
    // An insertion sort that holds the fragment it inserts: each step loads one index and one
    // fragment and stores one index.
    var steps = 0u;
    for (var i = 1u; i < count; i++) {
        let moving = by_pixel[begin + i];
        let key = fragments[moving];
        var j = i;
        while j > 0u {
            let before = by_pixel[begin + j - 1u];
            if !fragment_before(key, fragments[before]) {
                break;
            }
            by_pixel[begin + j] = before;
            j -= 1u;
            steps += 1u;
        }
        by_pixel[begin + j] = moving;
    }
#ifdef MULTISAMPLED
    composite_samples(pixel, begin, count);
    return steps + count;
#else
    var limit = count;
    if tp.k != 0u {
        limit = min(count, tp.k);
    }
    var composite = composite_new();
    for (var i = 0u; i < limit; i++) {
        composite_front(&composite, fragments[by_pixel[begin + i]]);
    }
    let tail_params = tiled_tail();
    if tail_params.mode != 0u && count > limit {
        var tail = tail_empty();
        for (var i = limit; i < count; i++) {
            tail_join(&tail, tail_params, fragments[by_pixel[begin + i]]);
        }
        composite_tail_of(&composite, tail, tail_params);
    }
    write_resolved(pixel, composite_finish(composite), count, limit);
    return steps + count;
#endif
}

#ifdef MULTISAMPLED
// --msaa: each sample composites the sorted run's fragments that cover it — with --k its k
// nearest, the rest dropped or joined to its tail — and the pixel is the samples' mean. A
// fragment counts as composited once, however many samples composited it.
fn composite_samples(pixel: vec2<u32>, begin: u32, count: u32) {
    let tail_params = tiled_tail();
    var sum = resolved_sum_new();
    // Bit i % 32 of word i / 32: the run's fragment i was composited by some sample.
    var used: array<u32, 4>;
    for (var s = 0u; s < frame.coverage_bits; s++) {
        var composite = composite_new();
        var tail = tail_empty();
        var past = 0u;
        for (var i = 0u; i < count; i++) {
            let f = fragments[by_pixel[begin + i]];
            if (fragment_coverage(f) & (1u << s)) == 0u {
                continue;
            }
            if tp.k == 0u || composite.count < tp.k {
                composite_front(&composite, f);
                used[i / 32u] |= 1u << (i % 32u);
            } else if tail_params.mode != 0u {
                tail_join(&tail, tail_params, f);
                past += 1u;
            } else {
                break;
            }
        }
        if past > 0u {
            composite_tail_of(&composite, tail, tail_params);
        }
        resolved_sum_add(&sum, composite_finish(composite));
    }
    let kept = countOneBits(used[0]) + countOneBits(used[1]) + countOneBits(used[2]) + countOneBits(used[3]);
    write_resolved(pixel, resolved_mean(sum, frame.coverage_bits, kept), count, kept);
}
#endif
