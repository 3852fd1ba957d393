#define_import_path strata::kbuffer::sbuffer_scan
#import strata::kbuffer::scan_level::{ScanLevel}
#ifdef STORAGE_KPLUS_SBUFFER
#import strata::kbuffer::kplus_sbuffer::{region_size, set_region_start}
#else
#import strata::kbuffer::sbuffer::{region_size, set_region_start}
#endif

// The S-buffer's exclusive prefix sum over the pixels' region sizes, in levels of 256: `gather`
// copies each pixel's `region_size` into level 0 of `scan`; `scan_blocks` replaces each block of 256 values of a level by
// its exclusive prefix sums and writes the block's total into the next level; `add_block_offsets`
// adds each block's scanned total back, top level down; `scatter` hands the results to
// `set_region_start`. The storage layout's module (sbuffer.wgsl, or kplus_sbuffer.wgsl with STORAGE_KPLUS_SBUFFER) defines both. Sums saturate at 2³² − 1
// instead of wrapping, so a frame with more fragments than a u32 counts gets starts past any pool
// (its regions then count as overflowed) rather than starts that overlap other regions. Keep `ScanLevel` in sync with `ScanLevel` in sbuffer.rs.


@group(2) @binding(0) var<uniform> level: ScanLevel;
@group(2) @binding(1) var<storage, read_write> scan: array<u32>;

const SCAN_BLOCK: u32 = 256u;

var<workgroup> tile: array<u32, 256>;

fn saturating_add(a: u32, b: u32) -> u32 {
    return select(a + b, 0xffffffffu, a > 0xffffffffu - b);
}

fn scan_index(wid: vec3<u32>, lid: vec3<u32>) -> u32 {
    return (wid.y * level.groups_x + wid.x) * SCAN_BLOCK + lid.x;
}

@compute @workgroup_size(256)
fn cs_gather(@builtin(workgroup_id) wid: vec3<u32>, @builtin(local_invocation_id) lid: vec3<u32>) {
    let i = scan_index(wid, lid);
    if i < level.len {
        scan[level.offset + i] = region_size(i);
    }
}

@compute @workgroup_size(256)
fn cs_scan_blocks(@builtin(workgroup_id) wid: vec3<u32>, @builtin(local_invocation_id) lid: vec3<u32>) {
    let i = scan_index(wid, lid);
    var v = 0u;
    if i < level.len {
        v = scan[level.offset + i];
    }
    tile[lid.x] = v;
    workgroupBarrier();
    // Hillis–Steele inclusive scan of the tile: 8 steps for 256 values.
    for (var d = 1u; d < SCAN_BLOCK; d = d << 1u) {
        var t = 0u;
        if lid.x >= d {
            t = tile[lid.x - d];
        }
        workgroupBarrier();
        tile[lid.x] = saturating_add(tile[lid.x], t);
        workgroupBarrier();
    }
    if i < level.len {
        // A saturated inclusive sum leaves the exclusive one unknown: saturated too.
        scan[level.offset + i] = select(tile[lid.x] - v, 0xffffffffu, tile[lid.x] == 0xffffffffu);
    }
    // Dispatches wrapped into y may run groups past the level's end: they write nothing.
    let group = wid.y * level.groups_x + wid.x;
    if lid.x == SCAN_BLOCK - 1u && group * SCAN_BLOCK < level.len {
        scan[level.sums + group] = tile[lid.x];
    }
}

@compute @workgroup_size(256)
fn cs_add_block_offsets(@builtin(workgroup_id) wid: vec3<u32>, @builtin(local_invocation_id) lid: vec3<u32>) {
    let i = scan_index(wid, lid);
    if i < level.len {
        scan[level.offset + i] = saturating_add(scan[level.offset + i], scan[level.sums + wid.y * level.groups_x + wid.x]);
    }
}

@compute @workgroup_size(256)
fn cs_scatter(@builtin(workgroup_id) wid: vec3<u32>, @builtin(local_invocation_id) lid: vec3<u32>) {
    let i = scan_index(wid, lid);
    if i < level.len {
        set_region_start(i, scan[level.offset + i]);
    }
}
