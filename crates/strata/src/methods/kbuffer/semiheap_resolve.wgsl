#define_import_path strata::kbuffer::semiheap_resolve
#import strata::kbuffer::storage::{kp, pixel_word, pixels}
#import strata::kbuffer::words::{FILLED}
#import strata::fragment::{Fragment}
#import strata::kbuffer::slot_access::{load_slot}

// Resolve access to the semi-heap: H's fragments (slots 0..|H|), then S's (slots h..).

fn stored_count(p: u32) -> u32 {
    let filled = atomicLoad(&pixels[pixel_word(p, FILLED)]);
    return (filled & 0xffffu) + (filled >> 16u);
}

fn stored_fragment(p: u32, i: u32) -> Fragment {
    let heap_size = atomicLoad(&pixels[pixel_word(p, FILLED)]) >> 16u;
    if i < heap_size {
        return load_slot(p, i);
    }
    return load_slot(p, kp.aux + i - heap_size);
}
