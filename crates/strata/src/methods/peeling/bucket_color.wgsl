// Bucket depth peeling, pass 3 (color): a fragment whose depth is its bucket's nearest claims
// slot 2b, one at its farthest slot 2b + 1 (one atomicOr on the pixel's claim word), and the
// claimant stores its shaded record there. Everything else collided — a third fragment in a
// bucket, or an equal depth whose slot was taken — and is counted by the resolve as dropped.

@group(1) @binding(1) var bounds: texture_2d<f32>;
@group(1) @binding(2) var buckets: texture_2d_array<f32>;
@group(1) @binding(3) var<storage, read_write> claims: array<atomic<u32>>;
@group(1) @binding(4) var<storage, read_write> records: array<Fragment>;

// Claims `slot` of pixel p; true for the one fragment that gets it.
fn claim(p: u32, slot: u32) -> bool {
    let bit = 1u << slot;
    return (atomicOr(&claims[p], bit) & bit) == 0u;
}

@fragment
fn fs_color(v: SceneVarying, @builtin(front_facing) front_facing: bool) {
    if behind_opaque(v.position) {
        discard;
    }
    let pixel = pixel_of(v.position);
    let p = pixel_index(pixel);
    let z = v.position.z;
    let range = textureLoad(bounds, pixel, 0);
    let b = route(z, -range.x, range.y, p);
    let pair = textureLoad(buckets, pixel, b / 2u, 0);
    let c = 2u * (b % 2u);
    var slot = 2u * b;
    // Two fragments at one depth that is both the bucket's nearest and farthest take a slot each.
    var claimed = z == -pair[c] && claim(p, slot);
    if !claimed && z == pair[c + 1u] {
        slot += 1u;
        claimed = claim(p, slot);
    }
    if claimed {
        records[p * params.slots + slot] = scene_fragment(v, front_facing);
    }
}
