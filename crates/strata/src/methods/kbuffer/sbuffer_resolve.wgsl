#define_import_path strata::kbuffer::sbuffer_resolve
#import strata::kbuffer::storage::{pixel_word, pixels}
#import strata::kbuffer::words::{FILLED}
#import strata::fragment::{Fragment}
#import strata::kbuffer::sbuffer::{pool, region_size, region_start}

// Resolve access to the S-buffer: a pixel's region (never past what the count pass sized it
// for), cut at the pool's end.

fn stored_count(p: u32) -> u32 {
    let start = region_start(p);
    let room = select(0u, arrayLength(&pool) - start, start < arrayLength(&pool));
    return min(min(atomicLoad(&pixels[pixel_word(p, FILLED)]), region_size(p)), room);
}

fn stored_fragment(p: u32, i: u32) -> Fragment {
    return pool[region_start(p) + i];
}
