#define_import_path strata::kbuffer::kb_capture
#import strata::kbuffer::storage::{FILLED, count_seen, culled, kp, lock_failed, pixel_word, pixels, publish_bound, tail_add, try_lock, unlock}
#import strata::fragment::{Fragment, fragment_before}
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
    while i > 0u {
        let prev = load_slot(p, i - 1u);
        if !fragment_before(f, prev) {
            break;
        }
        store_slot(p, i, prev);
        i -= 1u;
    }
    store_slot(p, i, f);
    if n < kp.k {
        atomicStore(&pixels[pixel_word(p, FILLED)], n + 1u);
    }
    if n + 1u >= kp.k {
        publish_bound(p, load_slot(p, kp.k - 1u).depth);
    }
}

const UNLOCKED: u32 = 0u;
const LOCKED: u32 = 1u;

// The capture step of kb (UNLOCKED) and kb-ps (LOCKED); kb-ps tests the culling bound again
// before each try (see insert_locked).
fn capture_sorted(p: u32, f: Fragment, locking: u32) {
    count_seen(p);
    var waiting = true;
    if locking == UNLOCKED {
        if culled(p, f) {
            tail_add(p, f);
        } else {
            sorted_insert(p, f);
        }
        waiting = false;
    }
    for (var t = 0u; t < kp.max_tries && waiting; t++) {
        if culled(p, f) {
            tail_add(p, f);
            waiting = false;
        } else if try_lock(p) {
            sorted_insert(p, f);
            unlock(p);
            waiting = false;
        }
    }
    if waiting {
        lock_failed(p, f);
    }
}
