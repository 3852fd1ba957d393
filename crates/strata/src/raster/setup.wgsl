#define_import_path strata::raster::setup
#import strata::scene::{SceneVarying, frame, triangle_materials}

// Triangle setup of the compute rasterizer, shared by its bin and raster stages. It follows the
// GPU path and the CPU reference (crates/strata/src/reference/raster.rs): the vertex transform
// of `vs_scene`, clipping at the near plane (and at a guard band far outside the viewport),
// window coordinates snapped to 1/256 pixel, pixel centers with the top-left rule on exact
// 64-bit edge functions, depth interpolated linearly in the window and attributes
// perspective-correctly, both from the unsnapped window positions.

// The scene's vertex buffer (`GpuVertex`, six floats: position, normal) read as storage; the
// group is the stage's raster bindings (the definition RASTER_GROUP).
@group(#{RASTER_GROUP}) @binding(3) var<storage, read> scene_vertices: array<f32>;

struct SceneVertex {
    position: vec3<f32>,
    normal: vec3<f32>,
}

// Corner `corner` of triangle `prim`.
fn scene_vertex(prim: u32, corner: u32) -> SceneVertex {
    let at = (prim * 3u + corner) * 6u;
    return SceneVertex(
        vec3<f32>(scene_vertices[at], scene_vertices[at + 1u], scene_vertices[at + 2u]),
        vec3<f32>(scene_vertices[at + 3u], scene_vertices[at + 4u], scene_vertices[at + 5u]),
    );
}

const SUBPIXEL: f32 = 256.0;
const HALF_SUBPIXEL: i32 = 128;
// Pixels per side of the tiles large triangles are binned into.
const TILE: i32 = 8;
// A clipped triangle has at most 3 corners plus one per clipping plane (near, four guard band).
const MAX_CORNERS: u32 = 8u;

// 64-bit two's complement integers as (low, high) words: edge functions of coordinates up to
// 2^29 subpixels need 62 bits.
fn wide_from(a: i32) -> vec2<u32> {
    return vec2<u32>(bitcast<u32>(a), select(0u, 0xffffffffu, a < 0));
}

fn wide_add(a: vec2<u32>, b: vec2<u32>) -> vec2<u32> {
    let lo = a.x + b.x;
    return vec2<u32>(lo, a.y + b.y + select(0u, 1u, lo < a.x));
}

fn wide_negate(a: vec2<u32>) -> vec2<u32> {
    let lo = ~a.x + 1u;
    return vec2<u32>(lo, ~a.y + select(0u, 1u, lo == 0u));
}

// a·b for |a|, |b| < 2^31, from 16-bit partial products.
fn wide_mul(a: i32, b: i32) -> vec2<u32> {
    let ua = u32(abs(a));
    let ub = u32(abs(b));
    let a0 = ua & 0xffffu;
    let a1 = ua >> 16u;
    let b0 = ub & 0xffffu;
    let b1 = ub >> 16u;
    let low = a0 * b0;
    // a1, b1 < 2^15, so the middle sum stays below 2^32.
    let middle = a0 * b1 + a1 * b0;
    let lo = low + (middle << 16u);
    let hi = a1 * b1 + (middle >> 16u) + select(0u, 1u, lo < low);
    let product = vec2<u32>(lo, hi);
    return select(product, wide_negate(product), (a < 0) != (b < 0));
}

fn wide_negative(a: vec2<u32>) -> bool {
    return bitcast<i32>(a.y) < 0;
}

fn wide_zero(a: vec2<u32>) -> bool {
    return a.x == 0u && a.y == 0u;
}

// A corner of the clipped polygon: clip-space position and its barycentric weights in the
// original triangle.
struct Corner {
    clip: vec4<f32>,
    weights: vec3<f32>,
}

struct Polygon {
    corners: array<Corner, 8>,
    count: u32,
}

// Sutherland–Hodgman against the half-space dot(plane, clip) ≥ 0.
fn clip_polygon(polygon: Polygon, plane: vec4<f32>) -> Polygon {
    var source = polygon.corners;
    var out: Polygon;
    out.count = 0u;
    let n = min(polygon.count, MAX_CORNERS);
    for (var i = 0u; i < n; i++) {
        let a = source[i];
        let b = source[(i + 1u) % n];
        let da = dot(plane, a.clip);
        let db = dot(plane, b.clip);
        if da >= 0.0 && out.count < MAX_CORNERS {
            out.corners[out.count] = a;
            out.count += 1u;
        }
        if (da >= 0.0) != (db >= 0.0) && out.count < MAX_CORNERS {
            let t = da / (da - db);
            out.corners[out.count] = Corner(a.clip + (b.clip - a.clip) * t, a.weights + (b.weights - a.weights) * t);
            out.count += 1u;
        }
    }
    return out;
}

// Triangle `prim` transformed as `vs_scene` does and clipped: near plane z ≥ 0 (wgpu's), and
// |x|, |y| ≤ guard·w, which keeps window coordinates inside the edge functions' range.
fn clipped_triangle(prim: u32, guard: f32) -> Polygon {
    var polygon: Polygon;
    polygon.count = 3u;
    var in_front = true;
    var in_guard = true;
    for (var i = 0u; i < 3u; i++) {
        let v = scene_vertex(prim, i);
        let clip = frame.view_proj * vec4<f32>(v.position, 1.0);
        polygon.corners[i] = Corner(clip, vec3<f32>(f32(i == 0u), f32(i == 1u), f32(i == 2u)));
        in_front = in_front && clip.z >= 0.0;
        in_guard = in_guard && abs(clip.x) <= guard * clip.w && abs(clip.y) <= guard * clip.w;
    }
    // The near plane, then the four guard planes, in one loop: one copy of the clip in the
    // compiled shader rather than five (a software rasterizer's compile time).
    let planes = array<vec4<f32>, 5>(
        vec4<f32>(0.0, 0.0, 1.0, 0.0),
        vec4<f32>(-1.0, 0.0, 0.0, guard),
        vec4<f32>(1.0, 0.0, 0.0, guard),
        vec4<f32>(0.0, -1.0, 0.0, guard),
        vec4<f32>(0.0, 1.0, 0.0, guard),
    );
    for (var k = 0u; k < 5u; k++) {
        if select(!in_guard, !in_front, k == 0u) {
            polygon = clip_polygon(polygon, planes[k]);
        }
    }
    return polygon;
}

// A corner in the window: snapped position (subpixels, y down), unsnapped position (pixels),
// depth, 1/w and weights.
struct WindowCorner {
    snapped: vec2<i32>,
    window: vec2<f32>,
    z: f32,
    inv_w: f32,
    weights: vec3<f32>,
}

fn to_window(c: Corner) -> WindowCorner {
    let inv_w = 1.0 / c.clip.w;
    let size = vec2<f32>(frame.size);
    let window = vec2<f32>((c.clip.x * inv_w + 1.0) * 0.5 * size.x, (1.0 - c.clip.y * inv_w) * 0.5 * size.y);
    return WindowCorner(snapped(window), window, c.clip.z * inv_w, inv_w, c.weights);
}

// A window position snapped to the subpixel grid.
fn snapped(window: vec2<f32>) -> vec2<i32> {
    return vec2<i32>(floor(window * SUBPIXEL + 0.5));
}

// One triangle of a clipped polygon's fan, ready to rasterize.
struct SetupTriangle {
    corners: array<WindowCorner, 3>,
    // Doubled signed area in subpixels², y down; negative is counter-clockwise on screen, which
    // is front-facing.
    doubled_area: vec2<u32>,
    // Candidate pixels, inclusive, clamped to the viewport; empty when min > max.
    min: vec2<i32>,
    max: vec2<i32>,
    valid: bool,
}

// The fan triangle (0, j + 1, j + 2) of `polygon`.
fn fan_triangle(polygon: Polygon, j: u32) -> SetupTriangle {
    var corners = polygon.corners;
    var t = triangle_of(
        to_window(corners[0]),
        to_window(corners[min(j + 1u, MAX_CORNERS - 1u)]),
        to_window(corners[min(j + 2u, MAX_CORNERS - 1u)]),
    );
    t.valid = t.valid && j + 2u < polygon.count;
    return t;
}

// The triangle of three window corners: its doubled area and candidate pixels from the snapped
// positions; valid when it has area, lies in front of the eye and meets a pixel center's
// bounds in the viewport.
fn triangle_of(c0: WindowCorner, c1: WindowCorner, c2: WindowCorner) -> SetupTriangle {
    var t: SetupTriangle;
    t.corners = array<WindowCorner, 3>(c0, c1, c2);
    let a = c0.snapped;
    let b = c1.snapped;
    let c = c2.snapped;
    t.doubled_area = wide_add(wide_mul(b.x - a.x, c.y - a.y), wide_negate(wide_mul(c.x - a.x, b.y - a.y)));
    let lo = min(a, min(b, c));
    let hi = max(a, max(b, c));
    // Pixel p is a candidate when its center p + 1/2 lies in [lo, hi] (arithmetic shifts floor);
    // with --msaa (only tiled takes it here) when its square [p, p + 1) meets [lo, hi], which
    // holds every sample position.
    var first = (lo - vec2<i32>(HALF_SUBPIXEL) + vec2<i32>(255)) >> vec2<u32>(8u);
    var last = (hi - vec2<i32>(HALF_SUBPIXEL)) >> vec2<u32>(8u);
    if frame.coverage_bits != 0u {
        first = lo >> vec2<u32>(8u);
        last = hi >> vec2<u32>(8u);
    }
    t.min = max(first, vec2<i32>(0));
    t.max = min(last, vec2<i32>(frame.size) - vec2<i32>(1));
    let positive_w = c0.inv_w > 0.0 && c1.inv_w > 0.0 && c2.inv_w > 0.0;
    t.valid = !wide_zero(t.doubled_area) && positive_w && all(t.min <= t.max);
    return t;
}

// A set-up triangle as the bin stage stores it for later passes (tiled's): its primitive, then
// per corner the unsnapped window position, depth, 1/w and weights — SETUP_RECORD_WORDS words.
// The snapped positions, area and bounds are what `triangle_of` derives from those exactly, so
// a pass reading the record gets the bin's triangle bit for bit without clipping it again.
const SETUP_RECORD_WORDS: u32 = 22u;

fn setup_record(prim: u32, t: SetupTriangle) -> array<u32, SETUP_RECORD_WORDS> {
    var words: array<u32, SETUP_RECORD_WORDS>;
    var corners = t.corners;
    words[0] = prim;
    for (var i = 0u; i < 3u; i++) {
        let c = corners[i];
        let at = 1u + 7u * i;
        words[at] = bitcast<u32>(c.window.x);
        words[at + 1u] = bitcast<u32>(c.window.y);
        words[at + 2u] = bitcast<u32>(c.z);
        words[at + 3u] = bitcast<u32>(c.inv_w);
        words[at + 4u] = bitcast<u32>(c.weights.x);
        words[at + 5u] = bitcast<u32>(c.weights.y);
        words[at + 6u] = bitcast<u32>(c.weights.z);
    }
    return words;
}

// Corner `i` of a stored record.
fn record_corner(words: array<u32, SETUP_RECORD_WORDS>, i: u32) -> WindowCorner {
    var w = words;
    let at = 1u + 7u * i;
    let window = vec2<f32>(bitcast<f32>(w[at]), bitcast<f32>(w[at + 1u]));
    let weights = vec3<f32>(bitcast<f32>(w[at + 4u]), bitcast<f32>(w[at + 5u]), bitcast<f32>(w[at + 6u]));
    return WindowCorner(snapped(window), window, bitcast<f32>(w[at + 2u]), bitcast<f32>(w[at + 3u]), weights);
}

// The triangle a record holds.
fn record_triangle(words: array<u32, SETUP_RECORD_WORDS>) -> SetupTriangle {
    return triangle_of(record_corner(words, 0u), record_corner(words, 1u), record_corner(words, 2u));
}

// The edges of a set-up triangle, oriented so that its interior is where all three edge
// functions are positive. A pixel center exactly on an edge counts only for top edges
// (horizontal, interior below) and left edges (going up the screen, y down): the others are
// `strict`.
struct Edges {
    origin: array<vec2<i32>, 3>,
    delta: array<vec2<i32>, 3>,
    strict: array<bool, 3>,
}

fn oriented_edges(t: SetupTriangle) -> Edges {
    var order = array<u32, 3>(0u, 1u, 2u);
    if wide_negative(t.doubled_area) {
        order = array<u32, 3>(0u, 2u, 1u);
    }
    var corners = t.corners;
    var e: Edges;
    for (var i = 0u; i < 3u; i++) {
        let a = corners[order[i]].snapped;
        let d = corners[order[(i + 1u) % 3u]].snapped - a;
        e.origin[i] = a;
        e.delta[i] = d;
        e.strict[i] = !(d.y < 0 || (d.y == 0 && d.x > 0));
    }
    return e;
}

// Edge i's function at the subpixel point s: dx·(y − ay) − dy·(x − ax), exact in 64 bits.
fn edge_value(e: Edges, i: u32, s: vec2<i32>) -> vec2<u32> {
    var origin = e.origin;
    var delta = e.delta;
    let a = origin[i];
    let d = delta[i];
    return wide_add(wide_mul(d.x, s.y - a.y), wide_negate(wide_mul(d.y, s.x - a.x)));
}

// The pixel centers of the 8×8 tile `tile` inside `t`, as a 64-bit mask (bit (y − 8·tile.y)·8
// + x − 8·tile.x, low word first).
fn tile_coverage(t: SetupTriangle, tile: vec2<i32>) -> vec2<u32> {
    return tile_coverage_at(t, tile, vec2<i32>(HALF_SUBPIXEL));
}

// The pixels of the 8×8 tile `tile` whose point at `offset` (subpixels from the pixel's
// corner: a sample position) lies inside `t`, as `tile_coverage`'s mask: the edge functions
// evaluated exactly at the first pixel's point and stepped by whole pixels.
fn tile_coverage_at(t: SetupTriangle, tile: vec2<i32>, offset: vec2<i32>) -> vec2<u32> {
    var mask = vec2<u32>(0u);
    let corner = tile * TILE;
    let lo = max(t.min, corner);
    let hi = min(t.max, corner + vec2<i32>(TILE - 1));
    if !t.valid || any(lo > hi) {
        return mask;
    }
    let edges = oriented_edges(t);
    var strict = edges.strict;
    var delta = edges.delta;
    var edge: array<vec2<u32>, 3>;
    var step_x: array<vec2<u32>, 3>;
    var step_y: array<vec2<u32>, 3>;
    let start = lo * 256 + offset;
    for (var i = 0u; i < 3u; i++) {
        edge[i] = edge_value(edges, i, start);
        step_x[i] = wide_mul(-delta[i].y, 256);
        step_y[i] = wide_mul(delta[i].x, 256);
    }
    for (var y = lo.y; y <= hi.y; y++) {
        var row = edge;
        for (var x = lo.x; x <= hi.x; x++) {
            var inside = true;
            for (var i = 0u; i < 3u; i++) {
                if wide_negative(row[i]) || (strict[i] && wide_zero(row[i])) {
                    inside = false;
                }
                row[i] = wide_add(row[i], step_x[i]);
            }
            if inside {
                let bit = u32((y - corner.y) * TILE + x - corner.x);
                mask[bit / 32u] |= 1u << (bit % 32u);
            }
        }
        for (var i = 0u; i < 3u; i++) {
            edge[i] = wide_add(edge[i], step_y[i]);
        }
    }
    return mask;
}

// The pixel of bit `bit` of tile `tile`'s coverage mask.
fn tile_pixel(tile: vec2<i32>, bit: u32) -> vec2<i32> {
    return tile * TILE + vec2<i32>(i32(bit % 8u), i32(bit / 8u));
}

// Where `pixel`'s center lies in `t`: its barycentric weights in the window (from the
// unsnapped positions) and its depth, interpolated linearly and clamped as the GPU's path does.
struct Barycentrics {
    l: vec3<f32>,
    depth: f32,
}

fn barycentrics_at(t: SetupTriangle, pixel: vec2<i32>) -> Barycentrics {
    return barycentrics_at_point(t, vec2<f32>(f32(pixel.x) + 0.5, f32(pixel.y) + 0.5));
}

// `barycentrics_at` of the window point `point` (pixels): a sample position with --msaa.
fn barycentrics_at_point(t: SetupTriangle, point: vec2<f32>) -> Barycentrics {
    var corners = t.corners;
    let w0 = corners[0].window;
    let e1 = corners[1].window - w0;
    let e2 = corners[2].window - w0;
    let area = e1.x * e2.y - e2.x * e1.y;
    let p = point - w0;
    let l1 = (p.x * e2.y - e2.x * p.y) / area;
    let l2 = (e1.x * p.y - p.x * e1.y) / area;
    let l = vec3<f32>(1.0 - l1 - l2, l1, l2);
    // A centre on a near-clipped edge can interpolate to just below 0 (or to -0.0), which
    // keys made of a depth's bits (kpeel, MDT, dual, tiled) would sort last; the GPU's path
    // clamps depth to the viewport's range, and so does this one.
    let interpolated = dot(l, vec3<f32>(corners[0].z, corners[1].z, corners[2].z));
    return Barycentrics(l, select(interpolated, 0.0, !(interpolated > 0.0)));
}

// The window position `vs_scene` gives the fragment stage at `pixel`'s center (depth only: w
// is `varying_at`'s).
fn window_position(pixel: vec2<i32>, depth: f32) -> vec4<f32> {
    return vec4<f32>(f32(pixel.x) + 0.5, f32(pixel.y) + 0.5, depth, 1.0);
}

// What `vs_scene` passes the fragment stage at the center of `pixel`, inside primitive
// `prim`'s fan triangle `t`: depth interpolated linearly in the window, world position and
// normal perspective-correctly, both from the unsnapped window positions.
fn varying_at(t: SetupTriangle, prim: u32, pixel: vec2<i32>) -> SceneVarying {
    return varying_from(t, prim, pixel, barycentrics_at(t, pixel));
}

// `varying_at` from the pixel's barycentrics, already computed.
fn varying_from(t: SetupTriangle, prim: u32, pixel: vec2<i32>, b: Barycentrics) -> SceneVarying {
    var corners = t.corners;
    let pw = b.l * vec3<f32>(corners[0].inv_w, corners[1].inv_w, corners[2].inv_w);
    let inv_w = pw.x + pw.y + pw.z;
    let weights = (corners[0].weights * pw.x + corners[1].weights * pw.y + corners[2].weights * pw.z) / inv_w;
    let v0 = scene_vertex(prim, 0u);
    let v1 = scene_vertex(prim, 1u);
    let v2 = scene_vertex(prim, 2u);
    var v: SceneVarying;
    v.position = vec4<f32>(f32(pixel.x) + 0.5, f32(pixel.y) + 0.5, b.depth, inv_w);
    v.world = v0.position * weights.x + v1.position * weights.y + v2.position * weights.z;
    v.normal = v0.normal * weights.x + v1.normal * weights.y + v2.normal * weights.z;
    v.prim = prim;
    v.material = triangle_materials[prim];
    return v;
}
