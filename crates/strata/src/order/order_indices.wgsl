#define_import_path strata::order::order_indices
#import strata::dispatch::{GridThread}
#import strata::order::order_common::{params, thread_index}

// One thread per sorted position: the triangle there becomes three vertex numbers of the index
// buffer every geometry pass draws through (vertex 3t + i is corner i of triangle t).

@group(0) @binding(1) var<storage, read> sorted_triangles: array<u32>;
@group(0) @binding(2) var<storage, read_write> indices: array<u32>;

@compute @workgroup_size(256)
fn draw_indices(at: GridThread) {
    let i = thread_index(at);
    if i >= params.count {
        return;
    }
    // Bounded so that no value can index past the vertex buffer.
    let t = min(sorted_triangles[i], params.count - 1u);
    indices[3u * i] = 3u * t;
    indices[3u * i + 1u] = 3u * t + 1u;
    indices[3u * i + 2u] = 3u * t + 2u;
}
