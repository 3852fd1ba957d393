// k-depth peeling's running composite, kept in the frame's `output` between passes: a valid
// Resolved at every step (premultiplied color, alpha = 1 − transmittance, count), its spare
// words holding the last composited fragment — the next pass's bound — and the exact
// transmittance. The view distance of the last fragment is recomputed from its depth.

fn kpeel_state(p: u32) -> Composite {
    let r = output[p];
    let depth = bitcast<f32>(r._pad0);
    return Composite(r.color.rgb, bitcast<f32>(r._pad2), r.count, depth, r._pad1, view_distance(depth));
}

fn kpeel_store(p: u32, s: Composite) {
    output[p] = Resolved(
        vec4<f32>(s.color, 1.0 - s.transmittance),
        s.count,
        bitcast<u32>(s.last_depth),
        s.last_tag,
        bitcast<u32>(s.transmittance),
    );
}

// The last composited fragment of a pixel (ordering fields only; meaningless while count is 0).
fn kpeel_bound(p: u32) -> Fragment {
    let r = output[p];
    return Fragment(bitcast<f32>(r._pad0), r._pad1, 0u, 0u);
}
