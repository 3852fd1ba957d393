// dual peeling's depth key without 64-bit atomics: the depth's bits (non-negative floats compare
// as their bits). Fragments at exactly equal depth in one pixel share a key: one is kept, the
// others are counted as dropped.

alias Key = u32;

fn fragment_key(depth: f32, tag: u32) -> Key {
    return bitcast<u32>(depth);
}

fn no_min() -> Key {
    return 0xffffffffu;
}

fn no_max() -> Key {
    return 0u;
}
