#define_import_path strata::order::order_keys
#import strata::dispatch::{GridThread}
#import strata::order::order_common::{MODE_BACK, MODE_RANDOM, MODE_SCENE, params, scramble, thread_index}

// One thread per triangle: its centroid's view depth as an orderable integer, and the key the
// sort orders by (the depth, its complement for back to front, or a hash for a random order).

@group(0) @binding(1) var<storage, read> centroids: array<f32>;
@group(0) @binding(2) var<storage, read_write> depth_keys: array<u32>;
@group(0) @binding(3) var<storage, read_write> sort_keys: array<u32>;
@group(0) @binding(4) var<storage, read_write> sort_values: array<u32>;

// Floats as unsigned integers in the same order: negatives have every bit flipped, the rest
// gain the sign bit.
fn orderable(x: f32) -> u32 {
    let bits = bitcast<u32>(x);
    return select(bits | 0x80000000u, ~bits, (bits & 0x80000000u) != 0u);
}

@compute @workgroup_size(256)
fn triangle_keys(at: GridThread) {
    let t = thread_index(at);
    if t >= params.count {
        return;
    }
    let c = vec3<f32>(centroids[3u * t], centroids[3u * t + 1u], centroids[3u * t + 2u]);
    let depth = orderable(dot(params.depth_row.xyz, c) + params.depth_row.w);
    depth_keys[t] = depth;
    if params.mode == MODE_SCENE {
        return;
    }
    var key = depth;
    if params.mode == MODE_BACK {
        key = ~depth;
    } else if params.mode == MODE_RANDOM {
        key = scramble(t ^ scramble(params.seed));
    }
    sort_keys[t] = key;
    sort_values[t] = t;
}
