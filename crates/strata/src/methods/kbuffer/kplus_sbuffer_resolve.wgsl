#define_import_path strata::kbuffer::kplus_sbuffer_resolve
#import strata::kbuffer::storage::{pixel_word, pixels}
#import strata::kbuffer::words::{FILLED}
#import strata::fragment::{Fragment}
#import strata::kbuffer::kplus_sbuffer::{region_fits, region_size}
#import strata::kbuffer::slot_access::{load_slot, sort_slots}

// The memory-aware k+-buffer's resolve access (kplus_sbuffer.wgsl): the stored fragments of a
// region that fits.

fn stored_count(p: u32) -> u32 {
    if !region_fits(p) {
        return 0u;
    }
    return min(atomicLoad(&pixels[pixel_word(p, FILLED)]), region_size(p));
}

fn stored_fragment(p: u32, i: u32) -> Fragment {
    return load_slot(p, i);
}

// Puts pixel p's n slots of its region in (depth, tag) order in place (`sort_slots`).
fn sort_in_place(p: u32, n: u32) -> bool {
    return sort_slots(p, n);
}
