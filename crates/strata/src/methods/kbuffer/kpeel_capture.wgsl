#define_import_path strata::kbuffer::kpeel_capture
#import strata::scene::{SceneVarying, behind_opaque, scene_fragment_covering}
#import strata::kbuffer::storage::{count_pixel_fragment, count_seen, kp, kpixel, pixel_word, pixels, sample_pixel, storage_samples, storage_slots}
#import strata::kbuffer::words::{FILLED}
#import strata::kbuffer::kplus_capture::{VARIANT_ARRAY, VARIANT_HEAP, capture_locked}
#import strata::kbuffer::kpeel_state::{peel_pending}

// k-depth peeling capture (seed 003 §4.3): each geometry pass keeps the k nearest fragments
// strictly after the pixel's last composited one in (depth, primitive) order — a k+-buffer
// capture (max-array for k ≤ 16, max-heap above) behind that bound. Ordering by the pair, not
// the depth alone, loses nothing at exactly equal depths. With --msaa every sample peels on its
// own: a fragment enters the capture of each covered sample it is still pending at.


// fs_kpeel's capture step: its made fragment stage and the compute rasterizer call it.
fn fs_kpeel_capture(v: SceneVarying, front_facing: bool, mask: u32) {
    if behind_opaque(v.position) {
        return;
    }
    let p = kpixel(v.position);
    let f = scene_fragment_covering(v, front_facing, mask);
    let variant = select(VARIANT_HEAP, VARIANT_ARRAY, kp.k <= 16u);
    let samples = storage_samples(mask);
#ifdef MULTISAMPLED
    for (var s = 0u; s < storage_slots(); s++) {
        let q = sample_pixel(p, s);
        // Composited by an earlier pass where not pending.
        if ((samples >> s) & 1u) != 0u && peel_pending(q, f) {
            capture_locked(q, f, variant);
        }
    }
#else
    if samples != 0u && peel_pending(p, f) {
        capture_locked(p, f, variant);
    }
#endif
}

// --msaa's account, a geometry pass after the last resolve (the per-pixel words cleared): each
// fragment once at its pixel, once at each sample it covers (a sample's depth complexity), and
// as stored when some covered sample composited it (not pending there: per sample, peeling
// composites in order). The counts go to sample pixel 0's FILLED word and to each sample's
// SEEN word.
// fs_kpeel_account's capture step: its made fragment stage and the compute rasterizer call it.
fn fs_kpeel_account_capture(v: SceneVarying, front_facing: bool, mask: u32) {
    if behind_opaque(v.position) {
        return;
    }
    let p = kpixel(v.position);
    let f = scene_fragment_covering(v, front_facing, mask);
    count_pixel_fragment(p);
    let samples = storage_samples(mask);
    var stored = false;
    for (var s = 0u; s < storage_slots(); s++) {
        if ((samples >> s) & 1u) == 0u {
            continue;
        }
        let q = sample_pixel(p, s);
        count_seen(q);
        stored = stored || !peel_pending(q, f);
    }
    if stored {
        atomicAdd(&pixels[pixel_word(sample_pixel(p, 0u), FILLED)], 1u);
    }
}
