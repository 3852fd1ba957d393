// The built-in capture entry points of the linked-list methods.

@fragment
fn fs_ab_ll(v: SceneVarying, @builtin(front_facing) front_facing: bool, @builtin(sample_mask) mask: u32) {
    if behind_opaque(v.position) {
        discard;
    }
    capture_list(kpixel(v.position), scene_fragment_covering(v, front_facing, mask));
}

@fragment
fn fs_sorted_ll(v: SceneVarying, @builtin(front_facing) front_facing: bool) {
    if behind_opaque(v.position) {
        discard;
    }
    capture_sorted_list(kpixel(v.position), scene_fragment(v, front_facing));
}
