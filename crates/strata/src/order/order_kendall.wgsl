#define_import_path strata::order::order_kendall
#import strata::dispatch::{GridThread}
#import strata::order::order_common::{MODE_SCENE, params, scramble, thread_index}

// One thread per sampled pair of submission positions i < j: the pair is discordant when the
// triangle submitted first lies farther than the one submitted later. Pairs of equal depth
// count in neither total, so front to back gives 0 and back to front 1.

@group(0) @binding(1) var<storage, read> sorted_triangles: array<u32>;
@group(0) @binding(2) var<storage, read> depth_keys: array<u32>;
// [discordant pairs, pairs of distinct depth]; cleared every frame.
@group(0) @binding(3) var<storage, read_write> pair_counts: array<atomic<u32>, 2>;

fn submitted(position: u32) -> u32 {
    if params.mode == MODE_SCENE {
        return position;
    }
    return min(sorted_triangles[position], params.count - 1u);
}

@compute @workgroup_size(256)
fn sample_pairs(at: GridThread) {
    let s = thread_index(at);
    if s >= params.samples || params.count < 2u {
        return;
    }
    let h = scramble(s ^ scramble(params.seed ^ 0x9e3779b9u));
    let a = h % params.count;
    let b = scramble(h) % params.count;
    if a == b {
        return;
    }
    let first = depth_keys[submitted(min(a, b))];
    let later = depth_keys[submitted(max(a, b))];
    if first != later {
        atomicAdd(&pair_counts[1], 1u);
        if first > later {
            atomicAdd(&pair_counts[0], 1u);
        }
    }
}
