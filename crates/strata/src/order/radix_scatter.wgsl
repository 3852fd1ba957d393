#define_import_path strata::order::radix_scatter
#import strata::dispatch::{GridThread}
#import strata::order::radix_common::{BLOCK, DIGITS, ITEMS, block_index, digit_of, radix}

// One workgroup per block, in four rounds of 256 keys: each key moves to its digit's next
// free place for this block. A key's rank among the round's keys of its digit comes from an
// inclusive scan over the workgroup of one-hot digit counters — sixteen 16-bit counters packed
// two to a word — so keys of equal digits keep their order and the sort is stable.

@group(0) @binding(1) var<storage, read> keys_in: array<u32>;
@group(0) @binding(2) var<storage, read> values_in: array<u32>;
@group(0) @binding(3) var<storage, read> block_offsets: array<u32>;
@group(0) @binding(4) var<storage, read_write> keys_out: array<u32>;
@group(0) @binding(5) var<storage, read_write> values_out: array<u32>;

var<workgroup> counters: array<array<u32, 8>, 256>;
var<workgroup> next_place: array<u32, 16>;

fn packed(words: ptr<function, array<u32, 8>>, digit: u32) -> u32 {
    return ((*words)[digit / 2u] >> (16u * (digit % 2u))) & 0xffffu;
}

@compute @workgroup_size(256)
fn scatter_keys(at: GridThread) {
    let local = at.local;
    let block = block_index(at);
    let live = block < radix.blocks;
    if local < DIGITS && live {
        next_place[local] = block_offsets[local * radix.blocks + block];
    }
    workgroupBarrier();
    for (var round = 0u; round < ITEMS; round++) {
        let i = block * BLOCK + round * 256u + local;
        let valid = live && i < radix.count;
        var key = 0u;
        var value = 0u;
        var digit = 0u;
        var mine: array<u32, 8>;
        if valid {
            key = keys_in[i];
            value = values_in[i];
            digit = digit_of(key);
            mine[digit / 2u] = 1u << (16u * (digit % 2u));
        }
        counters[local] = mine;
        workgroupBarrier();
        for (var offset = 1u; offset < 256u; offset *= 2u) {
            if local >= offset {
                for (var w = 0u; w < 8u; w++) {
                    mine[w] += counters[local - offset][w];
                }
            }
            workgroupBarrier();
            counters[local] = mine;
            workgroupBarrier();
        }
        if valid {
            let place = next_place[digit] + packed(&mine, digit) - 1u;
            if place < radix.count {
                keys_out[place] = key;
                values_out[place] = value;
            }
        }
        workgroupBarrier();
        if local < DIGITS {
            var last = counters[255];
            next_place[local] += packed(&last, local);
        }
        workgroupBarrier();
    }
}
