#define_import_path strata::gpu::bandwidth
#import strata::gpu::probe_params::{ProbeParams}

// The device probes of `bench bandwidth`: a streaming copy through the shader cores and atomic
// increments at three contention levels. Every loop is bounded by the probe's own count.

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
