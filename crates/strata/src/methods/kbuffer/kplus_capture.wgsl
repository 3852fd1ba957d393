#define_import_path strata::kbuffer::kplus_capture
#import strata::kbuffer::storage::{acquire_published, count_seen, culled, kp, lock_failed, pixel_word, pixels, publish_bound, release_published, spend_tries, tail_add, try_budget, try_lock, unlock}
#import strata::kbuffer::words::{BOUND, FILLED}
#import strata::fragment::{Fragment, fragment_before}
#import strata::kbuffer::slot_access::{load_key, load_slot, store_slot}

// k+-buffer capture (Vasilakis et al. 2015): the k nearest fragments, unsorted, in one pass.
// max-array keeps the farthest stored fragment in slot 0; max-heap keeps a binary max-heap.
// Fragments strictly behind the published bound of a full pixel (storage.wgsl) are culled before
// taking the lock, and the full test is repeated inside it. Order is (depth, primitive): exact
// with ties.

// Counts the fragment just stored in slot `n` of a filling pixel (lock held), and publishes the
// bound (slot 0, the farthest) once that fills the pixel.
fn count_filled(p: u32, n: u32) {
    atomicStore(&pixels[pixel_word(p, FILLED)], n + 1u);
    if n + 1u == kp.k {
        publish_bound(p, load_slot(p, 0u).depth);
    }
}

// `f` against the farthest fragment (slot 0) of a pixel whose kept fragments are full (lock
// held): the farther of the two joins the tail. True when that is the stored one, whose place
// `f` then takes.
fn evict_farthest(p: u32, f: Fragment) -> bool {
    let m = load_slot(p, 0u);
    if !fragment_before(f, m) {
        tail_add(p, f);
        return false;
    }
    tail_add(p, m);
    return true;
}

// Inserts into a max-array holding `n` fragments (lock held).
fn array_insert(p: u32, n: u32, f: Fragment) {
    if n < kp.k {
        if n > 0u {
            let m = load_slot(p, 0u);
            if fragment_before(m, f) {
                store_slot(p, n, m);
                store_slot(p, 0u, f);
            } else {
                store_slot(p, n, f);
            }
        } else {
            store_slot(p, 0u, f);
        }
        count_filled(p, n);
        return;
    }
    if evict_farthest(p, f) {
        array_replace_max(p, f);
        publish_bound(p, load_slot(p, 0u).depth);
    }
}

// Puts `f` in place of the maximum of a full max-array and moves the new maximum to slot 0.
fn array_replace_max(p: u32, f: Fragment) {
    var max_key = f;
    var max_i = 0u;
    for (var i = 1u; i < kp.k; i++) {
        let c = load_key(p, i);
        if fragment_before(max_key, c) {
            max_key = c;
            max_i = i;
        }
    }
    if max_i == 0u {
        store_slot(p, 0u, f);
    } else {
        store_slot(p, 0u, load_slot(p, max_i));
        store_slot(p, max_i, f);
    }
}

// Puts `f` at index `i` of a max-heap in the pixel's slots 0.. and sifts it up (lock held).
fn heap_sift_up(p: u32, start: u32, f: Fragment) {
    var i = start;
    while i > 0u {
        let parent = (i - 1u) / 2u;
        let pf = load_slot(p, parent);
        if !fragment_before(pf, f) {
            break;
        }
        store_slot(p, i, pf);
        i = parent;
    }
    store_slot(p, i, f);
}

// Puts `f` in place of the root of a full max-heap of `size` slots and sifts it down (lock held).
fn heap_sift_down(p: u32, size: u32, f: Fragment) {
    var i = 0u;
    loop {
        let left = 2u * i + 1u;
        if left >= size {
            break;
        }
        var child = left;
        var cf = load_slot(p, left);
        if left + 1u < size {
            let rf = load_slot(p, left + 1u);
            if fragment_before(cf, rf) {
                child = left + 1u;
                cf = rf;
            }
        }
        if !fragment_before(f, cf) {
            break;
        }
        store_slot(p, i, cf);
        i = child;
    }
    store_slot(p, i, f);
}

fn heap_insert(p: u32, n: u32, f: Fragment) {
    if n < kp.k {
        heap_sift_up(p, n, f);
        count_filled(p, n);
        return;
    }
    if evict_farthest(p, f) {
        heap_sift_down(p, kp.k, f);
        publish_bound(p, load_slot(p, 0u).depth);
    }
}

const VARIANT_ARRAY: u32 = 0u;
const VARIANT_HEAP: u32 = 1u;

// The capture step of kplus-array (variant 0) and kplus-heap (variant 1): any fragment shader
// with these bindings can call it with its pixel (`kpixel`) and its fragment.
fn capture_locked(p: u32, f: Fragment, variant: u32) {
    count_seen(p);
    insert_locked(p, f, variant);
}

// The insertion under the pixel's lock (the fragment is already counted). A waiter tests the
// culling bound again before each try: the bound only falls, so a fragment culled while it
// waited is behind the k nearest for good and goes to the tail without the lock.
fn insert_locked(p: u32, f: Fragment, variant: u32) {
    var waiting = true;
    let budget = try_budget();
    var t = 0u;
    for (; t < budget && waiting; t++) {
        if culled(p, f) {
            tail_add(p, f);
            waiting = false;
        } else if try_lock(p) {
            let n = atomicLoad(&pixels[pixel_word(p, FILLED)]);
            if variant == VARIANT_ARRAY {
                array_insert(p, n, f);
            } else {
                heap_insert(p, n, f);
            }
            unlock(p);
            waiting = false;
        }
    }
    spend_tries(t);
    if waiting {
        lock_failed(p, f);
    }
}

// Revised max-array: the first k fragments take slots from the seen counter without the lock
// ("fast store") and publish themselves in FILLED (release); later fragments wait until all k
// are published (acquire: their stores are then visible) before they try the lock, find the
// maximum once (a published bound marks it found), then replace as the max-array does. The fast
// stores come first in program order, in an `if` of their own, so a SIMD group finishes them
// before any of its lanes waits: a slow fragment never waits on a fast store of its own group.
fn capture_array_r(p: u32, f: Fragment) {
    let s = count_seen(p);
    let fast = s < kp.k;
    if fast {
        store_slot(p, s, f);
        release_published(pixel_word(p, FILLED), 1u);
    }
    var waiting = !fast;
    let budget = try_budget();
    var t = 0u;
    for (; t < budget && waiting; t++) {
        if culled(p, f) {
            tail_add(p, f);
            waiting = false;
        } else if acquire_published(pixel_word(p, FILLED)) >= kp.k && try_lock(p) {
            if atomicLoad(&pixels[pixel_word(p, BOUND)]) == 0u {
                array_replace_max(p, load_slot(p, 0u));
                publish_bound(p, load_slot(p, 0u).depth);
            }
            if evict_farthest(p, f) {
                array_replace_max(p, f);
                publish_bound(p, load_slot(p, 0u).depth);
            }
            unlock(p);
            waiting = false;
        }
    }
    spend_tries(t);
    if waiting {
        lock_failed(p, f);
    }
}
