#define_import_path strata::kbuffer::semiheap_capture
#import strata::kbuffer::storage::{acquire_published, count_seen, culled, kp, lock_failed, pixel_word, pixels, publish_bound, release_published, spend_tries, tail_add, try_budget, try_lock, unlock}
#import strata::kbuffer::words::{FILLED}
#import strata::fragment::{Fragment, fragment_before}
#import strata::kbuffer::slot_access::{load_key, load_slot, store_slot}
#import strata::kbuffer::kplus_capture::{evict_farthest, heap_sift_down, heap_sift_up}

// The semi-heap k-buffer (seed 000, `kplus-semiheap`): each pixel's k slots are a max-heap H of
// |H| = h slots (0..h), holding the h farthest of the cached fragments, and an unordered
// sequence S (h..k) with the rest. The first k − h fragments take S's slots from the seen counter
// without the lock (it starts past the heap). Later fragments are culled against the published
// bound (H's root, once H is full) before the lock and tested again inside it; inside, the
// farthest b of S and the incoming fragment moves into H (sift-up while H fills, in place of the
// evicted root and sift-down once full) and the incoming fragment takes b's slot. FILLED counts
// S's published fast stores in its low 16 bits and H's size in its high 16 (k ≤ 256). `kp.aux`
// is h. Exact: H always holds the h farthest of the k nearest.

const SEMIHEAP_H_ONE: u32 = 0x10000u;

fn semiheap_insert(p: u32, heap_size: u32, f: Fragment) {
    let h = kp.aux;
    if heap_size == h && !evict_farthest(p, f) {
        return;
    }
    // b: the farthest of S and f.
    var b = f;
    var b_at = kp.k;
    for (var i = h; i < kp.k; i++) {
        let c = load_key(p, i);
        if fragment_before(b, c) {
            b = c;
            b_at = i;
        }
    }
    if b_at < kp.k {
        b = load_slot(p, b_at);
        store_slot(p, b_at, f);
    }
    if heap_size < h {
        heap_sift_up(p, heap_size, b);
        atomicAdd(&pixels[pixel_word(p, FILLED)], SEMIHEAP_H_ONE);
        if heap_size + 1u < h {
            return;
        }
    } else {
        heap_sift_down(p, h, b);
    }
    publish_bound(p, load_slot(p, 0u).depth);
}

// The capture step of kplus-semiheap. The direct stores come first in program order, in an `if`
// of their own, and are published in FILLED's low half (release); a later fragment waits until
// all are published (acquire) before it tries the lock (see capture_array_r), and tests the
// culling bound again before each try (see insert_locked).
fn capture_semiheap(p: u32, f: Fragment) {
    let direct = kp.k - kp.aux;
    let s = count_seen(p);
    let fast = s < direct;
    if fast {
        store_slot(p, kp.aux + s, f);
        release_published(pixel_word(p, FILLED), 1u);
    }
    var waiting = !fast;
    let budget = try_budget();
    var t = 0u;
    for (; t < budget && waiting; t++) {
        if culled(p, f) {
            tail_add(p, f);
            waiting = false;
        } else if (acquire_published(pixel_word(p, FILLED)) & 0xffffu) >= direct && try_lock(p) {
            let filled = atomicLoad(&pixels[pixel_word(p, FILLED)]);
            semiheap_insert(p, filled >> 16u, f);
            unlock(p);
            waiting = false;
        }
    }
    spend_tries(t);
    if waiting {
        lock_failed(p, f);
    }
}
