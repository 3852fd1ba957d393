#define_import_path strata::order::radix_scan
#import strata::order::radix_common::{DIGITS, radix}

// One workgroup: the digit-major block counts become exclusive prefix sums in place, so entry
// (d, b) is where block b's first key of digit d goes. Each thread sums a contiguous chunk,
// the 256 chunk sums are scanned in workgroup memory, then each chunk is rewritten.

@group(0) @binding(1) var<storage, read_write> block_digits: array<u32>;

var<workgroup> chunk_sums: array<u32, 256>;

@compute @workgroup_size(256)
fn scan_digits(@builtin(local_invocation_index) local: u32) {
    let total = radix.blocks * DIGITS;
    let chunk = (total + 255u) / 256u;
    let start = min(local * chunk, total);
    let end = min(start + chunk, total);
    var sum = 0u;
    for (var i = start; i < end; i++) {
        sum += block_digits[i];
    }
    chunk_sums[local] = sum;
    workgroupBarrier();
    for (var offset = 1u; offset < 256u; offset *= 2u) {
        var v = chunk_sums[local];
        if local >= offset {
            v += chunk_sums[local - offset];
        }
        workgroupBarrier();
        chunk_sums[local] = v;
        workgroupBarrier();
    }
    var running = chunk_sums[local] - sum;
    for (var i = start; i < end; i++) {
        let c = block_digits[i];
        block_digits[i] = running;
        running += c;
    }
}
