// k-depth peeling's compute passes: init (an empty composite per pixel), resolve after each
// geometry pass (the captured layers composited behind the running result), finish (the
// accounting of pixels the last pass left unfinished).
//
// Accounting: a pixel is reported once, in the pass that finishes it (it saw at most k
// fragments behind its bound); one still unfinished after the last pass is reported by finish,
// the fragments behind its last bound counted as dropped. Either way generated = composited
// before the pass + seen in it.

@compute @workgroup_size(8, 8)
fn cs_kpeel_init(@builtin(global_invocation_id) id: vec3<u32>) {
    if id.x >= frame.size.x || id.y >= frame.size.y {
        return;
    }
    kpeel_store(id.y * kp.width + id.x, composite_new());
}

@compute @workgroup_size(8, 8)
fn cs_kpeel_resolve(@builtin(global_invocation_id) id: vec3<u32>) {
    if id.x >= frame.size.x || id.y >= frame.size.y {
        return;
    }
    let p = id.y * kp.width + id.x;
    let seen = atomicLoad(&pixels[pixel_word(p, SEEN)]);
    if seen == 0u {
        return;
    }
    let n = stored_count(p);
    let limit = min(n, kp.k);
    var s = kpeel_state(p);
    var t = Tail(vec4<f32>(0.0), 0.0);
    composite_stored(p, n, limit, &s, &t);
    kpeel_store(p, s);
    if seen <= kp.k {
        report_pixel(s.count - limit + seen, s.count);
    }
}

@compute @workgroup_size(8, 8)
fn cs_kpeel_finish(@builtin(global_invocation_id) id: vec3<u32>) {
    if id.x >= frame.size.x || id.y >= frame.size.y {
        return;
    }
    let p = id.y * kp.width + id.x;
    let seen = atomicLoad(&pixels[pixel_word(p, SEEN)]);
    if seen > kp.k {
        let count = output[p].count;
        report_pixel(count - min(stored_count(p), kp.k) + seen, count);
    }
}
