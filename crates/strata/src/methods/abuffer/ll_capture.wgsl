// abuffer-ll capture: every fragment takes a node from the pool with an atomic counter and is
// pushed onto its pixel's list by exchanging the head. Heads hold node index + 1 (0 = empty).
// When the pool is full the counter still counts, so the frame knows how many nodes it needed.

struct Node {
    fragment: Fragment,
    next: u32,
}

@group(1) @binding(0) var<storage, read_write> heads: array<atomic<u32>>;
@group(1) @binding(1) var<storage, read_write> nodes: array<Node>;
@group(1) @binding(2) var<storage, read_write> allocated: array<atomic<u32>>;

// The capture step: any fragment shader with these bindings can call it with its own fragment.
fn capture(pixel: vec2<u32>, f: Fragment) {
    let node = atomicAdd(&allocated[0], 1u);
    if node >= arrayLength(&nodes) {
        return;
    }
    nodes[node].fragment = f;
    nodes[node].next = atomicExchange(&heads[pixel_index(pixel)], node + 1u);
}

@fragment
fn fs_capture(v: SceneVarying, @builtin(front_facing) front_facing: bool) {
    if behind_opaque(v.position) {
        discard;
    }
    capture(pixel_of(v.position), scene_fragment(v, front_facing));
}
