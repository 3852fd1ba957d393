#define_import_path strata::tiled::tile
#import strata::scene::{covering_tag, fragment_coverage, frame, pixel_index, report_pixels, scene_fragment_covering}
#import strata::color::{resolved_mean, resolved_sum_add, resolved_sum_new}
#import strata::fragment::{Fragment, fragment_before}
#import strata::composite::{composite_finish, composite_front, composite_new}
#import strata::raster::records::{recorded_triangle}
#import strata::raster::setup::{Barycentrics, SetupTriangle, barycentrics_at, varying_from, wide_negative}
#import strata::tiled::constants::{COUNTER_CUT_SHORT, COUNTER_DEEPEST, COUNTER_DEEPEST_IN_ROUNDS, COUNTER_EVALUATIONS, COUNTER_LONGEST_LIST, COUNTER_ROUNDS, COUNTER_ROUNDS_RECORDED, COUNTER_RECORD_LOADS, COUNTER_SHADINGS, COUNTER_UNFINISHED, COUNTER_WARP_STEPS, KEEP, ROUND_BINS}
#import strata::tiled::lists::{PROGRESS_DONE, PROGRESS_FRESH, PROGRESS_LEFT, PROGRESS_RESOLVED, PixelState, fragments_left, list_entry, load_state, output, progress_of, set_progress, store_state, tile_counts, tile_rounds, tile_starts, tiled_counters, tiled_tail, tp, work_add}
#import strata::tiled::samples::{SamplesAccount, fragment_samples, load_account, load_sample, sample_count, store_account, store_sample}
#import strata::tail::{Tail, composite_tail_of, tail_empty, tail_join, tail_leave}

// One round of the tile pass (recorded once per round): one workgroup per 8×8-pixel tile, one
// thread per pixel (thread lid owns bit lid of the coverage masks), no atomics on pixel data.
// The tile's list is walked in chunks of CHUNK triangles: the threads load one triangle's setup
// record (the bin's) each into workgroup memory, then every thread tests its pixel's bit of each triangle's coverage
// mask (made by the count pass) and keeps the KEEP nearest fragments strictly behind its
// bound — the last fragment it composited — sorted by (depth, primitive) in its registers. At the
// end of the round it composites them front to back after what earlier rounds composited. Only
// tiles with a pixel that has fragments left run a round, fragments at equal depths are told
// apart by their primitive, and the result does not depend on the order of the list: the same
// frame gives the same bytes.
//
// One round per dispatch bounds each invocation's loops by its tile's list: lavapipe ends the
// loops of an invocation after 65535 iterations in all, which one loop over every round of a
// deep tile exceeded (lanes count what they walked, and a walk cut short is reported).

const CHUNK: u32 = 64u;
// The most list entries a round walks (docs/watchdog.md, T1): about 20 ms of a thread's walk on
// a GPU, whose rounds have no loop limit of their own. A tile whose list is longer (over a
// million triangles meeting one 8×8 tile) is walked this far and reported cut short: the frame
// says it cannot complete, as lavapipe's frames do far sooner.
const ROUND_WALK_LIMIT: u32 = 1048576u;

var<workgroup> chunk: array<SetupTriangle, CHUNK>;
var<workgroup> chunk_prims: array<u32, CHUNK>;
var<workgroup> chunk_masks: array<vec2<u32>, CHUNK>;
var<workgroup> list_length: u32;
// The lanes (pixels) with fragments left: a triangle none of them covers needs no setup.
var<workgroup> working_bits: array<atomic<u32>, 2>;
var<workgroup> working_mask: vec2<u32>;
// The round's record loads, evaluations and shadings, summed here first: one atomic per workgroup
// and counter on the frame's counters.
var<workgroup> work_sums: array<atomic<u32>, 3>;

// Inserts `f` into the `kept` fragments, nearest first; a full array drops its farthest (which
// the caller checked lies behind `f`).
fn keep(kept: ptr<function, array<Fragment, KEEP>>, count: ptr<function, u32>, f: Fragment) {
    var at = min(*count, KEEP - 1u);
    while at > 0u {
        if !fragment_before(f, (*kept)[at - 1u]) {
            break;
        }
        (*kept)[at] = (*kept)[at - 1u];
        at -= 1u;
    }
    (*kept)[at] = f;
    *count = min(*count + 1u, KEEP);
}

// Fragments a pixel that composited `count` may composite this round.
fn round_limit(count: u32) -> u32 {
    if tp.k == 0u {
        return KEEP;
    }
    return min(KEEP, tp.k - min(count, tp.k));
}

// A thread of a tile's workgroup: the workgroup is one 8×8 tile, the thread one of its pixels
// (and bit `lid` of the tile's coverage masks).
struct TileThread {
    @builtin(workgroup_id) group: vec3<u32>,
    @builtin(local_invocation_id) local: vec3<u32>,
    @builtin(local_invocation_index) lid: u32,
}

// The thread's tile, numbered row by row.
fn thread_tile(t: TileThread) -> u32 {
    return t.group.y * tp.tiles_x + t.group.x;
}

// The thread's pixel (past the frame's edge in the last row and column of tiles).
fn thread_pixel(t: TileThread) -> vec2<u32> {
    return t.group.xy * 8u + t.local.xy;
}

// The walk of a tile's list in a round: its length, and the lanes (pixels) with fragments left.
struct Walk {
    n: u32,
    lanes: vec2<u32>,
}

// Starts a round's walk: the tile's list and the lanes `working` marks (the workgroup leaves
// where the walk is empty), and where it is not, counts the round and its warps' steps.
fn walk_begin(lid: u32, tile: u32, working: bool) -> Walk {
    if lid == 0u {
        atomicStore(&working_bits[0], 0u);
        atomicStore(&working_bits[1], 0u);
        list_length = atomicLoad(&tile_counts[tile]);
    }
    if lid < 3u {
        atomicStore(&work_sums[lid], 0u);
    }
    workgroupBarrier();
    if working {
        atomicOr(&working_bits[lid / 32u], 1u << (lid % 32u));
    }
    workgroupBarrier();
    if lid == 0u {
        working_mask = vec2<u32>(atomicLoad(&working_bits[0]), atomicLoad(&working_bits[1]));
    }
    let walk = Walk(workgroupUniformLoad(&list_length), workgroupUniformLoad(&working_mask));
    if lid == 0u && walk.n > 0u && any(walk.lanes != vec2<u32>(0u)) {
        tile_rounds[tile] += 1u;
        atomicMax(&tiled_counters[COUNTER_LONGEST_LIST], walk.n);
        // Each of the tile's 32-lane warps with a pixel left steps through the whole list.
        let warps = select(0u, 1u, walk.lanes.x != 0u) + select(0u, 1u, walk.lanes.y != 0u);
        work_add(COUNTER_WARP_STEPS, warps * walk.n);
    }
    return walk;
}

fn walk_empty(walk: Walk) -> bool {
    return walk.n == 0u || all(walk.lanes == vec2<u32>(0u));
}

// Loads the chunk of the list from entry `base` into workgroup memory: the masks (only the
// working lanes' bits) and the records of the triangles covering one of them. Returns the
// records this thread loaded.
fn load_chunk(start: u32, base: u32, walk: Walk, lid: u32) -> u32 {
    // Everyone is done with the previous chunk before it is overwritten.
    workgroupBarrier();
    var loads = 0u;
    if base + lid < walk.n {
        let entry = list_entry(start + base + lid, walk.lanes);
        chunk_masks[lid] = entry.mask;
        // A triangle that covers none of those pixels needs no record.
        if any(entry.mask != vec2<u32>(0u)) {
            let recorded = recorded_triangle(entry.setup);
            chunk[lid] = recorded.t;
            chunk_prims[lid] = recorded.prim;
            loads = 1u;
        }
    }
    workgroupBarrier();
    return loads;
}

// Whether chunk entry j covers lane `lid`'s pixel.
fn chunk_covers(j: u32, lid: u32) -> bool {
    return ((chunk_masks[j][lid / 32u] >> (lid % 32u)) & 1u) == 1u;
}

// Chunk entry j's fragment at `pixel`, evaluated but not shaded (the attributes and shading
// only for a fragment that is kept): its depth, the samples it covers (none where it is
// clipped or behind the opaque depth; single-sampled 1) and its key (depth, tag).
struct RoundCandidate {
    t: SetupTriangle,
    prim: u32,
    b: Barycentrics,
    covered: u32,
    front_facing: bool,
    key: Fragment,
}

fn round_candidate(j: u32, pixel: vec2<i32>) -> RoundCandidate {
    let t = chunk[j];
    let prim = chunk_prims[j];
    let b = barycentrics_at(t, pixel);
    let covered = fragment_samples(t, pixel, b.depth);
    let front_facing = wide_negative(t.doubled_area);
    let key = Fragment(b.depth, covering_tag(prim, front_facing, covered), 0u, 0u);
    return RoundCandidate(t, prim, b, covered, front_facing, key);
}

// The candidate shaded: the fragment a round keeps or joins to a tail.
fn shade_candidate(c: RoundCandidate, pixel: vec2<i32>) -> Fragment {
    return scene_fragment_covering(varying_from(c.t, c.prim, pixel, c.b), c.front_facing, c.covered);
}

// Ends a round's walk: the workgroup's record loads, evaluations and shadings added to the
// frame's counters, one atomic each.
fn walk_end(lid: u32, loads: u32, evaluations: u32, shadings: u32) {
    atomicAdd(&work_sums[0], loads);
    atomicAdd(&work_sums[1], evaluations);
    atomicAdd(&work_sums[2], shadings);
    workgroupBarrier();
    if lid == 0u {
        work_add(COUNTER_RECORD_LOADS, atomicLoad(&work_sums[0]));
        work_add(COUNTER_EVALUATIONS, atomicLoad(&work_sums[1]));
        work_add(COUNTER_SHADINGS, atomicLoad(&work_sums[2]));
    }
}

@compute @workgroup_size(8, 8)
fn cs_round(invocation: TileThread) {
    let lid = invocation.lid;
    let tile = thread_tile(invocation);
    let pixel = vec2<i32>(thread_pixel(invocation));
    let on_screen = all(vec2<u32>(pixel) < frame.size);
    let p = pixel_index(vec2<u32>(min(vec2<i32>(frame.size) - 1, pixel)));
    var composite = composite_new();
    var progress = PROGRESS_DONE;
    if on_screen {
        let state = load_state(p);
        composite = state.s;
        progress = state.progress;
    }
    let limit = round_limit(composite.count);
    // Fresh, or with fragments left: not done, nor resolved by the one-pass kernel.
    let working = (progress == PROGRESS_FRESH || progress >= PROGRESS_LEFT) && limit > 0u;
    let walk = walk_begin(lid, tile, working);
    if walk_empty(walk) {
        return;
    }
    // A list past ROUND_WALK_LIMIT is walked that far and reported cut short.
    let n = min(walk.n, ROUND_WALK_LIMIT);
    let start = tile_starts[tile];
    let bounded = composite.count > 0u;
    let bound = Fragment(composite.last_depth, composite.last_tag, 0u, 0u);
    var kept: array<Fragment, KEEP>;
    var count = 0u;
    var candidates = 0u;
    var walked = 0u;
    var loads = 0u;
    var evaluations = 0u;
    var shadings = 0u;
    // The round that reaches k with --tail: every fragment behind the bound joins the tail as it
    // is shaded, and the ones composited leave it again at the end.
    let tail_params = tiled_tail();
    let tail_round = tail_params.mode != 0u && tp.k - min(composite.count, tp.k) <= KEEP;
    var tail = tail_empty();
    for (var base = 0u; base < n; base += CHUNK) {
        loads += load_chunk(start, base, walk, lid);
        // A thread with nothing left still takes part in the barriers above.
        if working {
            let chunk_size = min(CHUNK, n - base);
            for (var j = 0u; j < chunk_size; j++) {
                walked += 1u;
                if !chunk_covers(j, lid) {
                    continue;
                }
                let c = round_candidate(j, pixel);
                evaluations += 1u;
                if c.covered == 0u || (bounded && !fragment_before(bound, c.key)) {
                    continue;
                }
                candidates += 1u;
                let nearer = count < KEEP || fragment_before(c.key, kept[KEEP - 1u]);
                if !nearer && !tail_round {
                    continue;
                }
                shadings += 1u;
                let f = shade_candidate(c, pixel);
                if tail_round {
                    tail_join(&tail, tail_params, f);
                }
                if nearer {
                    keep(&kept, &count, f);
                }
            }
        }
    }
    walk_end(lid, loads, evaluations, shadings);
    if !working {
        return;
    }
    if walked != walk.n {
        atomicAdd(&tiled_counters[COUNTER_CUT_SHORT], 1u);
    }
    let composited = min(count, limit);
    for (var i = 0u; i < composited; i++) {
        composite_front(&composite, kept[i]);
    }
    if tail_round && candidates > composited {
        for (var i = 0u; i < composited; i++) {
            tail_leave(&tail, tail_params, kept[i]);
        }
        composite_tail_of(&composite, tail, tail_params);
    }
    let left = select(PROGRESS_DONE, PROGRESS_LEFT + candidates - composited, candidates > composited);
    store_state(p, PixelState(composite, left));
}

#ifdef MULTISAMPLED
// The most samples a pixel has (--msaa 8).
const MAX_SAMPLES: u32 = 8u;

// A round with --msaa: the pixel's thread takes the KEEP nearest fragments behind its bound in
// the pixel's (depth, tag) order, whichever samples they cover — the tag holds the coverage, so
// that order restricted to one sample is the sample's — and composites each into the samples it
// covers that have room (with --k: fewer than k composited). The rounds go on until the pixel's
// fragments are taken or every sample is full. With --tail, a sample that may fill this round
// (k less its count at most KEEP) joins every fragment behind the bound that covers it to its
// tail as it is shaded; if it fills, the ones it composited leave again and the rest are
// composited as its tail — the single-sampled round's rule, per sample.
@compute @workgroup_size(8, 8)
fn cs_round_samples(invocation: TileThread) {
    let lid = invocation.lid;
    let tile = thread_tile(invocation);
    let pixel = vec2<i32>(thread_pixel(invocation));
    let on_screen = all(vec2<u32>(pixel) < frame.size);
    let p = pixel_index(vec2<u32>(min(vec2<i32>(frame.size) - 1, pixel)));
    let samples = frame.coverage_bits;
    var progress = PROGRESS_DONE;
    if on_screen {
        progress = progress_of(p);
    }
    let fresh = progress == PROGRESS_FRESH;
    var account = SamplesAccount(0.0, 0u, 0u, 0u);
    // Samples with room left, and those that may fill this round (with --tail).
    var open = 0u;
    var filling = 0u;
    let tail_params = tiled_tail();
    if fresh || progress >= PROGRESS_LEFT {
        if !fresh {
            account = load_account(p);
        }
        for (var s = 0u; s < samples; s++) {
            var count = 0u;
            if !fresh {
                count = sample_count(p, s);
            }
            if tp.k == 0u || count < tp.k {
                open |= 1u << s;
                if tail_params.mode != 0u && tp.k - count <= KEEP {
                    filling |= 1u << s;
                }
            }
        }
    }
    let working = open != 0u;
    let walk = walk_begin(lid, tile, working);
    if walk_empty(walk) {
        return;
    }
    // A list past ROUND_WALK_LIMIT is walked that far and reported cut short.
    let n = min(walk.n, ROUND_WALK_LIMIT);
    let start = tile_starts[tile];
    let bounded = !fresh;
    let bound = Fragment(account.bound_depth, account.bound_tag, 0u, 0u);
    var kept: array<Fragment, KEEP>;
    var count = 0u;
    var candidates = 0u;
    var walked = 0u;
    var loads = 0u;
    var evaluations = 0u;
    var shadings = 0u;
    var tails: array<Tail, MAX_SAMPLES>;
    var joined: array<u32, MAX_SAMPLES>;
    for (var base = 0u; base < n; base += CHUNK) {
        loads += load_chunk(start, base, walk, lid);
        if working {
            let chunk_size = min(CHUNK, n - base);
            for (var j = 0u; j < chunk_size; j++) {
                walked += 1u;
                if !chunk_covers(j, lid) {
                    continue;
                }
                let c = round_candidate(j, pixel);
                evaluations += 1u;
                if c.covered == 0u || (bounded && !fragment_before(bound, c.key)) {
                    continue;
                }
                candidates += 1u;
                let nearer = count < KEEP || fragment_before(c.key, kept[KEEP - 1u]);
                let joins = c.covered & filling;
                if !nearer && joins == 0u {
                    continue;
                }
                shadings += 1u;
                let f = shade_candidate(c, pixel);
                for (var s = 0u; s < samples; s++) {
                    if ((joins >> s) & 1u) == 1u {
                        // Through a copy: naga 30's SPIR-V output panics on a pointer to an
                        // element of a function's array of structs passed to a function.
                        var sample_tail = tails[s];
                        tail_join(&sample_tail, tail_params, f);
                        tails[s] = sample_tail;
                        joined[s] += 1u;
                    }
                }
                if nearer {
                    keep(&kept, &count, f);
                }
            }
        }
    }
    walk_end(lid, loads, evaluations, shadings);
    if !working {
        return;
    }
    if walked != walk.n {
        atomicAdd(&tiled_counters[COUNTER_CUT_SHORT], 1u);
    }
    // Bit i: taken fragment i was composited by some sample.
    var used = 0u;
    for (var s = 0u; s < samples; s++) {
        var c = load_sample(p, s, fresh);
        let had = c.count;
        for (var i = 0u; i < count; i++) {
            if (fragment_coverage(kept[i]) & (1u << s)) == 0u {
                continue;
            }
            if tp.k != 0u && c.count >= tp.k {
                break;
            }
            composite_front(&c, kept[i]);
            used |= 1u << i;
        }
        let composited = c.count - had;
        if ((filling >> s) & 1u) == 1u && c.count == tp.k && joined[s] > composited {
            var leaving = composited;
            for (var i = 0u; i < count; i++) {
                if leaving == 0u {
                    break;
                }
                if (fragment_coverage(kept[i]) & (1u << s)) != 0u {
                    var sample_tail = tails[s];
                    tail_leave(&sample_tail, tail_params, kept[i]);
                    tails[s] = sample_tail;
                    leaving -= 1u;
                }
            }
            composite_tail_of(&c, tails[s], tail_params);
        }
        store_sample(p, s, c);
    }
    if count > 0u {
        account.bound_depth = kept[count - 1u].depth;
        account.bound_tag = kept[count - 1u].tag;
    }
    account.taken += count;
    account.kept += countOneBits(used);
    store_account(p, account);
    set_progress(p, select(PROGRESS_DONE, PROGRESS_LEFT + candidates - count, candidates > count));
}
#endif

// A pixel the rounds finish: its fragments, those composited, and whether some were left
// behind its last round that it had room for.
struct Finished {
    total: u32,
    kept: u32,
    unfinished: bool,
}

// Writes single-sampled pixel p's result from its state.
fn finish_single(p: u32) -> Finished {
    let state = load_state(p);
    let left = fragments_left(state.progress);
    output[p] = composite_finish(state.s);
    return Finished(state.s.count + left, state.s.count, left > 0u && (tp.k == 0u || state.s.count < tp.k));
}

#ifdef MULTISAMPLED
// Writes multisampled pixel p's result: the mean of its samples' composites.
fn finish_samples(p: u32, progress: u32) -> Finished {
    let fresh = progress == PROGRESS_FRESH;
    var account = SamplesAccount(0.0, 0u, 0u, 0u);
    if !fresh {
        account = load_account(p);
    }
    let samples = frame.coverage_bits;
    var sum = resolved_sum_new();
    var open = false;
    for (var s = 0u; s < samples; s++) {
        let c = load_sample(p, s, fresh);
        if tp.k == 0u || c.count < tp.k {
            open = true;
        }
        resolved_sum_add(&sum, composite_finish(c));
    }
    output[p] = resolved_mean(sum, samples, account.kept);
    let left = fragments_left(progress);
    return Finished(account.taken + left, account.kept, left > 0u && open);
}
#endif

// After the last round: each pixel's result, its fragments (those left behind the last round
// are counted as generated and dropped), and the tile's rounds — for the pixels the one-pass
// kernel did not resolve. The workgroup sums its pixels' account first: one atomic per counter
// and tile, not per pixel.
var<workgroup> finished: array<atomic<u32>, 6>;

@compute @workgroup_size(8, 8)
fn cs_finish(invocation: TileThread) {
    let lid = invocation.lid;
    let tile = thread_tile(invocation);
    let rounds = tile_rounds[tile];
    if lid < 6u {
        atomicStore(&finished[lid], 0u);
    }
    workgroupBarrier();
    let pixel = thread_pixel(invocation);
    if all(pixel < frame.size) {
        let p = pixel_index(pixel);
        let progress = progress_of(p);
        if progress != PROGRESS_RESOLVED {
#ifdef MULTISAMPLED
            let done = finish_samples(p, progress);
#else
            let done = finish_single(p);
#endif
            let total = done.total;
            if done.unfinished {
                atomicAdd(&finished[4], 1u);
            }
            atomicAdd(&finished[0], total);
            atomicAdd(&finished[1], min(done.kept, total));
            atomicAdd(&finished[2], total - min(done.kept, total));
            atomicMax(&finished[3], total);
            // A tile some round ran in (the one-pass kernel resolved the others).
            if rounds > 0u {
                atomicMax(&finished[5], total);
            }
        }
    }
    workgroupBarrier();
    if lid == 0u {
        atomicAdd(&tiled_counters[COUNTER_ROUNDS + min(rounds, ROUND_BINS - 1u)], 1u);
        if tile == 0u {
            atomicStore(&tiled_counters[COUNTER_ROUNDS_RECORDED], tp.rounds);
        }
        let deepest = atomicLoad(&finished[3]);
        if deepest > 0u {
            atomicMax(&tiled_counters[COUNTER_DEEPEST], deepest);
        }
        if rounds > 0u {
            atomicMax(&tiled_counters[COUNTER_DEEPEST_IN_ROUNDS], atomicLoad(&finished[5]));
        }
        let unfinished = atomicLoad(&finished[4]);
        if unfinished > 0u {
            atomicAdd(&tiled_counters[COUNTER_UNFINISHED], unfinished);
        }
        report_pixels(atomicLoad(&finished[0]), atomicLoad(&finished[1]), atomicLoad(&finished[2]), deepest);
    }
}
