#define_import_path strata::kbuffer::slot_access
#import strata::fragment::{Fragment}
#import strata::kbuffer::storage::{fragment_words}
#ifdef STORAGE_KPLUS_SBUFFER
#import strata::kbuffer::kplus_sbuffer::{slot_word}
#else
#import strata::kbuffer::slots::{slot_word}
#endif

// Slot accessors over the fragment storage and a `slot_word(p, i)` (the word of slot i of pixel p) of the
// storage layout: fixed arrays (slots.wgsl) or, with STORAGE_KPLUS_SBUFFER, S-buffer regions
// (kplus_sbuffer.wgsl).

fn load_slot(p: u32, i: u32) -> Fragment {
    let w = slot_word(p, i);
    return Fragment(
        bitcast<f32>(atomicLoad(&fragment_words[w])),
        atomicLoad(&fragment_words[w + 1u]),
        atomicLoad(&fragment_words[w + 2u]),
        atomicLoad(&fragment_words[w + 3u]),
    );
}

// Depth and tag only: what ordering needs.
fn load_key(p: u32, i: u32) -> Fragment {
    let w = slot_word(p, i);
    return Fragment(bitcast<f32>(atomicLoad(&fragment_words[w])), atomicLoad(&fragment_words[w + 1u]), 0u, 0u);
}

fn store_slot(p: u32, i: u32, f: Fragment) {
    let w = slot_word(p, i);
    atomicStore(&fragment_words[w], bitcast<u32>(f.depth));
    atomicStore(&fragment_words[w + 1u], f.tag);
    atomicStore(&fragment_words[w + 2u], f.rg);
    atomicStore(&fragment_words[w + 3u], f.ba);
}

