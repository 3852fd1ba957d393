#define_import_path strata::kbuffer::temporal
#import strata::kbuffer::temporal_params::{TemporalParams}

// Reverse-reprojection temporal culling (seed 000), shared by every k-buffer stage.
//
// Each frame records, per pixel, the depth of the nearest fragment its cache did not keep —
// evicted, rejected, culled or blended into the tail: the (k+1)-th nearest — in `interface`
// (stored as !bits, so that atomicMax keeps the nearest and a cleared word means "none"). The
// next frame carries each fragment's world position back to where it was (moving objects, by
// their motion since last frame) and reprojects it with the previous view-projection, and
// culls it before any lock when it lies farther than that depth by more than ε at all four
// interface texels around where it was (border and "none" mean far: no culling). Tiles of
// 16×16 pixels skip culling one frame in `refresh_period`, in a rotating pattern, so that
// what was wrongly culled comes back.

@group(#{KBUFFER_GROUP}) @binding(6) var<storage, read> temporal: TemporalParams;
@group(#{KBUFFER_GROUP}) @binding(7) var<storage, read> previous_culling_interface: array<u32>;
// One word per pixel, then the frame's count of culled fragments (64-bit, low word first).
@group(#{KBUFFER_GROUP}) @binding(8) var<storage, read_write> culling_interface: array<atomic<u32>>;
// With `moving`: each triangle's object, and per object the transform from where it is this
// frame to where it was last frame.
@group(#{KBUFFER_GROUP}) @binding(9) var<storage, read> motion_triangle_objects: array<u32>;
@group(#{KBUFFER_GROUP}) @binding(10) var<storage, read> motion_to_previous: array<mat4x4<f32>>;

const REFRESH_TILE: u32 = 16u;

// Notes a fragment the cache does not keep at pixel `p`.
fn note_outside(p: u32, depth: f32) {
    if temporal.record != 0u {
        atomicMax(&culling_interface[p], ~bitcast<u32>(depth));
    }
}

// True when the fragment of triangle `prim` at `world` (window position `position` this frame)
// lay behind last frame's (k+1)-th nearest depth by more than ε where it was then.
fn temporally_culled(world: vec3<f32>, position: vec4<f32>, prim: u32) -> bool {
    if temporal.cull == 0u {
        return false;
    }
    let pixel = vec2<u32>(position.xy);
    if temporal.refresh_period > 0u {
        let tiles_x = (temporal.width + REFRESH_TILE - 1u) / REFRESH_TILE;
        let tile = (pixel.y / REFRESH_TILE) * tiles_x + pixel.x / REFRESH_TILE;
        if (tile + temporal.frame) % temporal.refresh_period == 0u {
            return false;
        }
    }
    var before = vec4<f32>(world, 1.0);
    if temporal.moving != 0u {
        before = motion_to_previous[motion_triangle_objects[prim]] * before;
    }
    let clip = temporal.previous_view_proj * before;
    if !(clip.w > 0.0) {
        return false;
    }
    let ndc = clip.xyz / clip.w;
    let size = vec2<f32>(f32(temporal.width), f32(temporal.height));
    let window = vec2<f32>((ndc.x * 0.5 + 0.5) * size.x, (0.5 - ndc.y * 0.5) * size.y);
    if !(all(window >= vec2<f32>(0.0)) && all(window <= size)) {
        return false;
    }
    let corner = vec2<u32>(max(floor(window - 0.5), vec2<f32>(0.0)));
    let last = vec2<u32>(temporal.width - 1u, temporal.height - 1u);
    var farthest = 0.0;
    for (var i = 0u; i < 4u; i++) {
        let t = min(corner + vec2<u32>(i & 1u, i >> 1u), last);
        let word = previous_culling_interface[t.y * temporal.width + t.x];
        if word == 0u {
            return false;
        }
        farthest = max(farthest, bitcast<f32>(~word));
    }
    return ndc.z > farthest + temporal.epsilon;
}
