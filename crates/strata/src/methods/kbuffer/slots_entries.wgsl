// The built-in capture entry points of the slot k-buffers: the scene's rasterized fragments,
// tested against the opaque depth and (except the fixed arrays) temporal culling, through each
// method's capture step.

// Temporal culling before any lock (temporal.wgsl): true when the fragment was culled — then
// counted, noted in the interface, and blended into the tail with --tail blend.
fn culled_by_last_frame(v: SceneVarying, front_facing: bool) -> bool {
    if !temporally_culled(v.world, v.position, v.prim) {
        return false;
    }
    count_temporal_cull();
    let p = kpixel(v.position);
    if kp.tail_blend != 0u {
        tail_add(p, scene_fragment(v, front_facing));
    } else {
        note_outside(p, v.position.z);
    }
    return true;
}

@fragment
fn fs_kplus_array(v: SceneVarying, @builtin(front_facing) front_facing: bool) {
    if behind_opaque(v.position) {
        discard;
    }
    if culled_by_last_frame(v, front_facing) {
        return;
    }
    capture_locked(kpixel(v.position), scene_fragment(v, front_facing), VARIANT_ARRAY);
}

@fragment
fn fs_kplus_heap(v: SceneVarying, @builtin(front_facing) front_facing: bool) {
    if behind_opaque(v.position) {
        discard;
    }
    if culled_by_last_frame(v, front_facing) {
        return;
    }
    capture_locked(kpixel(v.position), scene_fragment(v, front_facing), VARIANT_HEAP);
}

@fragment
fn fs_kplus_array_r(v: SceneVarying, @builtin(front_facing) front_facing: bool) {
    if behind_opaque(v.position) {
        discard;
    }
    if culled_by_last_frame(v, front_facing) {
        return;
    }
    capture_array_r(kpixel(v.position), scene_fragment(v, front_facing));
}

@fragment
fn fs_kb(v: SceneVarying, @builtin(front_facing) front_facing: bool) {
    if behind_opaque(v.position) {
        discard;
    }
    if culled_by_last_frame(v, front_facing) {
        return;
    }
    capture_sorted(kpixel(v.position), scene_fragment(v, front_facing), UNLOCKED);
}

@fragment
fn fs_kb_ps(v: SceneVarying, @builtin(front_facing) front_facing: bool) {
    if behind_opaque(v.position) {
        discard;
    }
    if culled_by_last_frame(v, front_facing) {
        return;
    }
    capture_sorted(kpixel(v.position), scene_fragment(v, front_facing), LOCKED);
}

@fragment
fn fs_fixed(v: SceneVarying, @builtin(front_facing) front_facing: bool, @builtin(sample_mask) mask: u32) {
    if behind_opaque(v.position) {
        discard;
    }
    capture_fixed(kpixel(v.position), scene_fragment_covering(v, front_facing, mask));
}

@fragment
fn fs_kplus_semiheap(v: SceneVarying, @builtin(front_facing) front_facing: bool) {
    if behind_opaque(v.position) {
        discard;
    }
    if culled_by_last_frame(v, front_facing) {
        return;
    }
    capture_semiheap(kpixel(v.position), scene_fragment(v, front_facing));
}
