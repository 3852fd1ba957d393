#define_import_path strata::deferred::forward
#import strata::scene::{SceneVarying, shade}

// Forward pipeline's opaque pass: every opaque fragment that passes the depth test is shaded
// with every light of the scene (the loop in `shade`), seed 004's comparison. Output alpha 1
// marks covered pixels for the tone map.

@fragment
fn fs_forward(v: SceneVarying) -> @location(0) vec4<f32> {
    return vec4<f32>(shade(v.world, v.normal, v.material).rgb, 1.0);
}
