#define_import_path strata::kbuffer::slots_entries
#import strata::scene::{SceneVarying, behind_opaque, scene_fragment, scene_fragment_covering}
#import strata::fragment::{Fragment}
#import strata::kbuffer::storage::{count_pixel_fragment, count_temporal_cull, kp, kpixel, sample_pixel, storage_samples, storage_slots, tail_add}
#import strata::kbuffer::temporal::{note_outside, temporally_culled}
#import strata::kbuffer::kplus_capture::{VARIANT_ARRAY, VARIANT_HEAP, capture_array_r, capture_locked}
#import strata::kbuffer::kb_capture::{capture_mlab, capture_sorted_locked, capture_sorted_unlocked}
#import strata::kbuffer::fixed_capture::{capture_fixed}
#import strata::kbuffer::semiheap_capture::{capture_semiheap}

// The built-in capture entry points of the slot k-buffers: the scene's rasterized fragments,
// tested against the opaque depth and (except the fixed arrays) temporal culling, through each
// method's capture step.

// Temporal culling before any lock (temporal.wgsl): true when the fragment was culled — then
// counted, noted in the interface, and blended into the tail with --tail blend.
fn culled_by_last_frame(v: SceneVarying, front_facing: bool) -> bool {
    if !temporally_culled(v.world, v.position, v.prim) {
        return false;
    }
    count_temporal_cull();
    let p = kpixel(v.position);
    if kp.tail_blend != 0u {
        tail_add(p, scene_fragment(v, front_facing));
    } else {
        note_outside(p, v.position.z);
    }
    return true;
}

const CAPTURE_KPLUS_ARRAY: u32 = 0u;
const CAPTURE_KPLUS_HEAP: u32 = 1u;
const CAPTURE_KPLUS_ARRAY_R: u32 = 2u;
const CAPTURE_KB: u32 = 3u;
const CAPTURE_KB_PS: u32 = 4u;
const CAPTURE_KPLUS_SEMIHEAP: u32 = 5u;
const CAPTURE_MLAB: u32 = 6u;

// The capture step of a capture-time k-buffer (the argument is a constant at every call site).
fn capture_step(p: u32, f: Fragment, method: u32) {
    switch method {
        case CAPTURE_KPLUS_ARRAY: {
            capture_locked(p, f, VARIANT_ARRAY);
        }
        case CAPTURE_KPLUS_HEAP: {
            capture_locked(p, f, VARIANT_HEAP);
        }
        case CAPTURE_KPLUS_ARRAY_R: {
            capture_array_r(p, f);
        }
        case CAPTURE_KB: {
            capture_sorted_unlocked(p, f);
        }
        case CAPTURE_KB_PS: {
            capture_sorted_locked(p, f);
        }
        case CAPTURE_MLAB: {
            capture_mlab(p, f);
        }
        default: {
            capture_semiheap(p, f);
        }
    }
}

// A rasterized fragment through a capture-time k-buffer: into its pixel's storage, or with
// --msaa into the storage of each sample it covers (each sample keeps its own k nearest; the
// fragment is shaded once). Pixel fragments are counted once for the statistics.
fn capture_covering(v: SceneVarying, front_facing: bool, mask: u32, method: u32) {
    if behind_opaque(v.position) {
        return;
    }
    if culled_by_last_frame(v, front_facing) {
        return;
    }
    let p = kpixel(v.position);
    let f = scene_fragment_covering(v, front_facing, mask);
    count_pixel_fragment(p);
    let samples = storage_samples(mask);
#ifdef MULTISAMPLED
    for (var s = 0u; s < storage_slots(); s++) {
        if ((samples >> s) & 1u) != 0u {
            capture_step(sample_pixel(p, s), f, method);
        }
    }
#else
    if samples != 0u {
        capture_step(p, f, method);
    }
#endif
}

// fs_kplus_array's capture step: its made fragment stage and the compute rasterizer call it.
fn fs_kplus_array_capture(v: SceneVarying, front_facing: bool, mask: u32) {
    capture_covering(v, front_facing, mask, CAPTURE_KPLUS_ARRAY);
}

// fs_kplus_heap's capture step: its made fragment stage and the compute rasterizer call it.
fn fs_kplus_heap_capture(v: SceneVarying, front_facing: bool, mask: u32) {
    capture_covering(v, front_facing, mask, CAPTURE_KPLUS_HEAP);
}

// fs_kplus_array_r's capture step: its made fragment stage and the compute rasterizer call it.
fn fs_kplus_array_r_capture(v: SceneVarying, front_facing: bool, mask: u32) {
    capture_covering(v, front_facing, mask, CAPTURE_KPLUS_ARRAY_R);
}

// fs_kb's capture step: its made fragment stage and the compute rasterizer call it.
fn fs_kb_capture(v: SceneVarying, front_facing: bool, mask: u32) {
    capture_covering(v, front_facing, mask, CAPTURE_KB);
}

// fs_kb_ps's capture step: its made fragment stage and the compute rasterizer call it.
fn fs_kb_ps_capture(v: SceneVarying, front_facing: bool, mask: u32) {
    capture_covering(v, front_facing, mask, CAPTURE_KB_PS);
}

// fs_mlab's capture step: its made fragment stage and the compute rasterizer call it.
fn fs_mlab_capture(v: SceneVarying, front_facing: bool, mask: u32) {
    capture_covering(v, front_facing, mask, CAPTURE_MLAB);
}

// fs_fixed's capture step: its made fragment stage and the compute rasterizer call it.
fn fs_fixed_capture(v: SceneVarying, front_facing: bool, mask: u32) {
    if behind_opaque(v.position) {
        return;
    }
    capture_fixed(kpixel(v.position), scene_fragment_covering(v, front_facing, mask));
}

// fs_kplus_semiheap's capture step: its made fragment stage and the compute rasterizer call it.
fn fs_kplus_semiheap_capture(v: SceneVarying, front_facing: bool, mask: u32) {
    capture_covering(v, front_facing, mask, CAPTURE_KPLUS_SEMIHEAP);
}
