// Fixed per-pixel slot arrays: `stride` fragment records of 4 words (depth bits, tag, rg, ba) per
// pixel, every word an atomic so that reads inside a spin lock see the last holder's writes
// (WGSL has no @coherent).

@group(1) @binding(1) var<storage, read_write> slots: array<atomic<u32>>;

fn slot_word(p: u32, i: u32) -> u32 {
    return (p * kp.stride + i) * 4u;
}

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

