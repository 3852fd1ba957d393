// convex capture pass: the groups of one pass, which cannot share a pixel, each give a pixel at
// most LAYERS fragments (two per convex part: the front-facing and the back-facing layer). They
// are appended unsorted behind the pixel's claim counter; the merge sorts them. A container is
// drawn twice, its front cap (fs_front) before what it holds and its back cap (fs_back) after.
// LAYERS is prepended by the method.

@group(1) @binding(0) var<storage, read_write> claims: array<atomic<u32>>;
@group(1) @binding(1) var<storage, read_write> slots: array<Fragment>;

fn capture(v: SceneVarying, front_facing: bool) {
    let i = pixel_index(pixel_of(v.position));
    // Claims past LAYERS are counted and dropped by the merge, never written.
    let n = atomicAdd(&claims[i], 1u);
    if n < LAYERS {
        slots[i * LAYERS + n] = scene_fragment(v, front_facing);
    }
}

@fragment
fn fs_whole(v: SceneVarying, @builtin(front_facing) front_facing: bool) {
    if behind_opaque(v.position) {
        discard;
    }
    capture(v, front_facing);
}

@fragment
fn fs_front(v: SceneVarying, @builtin(front_facing) front_facing: bool) {
    if !front_facing || behind_opaque(v.position) {
        discard;
    }
    capture(v, front_facing);
}

@fragment
fn fs_back(v: SceneVarying, @builtin(front_facing) front_facing: bool) {
    if front_facing || behind_opaque(v.position) {
        discard;
    }
    capture(v, front_facing);
}
