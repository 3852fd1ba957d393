#define_import_path strata::peeling::dual_key64

// dual peeling's key with 64-bit atomics (SHADER_INT64_ATOMIC_MIN_MAX): the depth's bits above
// the fragment's tag (primitive << 1 | facing). A primitive covers a pixel once, so keys are
// unique and fragments at equal depth peel one by one in primitive order, as f2b peels them.

fn fragment_key(depth: f32, tag: u32) -> u64 {
    return (u64(bitcast<u32>(depth)) << 32u) | u64(tag);
}

fn no_min() -> u64 {
    return (u64(0xffffffffu) << 32u) | u64(0xffffffffu);
}

fn no_max() -> u64 {
    return u64(0u);
}
