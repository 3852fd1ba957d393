#define_import_path strata::animation::animate_common
#import strata::dispatch::{GridThread, grid_thread}

// Shared by the animation stages (object transforms, moved vertices).
// Keep in sync with `AnimationParams` and `GpuMotion` in crates/strata/src/animation/mod.rs.

struct AnimationParams {
    // The time (frames) this frame shows, and the time the previous frame showed.
    time: f32,
    previous_time: f32,
    objects: u32,
    // Workgroups per row of a two-dimensional dispatch (one dimension holds 65535).
    grid_x: u32,
    // 1 when the moved vertices' triangle centroids are also written (for --order).
    write_centroids: u32,
    pad_a: u32,
    pad_b: u32,
    pad_c: u32,
}

// One object's motion: its object-space mesh scaled by `scale` and carried along the orbit
// centre + radius·(cos a·u + sin a·v), a = angular_speed·t + phase. `moving` 0: the object
// stays where its rest vertices are (world space).
struct Motion {
    centre: vec3<f32>,
    radius: f32,
    u: vec3<f32>,
    angular_speed: f32,
    v: vec3<f32>,
    phase: f32,
    scale: f32,
    moving: u32,
    pad_a: u32,
    pad_b: u32,
}

@group(0) @binding(0) var<uniform> params: AnimationParams;

// The thread's number in this family's dispatches (64-thread workgroups).
fn thread_index(at: GridThread) -> u32 {
    return grid_thread(at, params.grid_x, 64u);
}
