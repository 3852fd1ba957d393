#define_import_path strata::kbuffer::mdt32_resolve
#import strata::kbuffer::storage::{fragment_words}
#import strata::fragment::{Fragment}
#import strata::kbuffer::mdt::{key_count, key_depth, key_slot, slots_in_frame}

// Resolve access to kb-mdt32's keys and colors. A slot whose color no fragment claimed (a depth
// tie lost in the color pass) has zero color and opacity.

fn stored_count(p: u32) -> u32 {
    return key_count(p);
}

fn stored_fragment(p: u32, i: u32) -> Fragment {
    let s = key_slot(p, i);
    let c = 2u * slots_in_frame() + 3u * s;
    return Fragment(key_depth(atomicLoad(&fragment_words[s])), atomicLoad(&fragment_words[c]), atomicLoad(&fragment_words[c + 1u]), atomicLoad(&fragment_words[c + 2u]));
}
