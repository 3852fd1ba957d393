#define_import_path strata::peeling::bucket_resolve
#import strata::scene::{frame, pixel_index, report_pixel, sample_entry, samples_per_pixel}
#import strata::color::{Resolved, resolved_mean, resolved_sum_add, resolved_sum_new}
#import strata::fragment::{Fragment, fragment_before}
#import strata::composite::{Composite, composite_finish, composite_front, composite_new}
#import strata::peeling::bucket_common::{MAX_BUCKETS, kept_word, params}

// Bucket depth peeling, the resolve: each sample entry's claimed slots in bucket order, nearest
// then farthest within a bucket (by depth and primitive, for two fragments at one depth), are
// composited front to back and the samples averaged; the fragments that reached the pixel but
// hold no slot at any sample are dropped (with --msaa the color pass counted those kept, once
// each, after the claim words).

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

// cs_resolve's pixel step: its made compute stage calls it for each pixel of the frame.
fn cs_resolve_pixel(pixel: vec2<u32>) {
    let p = pixel_index(pixel);
    if frame.coverage_bits == 0u {
        let s = composite_entry(p);
        output[p] = composite_finish(s);
        report_pixel(counts[p], s.count);
        return;
    }
    let samples = samples_per_pixel();
    var sum = resolved_sum_new();
    for (var s = 0u; s < samples; s++) {
        resolved_sum_add(&sum, composite_finish(composite_entry(sample_entry(p, s))));
    }
    let kept = claims[kept_word(p)];
    output[p] = resolved_mean(sum, samples, kept);
    report_pixel(counts[p], kept);
}
