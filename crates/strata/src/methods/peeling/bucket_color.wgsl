#define_import_path strata::peeling::bucket_color
#import strata::scene::{SceneVarying, behind_opaque, frame, pixel_index, pixel_of, sample_entry, samples_per_pixel, scene_fragment_covering}
#import strata::fragment::{Fragment}
#import strata::peeling::bucket_common::{covered_samples, kept_word, params, route}

// Bucket depth peeling, the color pass: at each sample it covers, a fragment whose depth is its
// bucket's nearest claims slot 2b, one at its farthest slot 2b + 1 (one atomicOr on the sample
// entry's claim word), and the claimant stores its shaded record there (shaded once, for every
// sample). Everything else collided — a third fragment in a bucket, or an equal depth whose slot
// was taken — and is counted by the resolve as dropped. A claim is never taken back, so with
// --msaa a fragment that claimed at some sample counts itself kept here, once (the word after
// the claim words). The bucket targets are separate
// textures, one per layer of four slots (multisampled 2D arrays are not core WebGPU), bound at
// 6..13 (unused ones repeat the last) and picked by `bucket_pair`.

@group(1) @binding(1) var bounds: texture_2d<f32>;
@group(1) @binding(3) var<storage, read_write> claims: array<atomic<u32>>;
@group(1) @binding(4) var<storage, read_write> records: array<Fragment>;
// The layer textures: multisampled with --msaa (a composable module cannot alias their type).
#ifdef MULTISAMPLED
@group(1) @binding(6) var layer0: texture_multisampled_2d<f32>;
@group(1) @binding(7) var layer1: texture_multisampled_2d<f32>;
@group(1) @binding(8) var layer2: texture_multisampled_2d<f32>;
@group(1) @binding(9) var layer3: texture_multisampled_2d<f32>;
@group(1) @binding(10) var layer4: texture_multisampled_2d<f32>;
@group(1) @binding(11) var layer5: texture_multisampled_2d<f32>;
@group(1) @binding(12) var layer6: texture_multisampled_2d<f32>;
@group(1) @binding(13) var layer7: texture_multisampled_2d<f32>;
#else
@group(1) @binding(6) var layer0: texture_2d<f32>;
@group(1) @binding(7) var layer1: texture_2d<f32>;
@group(1) @binding(8) var layer2: texture_2d<f32>;
@group(1) @binding(9) var layer3: texture_2d<f32>;
@group(1) @binding(10) var layer4: texture_2d<f32>;
@group(1) @binding(11) var layer5: texture_2d<f32>;
@group(1) @binding(12) var layer6: texture_2d<f32>;
@group(1) @binding(13) var layer7: texture_2d<f32>;
#endif

// Sample s of target layer `layer` at `pixel` (the mip level, 0, when single-sampled).
fn bucket_pair(layer: u32, pixel: vec2<u32>, s: u32) -> vec4<f32> {
    switch layer {
        case 0u: {
            return textureLoad(layer0, pixel, i32(s));
        }
        case 1u: {
            return textureLoad(layer1, pixel, i32(s));
        }
        case 2u: {
            return textureLoad(layer2, pixel, i32(s));
        }
        case 3u: {
            return textureLoad(layer3, pixel, i32(s));
        }
        case 4u: {
            return textureLoad(layer4, pixel, i32(s));
        }
        case 5u: {
            return textureLoad(layer5, pixel, i32(s));
        }
        case 6u: {
            return textureLoad(layer6, pixel, i32(s));
        }
        default: {
            return textureLoad(layer7, pixel, i32(s));
        }
    }
}

// Claims `slot` of sample entry e; true for the one fragment that gets it.
fn claim(e: u32, slot: u32) -> bool {
    let bit = 1u << slot;
    return (atomicOr(&claims[e], bit) & bit) == 0u;
}

// fs_color's capture step: its made fragment stage and the compute rasterizer call it.
fn fs_color_capture(v: SceneVarying, front_facing: bool, mask: u32) {
    if behind_opaque(v.position) {
        return;
    }
    let pixel = pixel_of(v.position);
    let p = pixel_index(pixel);
    let z = v.position.z;
    let range = textureLoad(bounds, pixel, 0);
    let b = route(z, -range.x, range.y, p);
    let c = 2u * (b % 2u);
    let samples = covered_samples(mask);
    var record: Fragment;
    var shaded = false;
    for (var s = 0u; s < samples_per_pixel(); s++) {
        if ((samples >> s) & 1u) == 0u {
            continue;
        }
        let e = sample_entry(p, s);
        let pair = bucket_pair(b / 2u, pixel, s);
        var slot = 2u * b;
        // Two fragments at one depth that is both the bucket's nearest and farthest take a
        // slot each.
        var claimed = z == -pair[c] && claim(e, slot);
        if !claimed && z == pair[c + 1u] {
            slot += 1u;
            claimed = claim(e, slot);
        }
        if claimed {
            if !shaded {
                record = scene_fragment_covering(v, front_facing, mask);
                shaded = true;
            }
            records[e * params.slots + slot] = record;
        }
    }
    if shaded && frame.coverage_bits != 0u {
        atomicAdd(&claims[kept_word(p)], 1u);
    }
}
