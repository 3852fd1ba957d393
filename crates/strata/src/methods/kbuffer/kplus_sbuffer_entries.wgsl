#define_import_path strata::kbuffer::kplus_sbuffer_entries
#import strata::scene::{SceneVarying, behind_opaque, scene_fragment_covering}
#import strata::fragment::{Fragment}
#import strata::kbuffer::counters::{COUNTER_OVERFLOWED}
#import strata::kbuffer::storage::{count_pixel_fragment, count_seen, counter_add, kp, kpixel, pixel_word, pixels, sample_pixel, storage_samples, storage_slots}
#import strata::kbuffer::words::{FILLED, SEEN}
#import strata::kbuffer::kplus_capture::{VARIANT_ARRAY, VARIANT_HEAP, insert_locked}
#import strata::kbuffer::kplus_sbuffer::{region_fits, region_size}
#import strata::kbuffer::slot_access::{store_slot}

// The memory-aware k+-buffer's geometry passes (storage in kplus_sbuffer.wgsl). With --msaa
// every sample pixel has its own count, region and k nearest.

// Above this k a full pixel keeps a max-heap (O(log k) per replacement), else a max-array.
const ARRAY_MAX_K: u32 = 16u;

// fs_kplus_sbuffer_count's capture step: its made fragment stage and the compute rasterizer call it.
fn fs_kplus_sbuffer_count_capture(v: SceneVarying, front_facing: bool, mask: u32) {
    if behind_opaque(v.position) {
        return;
    }
    let p = kpixel(v.position);
    count_pixel_fragment(p);
    let samples = storage_samples(mask);
#ifdef MULTISAMPLED
    for (var s = 0u; s < storage_slots(); s++) {
        if ((samples >> s) & 1u) != 0u {
            count_seen(sample_pixel(p, s));
        }
    }
#else
    if samples != 0u {
        count_seen(p);
    }
#endif
}

// A pixel with at most k fragments appends them without the lock (its region holds them all);
// a pixel with more keeps its k nearest under the lock, by max-array or max-heap.
fn store_in_region(p: u32, f: Fragment) {
    if !region_fits(p) {
        counter_add(COUNTER_OVERFLOWED, 1u);
        return;
    }
    if atomicLoad(&pixels[pixel_word(p, SEEN)]) <= kp.k {
        let n = atomicAdd(&pixels[pixel_word(p, FILLED)], 1u);
        if n < region_size(p) {
            store_slot(p, n, f);
        } else {
            // More fragments than the count pass saw: not from the same draws.
            counter_add(COUNTER_OVERFLOWED, 1u);
        }
        return;
    }
    insert_locked(p, f, select(VARIANT_HEAP, VARIANT_ARRAY, kp.k <= ARRAY_MAX_K));
}

// fs_kplus_sbuffer_store's capture step: its made fragment stage and the compute rasterizer call it.
fn fs_kplus_sbuffer_store_capture(v: SceneVarying, front_facing: bool, mask: u32) {
    if behind_opaque(v.position) {
        return;
    }
    let p = kpixel(v.position);
    let f = scene_fragment_covering(v, front_facing, mask);
    let samples = storage_samples(mask);
#ifdef MULTISAMPLED
    for (var s = 0u; s < storage_slots(); s++) {
        if ((samples >> s) & 1u) != 0u {
            store_in_region(sample_pixel(p, s), f);
        }
    }
#else
    if samples != 0u {
        store_in_region(p, f);
    }
#endif
}
