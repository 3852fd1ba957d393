#define_import_path strata::kbuffer::kb_capture
#import strata::kbuffer::storage::{count_seen, culled, kp, lock_failed, pixel_word, pixels, publish_bound, spend_tries, tail_add, try_budget, try_lock, unlock}
#import strata::kbuffer::words::{FILLED}
#import strata::fragment::{Fragment, fragment_before, fragment_color}
#import strata::kbuffer::slot_access::{load_slot, store_slot}

// The k-buffer with sorted insertion (Bavoil et al. 2007): slots kept in (depth, primitive)
// order, a new fragment shifts the farther ones back and the last falls out.
// `kb` does it with no lock: concurrent fragments of one pixel read, modify and write the same
// slots, and the hazard's artifacts are the method's known flaw, kept as they are.
// `kb-ps` does the same inside the per-pixel spin lock, standing in for pixel synchronisation.

fn sorted_insert(p: u32, f: Fragment) {
    let n = atomicLoad(&pixels[pixel_word(p, FILLED)]);
    var i = n;
    if n >= kp.k {
        let last = load_slot(p, kp.k - 1u);
        if !fragment_before(f, last) {
            tail_add(p, f);
            return;
        }
        tail_add(p, last);
        i = kp.k - 1u;
    }
    shift_in(p, i, f);
    if n < kp.k {
        atomicStore(&pixels[pixel_word(p, FILLED)], n + 1u);
    }
    if n + 1u >= kp.k {
        publish_bound(p, load_slot(p, kp.k - 1u).depth);
    }
}

// Stores `f` in its place among the sorted slots before slot `end` (whose content it
// overwrites), moving the ones after it back by one.
fn shift_in(p: u32, end: u32, f: Fragment) {
    var i = end;
    while i > 0u {
        let prev = load_slot(p, i - 1u);
        if !fragment_before(f, prev) {
            break;
        }
        store_slot(p, i, prev);
        i -= 1u;
    }
    store_slot(p, i, f);
}

// Multi-layer alpha blending (Salvi & Vaidyanathan 2014), `mlab`: the slots hold up to k layers
// in (depth, primitive) order, each a fragment or several merged into one. A new fragment takes
// its place in the order; when that makes k + 1 layers the two farthest merge. Nothing is culled
// (a fragment behind every layer merges into the last), so every fragment takes the lock.
fn mlab_insert(p: u32, f: Fragment) {
    let n = atomicLoad(&pixels[pixel_word(p, FILLED)]);
    if n < kp.k {
        shift_in(p, n, f);
        atomicStore(&pixels[pixel_word(p, FILLED)], n + 1u);
        return;
    }
    let last = kp.k - 1u;
    let farthest = load_slot(p, last);
    if !fragment_before(f, farthest) {
        store_slot(p, last, merge_layers(farthest, f));
        return;
    }
    shift_in(p, last, f);
    store_slot(p, last, merge_layers(load_slot(p, last), farthest));
}

// Two adjacent layers as one: the front one's key and the pair's opacity and straight color, so
// compositing it equals compositing `front` then `back` (without absorption between them).
fn merge_layers(front: Fragment, back: Fragment) -> Fragment {
    let a = fragment_color(front);
    let b = fragment_color(back);
    let alpha = a.a + (1.0 - a.a) * b.a;
    var color = vec3<f32>(0.0);
    if alpha > 0.0 {
        color = (a.a * a.rgb + (1.0 - a.a) * b.a * b.rgb) / alpha;
    }
    return Fragment(front.depth, front.tag, pack2x16float(color.rg), pack2x16float(vec2<f32>(color.b, alpha)));
}

// The capture step of mlab: the insertion under the pixel's lock (no culling bound to test
// while waiting: every fragment is merged somewhere).
fn capture_mlab(p: u32, f: Fragment) {
    count_seen(p);
    var waiting = true;
    let budget = try_budget();
    var t = 0u;
    for (; t < budget && waiting; t++) {
        if try_lock(p) {
            mlab_insert(p, f);
            unlock(p);
            waiting = false;
        }
    }
    spend_tries(t);
    if waiting {
        lock_failed(p, f);
    }
}

// The capture step of kb: the sorted insertion with no lock. A function apart from kb-ps's,
// with no lock loop at all: a software rasterizer runs a loop's body at least once under its
// lanes' masks, even one no lane enters.
fn capture_sorted_unlocked(p: u32, f: Fragment) {
    count_seen(p);
    if culled(p, f) {
        tail_add(p, f);
    } else {
        sorted_insert(p, f);
    }
}

// The capture step of kb-ps: the sorted insertion under the pixel's lock, testing the culling
// bound again before each try (see insert_locked).
fn capture_sorted_locked(p: u32, f: Fragment) {
    count_seen(p);
    var waiting = true;
    let budget = try_budget();
    var t = 0u;
    for (; t < budget && waiting; t++) {
        if culled(p, f) {
            tail_add(p, f);
            waiting = false;
        } else if try_lock(p) {
            sorted_insert(p, f);
            unlock(p);
            waiting = false;
        }
    }
    spend_tries(t);
    if waiting {
        lock_failed(p, f);
    }
}
