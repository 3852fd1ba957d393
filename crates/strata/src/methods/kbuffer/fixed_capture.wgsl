// Fixed-array A-buffer capture (the FABS scheme): a per-pixel counter gives each fragment a slot
// of a fixed-size array (`stride` slots). Fragments past the array are counted, and blended into
// the tail with --tail blend. Used by `abuffer-fixed` (stride k) and `kb-ab-fixed` (stride sized
// from measured need, the k nearest selected in resolve).

@fragment
fn fs_fixed(v: SceneVarying, @builtin(front_facing) front_facing: bool) {
    if behind_opaque(v.position) {
        discard;
    }
    let p = pixel_index(pixel_of(v.position));
    let f = scene_fragment(v, front_facing);
    let s = count_seen(p);
    if s < kp.stride {
        store_slot(p, s, f);
    } else {
        tail_add(p, f);
    }
}
