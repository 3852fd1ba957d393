#define_import_path strata::kbuffer::pack_resolve
#import strata::kbuffer::storage::{fragment_words}
#import strata::fragment::{Fragment}
#import strata::kbuffer::mdt::{key_count, key_slot, slots_in_frame, unpack_keys}

// Resolve access to kb-mdt-pack's two key arrays: slot i of each is taken as one fragment.

fn stored_count(p: u32) -> u32 {
    return key_count(p);
}

fn stored_fragment(p: u32, i: u32) -> Fragment {
    let s = key_slot(p, i);
    return unpack_keys(atomicLoad(&fragment_words[s]), atomicLoad(&fragment_words[slots_in_frame() + s]));
}
