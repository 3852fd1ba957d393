// The built-in capture entry points of the slot k-buffers: the scene's rasterized fragments,
// tested against the opaque depth, through each method's capture step.

@fragment
fn fs_kplus_array(v: SceneVarying, @builtin(front_facing) front_facing: bool) {
    if behind_opaque(v.position) {
        discard;
    }
    capture_locked(kpixel(v.position), scene_fragment(v, front_facing), VARIANT_ARRAY);
}

@fragment
fn fs_kplus_heap(v: SceneVarying, @builtin(front_facing) front_facing: bool) {
    if behind_opaque(v.position) {
        discard;
    }
    capture_locked(kpixel(v.position), scene_fragment(v, front_facing), VARIANT_HEAP);
}

@fragment
fn fs_kplus_array_r(v: SceneVarying, @builtin(front_facing) front_facing: bool) {
    if behind_opaque(v.position) {
        discard;
    }
    capture_array_r(kpixel(v.position), scene_fragment(v, front_facing));
}

@fragment
fn fs_kb(v: SceneVarying, @builtin(front_facing) front_facing: bool) {
    if behind_opaque(v.position) {
        discard;
    }
    capture_sorted(kpixel(v.position), scene_fragment(v, front_facing), UNLOCKED);
}

@fragment
fn fs_kb_ps(v: SceneVarying, @builtin(front_facing) front_facing: bool) {
    if behind_opaque(v.position) {
        discard;
    }
    capture_sorted(kpixel(v.position), scene_fragment(v, front_facing), LOCKED);
}

@fragment
fn fs_fixed(v: SceneVarying, @builtin(front_facing) front_facing: bool) {
    if behind_opaque(v.position) {
        discard;
    }
    capture_fixed(kpixel(v.position), scene_fragment(v, front_facing));
}

@fragment
fn fs_kplus_semiheap(v: SceneVarying, @builtin(front_facing) front_facing: bool) {
    if behind_opaque(v.position) {
        discard;
    }
    capture_semiheap(kpixel(v.position), scene_fragment(v, front_facing));
}
