#define_import_path strata::kbuffer::keys
#import strata::scene::{SceneVarying, behind_opaque, scene_fragment_covering}
#import strata::fragment::{Fragment}
#import strata::kbuffer::storage::{clearly_behind, count_pixel_fragment, count_seen, fragment_keys, kp, kpixel, pixel_item, sample_pixel, storage_pixels, storage_samples, storage_slots, tail_add}

// kb-keys: the lock-free exact k-buffer. Each slot is two 64-bit words: a key — the depth's bits
// above the fragment's tag, inverted so that 0 marks an empty slot and a larger key is a nearer
// fragment — and the payload (the color's two f16 pairs); every key comes before every payload,
// so the keys pass touches keys alone. Keys are unique per pixel, so the (depth, primitive)
// order is total and nothing is lost or swapped at equal depths.
// A keys pass sends each fragment's key through an atomicMax cascade over its pixel's k slots
// (the key displaced from a slot carries on to the next), which keeps the k nearest sorted with
// no lock; with culling on, a binary search of the slots finds where a key enters, so a key not
// nearer than a full pixel's k-th never reaches an atomic. A colors pass finds each fragment's
// slot (by its own key's binary search where the depth is invariant, else by its tag) and
// stores its payload there; a fragment whose key was not kept goes to the tail. Nothing spins
// and nothing can fail: relaxed atomics suffice, since the passes are separated by the render
// pass boundary. Needs SHADER_INT64_ATOMIC_ALL_OPS.

fn fragment_key(f: Fragment) -> u64 {
    return ~((u64(bitcast<u32>(f.depth)) << 32u) | u64(f.tag));
}

// Pixel p's i-th key; the keys of every pixel come first, then the payloads (`payload_word`).
fn key_word(p: u32, i: u32) -> u32 {
    return pixel_item(p, i, kp.k);
}

// The payload of the fragment whose key is at word `key_at`.
fn payload_word(key_at: u32) -> u32 {
    return kp.k * storage_pixels() + key_at;
}

// The first of pixel p's slots whose key is not nearer than `key` (k when all are: the key is
// culled). A pixel's keys stay in descending order, and a slot's key only grows during the pass,
// so a slot read as nearer stays nearer, and so do the slots before it: a binary search of loads
// stands in for the atomicMax calls that would leave those slots as they are, which are the most
// contended words of the pass (every fragment of the pixel passes its first slots). The last
// slot is read first: once a pixel is full it culls most keys with one load.
fn first_slot_not_nearer(p: u32, key: u64) -> u32 {
    if atomicLoad(&fragment_keys[key_word(p, kp.k - 1u)]) > key {
        return kp.k;
    }
    var low = 0u;
    var high = kp.k - 1u;
    while low < high {
        let middle = (low + high) / 2u;
        if atomicLoad(&fragment_keys[key_word(p, middle)]) > key {
            low = middle + 1u;
        } else {
            high = middle;
        }
    }
    return low;
}

// The keys pass for one storage pixel: counts the fragment and cascades its key from the first
// slot it can enter. With --culling off the cascade starts at the first slot, as the papers'.
fn cascade_key(p: u32, f: Fragment) {
    count_seen(p);
    var key = fragment_key(f);
    var first = 0u;
    if kp.culling != 0u {
        first = first_slot_not_nearer(p, key);
    }
    for (var i = first; i < kp.k; i++) {
        let old = atomicMax(&fragment_keys[key_word(p, i)], key);
        if old == u64(0u) {
            break;
        }
        key = min(key, old);
    }
}

// The colors pass for one storage pixel: the slot whose key carries the fragment's tag gets its
// payload. Which slot is decided by the kept key alone — not by a depth or an opaque test this
// pass would compute again — so a kept key always gets its payload. Where the rasterizer gives
// the fragment its keys-pass depth again (INVARIANT_DEPTH), the fragment's own key finds its
// slot by the same binary search the keys pass ran (the keys are final and sorted): log k loads
// instead of a walk over the slots; and one clearly behind a full pixel's k-th key was not kept
// (`clearly_behind`: one more load of the slot the search read first). A kept fragment whose
// depth came out otherwise in this pass falls through to the walk by tag.
fn store_payload(p: u32, f: Fragment) -> bool {
#ifdef INVARIANT_DEPTH
    let key = fragment_key(f);
    let slot = first_slot_not_nearer(p, key);
    if slot < kp.k {
        let w = key_word(p, slot);
        if atomicLoad(&fragment_keys[w]) == key {
            store_payload_at(w, f);
            return true;
        }
    }
    let last = atomicLoad(&fragment_keys[key_word(p, kp.k - 1u)]);
    if last != u64(0u) && clearly_behind(f.depth, ~u32(last >> 32u)) {
        return false;
    }
#endif
    let tag_word = ~f.tag;
    for (var i = 0u; i < kp.k; i++) {
        let w = key_word(p, i);
        let stored = atomicLoad(&fragment_keys[w]);
        // Kept keys fill the slots from the first: an empty one ends them.
        if stored == u64(0u) {
            break;
        }
        if u32(stored & u64(0xffffffffu)) == tag_word {
            store_payload_at(w, f);
            return true;
        }
    }
    return false;
}

// Stores f's color as the payload of the key at word `key_at`.
fn store_payload_at(key_at: u32, f: Fragment) {
    atomicStore(&fragment_keys[payload_word(key_at)], (u64(f.ba) << 32u) | u64(f.rg));
}

// The colors pass for one storage pixel: the payload into its slot, or a fragment not kept
// (beyond the k nearest; the keys pass hid nothing it kept) into the tail.
fn store_or_tail(p: u32, f: Fragment, hidden: bool) {
    if !store_payload(p, f) && !hidden {
        tail_add(p, f);
    }
}

// fs_keys's capture step: its made fragment stage and the compute rasterizer call it.
fn fs_keys_capture(v: SceneVarying, front_facing: bool, mask: u32) {
    if behind_opaque(v.position) {
        return;
    }
    let pixel = kpixel(v.position);
    let f = scene_fragment_covering(v, front_facing, mask);
    count_pixel_fragment(pixel);
    let samples = storage_samples(mask);
#ifdef MULTISAMPLED
    for (var s = 0u; s < storage_slots(); s++) {
        if ((samples >> s) & 1u) != 0u {
            cascade_key(sample_pixel(pixel, s), f);
        }
    }
#else
    if samples != 0u {
        cascade_key(pixel, f);
    }
#endif
}

// fs_keys_colors's capture step: its made fragment stage and the compute rasterizer call it.
fn fs_keys_colors_capture(v: SceneVarying, front_facing: bool, mask: u32) {
    let pixel = kpixel(v.position);
    let f = scene_fragment_covering(v, front_facing, mask);
    let samples = storage_samples(mask);
    let hidden = behind_opaque(v.position);
#ifdef MULTISAMPLED
    for (var s = 0u; s < storage_slots(); s++) {
        if ((samples >> s) & 1u) != 0u {
            store_or_tail(sample_pixel(pixel, s), f, hidden);
        }
    }
#else
    if samples != 0u {
        store_or_tail(pixel, f, hidden);
    }
#endif
}
