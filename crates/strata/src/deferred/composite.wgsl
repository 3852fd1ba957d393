#define_import_path strata::deferred::composite
#import strata::scene::{SHADING_UNLIT, blinn_phong_terms, frame, materials, view_direction}
#import strata::deferred::deferred_common::{ambient_occlusion, gbuffer_depth, light_diffuse, light_specular, params, read_surface}

// Composite: albedo × (ambient · occlusion + diffuse) + specular per covered pixel, unlit
// materials their albedo; the headlight (a scene without lights) is evaluated here. Uncovered
// pixels are left clear for the transparent method and the tone map's background.

@fragment
fn fs_composite(@builtin(position) position: vec4<f32>) -> @location(0) vec4<f32> {
    let pixel = vec2<i32>(position.xy);
    let depth = textureLoad(gbuffer_depth, pixel, 0).r;
    if depth >= 1.0 {
        discard;
    }
    let s = read_surface(pixel, depth);
    if materials[s.material].shading == SHADING_UNLIT {
        return vec4<f32>(s.albedo, 1.0);
    }
    var ambient = frame.ambient.rgb;
    if params.ssao != 0u {
        ambient *= textureLoad(ambient_occlusion, pixel, 0).r;
    }
    var diffuse = ambient + textureLoad(light_diffuse, pixel, 0).rgb;
    var specular = textureLoad(light_specular, pixel, 0).rgb;
    if frame.headlight != 0u {
        let v = view_direction(s.world);
        let t = blinn_phong_terms(s.normal, v, v, s.shininess);
        diffuse += t.diffuse;
        specular += t.specular;
    }
    return vec4<f32>(s.albedo * diffuse + specular, 1.0);
}
