#define_import_path strata::order::order_common
#import strata::dispatch::{GridThread, grid_thread}

// Shared by the triangle-order stages (keys, draw indices, Kendall sampling).
// Keep in sync with `OrderParams` in crates/strata/src/order/mod.rs.

struct OrderParams {
    // A point p lies at view depth dot(depth_row.xyz, p) + depth_row.w (larger is farther).
    depth_row: vec4<f32>,
    count: u32,
    mode: u32,
    // Random permutations and the Kendall samples draw from it; it changes every frame.
    seed: u32,
    // Workgroups per row of a two-dimensional dispatch (one dimension holds 65535).
    grid_x: u32,
    samples: u32,
    pad_a: u32,
    pad_b: u32,
    pad_c: u32,
}

const MODE_SCENE: u32 = 0u;
const MODE_FRONT: u32 = 1u;
const MODE_BACK: u32 = 2u;
const MODE_RANDOM: u32 = 3u;

@group(0) @binding(0) var<uniform> params: OrderParams;

// The thread's number in this family's dispatches (256-thread workgroups).
fn thread_index(at: GridThread) -> u32 {
    return grid_thread(at, params.grid_x, 256u);
}

// A 32-bit permutation with good avalanche (an LCG step, then a PCG output permutation): keys
// hashed from distinct indices never collide, so a random order has no ties.
fn scramble(v: u32) -> u32 {
    let state = v * 747796405u + 2891336453u;
    let word = ((state >> ((state >> 28u) + 4u)) ^ state) * 277803737u;
    return (word >> 22u) ^ word;
}
