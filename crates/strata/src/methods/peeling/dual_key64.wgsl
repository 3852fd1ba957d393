// dual peeling's key with 64-bit atomics (SHADER_INT64_ATOMIC_MIN_MAX): the depth's bits above
// the fragment's tag (primitive << 1 | facing). A primitive covers a pixel once, so keys are
// unique and fragments at equal depth peel one by one in primitive order, as f2b peels them.

alias Key = u64;

fn fragment_key(depth: f32, tag: u32) -> Key {
    return (u64(bitcast<u32>(depth)) << 32u) | u64(tag);
}

fn no_min() -> Key {
    return (u64(0xffffffffu) << 32u) | u64(0xffffffffu);
}

fn no_max() -> Key {
    return u64(0u);
}
