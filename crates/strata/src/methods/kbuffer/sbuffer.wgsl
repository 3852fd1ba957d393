#define_import_path strata::kbuffer::sbuffer
#import strata::scene::{SceneVarying, behind_opaque, scene_fragment_covering}
#import strata::fragment::{Fragment}
#import strata::kbuffer::counters::{COUNTER_OVERFLOWED}
#import strata::kbuffer::storage::{count_seen, counter_add, kpixel, pixel_word, pixels}
#import strata::kbuffer::words::{FILLED, SEEN}

// The S-buffer (seed 003 §4): every pixel's fragments in one contiguous region of a shared pool.
// A count pass counts each pixel's fragments (SEEN); an exclusive prefix sum over the pixels
// (sbuffer_scan.wgsl) gives each pixel its region's start (OFFSET, the lock word, which no
// S-buffer pass takes); a store pass writes fragment FILLED++ of the pixel at OFFSET + FILLED.
// Pixels without fragments take no memory. A region past the pool's end (a pool sized from an
// earlier frame's need) is cut there, and its lost fragments are counted (COUNTER_OVERFLOWED).

#ifdef COHERENT
@group(#{KBUFFER_GROUP}) @binding(1) @coherent var<storage, read_write> pool: array<Fragment>;
#else
@group(#{KBUFFER_GROUP}) @binding(1) var<storage, read_write> pool: array<Fragment>;
#endif

const OFFSET: u32 = 2u;

fn region_start(p: u32) -> u32 {
    return atomicLoad(&pixels[pixel_word(p, OFFSET)]);
}

// The prefix sum's hooks (sbuffer_scan.wgsl): a region per fragment, its start in OFFSET.
fn region_size(p: u32) -> u32 {
    return atomicLoad(&pixels[pixel_word(p, SEEN)]);
}

fn set_region_start(p: u32, start: u32) {
    atomicStore(&pixels[pixel_word(p, OFFSET)], start);
}

// fs_sbuffer_count's capture step: its made fragment stage and the compute rasterizer call it.
fn fs_sbuffer_count_capture(v: SceneVarying, front_facing: bool, mask: u32) {
    if behind_opaque(v.position) {
        return;
    }
    count_seen(kpixel(v.position));
}

// fs_sbuffer_store's capture step: its made fragment stage and the compute rasterizer call it.
fn fs_sbuffer_store_capture(v: SceneVarying, front_facing: bool, mask: u32) {
    if behind_opaque(v.position) {
        return;
    }
    let p = kpixel(v.position);
    let start = region_start(p);
    let n = atomicAdd(&pixels[pixel_word(p, FILLED)], 1u);
    // Within the pixel's own region even if this pass meets a fragment the count pass did not
    // (on the compute rasterizer the two passes are two pipelines, which may round a depth
    // against the opaque one differently).
    if n < region_size(p) && start < arrayLength(&pool) && n < arrayLength(&pool) - start {
        pool[start + n] = scene_fragment_covering(v, front_facing, mask);
    } else {
        counter_add(COUNTER_OVERFLOWED, 1u);
    }
}
