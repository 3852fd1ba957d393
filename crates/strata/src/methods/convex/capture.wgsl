// convex capture pass: the groups of one pass, which cannot share a pixel, each give a pixel at
// most LAYERS fragments (two per convex part: the front-facing and the back-facing layer). They
// are appended unsorted behind the pixel's claim counter; the merge sorts them. A container is
// drawn twice, its front cap (fs_front) before what it holds and its back cap (fs_back) after.
// The first claim of a pixel in a pass lists the pixel, so the merge visits only the pixels the
// pass reached (a pass's groups cover a small part of the screen). LAYERS and MERGE_WORKGROUP
// are prepended by the method.

@group(1) @binding(0) var<storage, read_write> claims: array<atomic<u32>>;
@group(1) @binding(1) var<storage, read_write> slots: array<Fragment>;
// The pass's pixels in claim order, their count, and the merge's indirect dispatch (x counts
// started workgroups up to the 65535 a dimension allows; y and z are 1, set with the reset).
@group(1) @binding(2) var<storage, read_write> touched: array<u32>;
@group(1) @binding(3) var<storage, read_write> touched_count: atomic<u32>;
@group(1) @binding(4) var<storage, read_write> merge_args: array<atomic<u32>, 3>;

fn capture(v: SceneVarying, front_facing: bool) {
    let i = pixel_index(pixel_of(v.position));
    // Claims past LAYERS are counted and dropped by the merge, never written.
    let n = atomicAdd(&claims[i], 1u);
    if n == 0u {
        // Once per pixel and pass: the merge resets the claim, so t stays below the pixel count.
        let t = atomicAdd(&touched_count, 1u);
        if t < arrayLength(&touched) {
            touched[t] = i;
            if t % MERGE_WORKGROUP == 0u && t / MERGE_WORKGROUP < 65535u {
                atomicAdd(&merge_args[0], 1u);
            }
        }
    }
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
