#define_import_path strata::order::radix_common
#import strata::dispatch::{GridThread, grid_workgroup}
#import strata::order::radix_pass::{RadixPass}

// Shared by the radix sort's stages: 4-bit digits, blocks of 1024 keys per workgroup of 256.

const DIGITS: u32 = 16u;
const ITEMS: u32 = 4u;
const BLOCK: u32 = 1024u;

@group(0) @binding(0) var<uniform> radix: RadixPass;

fn block_index(at: GridThread) -> u32 {
    return grid_workgroup(at, radix.grid_x);
}

fn digit_of(key: u32) -> u32 {
    return (key >> radix.shift) & (DIGITS - 1u);
}
