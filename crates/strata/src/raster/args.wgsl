#define_import_path strata::raster::args
#import strata::raster::params::{RasterParams}

// Turns the bin stage's item count into the raster stage's indirect dispatch: 64 items per
// workgroup, at most 65535 workgroups per dimension.

@group(0) @binding(0) var<uniform> rp: RasterParams;
@group(0) @binding(1) var<storage, read> raster_counters: array<u32>;
@group(0) @binding(2) var<storage, read_write> dispatch_args: array<u32>;

@compute @workgroup_size(1)
fn cs_args() {
    var n = raster_counters[0];
    if raster_counters[1] != 0u || n > rp.capacity {
        n = rp.capacity;
    }
    let groups = (n + 63u) / 64u;
    let x = min(groups, 65535u);
    dispatch_args[0] = x;
    dispatch_args[1] = select(1u, (groups + x - 1u) / max(x, 1u), x > 0u);
    dispatch_args[2] = 1u;
}
