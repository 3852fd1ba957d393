#define_import_path strata::kbuffer::resolve
#import strata::scene::{fragment_coverage, frame, report_cut_short, report_pixel}
#import strata::color::{Resolved, resolved_mean, resolved_sum_add, resolved_sum_new}
#import strata::fragment::{Fragment, fragment_before}
#import strata::composite::{Composite, composite_finish, composite_front, composite_new}
#import strata::kbuffer::access::{sort_stored, stored_count, stored_fragment}
#import strata::kbuffer::storage::{kbuffer_tail, kp, kpixel_index, output, pixel_fragments_word, pixel_word, pixels, sample_pixel, tail, tail_word}
#import strata::tail::{Tail, composite_tail_of, tail_empty, tail_join}
#import strata::kbuffer::words::{SEEN}
#import strata::steps::{step, steps_spent}

// k-buffer resolve: composites a pixel's k nearest stored fragments in (depth, primitive) order.
// The multisampled paths are compiled only with MULTISAMPLED (--msaa): they double the shader,
// and a software rasterizer's compile time with it.
// Up to LOCAL_CAPACITY stored fragments are copied to a local array and sorted — insertion sort
// up to 16, bitonic sort above (with BITONIC_RESOLVE, bitonic at every length); longer lists use the k-depth sort (seed 003, Algorithm 4): chunks
// of CHUNK nearest fragments selected with a max-array, sorted and composited, the last one
// composited bounding the next selection. Where that would take more than SORTED_ROUNDS rounds,
// a storage that can sort itself in place (lists, slot arrays: `sort_stored`) does, and is read
// in order instead. Fragments beyond k join the tail (--tail blend).
// `stored_count(p)` and `stored_fragment(p, i)` are the storage layout's (access.wgsl).


const LOCAL_CAPACITY: u32 = 64u;
const CHUNK: u32 = 32u;
// Rounds of the k-depth sort beyond which a storage that can sort itself in place does so.
const SORTED_ROUNDS: u32 = 4u;

fn tail_sums(p: u32) -> Tail {
    var t = tail_empty();
    for (var i = 0u; i < 5u; i++) {
        t.sums[i] = vec2<u32>(atomicLoad(&tail[tail_word(p, 2u * i)]), atomicLoad(&tail[tail_word(p, 2u * i + 1u)]));
    }
    return t;
}

// `f`, a stored fragment past the pixel's limit, joins its local tail.
fn tail_add_local(t: ptr<function, Tail>, f: Fragment) {
    tail_join(t, kbuffer_tail(), f);
}

fn sort_local(a: ptr<function, array<Fragment, LOCAL_CAPACITY>>, n: u32) {
#ifdef BITONIC_RESOLVE
    // kplus-bitonic: the network at every length, over the smallest power of two that holds n.
    var size = 2u;
    while size < min(n, LOCAL_CAPACITY) {
        size <<= 1u;
    }
#else
    if n <= 16u {
        for (var i = 1u; i < n; i++) {
            let f = (*a)[i];
            var j = i;
            while j > 0u {
                if !fragment_before(f, (*a)[j - 1u]) {
                    break;
                }
                (*a)[j] = (*a)[j - 1u];
                j -= 1u;
            }
            (*a)[j] = f;
        }
        return;
    }
    // Bitonic sort (seed 002's resolve for long lists): a fixed network of compare-exchanges,
    // the same sequence whatever the data, over the list padded to a power of two with
    // fragments after every real one.
    var size = 32u;
    if n > 32u {
        size = LOCAL_CAPACITY;
    }
#endif
    for (var i = n; i < size; i++) {
        (*a)[i] = Fragment(bitcast<f32>(0x7f800000u), 0xffffffffu, 0u, 0u);
    }
    for (var k = 2u; k <= size; k <<= 1u) {
        for (var j = k >> 1u; j > 0u; j >>= 1u) {
            for (var i = 0u; i < size; i++) {
                let l = i ^ j;
                if l > i {
                    let x = (*a)[i];
                    let y = (*a)[l];
                    // Ascending where bit k of i is clear, descending where it is set.
                    let ascending = (i & k) == 0u;
                    if select(fragment_before(x, y), fragment_before(y, x), ascending) {
                        (*a)[i] = y;
                        (*a)[l] = x;
                    }
                }
            }
        }
    }
}

// The k-depth sort's total order: fragments by (depth, tag), exact duplicates (storages that
// keep no primitive give equal keys) by their storage index.
fn ordered_before(a: Fragment, ia: u32, b: Fragment, ib: u32) -> bool {
    return fragment_before(a, b) || (!fragment_before(b, a) && ia < ib);
}

// The last fragment a k-depth sort composited and how many it composited (for --msaa's count of
// the fragments some sample kept). Multisampled tags hold the coverage mask, so no two stored
// fragments of a pixel have equal keys there and the key alone says which were composited.
struct Composited {
    f: Fragment,
    done: u32,
}

// k-depth sort: composites the `limit` nearest of the `n` stored fragments that cover a sample
// of `coverage` (`fragment_coverage`), CHUNK at a time. With --tail blend the selection goes on
// past `limit` and the rest joins the tail.
// A deep pixel's sort runs O(n²/CHUNK) loop iterations, and lavapipe ends every loop of an
// invocation silently once it has run 65535 iterations in all (ARCHITECTURE, "Lavapipe ends
// loops"): from about 500 fragments a pixel there. So each loop's counter is checked once it
// ends, and a sort cut short is reported (`report_cut_short`): the frame is refused with the
// reason instead of composited from a partial selection. A GPU never ends a loop early.
fn k_depth_sort(p: u32, n: u32, limit: u32, coverage: u32, s: ptr<function, Composite>, t: ptr<function, Tail>) -> Composited {
    // A storage that can sort itself in place (lists, slot arrays) is read in order instead,
    // where the k-depth sort would take more than SORTED_ROUNDS rounds over it: a k nearest
    // few of many stored (kb-ab-fixed at k = 16 over 800) take one round, far less than a
    // whole sort (review: about 50× the memory traffic there).
    var selected = min(limit, n);
    if kp.tail_blend != 0u {
        selected = n;
    }
    if n > LOCAL_CAPACITY && selected > SORTED_ROUNDS * CHUNK && sort_stored(p, n) {
        return composite_in_order(p, n, limit, coverage, s, t);
    }
    var last = Composited(Fragment(0.0, 0u, 0u, 0u), 0u);
    var chunk: array<Fragment, LOCAL_CAPACITY>;
    var chunk_at: array<u32, LOCAL_CAPACITY>;
    var done = 0u;
    var bound = Fragment(0.0, 0u, 0u, 0u);
    var bound_at = 0u;
    var has_bound = false;
    var finished = false;
    var cut_short = false;
    // Each round composites at least one fragment: n / CHUNK + 1 rounds visit them all, and the
    // last ends the loop at one of its breaks.
    for (var round = 0u; round <= n / CHUNK; round++) {
        var m = 0u;
        var i = 0u;
        if n <= LOCAL_CAPACITY {
            // Few enough to hold them all: one round, every covered fragment sorted.
            for (; i < n; i++) {
                if !step() {
                    break;
                }
                let f = stored_fragment(p, i);
                if (fragment_coverage(f) & coverage) != 0u {
                    chunk[m] = f;
                    m += 1u;
                }
            }
        } else {
            // Select the CHUNK nearest fragments after the bound with a max-array (max in
            // slot 0).
            for (; i < n; i++) {
                if !step() {
                    break;
                }
                let f = stored_fragment(p, i);
                if (fragment_coverage(f) & coverage) == 0u {
                    continue;
                }
                if has_bound && !ordered_before(bound, bound_at, f, i) {
                    continue;
                }
                if m < CHUNK {
                    if m > 0u && ordered_before(chunk[0], chunk_at[0], f, i) {
                        chunk[m] = chunk[0];
                        chunk_at[m] = chunk_at[0];
                        chunk[0] = f;
                        chunk_at[0] = i;
                    } else {
                        chunk[m] = f;
                        chunk_at[m] = i;
                    }
                    m += 1u;
                } else if ordered_before(f, i, chunk[0], chunk_at[0]) {
                    chunk[0] = f;
                    chunk_at[0] = i;
                    var max_i = 0u;
                    var j = 1u;
                    for (; j < CHUNK; j++) {
                        if ordered_before(chunk[max_i], chunk_at[max_i], chunk[j], chunk_at[j]) {
                            max_i = j;
                        }
                    }
                    cut_short = cut_short || j < CHUNK;
                    let mx = chunk[max_i];
                    let mx_at = chunk_at[max_i];
                    chunk[max_i] = chunk[0];
                    chunk_at[max_i] = chunk_at[0];
                    chunk[0] = mx;
                    chunk_at[0] = mx_at;
                }
            }
        }
        cut_short = cut_short || i < n;
        if m == 0u {
            finished = true;
            break;
        }
        bound = chunk[0];
        bound_at = chunk_at[0];
        has_bound = true;
        sort_local(&chunk, m);
        var j = 0u;
        for (; j < m; j++) {
            if done < limit {
                composite_front(s, chunk[j]);
                done += 1u;
                last = Composited(chunk[j], done);
            } else if kp.tail_blend != 0u {
                tail_add_local(t, chunk[j]);
            }
        }
        cut_short = cut_short || j < m;
        if n <= LOCAL_CAPACITY || m < CHUNK || (done >= limit && kp.tail_blend == 0u) {
            finished = true;
            break;
        }
    }
    if cut_short || !finished {
        pixel_cut_short = true;
    }
    return last;
}

// Composites the `limit` nearest of the n stored fragments that cover `coverage` from a storage
// already in (depth, primitive) order (`sort_stored`); with --tail blend the rest join the tail.
// A loop the adapter ended early is reported, as in `k_depth_sort`.
fn composite_in_order(p: u32, n: u32, limit: u32, coverage: u32, s: ptr<function, Composite>, t: ptr<function, Tail>) -> Composited {
    var last = Composited(Fragment(0.0, 0u, 0u, 0u), 0u);
    var done = 0u;
    var i = 0u;
    for (; i < n; i++) {
        if ((done >= limit) & (kp.tail_blend == 0u)) || !step() {
            break;
        }
        let f = stored_fragment(p, i);
        if (fragment_coverage(f) & coverage) != 0u {
            if done < limit {
                composite_front(s, f);
                done += 1u;
                last = Composited(f, done);
            } else {
                tail_add_local(t, f);
            }
        }
    }
    if i < n && (done < limit || kp.tail_blend != 0u) {
        pixel_cut_short = true;
    }
    return last;
}

// Composites the tail behind the sorted fragments.
fn composite_tail(s: ptr<function, Composite>, t: Tail) {
    composite_tail_of(s, t, kbuffer_tail());
}

// Composites the `limit` nearest of the pixel's `n` stored fragments onto `s`, in order; with
// --tail blend the rest join `t`.
fn composite_stored(p: u32, n: u32, limit: u32, s: ptr<function, Composite>, t: ptr<function, Tail>) {
    // One sort and one composite loop in the compiled shader, whatever n (a software
    // rasterizer's compile time grows with every copy).
    k_depth_sort(p, n, limit, 0xffffffffu, s, t);
}

// The tail a (sample) pixel's resolve starts from: the one it captured with --tail blend, else
// none.
fn captured_tail(p: u32) -> Tail {
    if kp.tail_blend != 0u {
        return tail_sums(p);
    }
    return tail_empty();
}

// A (sample) pixel's result: the `limit` nearest of its `n` stored fragments composited in
// order, then the tail `captured` with the rest joined to it.
fn composite_pixel(p: u32, n: u32, limit: u32, captured: Tail) -> Resolved {
    var s = composite_new();
    var t = captured;
    composite_stored(p, n, limit, &s, &t);
    composite_tail(&s, t);
    return composite_finish(s);
}

#ifdef MULTISAMPLED
// --msaa: each sample composites its own fragments in depth order — its `limit` nearest, the
// rest joining its tail — and the pixel is the samples' average (premultiplied, so blending it
// over a background equals averaging the samples blended over it). A tail captured per pixel
// (fixed arrays past their slots) lies behind every sample. Returns the fragments some sample
// composited.
fn resolve_samples(p: u32, n: u32, limit: u32, captured: Tail) -> u32 {
    let samples = frame.coverage_bits;
    var sum = resolved_sum_new();
    var kept = 0u;
    if n <= LOCAL_CAPACITY {
        var local: array<Fragment, LOCAL_CAPACITY>;
        for (var i = 0u; i < n; i++) {
            local[i] = stored_fragment(p, i);
        }
        sort_local(&local, n);
        // Bit i of word i / 32: local fragment i was composited by some sample.
        var used = vec2<u32>(0u);
        for (var si = 0u; si < samples; si++) {
            let bit = 1u << si;
            var s = composite_new();
            var t = captured;
            var done = 0u;
            for (var i = 0u; i < n; i++) {
                let f = local[i];
                if (fragment_coverage(f) & bit) == 0u {
                    continue;
                }
                if done < limit {
                    composite_front(&s, f);
                    done += 1u;
                    used[i / 32u] |= 1u << (i % 32u);
                } else if kp.tail_blend != 0u {
                    tail_add_local(&t, f);
                } else {
                    break;
                }
            }
            composite_tail(&s, t);
            resolved_sum_add(&sum, composite_finish(s));
        }
        kept = countOneBits(used.x) + countOneBits(used.y);
    } else {
        // Each sample's last composited fragment: a fragment is kept when it is not behind it
        // for some sample it covers (or that sample composited all of its fragments).
        var last: array<Composited, 8>;
        for (var si = 0u; si < samples; si++) {
            var s = composite_new();
            var t = captured;
            last[si] = k_depth_sort(p, n, limit, 1u << si, &s, &t);
            composite_tail(&s, t);
            resolved_sum_add(&sum, composite_finish(s));
        }
        for (var i = 0u; i < n; i++) {
            if !step() {
                break;
            }
            let f = stored_fragment(p, i);
            let coverage = fragment_coverage(f);
            for (var si = 0u; si < samples; si++) {
                let l = last[si];
                if (coverage & (1u << si)) != 0u && (l.done < limit || !fragment_before(l.f, f)) {
                    kept += 1u;
                    break;
                }
            }
        }
    }
    output[p] = resolved_mean(sum, samples, kept);
    return kept;
}

// --msaa with per-sample storage: each sample composites its own stored k nearest with its
// own tail, and the pixel is the samples' average. A fragment counts as stored once however
// many samples kept it: at its first covered sample that kept it, a sample having kept it when
// that sample stored all its fragments or the fragment is not behind its farthest stored one.
// That inference holds where each sample's storage is exact (its k nearest); where it is not —
// a failed lock sent a fragment to the tail, kb-ll ran out of tries, kb raced — a fragment
// missing from an earlier sample is counted at none, so `fragments_stored` runs low there
// (frames already flagged by `lock_failures`, or by kb's design).
fn resolve_sample_storage(p: u32) {
    let samples = kp.sample_slots;
    var sum = resolved_sum_new();
    var farthest: array<Fragment, 8>;
    var stored_all: array<bool, 8>;
    for (var si = 0u; si < samples; si++) {
        let q = sample_pixel(p, si);
        let n = stored_count(q);
        let limit = min(n, kp.k);
        resolved_sum_add(&sum, composite_pixel(q, n, limit, captured_tail(q)));
        stored_all[si] = atomicLoad(&pixels[pixel_word(q, SEEN)]) <= limit;
        var far = Fragment(0.0, 0u, 0u, 0u);
        for (var i = 0u; i < limit; i++) {
            let f = stored_fragment(q, i);
            if i == 0u || fragment_before(far, f) {
                far = f;
            }
        }
        farthest[si] = far;
    }
    var kept = 0u;
    for (var si = 0u; si < samples; si++) {
        let q = sample_pixel(p, si);
        let limit = min(stored_count(q), kp.k);
        for (var i = 0u; i < limit; i++) {
            let f = stored_fragment(q, i);
            let coverage = fragment_coverage(f);
            var earlier = false;
            for (var sj = 0u; sj < si; sj++) {
                if (coverage & (1u << sj)) != 0u && (stored_all[sj] || !fragment_before(farthest[sj], f)) {
                    earlier = true;
                    break;
                }
            }
            if !earlier {
                kept += 1u;
            }
        }
    }
    // kb's unlocked insertions can leave one fragment in two slots: never more than arrived.
    let generated = atomicLoad(&pixels[pixel_fragments_word(p)]);
    kept = min(kept, generated);
    output[p] = resolved_mean(sum, samples, kept);
    report_pixel(generated, kept);
}

#endif

// A loop of this invocation's resolve ended early: by lavapipe's loop limit (the loop's own
// counter says so) or by the step budget (`strata::steps`). The pixel is reported once.
var<private> pixel_cut_short: bool = false;

// cs_resolve's pixel step: its made compute stage calls it for each pixel of the frame.
fn cs_resolve_pixel(pixel: vec2<u32>) {
    resolve_pixel(kpixel_index(pixel));
    if pixel_cut_short || steps_spent() {
        report_cut_short();
    }
}

fn resolve_pixel(p: u32) {
#ifdef MULTISAMPLED
    if kp.sample_slots > 1u {
        resolve_sample_storage(p);
        return;
    }
#endif
    let seen = atomicLoad(&pixels[pixel_word(p, SEEN)]);
    let n = stored_count(p);
    let limit = min(n, kp.k);
    let t = captured_tail(p);
#ifdef MULTISAMPLED
    if frame.coverage_bits != 0u {
        report_pixel(seen, resolve_samples(p, n, limit, t));
        return;
    }
#endif
    output[p] = composite_pixel(p, n, limit, t);
    report_pixel(seen, limit);
}
