#define_import_path strata::convex::capture
#import strata::scene::{SceneVarying, behind_opaque, frame, pixel_index, pixel_of, samples_per_pixel, scene_fragment, scene_fragment_covering}
#import strata::fragment::{Fragment}
const LAYERS: u32 = #{CONVEX_LAYERS}u;
const MERGE_WORKGROUP: u32 = #{MERGE_WORKGROUP}u;

// convex capture pass: the groups of one pass, which cannot share a pixel, each give a pixel at
// most LAYERS fragments (two per convex part: the front-facing and the back-facing layer). They
// are appended unsorted behind the pixel's claim counter; the merge sorts them. A container is
// drawn twice, its front cap (fs_front) before what it holds and its back cap (fs_back) after.
// The first claim of a pixel in a pass lists the pixel, so the merge visits only the pixels the
// pass reached (a pass's groups cover a small part of the screen). LAYERS and MERGE_WORKGROUP
// come from the method's definitions (CONVEX_LAYERS, MERGE_WORKGROUP).

@group(1) @binding(0) var<storage, read_write> claims: array<atomic<u32>>;
@group(1) @binding(1) var<storage, read_write> slots: array<Fragment>;
// The pass's pixels in claim order, their count, and the merge's indirect dispatch (x counts
// started workgroups up to the 65535 a dimension allows; y and z are 1, set with the reset).
@group(1) @binding(2) var<storage, read_write> touched: array<u32>;
@group(1) @binding(3) var<storage, read_write> touched_count: atomic<u32>;
@group(1) @binding(4) var<storage, read_write> merge_args: array<atomic<u32>, 3>;

// With --msaa each pixel has S sample entries `p * S + s` (S = `samples_per_pixel`) with their
// own claims, slots and state, and a fragment (shaded once) is captured at each it covers.

// Captures `f` at sample entry i; false when the entry's LAYERS were full.
fn capture_at(i: u32, f: Fragment) -> bool {
    // Claims past LAYERS are counted and dropped by the merge, never written.
    let n = atomicAdd(&claims[i], 1u);
    if n == 0u {
        // Once per entry and pass: the merge resets the claim, so t stays below the entry count.
        let t = atomicAdd(&touched_count, 1u);
        if t < arrayLength(&touched) {
            touched[t] = i;
            if t % MERGE_WORKGROUP == 0u && t / MERGE_WORKGROUP < 65535u {
                atomicAdd(&merge_args[0], 1u);
            }
        }
    }
    if n < LAYERS {
        slots[i * LAYERS + n] = f;
        return true;
    }
    return false;
}

fn capture(v: SceneVarying, front_facing: bool, mask: u32) {
    let p = pixel_index(pixel_of(v.position));
    if frame.coverage_bits == 0u {
        capture_at(p, scene_fragment(v, front_facing));
        return;
    }
    // --msaa: after the entries' claims, per pixel its fragments and those some covered sample
    // could not keep (counted as dropped: never fewer than the fragments no sample kept).
    let samples = samples_per_pixel();
    let pixels = frame.size.x * frame.size.y;
    let f = scene_fragment_covering(v, front_facing, mask);
    var kept_everywhere = true;
    for (var s = 0u; s < samples; s++) {
        if ((mask >> s) & 1u) != 0u {
            kept_everywhere = capture_at(p * samples + s, f) && kept_everywhere;
        }
    }
    atomicAdd(&claims[pixels * samples + p], 1u);
    if !kept_everywhere {
        atomicAdd(&claims[pixels * samples + pixels + p], 1u);
    }
}

fn fs_whole_capture(v: SceneVarying, front_facing: bool, mask: u32) {
    if behind_opaque(v.position) {
        discard;
    }
    capture(v, front_facing, mask);
}

fn fs_front_capture(v: SceneVarying, front_facing: bool, mask: u32) {
    if !front_facing || behind_opaque(v.position) {
        discard;
    }
    capture(v, front_facing, mask);
}

fn fs_back_capture(v: SceneVarying, front_facing: bool, mask: u32) {
    if front_facing || behind_opaque(v.position) {
        discard;
    }
    capture(v, front_facing, mask);
}
