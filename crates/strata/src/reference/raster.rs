//! Triangle setup and coverage for the CPU reference, following the GPU's rules: clipping at the
//! near plane (z ≥ 0 in clip space), window coordinates snapped to 1/256 pixel (the subpixel
//! precision of the software Vulkan driver tests run on), pixel-center sampling with the top-left
//! rule in exact integer arithmetic; depth (screen-linear) and attributes (perspective-correct)
//! interpolated from the *unsnapped* window positions, as lavapipe's attribute planes are — at
//! near edge-on triangles, where depth changes fast across a pixel, this decides the order of
//! fragments that are almost at the same depth. (The H100 interpolates from the snapped positions
//! instead: [`SetupTriangle::snap_planes`].) With `--msaa` coverage is tested at the
//! standard sample positions ([`crate::frame::msaa::positions`]) and a pixel's fragment is
//! shaded, and its depth taken, at the pixel center (extrapolated when the center lies outside),
//! as the GPU shades multisampled fragments.

use glam::{DMat4, DVec3, DVec4};

/// Subpixel steps per pixel.
pub const SUBPIXEL: f64 = 256.0;

/// Half-extent of the guard band in normalized device coordinates: a polygon reaching beyond
/// ±64 viewports is clipped to it (as GPUs clip at their guard band), which keeps snapped
/// coordinates below 2²⁷ subpixels at 16384 pixels and their products in i64. Polygons inside
/// it — every ordinary view — are rasterized exactly as before.
const GUARD_BAND: f64 = 64.0;

/// Window coordinates (pixels) beyond which a corner cannot come from the guard band at any
/// supported size: only precision loss puts one there.
const SNAP_LIMIT: f64 = (1u64 << 22) as f64;

/// Sutherland–Hodgman: the part of `poly` where `distance` ≥ 0, barycentric weights carried.
fn clip_polygon(poly: Vec<(DVec4, DVec3)>, distance: impl Fn(DVec4) -> f64) -> Vec<(DVec4, DVec3)> {
    let mut out = Vec::with_capacity(poly.len() + 1);
    for i in 0..poly.len() {
        let (a, wa) = poly[i];
        let (b, wb) = poly[(i + 1) % poly.len()];
        let (da, db) = (distance(a), distance(b));
        if da >= 0.0 {
            out.push((a, wa));
        }
        if (da >= 0.0) != (db >= 0.0) {
            let t = da / (da - db);
            out.push((a + (b - a) * t, wa + (wb - wa) * t));
        }
    }
    out
}

/// A triangle ready to rasterize: snapped window positions and, per corner, what interpolation
/// needs. A near-clipped triangle becomes several of these with the same primitive index.
#[derive(Clone, Debug)]
pub struct SetupTriangle {
    /// The scene's triangle index.
    pub prim: u32,
    /// Snapped window x, y in subpixel units (y down): coverage.
    pub xy: [[i64; 2]; 3],
    /// Window x, y in pixels that depth and attributes are interpolated from: unsnapped, as
    /// lavapipe's attribute planes use them, or the snapped `xy` after [`Self::snap_planes`].
    pub window: [[f64; 2]; 3],
    /// Window depth per corner.
    pub z: [f64; 3],
    /// 1/w per corner (1 for orthographic).
    pub inv_w: [f64; 3],
    /// Barycentric weights of each corner in the original triangle (clipping makes new corners).
    pub weights: [DVec3; 3],
    /// Signed doubled area in subpixel² units, y down; negative means counter-clockwise on screen
    /// (front-facing).
    pub area2: i64,
    /// Pixel bounds, inclusive, clamped to the viewport.
    pub min: [u32; 2],
    /// Largest pixel x, y covered (inclusive).
    pub max: [u32; 2],
}

impl SetupTriangle {
    /// Interpolates depth and attributes from the corners as snapped to the subpixel grid (`xy`)
    /// rather than from the exact window corners: what a rasterizer that sets up its planes from
    /// its fixed-point positions computes. The H100 does (2026-11-27): on near edge-on triangles
    /// its depths were up to 2.3e-5 from the exact planes' (1.5e-3 extrapolated to the centre of
    /// a partly covered pixel) and a few shaded colors 0.19 off, all on the snapped planes.
    pub fn snap_planes(&mut self) {
        self.window = self.xy.map(|c| c.map(|v| v as f64 / SUBPIXEL));
    }
}

/// The sample positions of `samples` per pixel in subpixel units from the pixel's corner.
fn sample_offsets(samples: u32) -> Vec<[i64; 2]> {
    crate::frame::msaa::positions(samples)
        .iter()
        .map(|p| p.map(|c| (c * SUBPIXEL) as i64))
        .collect()
}

/// Projects and clips triangle `prim` with corners `p` (world space); its pixel bounds hold
/// every pixel with a sample inside it at `samples` per pixel.
#[allow(clippy::too_many_arguments)]
pub fn setup(
    prim: u32,
    p: [DVec3; 3],
    view_proj: &DMat4,
    width: u32,
    height: u32,
    samples: u32,
    out: &mut Vec<SetupTriangle>,
) {
    let offsets = sample_offsets(samples);
    let clip: Vec<(DVec4, DVec3)> = (0..3)
        .map(|i| {
            (
                *view_proj * p[i].extend(1.0),
                DVec3::from_array(std::array::from_fn(|j| (i == j) as u32 as f64)),
            )
        })
        .collect();
    if clip.iter().any(|(c, _)| !c.is_finite()) {
        return;
    }
    // Clip the polygon against z >= 0 (wgpu's near plane), keeping barycentric weights.
    let mut poly = clip_polygon(clip, |c| c.z);
    if poly.len() < 3 {
        return;
    }
    let beyond = |c: &DVec4| c.x.abs() > GUARD_BAND * c.w || c.y.abs() > GUARD_BAND * c.w;
    if poly.iter().any(|(c, _)| beyond(c)) {
        for (axis, sign) in [(0, 1.0), (0, -1.0), (1, 1.0), (1, -1.0)] {
            poly = clip_polygon(poly, |c| GUARD_BAND * c.w - sign * c[axis]);
            if poly.len() < 3 {
                return;
            }
        }
    }
    let project = |(c, w): (DVec4, DVec3)| {
        let inv_w = 1.0 / c.w;
        let x = (c.x * inv_w + 1.0) * 0.5 * width as f64;
        let y = (1.0 - c.y * inv_w) * 0.5 * height as f64;
        (
            [(x * SUBPIXEL).round() as i64, (y * SUBPIXEL).round() as i64],
            c.z * inv_w,
            inv_w,
            w,
            [x, y],
        )
    };
    let corners: Vec<_> = poly.into_iter().map(project).collect();
    for i in 1..corners.len() - 1 {
        let tri = [corners[0], corners[i], corners[i + 1]];
        let xy = tri.map(|c| c.0);
        // Clipping an edge whose ends differ by ~1e24 can cancel a clipped corner's w to 0;
        // such a sliver has no pixels the guard band lets through, and its coordinates would
        // overflow the integer edge functions.
        let unsafe_corner = |c: &(_, f64, f64, _, [f64; 2])| {
            !(c.2.is_finite() && c.2 > 0.0)
                || c.4.iter().any(|v| v.is_nan() || v.abs() >= SNAP_LIMIT)
        };
        if tri.iter().any(unsafe_corner) {
            continue;
        }
        let area2 = (xy[1][0] - xy[0][0]) * (xy[2][1] - xy[0][1])
            - (xy[2][0] - xy[0][0]) * (xy[1][1] - xy[0][1]);
        if area2 == 0 || tri.iter().any(|c| !c.2.is_finite() || c.2 <= 0.0) {
            continue;
        }
        let lo = |k: usize| xy.iter().map(|v| v[k]).min().unwrap();
        let hi = |k: usize| xy.iter().map(|v| v[k]).max().unwrap();
        // Samples at p + offset: pixel p is a candidate if one of its samples lies in [lo, hi].
        let off = |k: usize| {
            let o = offsets.iter().map(|o| o[k]);
            (o.clone().min().unwrap_or(0), o.max().unwrap_or(0))
        };
        let first = |v: i64, max_off: i64| ((v - max_off) as f64 / SUBPIXEL).ceil() as i64;
        let last = |v: i64, min_off: i64| ((v - min_off) as f64 / SUBPIXEL).floor() as i64;
        let ((ox0, ox1), (oy0, oy1)) = (off(0), off(1));
        let (x0, x1) = (
            first(lo(0), ox1).max(0),
            last(hi(0), ox0).min(width as i64 - 1),
        );
        let (y0, y1) = (
            first(lo(1), oy1).max(0),
            last(hi(1), oy0).min(height as i64 - 1),
        );
        if x0 > x1 || y0 > y1 {
            continue;
        }
        out.push(SetupTriangle {
            prim,
            xy,
            z: tri.map(|c| c.1),
            inv_w: tri.map(|c| c.2),
            weights: tri.map(|c| c.3),
            window: tri.map(|c| c.4),
            area2,
            min: [x0 as u32, y0 as u32],
            max: [x1 as u32, y1 as u32],
        });
    }
}

/// Barycentric coordinates of (x, y) in the triangle `w` (any orientation).
fn barycentrics(w: &[[f64; 2]; 3], x: f64, y: f64) -> [f64; 3] {
    let area =
        (w[1][0] - w[0][0]) * (w[2][1] - w[0][1]) - (w[2][0] - w[0][0]) * (w[1][1] - w[0][1]);
    let l1 = ((x - w[0][0]) * (w[2][1] - w[0][1]) - (w[2][0] - w[0][0]) * (y - w[0][1])) / area;
    let l2 = ((w[1][0] - w[0][0]) * (y - w[0][1]) - (x - w[0][0]) * (w[1][1] - w[0][1])) / area;
    [1.0 - l1 - l2, l1, l2]
}

/// A covered pixel: window depth and perspective-correct barycentric weights of the original
/// triangle's corners at the pixel center, and the samples covered (bit i: sample i) with their
/// depths inside the depth range.
pub struct Sample {
    /// Pixel column.
    pub x: u32,
    /// Pixel row (0 at the top).
    pub y: u32,
    /// Window depth at the pixel center (0 near, 1 far).
    pub depth: f64,
    /// Barycentric weights of the original corners.
    pub weights: DVec3,
    /// Samples covered: bit i is sample i.
    pub coverage: u32,
}

/// Visits the pixels of rows `rows` that `t` covers under the top-left rule.
pub fn cover(t: &SetupTriangle, rows: std::ops::Range<u32>, visit: impl FnMut(Sample)) {
    cover_samples(t, rows, 1, visit)
}

/// Visits the pixels of rows `rows` where `t` covers one of `samples` sample positions (under
/// the top-left rule, with the sample's depth in [0, 1)).
pub fn cover_samples(
    t: &SetupTriangle,
    rows: std::ops::Range<u32>,
    samples: u32,
    mut visit: impl FnMut(Sample),
) {
    let offsets = sample_offsets(samples);
    // Orient so the interior is where all edge functions are positive.
    let order = if t.area2 > 0 { [0, 1, 2] } else { [0, 2, 1] };
    let v = order.map(|i| t.xy[i]);
    // Edge i runs from v[i] to v[i+1]; its function is positive inside and the bias makes a pixel
    // center exactly on it count only for top edges (horizontal, interior below) and left edges
    // (going up the screen, y down).
    let edges: [(i64, i64, i64); 3] = std::array::from_fn(|i| {
        let a = v[i];
        let b = v[(i + 1) % 3];
        let (dx, dy) = (b[0] - a[0], b[1] - a[1]);
        let top_left = dy < 0 || (dy == 0 && dx > 0);
        (dx, dy, if top_left { 0 } else { -1 })
    });
    let inside = |sx: i64, sy: i64| {
        (0..3).all(|i| {
            let a = v[i];
            let (dx, dy, bias) = edges[i];
            dx * (sy - a[1]) - dy * (sx - a[0]) + bias >= 0
        })
    };
    let depth_at = |x: f64, y: f64| {
        let l = barycentrics(&t.window, x, y);
        l[0] * t.z[0] + l[1] * t.z[1] + l[2] * t.z[2]
    };
    let y_start = t.min[1].max(rows.start);
    let y_end = (t.max[1] + 1).min(rows.end);
    for py in y_start..y_end {
        for px in t.min[0]..=t.max[0] {
            let (cx, cy) = (px as i64 * SUBPIXEL as i64, py as i64 * SUBPIXEL as i64);
            let mut coverage = 0u32;
            for (i, o) in offsets.iter().enumerate() {
                if !inside(cx + o[0], cy + o[1]) {
                    continue;
                }
                // Single-sampled, the center's depth is tested by the caller.
                let in_range = samples <= 1 || {
                    let d = depth_at(
                        px as f64 + o[0] as f64 / SUBPIXEL,
                        py as f64 + o[1] as f64 / SUBPIXEL,
                    );
                    (0.0..1.0).contains(&d)
                };
                if in_range {
                    coverage |= 1 << i;
                }
            }
            if coverage == 0 {
                continue;
            }
            let l = barycentrics(&t.window, px as f64 + 0.5, py as f64 + 0.5);
            let depth = l[0] * t.z[0] + l[1] * t.z[1] + l[2] * t.z[2];
            let pw = [l[0] * t.inv_w[0], l[1] * t.inv_w[1], l[2] * t.inv_w[2]];
            let sum = pw[0] + pw[1] + pw[2];
            let weights =
                (t.weights[0] * pw[0] + t.weights[1] * pw[1] + t.weights[2] * pw[2]) / sum;
            visit(Sample {
                x: px,
                y: py,
                depth,
                weights,
                coverage,
            });
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ortho_setup(corners: [[f64; 2]; 3], w: u32, h: u32) -> Vec<SetupTriangle> {
        // Identity view-projection: corners are NDC.
        let p = corners.map(|c| DVec3::new(c[0], c[1], 0.5));
        let mut out = Vec::new();
        setup(0, p, &DMat4::IDENTITY, w, h, 1, &mut out);
        out
    }

    fn covered(ts: &[SetupTriangle], h: u32) -> Vec<(u32, u32)> {
        let mut v = Vec::new();
        for t in ts {
            cover(t, 0..h, |s| v.push((s.x, s.y)));
        }
        v.sort();
        v
    }

    #[test]
    fn corners_far_beyond_the_viewport_are_clipped_at_the_guard_band() {
        // Corners at 1e12 viewports (a --fov of 1e-30 makes such) once overflowed the snapped
        // integer arithmetic; clipped at the guard band, the triangle covers every pixel once.
        let huge = ortho_setup([[-1e12, -1e12], [1e12, -1e12], [0.0, 1e12]], 16, 16);
        assert!(!huge.is_empty());
        let all = covered(&huge, 16);
        assert_eq!(all.len(), 256);
        let mut unique = all.clone();
        unique.dedup();
        assert_eq!(unique.len(), 256);
        // Non-finite corners draw nothing (and do not panic).
        assert!(ortho_setup([[f64::NAN, 0.0], [1.0, 0.0], [0.0, 1.0]], 16, 16).is_empty());
    }

    #[test]
    fn two_triangles_sharing_an_edge_cover_each_pixel_once() {
        // A full-screen quad split on its diagonal, both windings: 16×16 pixels, each once.
        let a = ortho_setup([[-1.0, -1.0], [1.0, -1.0], [1.0, 1.0]], 16, 16);
        let b = ortho_setup([[-1.0, -1.0], [1.0, 1.0], [-1.0, 1.0]], 16, 16);
        let mut all = covered(&a, 16);
        all.extend(covered(&b, 16));
        all.sort();
        let before = all.len();
        all.dedup();
        assert_eq!(before, all.len(), "a pixel was covered twice");
        assert_eq!(all.len(), 256);
    }

    #[test]
    fn edges_through_pixel_centers_follow_the_top_left_rule() {
        // A 4×4 viewport; a square whose edges pass exactly through pixel centers 1.5 and 2.5.
        // Left and top edges are in, right and bottom out: pixels x=1, y=1 only.
        let to_ndc = |x: f64, y: f64| [x / 2.0 - 1.0, 1.0 - y / 2.0];
        let (l, r, t, b) = (1.5, 2.5, 1.5, 2.5);
        let a = ortho_setup([to_ndc(l, t), to_ndc(l, b), to_ndc(r, b)], 4, 4);
        let c = ortho_setup([to_ndc(l, t), to_ndc(r, b), to_ndc(r, t)], 4, 4);
        let mut all = covered(&a, 4);
        all.extend(covered(&c, 4));
        all.sort();
        assert_eq!(all, vec![(1, 1)]);
    }

    #[test]
    fn ccw_on_screen_is_negative_area() {
        // CCW in NDC (y up) is CCW on screen: front-facing.
        let t = ortho_setup([[-1.0, -1.0], [1.0, -1.0], [0.0, 1.0]], 8, 8);
        assert!(t[0].area2 < 0);
    }
}
