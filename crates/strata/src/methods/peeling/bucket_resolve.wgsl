// Bucket depth peeling, pass 4 (resolve): each pixel's claimed slots in bucket order, nearest
// then farthest within a bucket (by depth and primitive, for two fragments at one depth), are
// composited front to back; the fragments that reached the pixel but hold no slot are dropped.

@group(1) @binding(1) var<storage, read> counts: array<u32>;
@group(1) @binding(2) var<storage, read> claims: array<u32>;
@group(1) @binding(3) var<storage, read> records: array<Fragment>;
@group(1) @binding(4) var<storage, read_write> output: array<Resolved>;

@compute @workgroup_size(8, 8)
fn cs_resolve(@builtin(global_invocation_id) id: vec3<u32>) {
    if id.x >= frame.size.x || id.y >= frame.size.y {
        return;
    }
    let p = pixel_index(id.xy);
    let claimed = claims[p];
    let base = p * params.slots;
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
    output[p] = composite_finish(s);
    report_pixel(counts[p], s.count);
}
