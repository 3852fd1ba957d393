// Bucket depth peeling, the resolve: each sample entry's claimed slots in bucket order, nearest
// then farthest within a bucket (by depth and primitive, for two fragments at one depth), are
// composited front to back and the samples averaged; the fragments that reached the pixel but
// hold no slot at any sample are dropped. A fragment kept at several samples counts once: at
// the lowest of them, found by its tag (primitive and coverage) in the samples below.

@group(1) @binding(1) var<storage, read> counts: array<u32>;
@group(1) @binding(2) var<storage, read> claims: array<u32>;
@group(1) @binding(3) var<storage, read> records: array<Fragment>;
@group(1) @binding(4) var<storage, read_write> output: array<Resolved>;

fn composite_entry(e: u32) -> Composite {
    let claimed = claims[e];
    let base = e * params.slots;
    var s = composite_new();
    for (var b = 0u; b < min(params.buckets, MAX_BUCKETS); b++) {
        let near = (claimed >> (2u * b)) & 1u;
        let far = (claimed >> (2u * b + 1u)) & 1u;
        if near == 1u && far == 1u {
            let a = records[base + 2u * b];
            let c = records[base + 2u * b + 1u];
            if fragment_before(c, a) {
                composite_front(&s, c);
                composite_front(&s, a);
            } else {
                composite_front(&s, a);
                composite_front(&s, c);
            }
        } else if near == 1u {
            composite_front(&s, records[base + 2u * b]);
        } else if far == 1u {
            composite_front(&s, records[base + 2u * b + 1u]);
        }
    }
    return s;
}

// Whether sample entry e holds a record tagged `tag`.
fn entry_holds(e: u32, tag: u32) -> bool {
    let claimed = claims[e];
    for (var slot = 0u; slot < min(params.slots, 2u * MAX_BUCKETS); slot++) {
        if ((claimed >> slot) & 1u) == 1u && records[e * params.slots + slot].tag == tag {
            return true;
        }
    }
    return false;
}

// Records of sample s of pixel p kept at no lower sample.
fn first_kept(p: u32, s: u32) -> u32 {
    let e = sample_entry(p, s);
    let claimed = claims[e];
    var n = 0u;
    for (var slot = 0u; slot < min(params.slots, 2u * MAX_BUCKETS); slot++) {
        if ((claimed >> slot) & 1u) == 0u {
            continue;
        }
        let f = records[e * params.slots + slot];
        let below = fragment_coverage(f) & ((1u << s) - 1u);
        var seen = false;
        for (var t = 0u; t < s; t++) {
            if ((below >> t) & 1u) == 1u && entry_holds(sample_entry(p, t), f.tag) {
                seen = true;
                break;
            }
        }
        if !seen {
            n += 1u;
        }
    }
    return n;
}

@compute @workgroup_size(8, 8)
fn cs_resolve(@builtin(global_invocation_id) id: vec3<u32>) {
    if id.x >= frame.size.x || id.y >= frame.size.y {
        return;
    }
    let p = pixel_index(id.xy);
    if frame.coverage_bits == 0u {
        let s = composite_entry(p);
        output[p] = composite_finish(s);
        report_pixel(counts[p], s.count);
        return;
    }
    let samples = samples_per_pixel();
    var sum = vec4<f32>(0.0);
    var kept = 0u;
    for (var s = 0u; s < samples; s++) {
        sum += composite_finish(composite_entry(sample_entry(p, s))).color;
        kept += first_kept(p, s);
    }
    output[p] = Resolved(sum / f32(samples), kept, 0u, 0u, 0u);
    report_pixel(counts[p], kept);
}
