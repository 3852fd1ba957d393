// dual peeling capture passes over a `Key` (dual_key32.wgsl or dual_key64.wgsl, prepended).
// bounds: nearest and farthest key per pixel. peel: the fragment at the current nearest key
// goes to the front slot, the one at the farthest to the back slot, everything between bounds
// the next pass. hits: per pixel the front and back slots' claims and (third word) every
// fragment of the pixel, counted by the bounds pass.

@group(1) @binding(0) var<storage, read> bounds: array<Key>;
@group(1) @binding(1) var<storage, read_write> next_bounds: array<atomic<Key>>;
@group(1) @binding(2) var<storage, read_write> layers: array<Fragment>;
@group(1) @binding(3) var<storage, read_write> hits: array<atomic<u32>>;

fn widen_next(i: u32, key: Key) {
    atomicMin(&next_bounds[2u * i], key);
    atomicMax(&next_bounds[2u * i + 1u], key);
}

fn key_of(v: SceneVarying, front_facing: bool) -> Key {
    return fragment_key(v.position.z, (v.prim << 1u) | select(0u, 1u, front_facing));
}

@fragment
fn fs_bounds(v: SceneVarying, @builtin(front_facing) front_facing: bool) {
    if behind_opaque(v.position) {
        discard;
    }
    let i = pixel_index(pixel_of(v.position));
    atomicAdd(&hits[3u * i + 2u], 1u);
    widen_next(i, key_of(v, front_facing));
}

@fragment
fn fs_peel(v: SceneVarying, @builtin(front_facing) front_facing: bool) {
    if behind_opaque(v.position) {
        discard;
    }
    let i = pixel_index(pixel_of(v.position));
    let key = key_of(v, front_facing);
    let lo = bounds[2u * i];
    let hi = bounds[2u * i + 1u];
    if key < lo || key > hi {
        return;
    }
    var slot = 2u * i;
    var claim = 3u * i;
    if key == hi && key != lo {
        slot += 1u;
        claim += 1u;
    } else if key != lo {
        widen_next(i, key);
        return;
    }
    // Fragments sharing a key (equal depth, 32-bit keys only) share a slot: the first keeps it,
    // the rest are counted.
    if atomicAdd(&hits[claim], 1u) == 0u {
        layers[slot] = scene_fragment(v, front_facing);
    }
}
