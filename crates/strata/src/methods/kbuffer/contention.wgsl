#define_import_path strata::kbuffer::contention
#import strata::fragment::{Fragment}
#import strata::kbuffer::access::{stored_count, stored_fragment}
#import strata::kbuffer::harness_step::harness_capture
#import strata::kbuffer::harness_params::{HarnessParams}

// The contention harness (contention.rs): a method's capture step driven from compute
// dispatches, so that many invocations — across workgroups, which lavapipe runs on parallel CPU
// threads, and within one — insert fragments into a few pixels at once. The module
// `strata::kbuffer::harness_step`, made for the method, defines `harness_capture(capture_pass,
// p, f)` (its capture step; `capture_pass` for methods of two passes); the storage layout's
// accessors read back what it stored.

@group(2) @binding(0) var<uniform> harness: HarnessParams;
// Per fragment: pixel, depth bits, tag, color word (both halves of the payload).
@group(2) @binding(1) var<storage, read> harness_input: array<vec4<u32>>;
// Per pixel: the stored count, then (depth bits, tag) of up to `capacity` stored fragments.
@group(2) @binding(2) var<storage, read_write> harness_output: array<u32>;

// HARNESS_WORKGROUP is 64 except for ordered captures on lavapipe before Mesa 22.3.7, which
// needs workgroups of one SIMD vector (`gpu::ordered::workgroup_limit`).
@compute @workgroup_size(#{HARNESS_WORKGROUP})
fn cs_harness_capture(@builtin(global_invocation_id) id: vec3<u32>) {
    if id.x < harness.fragments {
        let x = harness_input[id.x];
        harness_capture(harness.capture_pass, x.x, Fragment(bitcast<f32>(x.y), x.z, x.w, x.w));
    }
}

@compute @workgroup_size(64)
fn cs_harness_gather(@builtin(global_invocation_id) id: vec3<u32>) {
    let p = id.x;
    if p < harness.pixels {
        let n = stored_count(p);
        let base = p * (1u + 2u * harness.capacity);
        harness_output[base] = n;
        for (var i = 0u; i < min(n, harness.capacity); i++) {
            let f = stored_fragment(p, i);
            harness_output[base + 1u + 2u * i] = bitcast<u32>(f.depth);
            harness_output[base + 2u + 2u * i] = f.tag;
        }
    }
}
