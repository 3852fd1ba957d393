#define_import_path strata::kbuffer::kpeel_resolve
#import strata::scene::{frame, report_pixel, report_samples}
#import strata::color::{Resolved, resolved_mean, resolved_sum_add, resolved_sum_new}
#import strata::composite::{composite_finish, composite_new}
#import strata::kbuffer::storage::{kp, kpixel_index, output, pixel_fragments_word, pixel_word, pixels, sample_pixel, storage_slots}
#import strata::kbuffer::words::{FILLED, SEEN}
#import strata::kbuffer::resolve::{composite_stored}
#import strata::tail::{tail_empty}
#import strata::kbuffer::access::{stored_count}
#import strata::kbuffer::kpeel_state::{kpeel_state, kpeel_store}

// k-depth peeling's compute passes: init (an empty composite per pixel, or per sample with
// --msaa), resolve after each geometry pass (the captured layers composited behind the running
// result), finish (the accounting; with --msaa the samples' average).
//
// The multisampled paths compile only with MULTISAMPLED (they would double the resolve).
// Accounting: a pixel is reported once, in the pass that finishes it (it saw at most k
// fragments behind its bound); one still unfinished after the last pass is reported by finish,
// the fragments behind its last bound counted as dropped. Either way generated = composited
// before the pass + seen in it. With --msaa the account pass (kpeel_capture.wgsl) counts, and
// finish reports.

// cs_kpeel_init's pixel step: its made compute stage calls it for each pixel of the frame.
fn cs_kpeel_init_pixel(pixel: vec2<u32>) {
    let p = kpixel_index(pixel);
    for (var s = 0u; s < storage_slots(); s++) {
        kpeel_store(sample_pixel(p, s), composite_new());
    }
}

// Composites what (sample) pixel q captured this pass behind its running result; returns the
// fragments it captured, 0 when it saw none.
fn kpeel_resolve_one(q: u32) -> u32 {
    let seen = atomicLoad(&pixels[pixel_word(q, SEEN)]);
    if seen == 0u {
        return 0u;
    }
    let n = stored_count(q);
    let limit = min(n, kp.k);
    var s = kpeel_state(q);
    var t = tail_empty();
    composite_stored(q, n, limit, &s, &t);
    kpeel_store(q, s);
    return limit;
}

// cs_kpeel_resolve's pixel step: its made compute stage calls it for each pixel of the frame.
fn cs_kpeel_resolve_pixel(pixel: vec2<u32>) {
    let p = kpixel_index(pixel);
#ifdef MULTISAMPLED
    if kp.sample_slots > 1u {
        for (var s = 0u; s < storage_slots(); s++) {
            kpeel_resolve_one(sample_pixel(p, s));
        }
        return;
    }
#endif
    let limit = kpeel_resolve_one(p);
    let seen = atomicLoad(&pixels[pixel_word(p, SEEN)]);
    if seen > 0u && seen <= kp.k {
        report_pixel(output[p].count - limit + seen, output[p].count);
    }
}

// cs_kpeel_finish's pixel step: its made compute stage calls it for each pixel of the frame.
fn cs_kpeel_finish_pixel(pixel: vec2<u32>) {
    let p = kpixel_index(pixel);
#ifdef MULTISAMPLED
    if kp.sample_slots > 1u {
        var sum = resolved_sum_new();
        var deepest = 0u;
        for (var s = 0u; s < storage_slots(); s++) {
            let q = sample_pixel(p, s);
            resolved_sum_add(&sum, composite_finish(kpeel_state(q)));
            deepest = max(deepest, atomicLoad(&pixels[pixel_word(q, SEEN)]));
        }
        let generated = atomicLoad(&pixels[pixel_fragments_word(p)]);
        let stored = atomicLoad(&pixels[pixel_word(sample_pixel(p, 0u), FILLED)]);
        output[p] = resolved_mean(sum, kp.sample_slots, stored);
        report_samples(generated, stored, deepest);
        return;
    }
#endif
    let seen = atomicLoad(&pixels[pixel_word(p, SEEN)]);
    if seen > kp.k {
        let count = output[p].count;
        report_pixel(count - min(stored_count(p), kp.k) + seen, count);
    }
}
