#define_import_path strata::peeling::dual_key32

// dual peeling's depth key without 64-bit atomics: the depth's bits (non-negative floats compare
// as their bits). Fragments at exactly equal depth in one pixel share a key: one is kept, the
// others are counted as dropped.

fn fragment_key(depth: f32, tag: u32) -> u32 {
    return bitcast<u32>(depth);
}

fn no_min() -> u32 {
    return 0xffffffffu;
}

fn no_max() -> u32 {
    return 0u;
}
