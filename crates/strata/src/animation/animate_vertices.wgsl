#define_import_path strata::animation::animate_vertices
#import strata::dispatch::{GridThread}
#import strata::animation::animate_common::{params, thread_index}

// One thread per triangle of one chunk (the bindings below start at the chunk's first
// triangle): its three rest vertices through its object's transform into the scene's vertex
// buffer (`GpuVertex`: position, normal), and with --order its centroid.

@group(0) @binding(1) var<storage, read> models: array<mat4x4<f32>>;
@group(0) @binding(2) var<storage, read> triangle_objects: array<u32>;
@group(0) @binding(3) var<storage, read> rest: array<f32>;
@group(0) @binding(4) var<storage, read_write> vertices: array<f32>;
@group(0) @binding(5) var<storage, read_write> centroids: array<f32>;

@compute @workgroup_size(64)
fn move_vertices(at: GridThread) {
    let t = thread_index(at);
    if t >= arrayLength(&triangle_objects) {
        return;
    }
    let model = models[triangle_objects[t]];
    var sum = vec3<f32>(0.0);
    for (var i = 0u; i < 3u; i++) {
        let at = 18u * t + 6u * i;
        let p = model * vec4<f32>(rest[at], rest[at + 1u], rest[at + 2u], 1.0);
        // Transforms are uniform scales and translations: the normal keeps its direction.
        let n = (model * vec4<f32>(rest[at + 3u], rest[at + 4u], rest[at + 5u], 0.0)).xyz;
        let len = length(n);
        let unit = select(vec3<f32>(0.0, 0.0, 1.0), n / len, len > 0.0);
        vertices[at] = p.x;
        vertices[at + 1u] = p.y;
        vertices[at + 2u] = p.z;
        vertices[at + 3u] = unit.x;
        vertices[at + 4u] = unit.y;
        vertices[at + 5u] = unit.z;
        sum += p.xyz;
    }
    if params.write_centroids != 0u {
        let c = sum / 3.0;
        centroids[3u * t] = c.x;
        centroids[3u * t + 1u] = c.y;
        centroids[3u * t + 2u] = c.z;
    }
}
