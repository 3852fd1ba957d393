#define_import_path strata::kbuffer::kpeel_state
#import strata::color::{Resolved}
#import strata::fragment::{Fragment, fragment_before}
#import strata::composite::{Composite, view_distance}
#import strata::kbuffer::storage::{kp, output}
#import strata::kbuffer::slots::{slots}

// k-depth peeling's running composite between passes: a valid Resolved at every step
// (premultiplied color, alpha = 1 − transmittance, count), its spare words holding the last
// composited fragment — the next pass's bound — and the exact transmittance. The view distance
// of the last fragment is recomputed from its depth. Single-sampled it is the frame's `output`;
// with --msaa each sample pixel's lies in the slots buffer after the slots (8 words each), and
// the finish averages them into `output`.

fn kpeel_state_word(q: u32) -> u32 {
    return (kp.pixels * kp.sample_slots * kp.stride + 2u * q) * 4u;
}

fn kpeel_load(q: u32) -> Resolved {
    if kp.sample_slots <= 1u {
        return output[q];
    }
    let w = kpeel_state_word(q);
    return Resolved(
        vec4<f32>(
            bitcast<f32>(atomicLoad(&slots[w])),
            bitcast<f32>(atomicLoad(&slots[w + 1u])),
            bitcast<f32>(atomicLoad(&slots[w + 2u])),
            bitcast<f32>(atomicLoad(&slots[w + 3u])),
        ),
        atomicLoad(&slots[w + 4u]),
        atomicLoad(&slots[w + 5u]),
        atomicLoad(&slots[w + 6u]),
        atomicLoad(&slots[w + 7u]),
    );
}

fn kpeel_state(q: u32) -> Composite {
    let r = kpeel_load(q);
    let depth = bitcast<f32>(r.pad_a);
    return Composite(r.color.rgb, bitcast<f32>(r.pad_c), r.count, depth, r.pad_b, view_distance(depth));
}

fn kpeel_store(q: u32, s: Composite) {
    let r = Resolved(
        vec4<f32>(s.color, 1.0 - s.transmittance),
        s.count,
        bitcast<u32>(s.last_depth),
        s.last_tag,
        bitcast<u32>(s.transmittance),
    );
    if kp.sample_slots <= 1u {
        output[q] = r;
        return;
    }
    let w = kpeel_state_word(q);
    atomicStore(&slots[w], bitcast<u32>(r.color.r));
    atomicStore(&slots[w + 1u], bitcast<u32>(r.color.g));
    atomicStore(&slots[w + 2u], bitcast<u32>(r.color.b));
    atomicStore(&slots[w + 3u], bitcast<u32>(r.color.a));
    atomicStore(&slots[w + 4u], r.count);
    atomicStore(&slots[w + 5u], r.pad_a);
    atomicStore(&slots[w + 6u], r.pad_b);
    atomicStore(&slots[w + 7u], r.pad_c);
}

// The last composited fragment of a (sample) pixel (ordering fields only; meaningless while
// count is 0).
fn kpeel_bound(q: u32) -> Fragment {
    let r = kpeel_load(q);
    return Fragment(bitcast<f32>(r.pad_a), r.pad_b, 0u, 0u);
}

// True for a fragment a pass may still capture at (sample) pixel q: behind its last composited
// one.
fn peel_pending(q: u32, f: Fragment) -> bool {
    return kpeel_load(q).count == 0u || fragment_before(kpeel_bound(q), f);
}
