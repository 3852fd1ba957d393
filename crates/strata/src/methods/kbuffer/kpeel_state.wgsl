#define_import_path strata::kbuffer::kpeel_state
#import strata::color::{Resolved}
#import strata::fragment::{Fragment, fragment_before}
#import strata::composite::{Composite, view_distance}
#import strata::kbuffer::storage::{fragment_words, kp, output, pixel_item}

// k-depth peeling's running composite between passes, a valid Resolved at every step
// (premultiplied color, count, RGB transmittance) whose spare word holds the last composited
// fragment's tag, plus that fragment's depth: together the next pass's bound. The view distance
// of the last fragment is recomputed from its depth. Single-sampled the Resolved is the frame's
// `output` and the depth is one word in the slots buffer after the slots; with --msaa each
// sample pixel's whole state lies there (KPEEL_STATE_WORDS each), and the finish averages them
// into `output`. Keep the sizes in sync with kpeel.rs.

const KPEEL_STATE_WORDS: u32 = 9u;

// The first word after the slots.
fn kpeel_state_base() -> u32 {
    return kp.pixels * kp.sample_slots * kp.stride * 4u;
}

// Word j of sample pixel q's state (--msaa), in the frame's layout.
fn state_word(q: u32, j: u32) -> u32 {
    return kpeel_state_base() + pixel_item(q, j, KPEEL_STATE_WORDS);
}

fn state_float(at: u32) -> f32 {
    return bitcast<f32>(atomicLoad(&fragment_words[at]));
}

fn kpeel_state(q: u32) -> Composite {
    if kp.sample_slots <= 1u {
        let r = output[q];
        let depth = state_float(kpeel_state_base() + q);
        return Composite(r.color, r.count, r.transmittance, r.spare, depth, view_distance(depth));
    }
    let depth = state_float(state_word(q, 8u));
    return Composite(
        vec3<f32>(state_float(state_word(q, 0u)), state_float(state_word(q, 1u)), state_float(state_word(q, 2u))),
        atomicLoad(&fragment_words[state_word(q, 3u)]),
        vec3<f32>(state_float(state_word(q, 4u)), state_float(state_word(q, 5u)), state_float(state_word(q, 6u))),
        atomicLoad(&fragment_words[state_word(q, 7u)]),
        depth,
        view_distance(depth),
    );
}

fn kpeel_store(q: u32, s: Composite) {
    if kp.sample_slots <= 1u {
        output[q] = Resolved(s.color, s.count, s.transmittance, s.last_tag);
        atomicStore(&fragment_words[kpeel_state_base() + q], bitcast<u32>(s.last_depth));
        return;
    }
    atomicStore(&fragment_words[state_word(q, 0u)], bitcast<u32>(s.color.r));
    atomicStore(&fragment_words[state_word(q, 1u)], bitcast<u32>(s.color.g));
    atomicStore(&fragment_words[state_word(q, 2u)], bitcast<u32>(s.color.b));
    atomicStore(&fragment_words[state_word(q, 3u)], s.count);
    atomicStore(&fragment_words[state_word(q, 4u)], bitcast<u32>(s.transmittance.r));
    atomicStore(&fragment_words[state_word(q, 5u)], bitcast<u32>(s.transmittance.g));
    atomicStore(&fragment_words[state_word(q, 6u)], bitcast<u32>(s.transmittance.b));
    atomicStore(&fragment_words[state_word(q, 7u)], s.last_tag);
    atomicStore(&fragment_words[state_word(q, 8u)], bitcast<u32>(s.last_depth));
}

// The last composited fragment of a (sample) pixel (ordering fields only; meaningless while
// count is 0).
fn kpeel_bound(q: u32) -> Fragment {
    let s = kpeel_state(q);
    return Fragment(s.last_depth, s.last_tag, 0u, 0u);
}

// True for a fragment a pass may still capture at (sample) pixel q: behind its last composited
// one.
fn peel_pending(q: u32, f: Fragment) -> bool {
    let s = kpeel_state(q);
    return s.count == 0u || fragment_before(Fragment(s.last_depth, s.last_tag, 0u, 0u), f);
}
