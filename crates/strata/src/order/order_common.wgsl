#define_import_path strata::order::order_common
#import strata::dispatch::{GridThread, grid_thread}
#import strata::order::params::{OrderParams}

// Shared by the triangle-order stages (keys, draw indices, Kendall sampling).

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
