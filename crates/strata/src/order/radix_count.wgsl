#define_import_path strata::order::radix_count
#import strata::dispatch::{GridThread}
#import strata::order::radix_common::{BLOCK, DIGITS, ITEMS, block_index, digit_of, radix}

// One workgroup per block: how many of its keys have each digit, stored digit-major
// (block_digits[d * blocks + b]) so that one scan turns the counts into scatter offsets.

@group(0) @binding(1) var<storage, read> keys_in: array<u32>;
@group(0) @binding(2) var<storage, read_write> block_digits: array<u32>;

var<workgroup> tally: array<atomic<u32>, 16>;

@compute @workgroup_size(256)
fn count_digits(at: GridThread) {
    let local = at.local;
    if local < DIGITS {
        atomicStore(&tally[local], 0u);
    }
    workgroupBarrier();
    let block = block_index(at);
    if block < radix.blocks {
        for (var item = 0u; item < ITEMS; item++) {
            let i = block * BLOCK + item * 256u + local;
            if i < radix.count {
                atomicAdd(&tally[digit_of(keys_in[i])], 1u);
            }
        }
    }
    workgroupBarrier();
    if local < DIGITS && block < radix.blocks {
        block_digits[local * radix.blocks + block] = atomicLoad(&tally[local]);
    }
}
