// k-depth peeling capture (seed 003 §4.3): each geometry pass keeps the k nearest fragments
// strictly after the pixel's last composited one in (depth, primitive) order — a k+-buffer
// capture (max-array for k ≤ 16, max-heap above) behind that bound. Ordering by the pair, not
// the depth alone, loses nothing at exactly equal depths.

@group(1) @binding(5) var<storage, read_write> output: array<Resolved>;

@fragment
fn fs_kpeel(v: SceneVarying, @builtin(front_facing) front_facing: bool) {
    if behind_opaque(v.position) {
        discard;
    }
    let p = kpixel(v.position);
    let f = scene_fragment(v, front_facing);
    if output[p].count > 0u && !fragment_before(kpeel_bound(p), f) {
        // Composited by an earlier pass.
        discard;
    }
    capture_locked(p, f, select(VARIANT_HEAP, VARIANT_ARRAY, kp.k <= 16u));
}
