#define_import_path strata::kbuffer::kplus_sbuffer
#import strata::kbuffer::storage::{fragment_words, kp, pixel_word, pixels}
#import strata::kbuffer::words::{SEEN}

// The memory-aware k+-buffer (seed 003 §4.1): k+-buffer slots in S-buffer regions. The count
// pass counts each pixel's fragments (SEEN); the prefix sum (sbuffer_scan.wgsl) over
// min(SEEN, k) gives each pixel a region of exactly that many slots; the store pass fills it.
// `slots` holds the pixels' region starts (`header_words()`: one per pixel, or per sample pixel
// with --msaa; the lock word is the k+-buffer's) and then the pool of 4-word fragment records (slot_access.wgsl). A pixel whose whole region
// does not fit in the pool (a pool sized from an earlier frame's need) stores nothing and counts
// its fragments as overflowed; its resolve sees no fragments.

fn region_start(p: u32) -> u32 {
    return atomicLoad(&fragment_words[p]);
}

// The prefix sum's hooks: min(f(p), k) slots per pixel, starts in the header.
fn region_size(p: u32) -> u32 {
    return min(atomicLoad(&pixels[pixel_word(p, SEEN)]), kp.k);
}

fn set_region_start(p: u32, start: u32) {
    atomicStore(&fragment_words[p], start);
}

fn header_words() -> u32 {
    return kp.pixels * kp.sample_slots;
}

fn slot_word(p: u32, i: u32) -> u32 {
    return header_words() + (region_start(p) + i) * 4u;
}

// Whether the pixel's whole region lies inside the pool (no overflowing arithmetic).
fn region_fits(p: u32) -> bool {
    let pool_slots = (arrayLength(&fragment_words) - header_words()) / 4u;
    let start = region_start(p);
    return start <= pool_slots && region_size(p) <= pool_slots - start;
}
