#define_import_path strata::peeling::f2b_peel
#import strata::scene::{SceneVarying, behind_opaque, frame, pixel_index, pixel_of, shade, target_samples}
#import strata::composite::{Composite}

// f2b peel pass: keeps fragments strictly after the last captured one in (depth, primitive)
// order; the depth test (LESS, primitive order among equals) picks the nearest of them.
// With MULTISAMPLED every sample peels on its own, shading stays once per fragment: a fragment
// covers the samples still waiting for it through its output sample mask, and writes its center
// depth to all of them, so each sample's LESS depth test keeps that sample's nearest in the same
// order the single-sampled peel and the reference use. The tag goes out as an exact float (the
// primitive is below 2^23), since 32-bit integer targets cannot be multisampled. Then an account
// pass counts what the frame peeled (see fs_account).

@group(1) @binding(0) var<storage, read> state: array<Composite>;
// Single-sampled: per pixel the fragments that reached it, counted by the first peel pass.
// Multisampled: per pixel the fragments that reached it, then per pixel those some sample
// composited, then per sample the fragments that cover it (the account pass's).
@group(1) @binding(1) var<storage, read_write> counts: array<atomic<u32>>;

fn fragment_tag(v: SceneVarying, front_facing: bool) -> u32 {
    return (v.prim << 1u) | select(0u, 1u, front_facing);
}

// True when sample `s` of pixel `p` has not yet captured the fragment (depth z, tag).
fn waiting(p: u32, s: u32, z: f32, tag: u32) -> bool {
    let st = state[p * target_samples() + s];
    return st.count == 0u || z > st.last_depth || (z == st.last_depth && tag > st.last_tag);
}

#ifdef MULTISAMPLED
struct PeelOut {
    @location(0) color: vec4<f32>,
    @location(1) tag: f32,
    @location(2) depth: f32,
    @builtin(frag_depth) frag_depth: f32,
    @builtin(sample_mask) mask: u32,
}
#else
// The depth travels as its bits, as the tag does: 32-bit float targets are not renderable on
// every backend (GL), 32-bit integer ones are.
struct PeelOut {
    @location(0) color: vec4<f32>,
    @location(1) tag: u32,
    @location(2) depth: u32,
}
#endif

// The first peel pass; single-sampled it also counts each pixel's fragments (multisampled, the
// account pass counts them).
fn fs_peel_first_step(v: SceneVarying, front_facing: bool, mask: u32) -> PeelOut {
    if behind_opaque(v.position) {
        discard;
    }
#ifndef MULTISAMPLED
    atomicAdd(&counts[pixel_index(pixel_of(v.position))], 1u);
#endif
    return peel(v, front_facing, mask);
}

fn fs_peel_step(v: SceneVarying, front_facing: bool, mask: u32) -> PeelOut {
    if behind_opaque(v.position) {
        discard;
    }
    return peel(v, front_facing, mask);
}

// The fragment's layer, if some sample it covers (single-sampled: its pixel) still waits for
// it; else it is discarded.
fn peel(v: SceneVarying, front_facing: bool, mask: u32) -> PeelOut {
    let p = pixel_index(pixel_of(v.position));
    let tag = fragment_tag(v, front_facing);
    let z = v.position.z;
    var out: PeelOut;
#ifdef MULTISAMPLED
    var pending = 0u;
    for (var s = 0u; s < target_samples(); s++) {
        if ((mask >> s) & 1u) != 0u && waiting(p, s, z, tag) {
            pending |= 1u << s;
        }
    }
    if pending == 0u {
        discard;
    }
    out.tag = f32(tag);
    out.frag_depth = z;
    out.mask = pending;
    out.depth = z;
#else
    if !waiting(p, 0u, z, tag) {
        discard;
    }
    out.tag = tag;
    out.depth = bitcast<u32>(z);
#endif
    out.color = shade(v.world, v.normal, v.material);
    return out;
}

// The account, a geometry pass after the last layer with --msaa: each fragment once at its
// pixel, once at each sample it covers (a sample's depth complexity, which sets the next
// frame's layers), and as composited when some covered sample captured it.
fn fs_account_capture(v: SceneVarying, front_facing: bool, mask: u32) {
    if behind_opaque(v.position) {
        return;
    }
    let pixels = frame.size.x * frame.size.y;
    let p = pixel_index(pixel_of(v.position));
    let tag = fragment_tag(v, front_facing);
    atomicAdd(&counts[p], 1u);
    var composited = false;
    for (var s = 0u; s < target_samples(); s++) {
        if ((mask >> s) & 1u) == 0u {
            continue;
        }
        atomicAdd(&counts[2u * pixels + p * target_samples() + s], 1u);
        composited = composited || !waiting(p, s, v.position.z, tag);
    }
    if composited {
        atomicAdd(&counts[pixels + p], 1u);
    }
}
