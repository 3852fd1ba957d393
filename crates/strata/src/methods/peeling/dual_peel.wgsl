// dual peeling capture passes. Depths compare as the bits of non-negative floats.
// bounds: nearest and farthest depth per pixel. peel: the fragment at the current nearest depth
// goes to the front slot, the one at the farthest to the back slot, everything between bounds
// the next pass. hits: per pixel the front and back slots' claims and (third word) every
// fragment of the pixel, counted by the bounds pass.

@group(1) @binding(0) var<storage, read> bounds: array<vec2<u32>>;
@group(1) @binding(1) var<storage, read_write> next_bounds: array<atomic<u32>>;
@group(1) @binding(2) var<storage, read_write> layers: array<Fragment>;
@group(1) @binding(3) var<storage, read_write> hits: array<atomic<u32>>;

fn widen_next(i: u32, bits: u32) {
    atomicMin(&next_bounds[2u * i], bits);
    atomicMax(&next_bounds[2u * i + 1u], bits);
}

@fragment
fn fs_bounds(v: SceneVarying) {
    if behind_opaque(v.position) {
        discard;
    }
    let i = pixel_index(pixel_of(v.position));
    atomicAdd(&hits[3u * i + 2u], 1u);
    widen_next(i, bitcast<u32>(v.position.z));
}

@fragment
fn fs_peel(v: SceneVarying, @builtin(front_facing) front_facing: bool) {
    if behind_opaque(v.position) {
        discard;
    }
    let i = pixel_index(pixel_of(v.position));
    let bits = bitcast<u32>(v.position.z);
    let b = bounds[i];
    if bits < b.x || bits > b.y {
        return;
    }
    var slot = 2u * i;
    var claim = 3u * i;
    if bits == b.y && bits != b.x {
        slot += 1u;
        claim += 1u;
    } else if bits != b.x {
        widen_next(i, bits);
        return;
    }
    // Fragments at exactly the same depth share a slot: the first keeps it, the rest are counted.
    if atomicAdd(&hits[claim], 1u) == 0u {
        layers[slot] = scene_fragment(v, front_facing);
    }
}
