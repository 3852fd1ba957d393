#define_import_path strata::kbuffer::slot_access
#import strata::fragment::{Fragment, fragment_before}
#import strata::kbuffer::storage::{fragment_words}
#ifdef STORAGE_KPLUS_SBUFFER
#import strata::kbuffer::kplus_sbuffer::{slot_word}
#else
#import strata::kbuffer::slots::{slot_word}
#endif
#import strata::steps::{step}

// Slot accessors over the fragment storage and a `slot_word(p, i)` (the word of slot i of pixel p) of the
// storage layout: fixed arrays (slots.wgsl) or, with STORAGE_KPLUS_SBUFFER, S-buffer regions
// (kplus_sbuffer.wgsl).

fn load_slot(p: u32, i: u32) -> Fragment {
    let w = slot_word(p, i);
    return Fragment(
        bitcast<f32>(atomicLoad(&fragment_words[w])),
        atomicLoad(&fragment_words[w + 1u]),
        atomicLoad(&fragment_words[w + 2u]),
        atomicLoad(&fragment_words[w + 3u]),
    );
}

// Depth and tag only: what ordering needs.
fn load_key(p: u32, i: u32) -> Fragment {
    let w = slot_word(p, i);
    return Fragment(bitcast<f32>(atomicLoad(&fragment_words[w])), atomicLoad(&fragment_words[w + 1u]), 0u, 0u);
}

fn store_slot(p: u32, i: u32, f: Fragment) {
    let w = slot_word(p, i);
    atomicStore(&fragment_words[w], bitcast<u32>(f.depth));
    atomicStore(&fragment_words[w + 1u], f.tag);
    atomicStore(&fragment_words[w + 2u], f.rg);
    atomicStore(&fragment_words[w + 3u], f.ba);
}

// Swaps pixel p's slots i and j.
fn swap_slots(p: u32, i: u32, j: u32) {
    let a = load_slot(p, i);
    store_slot(p, i, load_slot(p, j));
    store_slot(p, j, a);
}

// Whether pixel p's first n slots are in (depth, tag) order: one walk, which ends at the first
// slot out of order (false too where the adapter ended the walk early).
fn slots_in_order(p: u32, n: u32) -> bool {
    var i = 1u;
    for (; i < n; i++) {
        if !step() {
            break;
        }
        if fragment_before(load_key(p, i), load_key(p, i - 1u)) {
            return false;
        }
    }
    return i >= n;
}

// Restores the max-heap (the farthest fragment at the root) of pixel p's first `size` slots
// below `root`; false where the adapter ended the loop early (a heap of 2^32 slots is 32 deep).
fn sift_down(p: u32, root_at: u32, size: u32) -> bool {
    var root = root_at;
    for (var depth = 0u; depth < 32u; depth++) {
        if !step() {
            return false;
        }
        let left = 2u * root + 1u;
        if left >= size {
            return true;
        }
        var child = left;
        if left + 1u < size && fragment_before(load_key(p, left), load_key(p, left + 1u)) {
            child = left + 1u;
        }
        if !fragment_before(load_key(p, root), load_key(p, child)) {
            return true;
        }
        swap_slots(p, root, child);
        root = child;
    }
    return false;
}

// Sorts pixel p's first n slots in place into (depth, tag) order, so that a resolve reads them
// in order: a heap sort, at most 2·n·log₂ n steps, where the k-depth sort takes O(n²/32) (a
// GPU display's watchdog and lavapipe's loop limit meet the latter first); one walk where they
// are already in order (each sample after its pixel's first with --msaa). The slots' tags are
// unique within a pixel, so the order is total and an unstable sort gives the k-depth sort's
// order. Only the resolve runs it, one invocation per pixel, after every capture. False where a
// loop ended early (lavapipe's loop limit): the slots are then not in order.
fn sort_slots(p: u32, n: u32) -> bool {
    if slots_in_order(p, n) {
        return true;
    }
    var complete = true;
    var built = 0u;
    for (; built < n / 2u; built++) {
        if !step() {
            break;
        }
        complete = sift_down(p, n / 2u - 1u - built, n) && complete;
    }
    var end = n;
    for (; end > 1u; end--) {
        if !step() {
            break;
        }
        swap_slots(p, 0u, end - 1u);
        complete = sift_down(p, 0u, end - 1u) && complete;
    }
    return complete && built == n / 2u && end <= 1u;
}
