#define_import_path strata::kbuffer::slots_resolve
#import strata::kbuffer::storage::{kp, pixel_word, pixels}
#import strata::kbuffer::words::{FILLED, SEEN}
#import strata::fragment::{Fragment}
#import strata::kbuffer::slot_access::{load_slot, sort_slots}

// Resolve access to fixed per-pixel slot arrays (k+-buffers, kb, kb-ps, the fixed A-buffers).

fn stored_count(p: u32) -> u32 {
    if kp.aux != 0u {
        return min(atomicLoad(&pixels[pixel_word(p, SEEN)]), kp.stride);
    }
    return atomicLoad(&pixels[pixel_word(p, FILLED)]);
}

fn stored_fragment(p: u32, i: u32) -> Fragment {
    return load_slot(p, i);
}

// Puts pixel p's n slots in (depth, tag) order in place (`sort_slots`).
fn sort_in_place(p: u32, n: u32) -> bool {
    return sort_slots(p, n);
}
