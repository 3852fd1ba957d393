#define_import_path strata::kbuffer::list_entries
#import strata::scene::{SceneVarying, behind_opaque, scene_fragment_covering}
#import strata::kbuffer::storage::{count_pixel_fragment, kp, kpixel, sample_pixel, storage_samples, storage_slots}
#import strata::kbuffer::list::{capture_list, capture_sorted_list}

// The built-in capture entry points of the linked-list methods.

// fs_ab_ll's capture step: its made fragment stage and the compute rasterizer call it.
fn fs_ab_ll_capture(v: SceneVarying, front_facing: bool, mask: u32) {
    if behind_opaque(v.position) {
        return;
    }
    capture_list(kpixel(v.position), scene_fragment_covering(v, front_facing, mask));
}

// kb-ll: sorted insertion into the pixel's list, or with --msaa into each covered sample's.
// fs_sorted_ll's capture step: its made fragment stage and the compute rasterizer call it.
fn fs_sorted_ll_capture(v: SceneVarying, front_facing: bool, mask: u32) {
    if behind_opaque(v.position) {
        return;
    }
    let p = kpixel(v.position);
    let f = scene_fragment_covering(v, front_facing, mask);
    count_pixel_fragment(p);
    let samples = storage_samples(mask);
#ifdef MULTISAMPLED
    for (var s = 0u; s < storage_slots(); s++) {
        if ((samples >> s) & 1u) != 0u {
            capture_sorted_list(sample_pixel(p, s), f);
        }
    }
#else
    if samples != 0u {
        capture_sorted_list(p, f);
    }
#endif
}
