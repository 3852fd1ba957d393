#define_import_path strata::scene
#import strata::fragment::{Fragment, fragment_new}

// Scene bindings (group 0), the vertex stage every capture pass shares, and shading.
// Keep in sync with `FrameUniforms`, `GpuVertex`, `GpuMaterial`, `GpuLight` in Rust
// (crates/strata/src/render/uniforms.rs and scene/mod.rs).

struct Frame {
    view_proj: mat4x4<f32>,
    view: mat4x4<f32>,
    eye: vec4<f32>,
    // Direction from the scene towards the camera (orthographic views use it for every point).
    to_camera: vec4<f32>,
    background: vec4<f32>,
    checker_light: vec4<f32>,
    checker_dark: vec4<f32>,
    ambient: vec4<f32>,
    size: vec2<u32>,
    effect: u32,
    light_count: u32,
    near: f32,
    far: f32,
    orthographic: u32,
    headlight: u32,
    checker: u32,
    // With --msaa: samples per pixel, each fragment's tag then carries their coverage mask
    // (see `fragment_covering`); 0 single-sampled.
    coverage_bits: u32,
    // 1 when some material blends other than over (`material_blend` then looks it up).
    blend_modes: u32,
    pad_c: u32,
}

struct Material {
    color: vec3<f32>,
    opacity: f32,
    absorption: f32,
    ior: f32,
    shading: u32,
    shininess: f32,
    // BLEND_*.
    blend: u32,
    pad_a: u32,
    pad_b: u32,
    pad_c: u32,
}

struct Light {
    position: vec3<f32>,
    kind: u32,
    direction: vec3<f32>,
    cos_outer: f32,
    radiance: vec3<f32>,
    range: f32,
    cos_inner: f32,
    // Attenuation 1 / (a + b·d + c·d²), windowed to zero at `range`.
    attenuation_a: f32,
    attenuation_b: f32,
    attenuation_c: f32,
}

const EFFECT_TRANSPARENCY: u32 = 0u;
const EFFECT_TRANSLUCENCY: u32 = 1u;
const EFFECT_COMPLEXITY: u32 = 2u;
const SHADING_UNLIT: u32 = 0u;
const LIGHT_POINT: u32 = 0u;
const LIGHT_SPOT: u32 = 1u;
const LIGHT_DIRECTIONAL: u32 = 2u;
const SPECULAR: f32 = 0.3;
// Material::blend (crate::scene::Blend::index).
const BLEND_OVER: u32 = 0u;
const BLEND_ADD: u32 = 1u;
const BLEND_MULTIPLY: u32 = 2u;

@group(0) @binding(0) var<uniform> frame: Frame;
#ifdef UNIFORM_SCENE
// A downlevel device's scene (no storage buffers): materials and lights in uniform arrays of
// fixed length, each vertex carrying its triangle's material (see `vs_scene`), no frame totals.
// Keep the lengths in sync with crates/strata/src/methods/peeling/downlevel.rs.
const UNIFORM_MATERIALS: u32 = 256u;
const UNIFORM_LIGHTS: u32 = 64u;
@group(0) @binding(1) var<uniform> materials: array<Material, 256>;
@group(0) @binding(2) var<uniform> lights: array<Light, 64>;
@group(0) @binding(3) var opaque_depth: texture_2d<f32>;
#else
// Each triangle's index into `materials` (the vertices are a vertex buffer: see `vs_scene`).
@group(0) @binding(1) var<storage, read> triangle_materials: array<u32>;
@group(0) @binding(2) var<storage, read> materials: array<Material>;
@group(0) @binding(3) var<storage, read> lights: array<Light>;
@group(0) @binding(4) var opaque_depth: texture_2d<f32>;
// Frame totals every resolve adds its pixels to; cleared before each frame. Keep the TOTAL_
// indices in sync with `Totals` in crates/strata/src/frame/mod.rs.
@group(0) @binding(5) var<storage, read_write> totals: array<atomic<u32>>;
#endif

#ifndef UNIFORM_SCENE
const TOTAL_GENERATED: u32 = 0u;
const TOTAL_STORED: u32 = 2u;
const TOTAL_DROPPED: u32 = 4u;
const TOTAL_MAX_DEPTH: u32 = 6u;
const TOTAL_CUT_SHORT: u32 = 7u;

// Adds `n` to the 64-bit total at words (at, at + 1): the low word wraps into a carry, so frame
// totals never wrap at 2^32.
fn total_add(at: u32, n: u32) {
    if n == 0u {
        return;
    }
    let old = atomicAdd(&totals[at], n);
    if old > 0xffffffffu - n {
        atomicAdd(&totals[at + 1u], 1u);
    }
}

// A resolve's account of one pixel: `generated` fragments reached it, `stored` of them were
// composited (the rest were dropped, or blended into a tail).
fn report_pixel(generated: u32, stored: u32) {
    total_add(TOTAL_GENERATED, generated);
    total_add(TOTAL_STORED, stored);
    total_add(TOTAL_DROPPED, generated - min(stored, generated));
    atomicMax(&totals[TOTAL_MAX_DEPTH], generated);
}

// The account of a group of pixels at once (a workgroup's, summed in workgroup memory first):
// `generated` fragments reached them, `stored` were composited, `dropped` were not (summed per
// pixel as `report_pixel` counts them), and the deepest had `deepest` — four atomics for the
// group instead of four per pixel.
fn report_pixels(generated: u32, stored: u32, dropped: u32, deepest: u32) {
    total_add(TOTAL_GENERATED, generated);
    total_add(TOTAL_STORED, stored);
    total_add(TOTAL_DROPPED, dropped);
    atomicMax(&totals[TOTAL_MAX_DEPTH], deepest);
}

// A resolve whose loops the adapter ended early (lavapipe's loop limit; see the k-buffer resolve):
// the frame is refused with the reason.
fn report_cut_short() {
    atomicAdd(&totals[TOTAL_CUT_SHORT], 1u);
}

// A multisampled pixel's account where a sample's own fragments set the depth complexity (the
// peeling methods' --msaa): `generated` fragments reached it, `stored` of them some sample
// composited, and its deepest sample has `deepest` fragments.
fn report_samples(generated: u32, stored: u32, deepest: u32) {
    total_add(TOTAL_GENERATED, generated);
    total_add(TOTAL_STORED, stored);
    total_add(TOTAL_DROPPED, generated - min(stored, generated));
    atomicMax(&totals[TOTAL_MAX_DEPTH], deepest);
}
#endif

// `position` is invariant: passes of different pipelines compare its depth for equality
// (kb-mdt32's color pass, dual peeling's bounds and peel passes).
struct SceneVarying {
    @builtin(position) @invariant position: vec4<f32>,
    @location(0) world: vec3<f32>,
    @location(1) normal: vec3<f32>,
    @location(2) @interpolate(flat) prim: u32,
    @location(3) @interpolate(flat) material: u32,
}

// The scene's vertex buffer (`GpuVertex`): vertex 3t + i is corner i of triangle t, whether
// drawn in order or through an index buffer of such vertex numbers (a sorted draw), so the
// vertex index names the primitive.
@vertex
fn vs_scene(
    @builtin(vertex_index) vertex_index: u32,
    @location(0) position: vec3<f32>,
    @location(1) normal: vec3<f32>,
#ifdef UNIFORM_SCENE
    @location(2) material: u32,
#endif
) -> SceneVarying {
    let prim = vertex_index / 3u;
    var out: SceneVarying;
    out.position = frame.view_proj * vec4<f32>(position, 1.0);
    out.world = position;
    out.normal = normal;
    out.prim = prim;
#ifdef UNIFORM_SCENE
    out.material = material;
#else
    out.material = triangle_materials[prim];
#endif
    return out;
}

// Shades a rasterized scene fragment into a record.
fn scene_fragment(v: SceneVarying, front_facing: bool) -> Fragment {
    return fragment_new(v.position.z, v.prim, front_facing, shade(v.world, v.normal, v.material));
}

// With --msaa: the record of a fragment shaded once for the samples `mask` it covers — the
// center's depth and color, and a tag of primitive << (1 + S) | mask << 1 | front-facing for S
// samples, which still orders equal depths by primitive. Single-sampled: `scene_fragment`.
fn scene_fragment_covering(v: SceneVarying, front_facing: bool, mask: u32) -> Fragment {
    var f = scene_fragment(v, front_facing);
    f.tag = covering_tag(v.prim, front_facing, mask);
    return f;
}

// Samples per pixel of a stage's targets: the frame's in a stage composed with MULTISAMPLED
// (`shader::target_samples`), else 1, a constant the compiler folds.
fn target_samples() -> u32 {
#ifdef MULTISAMPLED
    return frame.coverage_bits;
#else
    return 1u;
#endif
}

// Samples per pixel of the frame: with --msaa the S sample entries `p * S + s` a storage
// method keeps per pixel (each with its own claims, slots and state), single-sampled 1.
fn samples_per_pixel() -> u32 {
    return max(frame.coverage_bits, 1u);
}

// The entry of sample s of pixel p in a storage method's per-sample arrays, p · S + s.
fn sample_entry(p: u32, s: u32) -> u32 {
    return p * samples_per_pixel() + s;
}

// The tag of a fragment of `prim` covering the samples `mask`: the multisampled layout above
// with --msaa, primitive << 1 | front-facing single-sampled.
fn covering_tag(prim: u32, front_facing: bool, mask: u32) -> u32 {
    let bits = frame.coverage_bits;
    let facing = select(0u, 1u, front_facing);
    if bits == 0u {
        return (prim << 1u) | facing;
    }
    return (prim << (1u + bits)) | ((mask & ((1u << bits) - 1u)) << 1u) | facing;
}

#ifdef UNIFORM_SCENE
// A downlevel tag, primitive << 9 | material << 1 | front-facing: with no storage to look a
// primitive's material up in, the tag carries it. Tags of one primitive differ only in facing,
// so they order equal depths by primitive as the other layout does.
const UNIFORM_TAG_MATERIAL_SHIFT: u32 = 1u;
const UNIFORM_TAG_PRIM_SHIFT: u32 = 9u;

fn uniform_scene_tag(prim: u32, material: u32, front_facing: bool) -> u32 {
    return (prim << UNIFORM_TAG_PRIM_SHIFT) | (material << UNIFORM_TAG_MATERIAL_SHIFT) | select(0u, 1u, front_facing);
}

fn tag_prim(tag: u32) -> u32 {
    return tag >> UNIFORM_TAG_PRIM_SHIFT;
}

fn tag_material(tag: u32) -> u32 {
    return (tag >> UNIFORM_TAG_MATERIAL_SHIFT) & (UNIFORM_MATERIALS - 1u);
}
#else
// The primitive a tag names.
fn tag_prim(tag: u32) -> u32 {
    return tag >> (1u + frame.coverage_bits);
}

// The material of the fragment tagged `tag`.
fn tag_material(tag: u32) -> u32 {
    return triangle_materials[tag_prim(tag)];
}
#endif

// The blend mode (BLEND_*) of the fragment tagged `tag`: its material's, looked up only when
// some material blends other than over.
fn tag_blend(tag: u32) -> u32 {
    if frame.blend_modes == 0u {
        return BLEND_OVER;
    }
    return materials[tag_material(tag)].blend;
}

// The samples a fragment covers, bit i for sample i (every bit single-sampled).
fn fragment_coverage(f: Fragment) -> u32 {
    let bits = frame.coverage_bits;
    if bits == 0u {
        return 0xffffffffu;
    }
    return (f.tag >> 1u) & ((1u << bits) - 1u);
}

fn pixel_of(position: vec4<f32>) -> vec2<u32> {
    return vec2<u32>(position.xy);
}

fn pixel_index(pixel: vec2<u32>) -> u32 {
    return pixel.y * frame.size.x + pixel.x;
}

// True when an opaque surface in front hides this fragment.
fn behind_opaque(position: vec4<f32>) -> bool {
    return position.z >= textureLoad(opaque_depth, vec2<i32>(position.xy), 0).r;
}

fn background_at(pixel: vec2<u32>) -> vec3<f32> {
    if frame.checker == 0u {
        return frame.background.rgb;
    }
    if ((pixel.x / 16u + pixel.y / 16u) % 2u) == 0u {
        return frame.checker_light.rgb;
    }
    return frame.checker_dark.rgb;
}

// What a surface point receives from one light: `diffuse` multiplies the albedo, `specular` is
// added. Shared by every pipeline (forward per fragment, deferred light volumes) so their
// lighting is one formula.
struct LightTerms {
    diffuse: vec3<f32>,
    specular: vec3<f32>,
}

// Blinn–Phong from direction `l`, unit radiance.
fn blinn_phong_terms(n: vec3<f32>, v: vec3<f32>, l: vec3<f32>, shininess: f32) -> LightTerms {
    let hv = l + v;
    let h = hv / max(length(hv), 1e-6);
    return LightTerms(vec3<f32>(max(dot(n, l), 0.0)), vec3<f32>(SPECULAR * pow(max(dot(n, h), 0.0), shininess)));
}

// One light at a surface point (unit normal `n` facing the viewer `v`): Blinn–Phong times the
// light's radiance and attenuation — seed 004's 1 / (a + b·d + c·d²), times a window
// (1 − (d/range)²)² that reaches zero at the light volume's radius, so a volume bounds the light
// exactly — and, for spots, the cone's fade.
fn light_terms(light: Light, world: vec3<f32>, n: vec3<f32>, v: vec3<f32>, shininess: f32) -> LightTerms {
    var l = -normalize(light.direction);
    var attenuation = 1.0;
    if light.kind == LIGHT_POINT || light.kind == LIGHT_SPOT {
        let to_light = light.position - world;
        let d = length(to_light);
        l = to_light / max(d, 1e-12);
        let window = clamp(1.0 - (d / light.range) * (d / light.range), 0.0, 1.0);
        attenuation = window * window / (light.attenuation_a + d * (light.attenuation_b + d * light.attenuation_c));
        if light.kind == LIGHT_SPOT {
            let c = dot(-l, normalize(light.direction));
            attenuation *= clamp((c - light.cos_outer) / max(light.cos_inner - light.cos_outer, 1e-6), 0.0, 1.0);
        }
    } else if light.kind != LIGHT_DIRECTIONAL {
        return LightTerms(vec3<f32>(0.0), vec3<f32>(0.0));
    }
    let t = blinn_phong_terms(n, v, l, shininess);
    let radiance = light.radiance * attenuation;
    return LightTerms(radiance * t.diffuse, radiance * t.specular);
}

// Direction towards the viewer from a surface point.
fn view_direction(world: vec3<f32>) -> vec3<f32> {
    if frame.orthographic == 0u {
        return normalize(frame.eye.xyz - world);
    }
    return frame.to_camera.xyz;
}

// The unit normal turned towards the viewer (two-sided lighting).
fn facing_normal(normal: vec3<f32>, v: vec3<f32>) -> vec3<f32> {
    let n = normal / max(length(normal), 1e-12);
    return select(n, -n, dot(n, v) < 0.0);
}

#ifdef APP_SHADING
// An application's geometry pass: its own fragment shader computed the colour (straight alpha,
// linear) and handed it to `strata_capture`, which keeps it here for the method's step, whose
// `shade` then returns it (strata's materials and lights take no part).
var<private> app_surface: vec4<f32>;

fn set_app_surface(color: vec4<f32>) {
    app_surface = color;
}

fn shade(world: vec3<f32>, normal: vec3<f32>, material_index: u32) -> vec4<f32> {
    return app_surface;
}
#else
// Color and opacity of a surface point: unlit or two-sided Blinn–Phong, with Schlick Fresnel
// folded into the opacity for the translucency effect.
fn shade(world: vec3<f32>, normal: vec3<f32>, material_index: u32) -> vec4<f32> {
    let m = materials[material_index];
    let v = view_direction(world);
    let n = facing_normal(normal, v);
    var color = m.color;
    if m.shading != SHADING_UNLIT {
        var diffuse = frame.ambient.rgb;
        var specular = vec3<f32>(0.0);
        if frame.headlight != 0u {
            let t = blinn_phong_terms(n, v, v, m.shininess);
            diffuse += t.diffuse;
            specular += t.specular;
        }
        for (var i = 0u; i < frame.light_count; i++) {
            let t = light_terms(lights[i], world, n, v, m.shininess);
            diffuse += t.diffuse;
            specular += t.specular;
        }
        color = m.color * diffuse + specular;
    }
    var alpha = m.opacity;
    if frame.effect == EFFECT_TRANSLUCENCY {
        let f0 = ((m.ior - 1.0) / (m.ior + 1.0)) * ((m.ior - 1.0) / (m.ior + 1.0));
        let fresnel = f0 + (1.0 - f0) * pow(1.0 - clamp(abs(dot(n, v)), 0.0, 1.0), 5.0);
        alpha = fresnel + (1.0 - fresnel) * alpha;
    }
    return vec4<f32>(color, alpha);
}
#endif
