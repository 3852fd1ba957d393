#define_import_path strata::kbuffer::keys_resolve
#import strata::kbuffer::storage::{fragment_keys, kp}
#import strata::fragment::{Fragment}
#import strata::kbuffer::keys::{key_word, payload_word}

// Resolve access to kb-keys' slots: the kept keys form a prefix of each pixel's slots, already
// in (depth, primitive) order.

fn stored_count(p: u32) -> u32 {
    var n = 0u;
    while n < kp.k {
        if atomicLoad(&fragment_keys[key_word(p, n)]) == u64(0u) {
            break;
        }
        n += 1u;
    }
    return n;
}

fn stored_fragment(p: u32, i: u32) -> Fragment {
    let w = key_word(p, i);
    let key = ~atomicLoad(&fragment_keys[w]);
    let payload = atomicLoad(&fragment_keys[payload_word(w)]);
    return Fragment(
        bitcast<f32>(u32(key >> 32u)),
        u32(key & u64(0xffffffffu)),
        u32(payload & u64(0xffffffffu)),
        u32(payload >> 32u),
    );
}
