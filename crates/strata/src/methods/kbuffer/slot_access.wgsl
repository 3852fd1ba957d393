#define_import_path strata::kbuffer::slot_access
#import strata::fragment::{Fragment}
#ifdef STORAGE_KPLUS_SBUFFER
#import strata::kbuffer::kplus_sbuffer::{slot_word, slots}
#else
#import strata::kbuffer::slots::{slot_word, slots}
#endif

// Slot accessors over `slots` and a `slot_word(p, i)` (the word of slot i of pixel p) of the
// storage layout: fixed arrays (slots.wgsl) or, with STORAGE_KPLUS_SBUFFER, S-buffer regions
// (kplus_sbuffer.wgsl).

fn load_slot(p: u32, i: u32) -> Fragment {
    let w = slot_word(p, i);
    return Fragment(
        bitcast<f32>(atomicLoad(&slots[w])),
        atomicLoad(&slots[w + 1u]),
        atomicLoad(&slots[w + 2u]),
        atomicLoad(&slots[w + 3u]),
    );
}

// Depth and tag only: what ordering needs.
fn load_key(p: u32, i: u32) -> Fragment {
    let w = slot_word(p, i);
    return Fragment(bitcast<f32>(atomicLoad(&slots[w])), atomicLoad(&slots[w + 1u]), 0u, 0u);
}

fn store_slot(p: u32, i: u32, f: Fragment) {
    let w = slot_word(p, i);
    atomicStore(&slots[w], bitcast<u32>(f.depth));
    atomicStore(&slots[w + 1u], f.tag);
    atomicStore(&slots[w + 2u], f.rg);
    atomicStore(&slots[w + 3u], f.ba);
}

