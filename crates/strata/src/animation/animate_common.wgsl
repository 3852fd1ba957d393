#define_import_path strata::animation::animate_common
#import strata::animation::params::{AnimationParams}
#import strata::dispatch::{GridThread, grid_thread}

// Shared by the animation stages (object transforms, moved vertices).

@group(0) @binding(0) var<uniform> params: AnimationParams;

// The thread's number in this family's dispatches (64-thread workgroups).
fn thread_index(at: GridThread) -> u32 {
    return grid_thread(at, params.grid_x, 64u);
}
