#define_import_path strata::gpu::bandwidth

// The device probes of `bench bandwidth`: a streaming copy through the shader cores and atomic
// increments at three contention levels. Every loop is bounded by the probe's own count.

// Keep in sync with `ProbeParams` in bandwidth.rs.
struct ProbeParams {
    // Elements to copy (vec4<u32>) or increments to make.
    count: u32,
    // Words the increments are spread over: increment i goes to word i % words.
    words: u32,
    // Invocations in the whole grid (the stride of the grid-stride loops).
    invocations: u32,
    _pad: u32,
}

@group(0) @binding(0) var<uniform> params: ProbeParams;
@group(0) @binding(1) var<storage, read> source: array<vec4<u32>>;
@group(0) @binding(2) var<storage, read_write> destination: array<vec4<u32>>;
@group(0) @binding(3) var<storage, read_write> counters: array<atomic<u32>>;

@compute @workgroup_size(256)
fn stream(@builtin(global_invocation_id) id: vec3<u32>) {
    // count / invocations + 1 trips at most: the loop ends whatever the buffer holds.
    for (var i = id.x; i < params.count; i += params.invocations) {
        destination[i] = source[i];
    }
}

@compute @workgroup_size(256)
fn increment(@builtin(global_invocation_id) id: vec3<u32>) {
    for (var i = id.x; i < params.count; i += params.invocations) {
        atomicAdd(&counters[i % params.words], 1u);
    }
}
