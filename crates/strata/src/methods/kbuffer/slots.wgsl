#define_import_path strata::kbuffer::slots
#import strata::kbuffer::storage::{fragment_words, kp, pixel_item}

// Fixed per-pixel slot arrays: `stride` fragment records of 4 words (depth bits, tag, rg, ba) per
// pixel, every word an atomic so that reads inside a spin lock see the last holder's writes
// (WGSL has no @coherent).

fn slot_word(p: u32, i: u32) -> u32 {
    return pixel_item(p, i, kp.stride) * 4u;
}
