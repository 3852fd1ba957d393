// The shared resolve: turns a pixel's fragments, visited in depth order, into a color.
// Front-to-back:  C += T·α·c; T *= (1 − α), with Beer–Lambert attenuation exp(−σ·d) over each
// gap between consecutive fragments for the translucency effect. Back-to-front (dual peeling's
// back layers) computes the same sum with the over operator. The output is (rgb, fragment count).
// Keep `Composite` in sync with `CompositeState` in crates/strata/src/resolve/mod.rs.

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
    return materials[vertices[(tag >> 1u) * 3u].material].absorption;
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

// Back-to-front state: `color` already includes everything behind (starting with the background).
fn composite_back_new(background: vec3<f32>) -> Composite {
    return Composite(background, 1.0, 0u, 0.0, 0u, 0.0);
}

// Adds the next fragment in front of everything visited so far (over operator).
fn composite_back(s: ptr<function, Composite>, f: Fragment) {
    let distance = view_distance(f.depth);
    var behind = (*s).color;
    if (*s).count > 0u {
        behind *= gap_transmittance(f.tag, distance, (*s).last_tag, (*s).last_distance);
    }
    let c = fragment_color(f);
    (*s).color = c.a * c.rgb + (1.0 - c.a) * behind;
    (*s).count += 1u;
    (*s).last_depth = f.depth;
    (*s).last_tag = f.tag;
    (*s).last_distance = distance;
}

// Joins a front-to-back state with the background.
fn composite_finish(s: Composite, pixel: vec2<u32>) -> vec4<f32> {
    return vec4<f32>(s.color + s.transmittance * background_at(pixel), f32(s.count));
}

// Joins a front-to-back state with a back-to-front state that already holds the background.
fn composite_join(front: Composite, back: Composite) -> vec4<f32> {
    var behind = back.color;
    if front.count > 0u && back.count > 0u {
        behind *= gap_transmittance(front.last_tag, front.last_distance, back.last_tag, back.last_distance);
    }
    return vec4<f32>(front.color + front.transmittance * behind, f32(front.count + back.count));
}
