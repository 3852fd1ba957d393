#define_import_path strata::composite
#import strata::scene::{BLEND_ADD, BLEND_MULTIPLY, EFFECT_TRANSLUCENCY, frame, materials, tag_blend, tag_material}
#import strata::fragment::{Fragment, fragment_color}
#import strata::color::{Resolved}

// The shared resolve: turns a pixel's fragments, visited in depth order, into a color.
// Each fragment, by its material's blend mode, adds an emission e (times the transmittance in
// front of it) and multiplies the RGB transmittance by m, what it lets pass: over e = α·c, m = 1 − α; add
// e = α·c, m = 1; multiply e = 0, m = (1 − α) + α·c. Front to back: C += T·e; T *= m, with
// Beer–Lambert attenuation exp(−σ·d) over each gap between consecutive fragments for the
// translucency effect. Back to front (dual peeling's back layers) computes the same sum as
// C = e + m·C. The output is `Resolved`: premultiplied color and RGB transmittance, the picture
// being color + transmittance·(what lies behind), and the fragment count.
// Keep `Composite` in sync with `CompositeState` in crates/strata/src/resolve/mod.rs. `Resolved`
// is in color.wgsl.

struct Composite {
    color: vec3<f32>,
    count: u32,
    transmittance: vec3<f32>,
    // The last fragment visited: tag, window depth and view-space distance.
    last_tag: u32,
    last_depth: f32,
    last_distance: f32,
}

fn composite_new() -> Composite {
    return Composite(vec3<f32>(0.0), 0u, vec3<f32>(1.0), 0u, 0.0, 0.0);
}

// A fragment's part in the composite: the light it adds and the filter it puts on what lies
// behind it.
struct BlendTerms {
    emission: vec3<f32>,
    passed: vec3<f32>,
}

fn blend_terms(f: Fragment) -> BlendTerms {
    let c = fragment_color(f);
    let mode = tag_blend(f.tag);
    if mode == BLEND_MULTIPLY {
        return BlendTerms(vec3<f32>(0.0), vec3<f32>(1.0 - c.a) + c.a * c.rgb);
    }
    let emission = c.a * c.rgb;
    if mode == BLEND_ADD {
        return BlendTerms(emission, vec3<f32>(1.0));
    }
    return BlendTerms(emission, vec3<f32>(1.0 - c.a));
}

// View-space distance along the view axis of a window-space depth.
fn view_distance(depth: f32) -> f32 {
    if frame.orthographic != 0u {
        return frame.near + depth * (frame.far - frame.near);
    }
    return frame.near * frame.far / (frame.far - depth * (frame.far - frame.near));
}

fn absorption_of(tag: u32) -> f32 {
    return materials[tag_material(tag)].absorption;
}

// σ of the medium between a nearer and a farther fragment: inside the nearer one's object if it
// is entered there (front-facing), else inside the farther one's if it is left there.
fn gap_absorption(nearer_tag: u32, farther_tag: u32) -> f32 {
    if (nearer_tag & 1u) == 1u {
        return absorption_of(nearer_tag);
    }
    if (farther_tag & 1u) == 0u {
        return absorption_of(farther_tag);
    }
    return 0.0;
}

fn gap_transmittance(nearer_tag: u32, nearer_distance: f32, farther_tag: u32, farther_distance: f32) -> f32 {
    if frame.effect != EFFECT_TRANSLUCENCY {
        return 1.0;
    }
    let sigma = gap_absorption(nearer_tag, farther_tag);
    if sigma == 0.0 {
        return 1.0;
    }
    return exp(-sigma * max(farther_distance - nearer_distance, 0.0));
}

// Adds the next fragment behind everything visited so far.
fn composite_front(s: ptr<function, Composite>, f: Fragment) {
    let distance = view_distance(f.depth);
    if (*s).count > 0u {
        (*s).transmittance *= gap_transmittance((*s).last_tag, (*s).last_distance, f.tag, distance);
    }
    let b = blend_terms(f);
    (*s).color += (*s).transmittance * b.emission;
    (*s).transmittance *= b.passed;
    (*s).count += 1u;
    (*s).last_depth = f.depth;
    (*s).last_tag = f.tag;
    (*s).last_distance = distance;
}

// Back-to-front state: `color` and `transmittance` are those of everything visited so far.
fn composite_back_new() -> Composite {
    return composite_new();
}

// Adds the next fragment in front of everything visited so far.
fn composite_back(s: ptr<function, Composite>, f: Fragment) {
    let distance = view_distance(f.depth);
    var behind = (*s).color;
    var behind_t = (*s).transmittance;
    if (*s).count > 0u {
        let g = gap_transmittance(f.tag, distance, (*s).last_tag, (*s).last_distance);
        behind *= g;
        behind_t *= g;
    }
    let b = blend_terms(f);
    (*s).color = b.emission + b.passed * behind;
    (*s).transmittance = b.passed * behind_t;
    (*s).count += 1u;
    (*s).last_depth = f.depth;
    (*s).last_tag = f.tag;
    (*s).last_distance = distance;
}

// The pixel's result from a front-to-back state.
fn composite_finish(s: Composite) -> Resolved {
    return Resolved(s.color, s.count, s.transmittance, 0u);
}

// Joins a front-to-back state with a back-to-front state behind it.
fn composite_join(front: Composite, back: Composite) -> Resolved {
    var behind = back.color;
    var behind_t = back.transmittance;
    if front.count > 0u && back.count > 0u {
        let g = gap_transmittance(front.last_tag, front.last_distance, back.last_tag, back.last_distance);
        behind *= g;
        behind_t *= g;
    }
    return Resolved(front.color + front.transmittance * behind, front.count + back.count, front.transmittance * behind_t, 0u);
}
