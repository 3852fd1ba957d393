//! The per-frame visibility order of `convex`'s groups (seed 001 §3.2, done differently): which
//! groups' fragments can meet in a pixel, which of each such pair comes first, and passes of
//! groups that cannot meet.
//!
//! Each group's bounding box is projected to a conservative pixel rectangle (boxes behind the
//! eye, beyond the far plane or off screen are culled; a box crossing the eye's plane covers the
//! whole screen). Two groups matter to each other only when their rectangles overlap and the
//! convex hulls of their projected vertices (which hold every sample point a group can cover:
//! pixel centres, or with `--msaa` anywhere in a pixel's square) are not apart; for such a pair
//! the plane that separates them (see [`super::decompose`]) decides: the group on the eye's side
//! is in front for every ray from the eye (for an orthographic view, the side the view
//! direction leaves). The pairs give a directed graph, topologically sorted (ready groups in any
//! order: the passes do not depend on it); a cycle (or a pair with no plane) is broken by taking
//! the nearest remaining centroid, counted, and what it costs shows in the frame's
//! `order_violations`. A group's pass is one more than the latest pass of any overlapping group
//! placed before it, so a pass never holds two groups that can share a pixel: passes ≈ the
//! depth complexity in groups, not the group count.
//!
//! Cost per view: projecting every group's distinct vertices (points well inside the polygon of
//! a group's 16 extreme points are dropped before the hull's sort), pairs found in screen tiles
//! sized to the median footprint, a linear topological sort.
//!
//! The paper orders pieces by walking a uniform grid front to back; the rectangles and planes
//! here play the grid's part (which pairs need an order, and what decides it) without its
//! special cases for pieces spanning cells.

use std::sync::atomic::{AtomicU32, Ordering};

use glam::{Mat4, Vec2, Vec3, Vec4, Vec4Swizzles};
use rayon::prelude::*;

use super::decompose::{Decomposition, Relation, Separation};
use crate::scene::{Camera, Projection};

/// Where the rays come from.
#[derive(Clone, Copy, Debug)]
pub enum Viewer {
    /// A perspective view's eye.
    Eye(Vec3),
    /// An orthographic view's direction.
    Toward(Vec3),
}

impl Viewer {
    /// The viewer of `camera`.
    pub fn of(camera: &Camera) -> Viewer {
        match camera.projection {
            Projection::Perspective { .. } => Viewer::Eye(camera.eye),
            Projection::Orthographic { .. } => {
                Viewer::Toward((camera.target - camera.eye).normalize_or_zero())
            }
        }
    }

    /// Whether rays meet the side below `s` first (`None`: the plane is seen edge-on, and
    /// either order holds).
    pub fn below_first(&self, s: &Separation) -> Option<bool> {
        let side = match *self {
            Viewer::Eye(e) => s.offset - s.normal.dot(e),
            Viewer::Toward(f) => s.normal.dot(f),
        };
        (side != 0.0).then_some(side > 0.0)
    }

    /// Distance of `p` along the view (for tie-breaking only).
    fn distance(&self, p: Vec3) -> f32 {
        match *self {
            Viewer::Eye(e) => (p - e).length_squared(),
            Viewer::Toward(f) => f.dot(p),
        }
    }
}

/// One frame's order.
#[derive(Clone, Debug, Default)]
pub struct FramePlan {
    /// Groups (with the cap drawn) per pass, front pass first; no two of a pass share a pixel.
    /// Each pass is sorted by cap, so its draws switch pipelines at most twice.
    pub passes: Vec<Vec<(u32, Cap)>>,
    /// Groups outside the view.
    pub culled: u32,
    /// Pairs of groups whose footprints (rectangle and projected hull) overlap.
    pub overlapping: u64,
    /// Overlapping pairs without a separating plane, ordered by centroid.
    pub unseparated: u64,
    /// Times the sort met a cycle and took the nearest remaining group instead.
    pub cycles_broken: u32,
    /// CPU milliseconds of the order.
    pub order_ms: f64,
}

/// A group's conservative pixel rectangle, inclusive.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Rect {
    x0: i32,
    y0: i32,
    x1: i32,
    y1: i32,
}

/// The pixels a box can cover under `view_proj` at `width`×`height` (`None`: none).
fn footprint(view_proj: Mat4, lo: Vec3, hi: Vec3, width: u32, height: u32) -> Option<Rect> {
    let (w, h) = (width as i32, height as i32);
    let full = Rect {
        x0: 0,
        y0: 0,
        x1: w - 1,
        y1: h - 1,
    };
    let clip: [Vec4; 8] = std::array::from_fn(|i| {
        let p = Vec3::new(
            if i & 1 == 0 { lo.x } else { hi.x },
            if i & 2 == 0 { lo.y } else { hi.y },
            if i & 4 == 0 { lo.z } else { hi.z },
        );
        view_proj * p.extend(1.0)
    });
    // Entirely outside one clip plane: nothing of it is drawn.
    let outside = |f: &dyn Fn(&Vec4) -> bool| clip.iter().all(f);
    if outside(&|c| c.x > c.w)
        || outside(&|c| c.x < -c.w)
        || outside(&|c| c.y > c.w)
        || outside(&|c| c.y < -c.w)
        || outside(&|c| c.z > c.w)
        || outside(&|c| c.z < 0.0)
    {
        return None;
    }
    if clip.iter().any(|c| c.w <= 0.0) {
        return Some(full);
    }
    let (mut x0, mut y0, mut x1, mut y1) = (f32::INFINITY, f32::INFINITY, f32::MIN, f32::MIN);
    for c in &clip {
        let ndc = c.xy() / c.w;
        let px = (ndc.x + 1.0) * 0.5 * width as f32;
        let py = (1.0 - ndc.y) * 0.5 * height as f32;
        x0 = x0.min(px);
        x1 = x1.max(px);
        y0 = y0.min(py);
        y1 = y1.max(py);
    }
    // A pixel is covered through its centre; one pixel of margin absorbs rounding.
    let r = Rect {
        x0: (x0.floor() as i32 - 1).max(0),
        y0: (y0.floor() as i32 - 1).max(0),
        x1: (x1.ceil() as i32 + 1).min(w - 1),
        y1: (y1.ceil() as i32 + 1).min(h - 1),
    };
    (r.x0 <= r.x1 && r.y0 <= r.y1).then_some(r)
}

/// `points` projected to pixel coordinates in `out` (replacing what it held); `false` when a
/// point lies at or behind the eye (the projection is unbounded there).
fn project(view_proj: Mat4, points: &[Vec3], width: u32, height: u32, out: &mut Vec<Vec2>) -> bool {
    out.clear();
    for p in points {
        let c = view_proj * p.extend(1.0);
        if c.w <= 1e-6 {
            return false;
        }
        let ndc = c.xy() / c.w;
        out.push(Vec2::new(
            (ndc.x + 1.0) * 0.5 * width as f32,
            (1.0 - ndc.y) * 0.5 * height as f32,
        ));
    }
    true
}

/// The groups' screen footprints in one frame.
struct Footprints {
    /// The pixels whose samples a group can cover (`None`: none, or outside the view).
    pixels: Vec<Option<Rect>>,
    /// Group g's projected hull (counter-clockwise in the plane's own orientation; it holds
    /// every sample point the group can cover) is `corners[start..end]`; `None` where the
    /// projection is unbounded (a point at or behind the eye: the box's rectangle decides
    /// alone) or the group covers no pixel.
    hulls: Vec<Option<(u32, u32)>>,
    corners: Vec<Vec2>,
}

impl Footprints {
    /// Where each group of `dec` with a rectangle in `rects` can lie on screen. A group whose
    /// projected points' box holds no sample point covers nothing, and its hull is not made.
    fn new(
        dec: &Decomposition,
        rects: &[Option<Rect>],
        view_proj: Mat4,
        (width, height): (u32, u32),
        samples: u32,
    ) -> Footprints {
        // Chunks of groups share scratch space and one corner list, so a frame allocates per
        // chunk, not per group.
        const CHUNK: usize = 2048;
        let chunks: Vec<Footprints> = rects
            .par_chunks(CHUNK)
            .enumerate()
            .map(|(chunk, rects)| {
                let mut projected = Vec::new();
                let mut part = Footprints {
                    pixels: Vec::with_capacity(rects.len()),
                    hulls: Vec::with_capacity(rects.len()),
                    corners: Vec::new(),
                };
                for (i, rect) in rects.iter().enumerate() {
                    let points = &dec.groups[chunk * CHUNK + i].points;
                    let (pixels, hull) = match rect {
                        None => (None, None),
                        Some(rect)
                            if !project(view_proj, points, width, height, &mut projected) =>
                        {
                            (Some(*rect), None)
                        }
                        Some(_) => {
                            let (lo, hi) = projected
                                .iter()
                                .fold((Vec2::INFINITY, Vec2::NEG_INFINITY), |(lo, hi), &p| {
                                    (lo.min(p), hi.max(p))
                                });
                            match box_pixels(lo, hi, width, height, samples) {
                                None => (None, None),
                                Some(pixels) => {
                                    let start = part.corners.len() as u32;
                                    convex_hull_into(&mut projected, &mut part.corners);
                                    (Some(pixels), Some((start, part.corners.len() as u32)))
                                }
                            }
                        }
                    };
                    part.pixels.push(pixels);
                    part.hulls.push(hull);
                }
                part
            })
            .collect();
        let mut all = Footprints {
            pixels: Vec::with_capacity(rects.len()),
            hulls: Vec::with_capacity(rects.len()),
            corners: Vec::with_capacity(chunks.iter().map(|c| c.corners.len()).sum()),
        };
        for part in chunks {
            let offset = all.corners.len() as u32;
            all.pixels.extend(part.pixels);
            all.hulls.extend(
                part.hulls
                    .into_iter()
                    .map(|h| h.map(|(start, end)| (start + offset, end + offset))),
            );
            all.corners.extend(part.corners);
        }
        all
    }

    fn hull(&self, g: u32) -> Option<&[Vec2]> {
        self.hulls[g as usize].map(|(start, end)| &self.corners[start as usize..end as usize])
    }
}

/// Bits of `v` whose unsigned order is `v`'s order, negative values included.
fn ordered_bits(v: f32) -> u32 {
    let bits = v.to_bits();
    if bits >> 31 == 1 {
        !bits
    } else {
        bits | 1 << 31
    }
}

/// Points at least this far inside the polygon of a cloud's extreme points cannot be corners of
/// its hull (a margin, so that rounding never drops one that is).
const INTERIOR_MARGIN_PX: f32 = 1e-3;

/// Drops the points lying well inside the polygon of `points`' extreme points along 16
/// directions (Akl and Toussaint's filter): every corner of their hull stays, and on a big
/// group's silhouette-like cloud few other points do, so the sort below has little left.
fn drop_interior(points: &mut Vec<Vec2>) {
    const AXES: usize = 8;
    let axes: [Vec2; AXES] =
        std::array::from_fn(|k| Vec2::from_angle(k as f32 * std::f32::consts::PI / AXES as f32));
    let mut highest = [(f32::NEG_INFINITY, Vec2::ZERO); AXES];
    let mut lowest = [(f32::INFINITY, Vec2::ZERO); AXES];
    for &p in points.iter() {
        for k in 0..AXES {
            let along = axes[k].dot(p);
            if along > highest[k].0 {
                highest[k] = (along, p);
            }
            if along < lowest[k].0 {
                lowest[k] = (along, p);
            }
        }
    }
    // Support points of directions turning positively (angle 0 to 2π) follow the hull's
    // positive turn.
    let mut corners: Vec<Vec2> = highest.iter().chain(&lowest).map(|&(_, p)| p).collect();
    corners.dedup();
    if corners.len() > 1 && corners.first() == corners.last() {
        corners.pop();
    }
    if corners.len() < 3 {
        return;
    }
    let edges: Vec<(Vec2, Vec2, f32)> = (0..corners.len())
        .map(|i| {
            let (from, to) = (corners[i], corners[(i + 1) % corners.len()]);
            (from, to - from, INTERIOR_MARGIN_PX * (to - from).length())
        })
        .collect();
    points.retain(|&p| {
        !edges
            .iter()
            .all(|&(from, edge, margin)| edge.perp_dot(p - from) > margin)
    });
}

/// Clouds smaller than this go straight to the sort.
const FILTERED_FROM: usize = 64;

/// Appends the corners of `points`' hull to `out`, each turn positive (collinear points
/// dropped); `points` is left reordered and filtered.
fn convex_hull_into(points: &mut Vec<Vec2>, out: &mut Vec<Vec2>) {
    if points.len() >= FILTERED_FROM {
        drop_interior(points);
    }
    monotone_chain_into(points, out);
}

/// Andrew's monotone chain over all of `points` (left sorted), its corners appended to `out`.
fn monotone_chain_into(points: &mut Vec<Vec2>, out: &mut Vec<Vec2>) {
    // x then y, as one integer key.
    points.sort_unstable_by_key(|p| {
        (u64::from(ordered_bits(p.x)) << 32) | u64::from(ordered_bits(p.y))
    });
    points.dedup();
    if points.len() < 3 {
        out.extend_from_slice(points);
        return;
    }
    let turn = |o: Vec2, a: Vec2, b: Vec2| (a - o).perp_dot(b - o);
    for pass in 0..2 {
        let start = out.len();
        let mut add = |p: Vec2| {
            while out.len() >= start + 2 && turn(out[out.len() - 2], out[out.len() - 1], p) <= 0.0 {
                out.pop();
            }
            out.push(p);
        };
        if pass == 0 {
            points.iter().for_each(|&p| add(p));
        } else {
            points.iter().rev().for_each(|&p| add(p));
        }
        out.pop();
    }
}

/// Side in pixels of the screen tiles that bin the groups when pairs are looked for: the
/// power of two (8 to 1024) nearest above the median rectangle's longer side, so that a typical
/// group lands in a few tiles (small tiles for a big group put it, and every pair it is in, in
/// hundreds of bins; big tiles for small groups sweep many that never meet).
fn tile_side(rects: impl Iterator<Item = Rect>) -> i32 {
    let mut sides: Vec<i32> = rects.map(|r| (r.x1 - r.x0).max(r.y1 - r.y0) + 1).collect();
    if sides.is_empty() {
        return 8;
    }
    let middle = sides.len() / 2;
    let median = *sides.select_nth_unstable(middle).1;
    (median as u32).next_power_of_two().clamp(8, 1024) as i32
}

/// Every pair (a < b) of `visible` groups whose pixel rectangles (`None`: no pixel) overlap
/// and whose hulls are not apart, in a deterministic order. Groups are binned into screen
/// tiles by rectangle; a pair is examined in the one tile holding its rectangles'
/// intersection's first corner, so the work is the pairs sharing tiles, not all pairs along a
/// screen axis.
fn meeting_pairs<'a>(
    visible: &[u32],
    rects: &[Option<Rect>],
    hull: impl Fn(u32) -> Option<&'a [Vec2]> + Sync,
    width: u32,
    height: u32,
) -> Vec<(u32, u32)> {
    let tile = tile_side(visible.iter().filter_map(|&g| rects[g as usize]));
    let tiles_x = (width as i32 + tile - 1) / tile;
    let tiles_y = (height as i32 + tile - 1) / tile;
    let mut bins: Vec<Vec<u32>> = vec![Vec::new(); (tiles_x * tiles_y) as usize];
    for &g in visible {
        let Some(r) = rects[g as usize] else {
            continue;
        };
        for ty in r.y0 / tile..=r.y1 / tile {
            for tx in r.x0 / tile..=r.x1 / tile {
                bins[(ty * tiles_x + tx) as usize].push(g);
            }
        }
    }
    bins.par_iter()
        .enumerate()
        .flat_map_iter(|(index, bin)| {
            let (tx, ty) = (index as i32 % tiles_x, index as i32 / tiles_x);
            let mut pairs = Vec::new();
            // Swept along x: each group meets only the later-starting ones it reaches.
            let mut bin: Vec<(Rect, u32)> = bin
                .iter()
                .map(|&g| (rects[g as usize].expect("binned"), g))
                .collect();
            bin.sort_unstable_by_key(|&(r, g)| (r.x0, g));
            for (i, &(ra, a)) in bin.iter().enumerate() {
                for &(rb, b) in bin[i + 1..].iter().take_while(|(rb, _)| rb.x0 <= ra.x1) {
                    let (x0, y0) = (rb.x0, ra.y0.max(rb.y0));
                    if y0 > ra.y1.min(rb.y1) {
                        continue;
                    }
                    if x0 / tile != tx || y0 / tile != ty {
                        continue;
                    }
                    if let (Some(ha), Some(hb)) = (hull(a), hull(b)) {
                        if hulls_apart(ha, hb) {
                            continue;
                        }
                    }
                    pairs.push((a.min(b), a.max(b)));
                }
            }
            pairs
        })
        .collect()
}

/// The pixels a hull's box (`lo` to `hi`) can cover: those whose sample points it holds (within
/// the margin), or `None` when it holds none on screen (the group can cover none).
/// Single-sampled, a pixel's one sample is its centre; multisampled, its samples may lie
/// anywhere in its square, so every pixel whose square the box meets counts.
fn box_pixels(lo: Vec2, hi: Vec2, width: u32, height: u32, samples: u32) -> Option<Rect> {
    // How far from its centre a pixel's samples can lie, along each axis.
    let reach = if samples > 1 { 0.5 } else { 0.0 } + HULL_MARGIN_PX;
    let first = |v: f32| (v - 0.5 - reach).ceil().max(0.0) as i32;
    let last = |v: f32, size: u32| (v - 0.5 + reach).floor().min(size as f32 - 1.0) as i32;
    let r = Rect {
        x0: first(lo.x),
        y0: first(lo.y),
        x1: last(hi.x, width),
        y1: last(hi.y, height),
    };
    (r.x0 <= r.x1 && r.y0 <= r.y1).then_some(r)
}

/// Pixels closer to a hull's edge than this count as possibly covered (the rasterizer snaps
/// vertices to a sub-pixel grid).
const HULL_MARGIN_PX: f32 = 0.01;

/// Whether one of the polygons' edges has the other polygon wholly outside it: then no pixel
/// centre lies in both and their groups never meet in a pixel.
fn hulls_apart(a: &[Vec2], b: &[Vec2]) -> bool {
    let apart_by_edges_of = |p: &[Vec2], q: &[Vec2]| {
        (p.len() >= 2)
            && (0..p.len()).any(|i| {
                let (from, to) = (p[i], p[(i + 1) % p.len()]);
                let edge = to - from;
                let margin = HULL_MARGIN_PX * edge.length();
                // Inside a positively turning hull lies to the left of every edge.
                q.iter().all(|&x| edge.perp_dot(x - from) < -margin)
            })
    };
    apart_by_edges_of(a, b) || apart_by_edges_of(b, a)
}

/// Which of a group's fragments a draw keeps: all, or (for a container, drawn twice around
/// what it holds) the front-facing or the back-facing ones.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Cap {
    /// Every fragment.
    Whole,
    /// Front-facing fragments only.
    Front,
    /// Back-facing fragments only.
    Back,
}

/// The order of `dec`'s groups for a frame seen by `camera` through `view_proj` at
/// `width`×`height` with `samples` per pixel.
pub fn plan(
    dec: &Decomposition,
    camera: &Camera,
    view_proj: Mat4,
    width: u32,
    height: u32,
    samples: u32,
) -> FramePlan {
    let start = std::time::Instant::now();
    let viewer = Viewer::of(camera);
    let n = dec.groups.len();
    let rects: Vec<Option<Rect>> = dec
        .groups
        .par_iter()
        .map(|g| footprint(view_proj, g.lo, g.hi, width, height))
        .collect();
    let visible: Vec<u32> = (0..n as u32)
        .filter(|&g| rects[g as usize].is_some())
        .collect();
    let culled = (n - visible.len()) as u32;
    let footprints = Footprints::new(dec, &rects, view_proj, (width, height), samples);
    // Nodes: g is group g whole, or its front cap when it is a container; n + i is the back
    // cap of the i-th container (few groups are: the graph stays about one node per group).
    let containers: Vec<u32> = (0..n as u32)
        .filter(|&g| dec.container[g as usize])
        .collect();
    let back_cap = |g: u32| {
        let i = containers.binary_search(&g).expect("a container");
        (n + i) as u32
    };
    let caps = |g: u32| std::iter::once(g).chain(dec.container[g as usize].then(|| back_cap(g)));
    let group_of = |node: u32| match (node as usize).checked_sub(n) {
        None => node,
        Some(i) => containers[i],
    };
    let distance: Vec<f32> = dec
        .groups
        .par_iter()
        .map(|g| viewer.distance(g.centroid))
        .collect();
    let meeting = meeting_pairs(
        &visible,
        &footprints.pixels,
        |g| footprints.hull(g),
        width,
        height,
    );
    // Each meeting pair's "comes before" edges (at most 4: two caps on each side), and whether
    // it had no plane.
    let ordered: Vec<PairEdges> = meeting
        .par_iter()
        .map(|&(a, b)| {
            let mut edges = [(0, 0); 4];
            let mut count = 0;
            let mut edge = |first: u32, second: u32| {
                edges[count] = (first, second);
                count += 1;
            };
            let (outer, inner) = match dec.relation(a, b) {
                Relation::Contains => (a, b),
                Relation::Inside => (b, a),
                other => {
                    let by_distance = || distance[a as usize] <= distance[b as usize];
                    let (a_first, unseparated) = match other {
                        Relation::Plane(s) => {
                            (viewer.below_first(&s).unwrap_or_else(by_distance), false)
                        }
                        Relation::Coplanar => {
                            (dec.first_primitive(a) < dec.first_primitive(b), false)
                        }
                        _ => (by_distance(), true),
                    };
                    let (first, second) = if a_first { (a, b) } else { (b, a) };
                    for f in caps(first) {
                        for s in caps(second) {
                            edge(f, s);
                        }
                    }
                    return PairEdges {
                        edges,
                        count,
                        unseparated,
                    };
                }
            };
            for c in caps(inner) {
                edge(outer, c);
                edge(c, back_cap(outer));
            }
            PairEdges {
                edges,
                count,
                unseparated: false,
            }
        })
        .collect();
    let overlapping = meeting.len() as u64;
    let unseparated = ordered.iter().filter(|o| o.unseparated).count() as u64;
    // A container's front cap comes before its back cap.
    let mut edges: Vec<(u32, u32)> = visible
        .iter()
        .filter(|&&g| dec.container[g as usize])
        .map(|&g| (g, back_cap(g)))
        .collect();
    edges.par_extend(
        ordered
            .par_iter()
            .flat_map_iter(|o| o.edges[..o.count].iter().copied()),
    );
    let graph = Graph::new(n + containers.len(), &edges);
    let nodes: Vec<u32> = visible.iter().flat_map(|&g| caps(g)).collect();
    let (node_passes, cycles_broken) =
        graph.passes(&nodes, |node| distance[group_of(node) as usize]);
    let passes = node_passes
        .into_iter()
        .map(|pass| {
            pass.into_iter()
                .map(|node| {
                    let g = group_of(node);
                    let cap = match (dec.container[g as usize], node == g) {
                        (false, _) => Cap::Whole,
                        (true, true) => Cap::Front,
                        (true, false) => Cap::Back,
                    };
                    (g, cap)
                })
                .collect::<Vec<_>>()
        })
        .map(|mut pass| {
            pass.sort_by_key(|&(g, cap)| (cap, g));
            pass
        })
        .collect();
    FramePlan {
        passes,
        culled,
        overlapping,
        unseparated,
        cycles_broken,
        order_ms: start.elapsed().as_secs_f64() * 1e3,
    }
}

/// The "comes before" edges of one pair of groups that can meet in a pixel (one per pair of
/// caps: at most 4), and whether the pair had no separating plane.
struct PairEdges {
    edges: [(u32, u32); 4],
    count: usize,
    unseparated: bool,
}

/// Nodes with "comes before" edges between nodes that can share a pixel.
struct Graph {
    /// Node i's neighbours are `neighbours[first[i]..first[i + 1]]`, each a node with
    /// [`AFTER`] set when it comes after node i.
    first: Vec<u32>,
    neighbours: Vec<u32>,
    /// Each node's state: its count of predecessors not yet placed, until [`Graph::passes`]
    /// places it.
    state: Vec<AtomicU32>,
}

/// The bit of a [`Graph`] neighbour entry that says it comes after the node.
const AFTER: u32 = 1 << 31;

/// A frontier shorter than this is swept on one thread: most of Kahn's levels hold a handful of
/// nodes, for which handing out work costs more than it saves.
const PARALLEL_FRONTIER: usize = 4096;

impl Graph {
    /// The graph of `nodes` nodes and `edges` (first, second), each node's neighbours in edge
    /// order. Built on one thread: with atomic counters on all cores it took twice as long on
    /// two cores.
    fn new(nodes: usize, edges: &[(u32, u32)]) -> Graph {
        assert!(
            nodes <= AFTER as usize,
            "{nodes} nodes do not fit a neighbour entry"
        );
        let mut first = vec![0u32; nodes + 1];
        let mut indegree = vec![0u32; nodes];
        for &(a, b) in edges {
            first[a as usize + 1] += 1;
            first[b as usize + 1] += 1;
            indegree[b as usize] += 1;
        }
        for i in 0..nodes {
            first[i + 1] += first[i];
        }
        let mut fill = first.clone();
        let mut neighbours = vec![0u32; 2 * edges.len()];
        for &(a, b) in edges {
            neighbours[fill[a as usize] as usize] = b | AFTER;
            fill[a as usize] += 1;
            neighbours[fill[b as usize] as usize] = a;
            fill[b as usize] += 1;
        }
        Graph {
            first,
            neighbours,
            state: indegree.into_iter().map(AtomicU32::new).collect(),
        }
    }

    /// Node `node`'s neighbours, each with whether it comes after `node`.
    fn neighbours(&self, node: u32) -> impl Iterator<Item = (u32, bool)> + '_ {
        self.neighbours[self.first[node as usize] as usize..self.first[node as usize + 1] as usize]
            .iter()
            .map(|&entry| (entry & !AFTER, entry & AFTER != 0))
    }

    /// Kahn's sort of `nodes` (a cycle takes the nearest unplaced node, counted); each node's
    /// pass is one past the latest pass of a neighbour placed before it. Returns the passes and
    /// the cycles broken.
    ///
    /// The passes do not depend on the order ready nodes are taken in: until the ready nodes
    /// run out, the sort places every node whose predecessors all get placed, whatever the
    /// order, and only then breaks a cycle; so a node's neighbours placed before it are the
    /// same in every order. The sort therefore goes level by level: all ready nodes at once
    /// (no two of them are neighbours: a ready node's successors wait for it), in parallel
    /// when there are many, then the nodes they leave ready. The order within a pass is
    /// arbitrary.
    fn passes(self, nodes: &[u32], distance: impl Fn(u32) -> f32 + Sync) -> (Vec<Vec<u32>>, u32) {
        self.passes_in_levels(nodes, distance, PARALLEL_FRONTIER)
    }

    /// [`Graph::passes`], sweeping a frontier in parallel from `parallel_from` nodes.
    fn passes_in_levels(
        self,
        nodes: &[u32],
        distance: impl Fn(u32) -> f32 + Sync,
        parallel_from: usize,
    ) -> (Vec<Vec<u32>>, u32) {
        // A node's state: its count of unplaced predecessors until it is placed, then its pass
        // with PLACED set (one word, so each neighbour visited costs one memory access).
        const PLACED: u32 = 1 << 31;
        let state = &self.state;
        let placed = |o: u32| state[o as usize].load(Ordering::Relaxed) & PLACED != 0;
        // Nearest first, ties by node: an integer key (distances are signed in an
        // orthographic view).
        let mut by_distance: Vec<u64> = nodes
            .par_iter()
            .map(|&g| (u64::from(ordered_bits(distance(g))) << 32) | u64::from(g))
            .collect();
        by_distance.par_sort_unstable();
        let mut next_nearest = 0;
        let mut frontier: Vec<u32> = nodes
            .par_iter()
            .copied()
            .filter(|&g| state[g as usize].load(Ordering::Relaxed) == 0)
            .collect();
        let mut next = Vec::new();
        let mut cycles_broken = 0;
        let mut placed_count = 0;
        // Each level places at least one node.
        while placed_count < nodes.len() {
            if frontier.is_empty() {
                let nearest = |i: usize| by_distance[i] as u32;
                while placed(nearest(next_nearest)) {
                    next_nearest += 1;
                }
                cycles_broken += 1;
                frontier.push(nearest(next_nearest));
            }
            // Frontier nodes are not neighbours of each other, so their passes read only
            // earlier levels' and may be stored as they are found.
            let place = |&g: &u32| {
                let pass = self
                    .neighbours(g)
                    .map(|(o, _)| state[o as usize].load(Ordering::Relaxed))
                    .filter(|s| s & PLACED != 0)
                    .map(|s| (s & !PLACED) + 1)
                    .max()
                    .unwrap_or(0);
                state[g as usize].store(pass | PLACED, Ordering::Relaxed);
            };
            // A successor is left ready by the one placement that takes its count to zero
            // (no successor of a frontier node is placed in the same level, so a count never
            // meets a pass).
            let released = |&g: &u32| {
                self.neighbours(g).filter_map(|(o, after)| {
                    (after && !placed(o) && state[o as usize].fetch_sub(1, Ordering::Relaxed) == 1)
                        .then_some(o)
                })
            };
            placed_count += frontier.len();
            next.clear();
            if frontier.len() >= parallel_from {
                frontier.par_iter().for_each(place);
                next.par_extend(frontier.par_iter().flat_map_iter(released));
            } else {
                frontier.iter().for_each(place);
                next.extend(frontier.iter().flat_map(released));
            }
            std::mem::swap(&mut frontier, &mut next);
        }
        let mut passes: Vec<Vec<u32>> = Vec::new();
        for &g in nodes {
            let pass = (state[g as usize].load(Ordering::Relaxed) & !PLACED) as usize;
            if passes.len() <= pass {
                passes.resize(pass + 1, Vec::new());
            }
            passes[pass].push(g);
        }
        (passes, cycles_broken)
    }
}

#[cfg(test)]
mod tests;
