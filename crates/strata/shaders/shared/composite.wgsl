#define_import_path strata::composite
#import strata::scene::{EFFECT_TRANSLUCENCY, frame, materials, tag_prim, triangle_materials}
#import strata::fragment::{Fragment, fragment_color}
#import strata::color::{Resolved}

// The shared resolve: turns a pixel's fragments, visited in depth order, into a color.
// Front-to-back:  C += T·α·c; T *= (1 − α), with Beer–Lambert attenuation exp(−σ·d) over each
// gap between consecutive fragments for the translucency effect. Back-to-front (dual peeling's
// back layers) computes the same sum with the over operator. The output is `Resolved`:
// premultiplied color and alpha = 1 − transmittance, to be blended OVER whatever is behind (the
// application's target, or the CLI's background), and the fragment count.
// Keep `Composite` in sync with `CompositeState` in crates/strata/src/resolve/mod.rs. `Resolved`
// is in color.wgsl.

struct Composite {
    color: vec3<f32>,
    transmittance: f32,
    count: u32,
    // The last fragment visited: window depth, tag, and view-space distance.
    last_depth: f32,
    last_tag: u32,
    last_distance: f32,
}

fn composite_new() -> Composite {
    return Composite(vec3<f32>(0.0), 1.0, 0u, 0.0, 0u, 0.0);
}

// View-space distance along the view axis of a window-space depth.
fn view_distance(depth: f32) -> f32 {
    if frame.orthographic != 0u {
        return frame.near + depth * (frame.far - frame.near);
    }
    return frame.near * frame.far / (frame.far - depth * (frame.far - frame.near));
}

fn absorption_of(tag: u32) -> f32 {
    return materials[triangle_materials[tag_prim(tag)]].absorption;
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
    let c = fragment_color(f);
    (*s).color += (*s).transmittance * c.a * c.rgb;
    (*s).transmittance *= 1.0 - c.a;
    (*s).count += 1u;
    (*s).last_depth = f.depth;
    (*s).last_tag = f.tag;
    (*s).last_distance = distance;
}

// Back-to-front state: `color` and `transmittance` are those of everything visited so far.
fn composite_back_new() -> Composite {
    return Composite(vec3<f32>(0.0), 1.0, 0u, 0.0, 0u, 0.0);
}

// Adds the next fragment in front of everything visited so far (over operator).
fn composite_back(s: ptr<function, Composite>, f: Fragment) {
    let distance = view_distance(f.depth);
    var behind = (*s).color;
    var behind_t = (*s).transmittance;
    if (*s).count > 0u {
        let g = gap_transmittance(f.tag, distance, (*s).last_tag, (*s).last_distance);
        behind *= g;
        behind_t *= g;
    }
    let c = fragment_color(f);
    (*s).color = c.a * c.rgb + (1.0 - c.a) * behind;
    (*s).transmittance = (1.0 - c.a) * behind_t;
    (*s).count += 1u;
    (*s).last_depth = f.depth;
    (*s).last_tag = f.tag;
    (*s).last_distance = distance;
}

// The pixel's result from a front-to-back state.
fn composite_finish(s: Composite) -> Resolved {
    return Resolved(vec4<f32>(s.color, 1.0 - s.transmittance), s.count, 0u, 0u, 0u);
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
    let t = front.transmittance * behind_t;
    return Resolved(vec4<f32>(front.color + front.transmittance * behind, 1.0 - t), front.count + back.count, 0u, 0u, 0u);
}
