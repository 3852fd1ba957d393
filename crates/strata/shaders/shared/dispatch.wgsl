#define_import_path strata::dispatch

// A thread of a compute grid longer than one dimension holds (65535 workgroups): the workgroups
// lie `grid_x` to a row, and a thread is numbered by its workgroup's place in that order and
// its own place in the workgroup.
struct GridThread {
    @builtin(workgroup_id) workgroup: vec3<u32>,
    @builtin(local_invocation_index) local: u32,
}

// The number of the thread's workgroup.
fn grid_workgroup(t: GridThread, grid_x: u32) -> u32 {
    return t.workgroup.x + t.workgroup.y * grid_x;
}

// The number of the thread, in workgroups of `size` threads.
fn grid_thread(t: GridThread, grid_x: u32, size: u32) -> u32 {
    return grid_workgroup(t, grid_x) * size + t.local;
}
