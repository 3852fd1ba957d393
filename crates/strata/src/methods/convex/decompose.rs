//! The preprocess of `convex` (seed 001 §3): convex parts by region growing over face
//! adjacency, inseparable neighbours paired into groups of two (the paper's slabs: at most four
//! layers), and a separating plane for every pair of groups whose bounding boxes overlap.
//!
//! A *part* is a set of triangles lying on the boundary of their own convex hull, each facing
//! out of it: every vertex of the part lies on or below every triangle's plane (within
//! [`Decomposition::tolerance`]), and no two of its edge-neighbours lie in one plane facing the
//! same way over each other (duplicated faces). A ray from the eye therefore meets a part at
//! most twice — once on a front-facing triangle, once on a back-facing one — whether or not the
//! part is closed.
//! Region growing takes the first unassigned triangle in primitive order as seed and adds
//! edge-neighbours for which that condition still holds both ways (the new triangle's vertices
//! below every plane of the part, the part's vertices below the new triangle's plane), breadth
//! first, up to [`MAX_PART_TRIANGLES`] (which bounds the cost of the test).
//!
//! The preprocess runs on rayon and gives the same parts as that one sequential sweep: the
//! mesh is welded and its edges matched by parallel sorts; edge-connected components grow
//! apart (a seed is the first free triangle of its component, and parts are sorted by seed);
//! a growing part keeps its planes and vertices in chunks of 32 (and blocks of 1024) reordered
//! along a Morton curve, each with a bound — a box for points; a mean normal, spread and offset
//! for planes — that passes a whole chunk only when it lies farther inside the tolerance than
//! f32 rounding can reach, so every answer equals the per-item f32 test (a twin of the plain
//! sweep checks it). Containment between large parts uses the same chunks, and a candidate
//! plane stops scanning a group's points once they reach past both ends of the other group.
//!
//! Parts are ordered per frame through planes that separate them (see [`super::order`]). Two
//! parts whose boxes are disjoint along an axis are separated by that axis; for the pairs whose
//! boxes overlap, a plane is searched among candidate normals (the line between their centroids,
//! the axes, and the normals of their triangles that come within the other's box — the paper
//! takes the PCA of the touching faces; their own normals include the planes a convex edge
//! between two parts lies on). A pair that no candidate separates is *inseparable*: the two
//! parts are captured together as one group (at most four layers per pixel, sorted in the merge
//! — the role of the paper's slab), each part joining at most one such pair. Inseparable pairs
//! left over (a part already paired) are counted (`unseparated`) and ordered by centroid each
//! frame; the frame's `order_violations` measure what that costs.

use rustc_hash::FxHashMap;

use glam::{DVec3, Vec3};
use rayon::prelude::*;

mod relation;
pub use relation::*;

/// How the groups of each pair (i < j) whose boxes overlap relate: a row per group i of its
/// pairs by ascending j (24 bytes a pair, in pair order as the cache file stores them; a hash
/// map took more memory and its reading from the cache hashed every pair).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Relations {
    /// Group i's pairs are `row[first[i]..first[i + 1]]`, each (j, relation).
    first: Vec<u32>,
    row: Vec<(u32, Relation)>,
}

impl Relations {
    /// From pairs (i < j), each given once, in any order.
    pub fn from_pairs(mut pairs: Vec<((u32, u32), Relation)>) -> Relations {
        pairs.par_sort_unstable_by_key(|&(pair, _)| pair);
        let rows = pairs.last().map_or(0, |&((i, _), _)| i as usize + 1);
        let mut first = vec![0u32; rows + 1];
        for &((i, _), _) in &pairs {
            first[i as usize + 1] += 1;
        }
        for i in 0..rows {
            first[i + 1] += first[i];
        }
        Relations {
            first,
            row: pairs.into_iter().map(|((_, j), r)| (j, r)).collect(),
        }
    }

    /// How `i` and `j` (i < j) relate, when their boxes overlap.
    pub fn get(&self, i: u32, j: u32) -> Option<Relation> {
        let (start, end) = (self.first.get(i as usize)?, self.first.get(i as usize + 1)?);
        let row = &self.row[*start as usize..*end as usize];
        row.binary_search_by_key(&j, |&(other, _)| other)
            .ok()
            .map(|k| row[k].1)
    }

    /// Rows of the table (groups).
    pub fn len(&self) -> usize {
        self.row.len()
    }

    /// Whether there are no rows.
    pub fn is_empty(&self) -> bool {
        self.row.is_empty()
    }

    /// Every pair (i < j) and its relation, in pair order.
    pub fn iter(&self) -> impl Iterator<Item = ((u32, u32), Relation)> + '_ {
        self.first
            .windows(2)
            .enumerate()
            .flat_map(move |(i, range)| {
                self.row[range[0] as usize..range[1] as usize]
                    .iter()
                    .map(move |&(j, r)| ((i as u32, j), r))
            })
    }
}

/// Region growing stops a part at this many triangles: the convexity test of a candidate grows
/// with the part's size (less than linearly, through the chunk bounds), so parts are bounded to
/// keep the preprocess near-linear.
pub const MAX_PART_TRIANGLES: usize = 8192;

/// Candidate triangle normals tried per side when separating two groups.
pub const TOUCHING_CANDIDATES: usize = 24;

/// A set of triangles drawn together (one or two convex parts), with the range of the static
/// index buffer that holds them.
#[derive(Clone, Debug, PartialEq)]
pub struct Group {
    /// Convex parts in this group (1, or 2 for an inseparable pair).
    pub parts: u32,
    /// Primitive indices, the group's triangles in order.
    pub triangles: Vec<u32>,
    /// The group's bounding box, low corner.
    pub lo: Vec3,
    /// The group's bounding box, high corner.
    pub hi: Vec3,
    /// The mean of its triangles' centroids.
    pub centroid: Vec3,
    /// The group's distinct vertices: their projection's hull bounds its screen footprint.
    pub points: Vec<Vec3>,
}

/// A plane n·x = offset with the first group of the pair (the lower index) on or below it and
/// the second on or above it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Separation {
    /// The plane's unit normal.
    pub normal: Vec3,
    /// The plane is `normal · x = offset`.
    pub offset: f32,
}

/// What the preprocess found.
#[derive(Clone, Debug, Default, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize))]
pub struct DecompositionStats {
    /// Triangles decomposed.
    pub triangles: u64,
    /// Convex parts from region growing.
    pub parts: u32,
    /// Groups drawn and ordered (parts, inseparable pairs joined).
    pub groups: u32,
    /// Inseparable pairs captured together as one group.
    pub paired: u32,
    /// Pairs of groups whose boxes overlap, each needing its own plane.
    pub overlapping_pairs: u64,
    /// Overlapping pairs where one group lies inside the other's convex hull.
    pub nested: u64,
    /// Overlapping pairs neither separated by a candidate plane nor nested: ordered by
    /// centroid per frame.
    pub unseparated: u64,
    /// Layers a pixel can need from one group: 2 per part.
    pub layers_per_group: u32,
    /// CPU milliseconds the preprocess took.
    pub preprocess_ms: f64,
    /// Read from the disk cache in this many ms (`preprocess_ms` is then the run that made it).
    #[cfg_attr(feature = "serde", serde(skip_serializing_if = "Option::is_none"))]
    pub read_from_cache_ms: Option<f64>,
}

/// Convex groups of a triangle list and the planes between them.
#[derive(Clone, Debug, PartialEq)]
pub struct Decomposition {
    /// The groups, in primitive order.
    pub groups: Vec<Group>,
    /// How each pair (i < j) of groups whose boxes overlap relates.
    pub relations: Relations,
    /// Groups holding another inside their hull, drawn as a front and a back cap.
    pub container: Vec<bool>,
    /// Distance within which a point counts as on a plane: a millionth of the scene's extent.
    pub tolerance: f32,
    /// What the preprocess found.
    pub stats: DecompositionStats,
}

/// Triangles welded into shared vertices, with planes and edge neighbours.
struct Mesh {
    positions: Vec<Vec3>,
    corners: Vec<[u32; 3]>,
    /// Unit normal and offset; `None` for a triangle without area.
    planes: Vec<Option<(Vec3, f32)>>,
    neighbours: Vec<Vec<u32>>,
}

impl Mesh {
    /// Whether face `g` and its edge neighbour `h` lie in one plane, face the same way and
    /// overlap there (a duplicated face, or one folded back over another): a ray through the
    /// overlap would meet a part holding both more than twice.
    fn overlap_in_plane(&self, g: u32, h: u32, tolerance: f32) -> bool {
        let (Some((gn, gd)), Some((hn, _))) = (self.planes[g as usize], self.planes[h as usize])
        else {
            return false;
        };
        if gn.dot(hn) <= 0.0 {
            return false;
        }
        let (cg, ch) = (self.corners[g as usize], self.corners[h as usize]);
        let only_g: Vec<u32> = cg.into_iter().filter(|v| !ch.contains(v)).collect();
        let only_h: Vec<u32> = ch.into_iter().filter(|v| !cg.contains(v)).collect();
        match (only_g.as_slice(), only_h.as_slice()) {
            // The same three vertices.
            ([], []) => true,
            (&[pg], &[ph]) => {
                let at = |v: u32| self.positions[v as usize];
                if (gn.dot(at(ph)) - gd).abs() > tolerance {
                    return false;
                }
                let shared: Vec<Vec3> = cg.into_iter().filter(|v| ch.contains(v)).map(at).collect();
                let (a, b) = (shared[0], shared[1]);
                let side = |p: Vec3| (b - a).cross(p - a).dot(gn);
                side(at(pg)) * side(at(ph)) > 0.0
            }
            _ => false,
        }
    }

    fn centroid(&self, face: u32) -> Vec3 {
        let c = self.corners[face as usize];
        (self.positions[c[0] as usize]
            + self.positions[c[1] as usize]
            + self.positions[c[2] as usize])
            / 3.0
    }

    fn new(triangles: &[[Vec3; 3]]) -> Mesh {
        // Welding and edge matching by parallel sorts (hash maps of millions of keys were most
        // of the preprocess); vertex numbers follow the sorted positions, which nothing
        // downstream depends on.
        let mut keyed: Vec<([u32; 3], u32)> = triangles
            .par_iter()
            .enumerate()
            .flat_map_iter(|(t, corners)| {
                (0..3).map(move |i| (corners[i].to_array().map(f32::to_bits), (3 * t + i) as u32))
            })
            .collect();
        keyed.par_sort_unstable();
        let mut vertex_of = vec![0u32; keyed.len()];
        let mut positions = Vec::new();
        for (i, &(key, corner)) in keyed.iter().enumerate() {
            if i == 0 || keyed[i - 1].0 != key {
                positions.push(Vec3::from_array(key.map(f32::from_bits)));
            }
            vertex_of[corner as usize] = positions.len() as u32 - 1;
        }
        drop(keyed);
        let corners: Vec<[u32; 3]> = vertex_of
            .chunks_exact(3)
            .map(|c| [c[0], c[1], c[2]])
            .collect();
        let planes = triangles
            .par_iter()
            .map(|t| {
                let n = (t[1] - t[0]).cross(t[2] - t[0]);
                let len = n.length();
                (len > 0.0 && len.is_finite()).then(|| {
                    let n = n / len;
                    (n, n.dot(t[0]))
                })
            })
            .collect();
        // (edge, face) for every edge of every face, sorted so faces sharing an edge are
        // adjacent.
        let mut edges: Vec<(u64, u32)> = corners
            .par_iter()
            .enumerate()
            .flat_map_iter(|(t, c)| {
                (0..3).filter_map(move |i| {
                    let (a, b) = (c[i], c[(i + 1) % 3]);
                    (a != b).then(|| (((a.min(b) as u64) << 32) | a.max(b) as u64, t as u32))
                })
            })
            .collect();
        edges.par_sort_unstable();
        let mut neighbours = vec![Vec::new(); triangles.len()];
        for sharing in edges.chunk_by(|x, y| x.0 == y.0) {
            for &(_, a) in sharing {
                for &(_, b) in sharing {
                    if a != b {
                        neighbours[a as usize].push(b);
                    }
                }
            }
        }
        neighbours.par_iter_mut().for_each(|n: &mut Vec<u32>| {
            n.sort_unstable();
            n.dedup();
        });
        Mesh {
            positions,
            corners,
            planes,
            neighbours,
        }
    }
}

/// Convex parts by region growing: each a list of primitive indices, every triangle in exactly
/// one. `tolerance` is the distance within which a vertex counts as on a plane.
pub fn convex_parts(triangles: &[[Vec3; 3]], tolerance: f32) -> Vec<Vec<u32>> {
    let mesh = Mesh::new(triangles);
    grow_parts(&mesh, tolerance)
}

fn grow_parts(mesh: &Mesh, tolerance: f32) -> Vec<Vec<u32>> {
    // Parts never cross between edge-connected components, and a component's seeds come in
    // primitive order, so growing components apart and sorting the parts by seed gives the
    // parts (and their order) of one sequential sweep.
    let components = components(mesh);
    let mut local_index = vec![0u32; mesh.corners.len()];
    for faces in &components {
        for (i, &f) in faces.iter().enumerate() {
            local_index[f as usize] = i as u32;
        }
    }
    let margin = rounding_margin(mesh);
    let curve = Curve::new(mesh);
    let mut parts: Vec<Vec<u32>> = components
        .par_iter()
        .flat_map_iter(|faces| grow_component(mesh, faces, &local_index, tolerance, margin, &curve))
        .collect();
    parts.sort_unstable_by_key(|p| p[0]);
    parts
}

/// The mesh's edge-connected components, each its faces in primitive order, ordered by their
/// first face.
fn components(mesh: &Mesh) -> Vec<Vec<u32>> {
    let n = mesh.corners.len();
    let mut seen = vec![false; n];
    let mut components = Vec::new();
    let mut stack = Vec::new();
    for first in 0..n {
        if seen[first] {
            continue;
        }
        seen[first] = true;
        let mut faces = vec![first as u32];
        stack.push(first as u32);
        while let Some(f) = stack.pop() {
            for &g in &mesh.neighbours[f as usize] {
                if !std::mem::replace(&mut seen[g as usize], true) {
                    faces.push(g);
                    stack.push(g);
                }
            }
        }
        faces.sort_unstable();
        components.push(faces);
    }
    components
}

/// Bounds the f32 rounding of `n·p − d` (unit n, |p| and |d| at most the mesh's radius from the
/// origin): a chunk whose exact bound lies this far inside the tolerance passes in f32 too.
fn rounding_margin(mesh: &Mesh) -> f64 {
    let radius = mesh
        .positions
        .iter()
        .map(|p| p.length() as f64)
        .fold(0.0, f64::max);
    16.0 * f32::EPSILON as f64 * radius
}

/// Region growing over one component (`faces` in primitive order; `local_index` maps a face to
/// its place there): the parts, each listing its seed first.
fn grow_component(
    mesh: &Mesh,
    faces: &[u32],
    local_index: &[u32],
    tolerance: f32,
    margin: f64,
    curve: &Curve,
) -> Vec<Vec<u32>> {
    const NONE: u32 = u32::MAX;
    let local = |f: u32| local_index[f as usize] as usize;
    let mut part_of = vec![NONE; faces.len()];
    // Per-part stamps: which part a vertex belongs to, which part rejected a triangle.
    let mut vertex_in: FxHashMap<u32, u32> = FxHashMap::default();
    let mut rejected_by = vec![NONE; faces.len()];
    let mut parts: Vec<Vec<u32>> = Vec::new();
    let mut queue = std::collections::VecDeque::new();
    for (seed_local, &seed) in faces.iter().enumerate() {
        if part_of[seed_local] != NONE {
            continue;
        }
        let id = parts.len() as u32;
        part_of[seed_local] = id;
        let mut members = vec![seed];
        let Some(seed_plane) = mesh.planes[seed as usize] else {
            // Without area a triangle has no plane to grow from: a part of its own.
            parts.push(members);
            continue;
        };
        let mut planes = PlaneChunks::default();
        planes.push(seed_plane, mesh.centroid(seed), curve);
        let mut vertices = PointChunks::default();
        for &v in &mesh.corners[seed as usize] {
            if vertex_in.insert(v, id) != Some(id) {
                vertices.push(mesh.positions[v as usize], curve);
            }
        }
        queue.clear();
        queue.extend(mesh.neighbours[seed as usize].iter().copied());
        while let Some(g) = queue.pop_front() {
            if members.len() >= MAX_PART_TRIANGLES {
                break;
            }
            let gl = local(g);
            if part_of[gl] != NONE || rejected_by[gl] == id {
                continue;
            }
            let Some((gn, gd)) = mesh.planes[g as usize] else {
                continue;
            };
            let corners = mesh.corners[g as usize];
            let overlaps_member = mesh.neighbours[g as usize]
                .iter()
                .any(|&h| part_of[local(h)] == id && mesh.overlap_in_plane(g, h, tolerance));
            if overlaps_member {
                rejected_by[gl] = id;
                continue;
            }
            let new_below_part = corners.iter().all(|&v| {
                vertex_in.get(&v) == Some(&id)
                    || planes.holds(mesh.positions[v as usize], tolerance, margin)
            });
            if !new_below_part || !vertices.all_below(gn, gd, tolerance, margin) {
                rejected_by[gl] = id;
                continue;
            }
            part_of[gl] = id;
            members.push(g);
            planes.push((gn, gd), mesh.centroid(g), curve);
            for &v in &corners {
                if vertex_in.insert(v, id) != Some(id) {
                    vertices.push(mesh.positions[v as usize], curve);
                }
            }
            queue.extend(mesh.neighbours[g as usize].iter().copied());
        }
        parts.push(members);
    }
    parts
}

/// A growing part's items (vertices, planes) come in chunks of [`CHUNK`], and chunks in blocks
/// of [`BLOCK`], each with a bound that answers the convexity test for all its items when they
/// lie far inside; only the chunks near the candidate are tested item by item, which keeps a
/// part's growth far below quadratic.
const CHUNK: usize = 32;
const BLOCK: usize = 32 * CHUNK;

/// Morton order over the mesh's box, 10 bits per axis.
struct Curve {
    lo: Vec3,
    scale: Vec3,
}

impl Curve {
    fn new(mesh: &Mesh) -> Curve {
        let (lo, hi) = bounds(mesh.positions.iter().copied());
        Curve {
            lo,
            scale: 1023.0 / (hi - lo).max(Vec3::splat(f32::MIN_POSITIVE)),
        }
    }

    fn key(&self, p: Vec3) -> u32 {
        let spread = |v: f32| {
            let mut x = (v.clamp(0.0, 1023.0) as u32) & 0x3ff;
            x = (x | (x << 16)) & 0x030000ff;
            x = (x | (x << 8)) & 0x0300f00f;
            x = (x | (x << 4)) & 0x030c30c3;
            (x | (x << 2)) & 0x09249249
        };
        let q = (p - self.lo) * self.scale;
        spread(q.x) | (spread(q.y) << 1) | (spread(q.z) << 2)
    }
}

/// Items with a bound per full chunk and per full block.
struct Bounded<T, B> {
    items: Vec<T>,
    chunks: Vec<B>,
    blocks: Vec<B>,
}

impl<T, B> Default for Bounded<T, B> {
    fn default() -> Self {
        Bounded {
            items: Vec::new(),
            chunks: Vec::new(),
            blocks: Vec::new(),
        }
    }
}

impl<T, B> Bounded<T, B> {
    /// Adds `item`; a full block is reordered by `place` (a space-filling-curve key) before
    /// its chunks' bounds are made again, so that each chunk is compact in space and its bound
    /// tight. (Insertion order is breadth first: a chunk of it is a strip along the front.)
    fn push(&mut self, item: T, bound: impl Fn(&[T]) -> B, place: impl Fn(&T) -> u32) {
        self.items.push(item);
        let n = self.items.len();
        if n.is_multiple_of(BLOCK) {
            let block = &mut self.items[n - BLOCK..];
            block.sort_by_cached_key(place);
            self.chunks.truncate(self.chunks.len() + 1 - BLOCK / CHUNK);
            self.chunks
                .extend(self.items[n - BLOCK..].chunks(CHUNK).map(&bound));
            self.blocks.push(bound(&self.items[n - BLOCK..]));
        } else if n.is_multiple_of(CHUNK) {
            self.chunks.push(bound(&self.items[n - CHUNK..]));
        }
    }

    /// Whether `test` holds for every item, where `inside(bound)` promises it for all the items
    /// of a bound.
    fn all(&self, inside: impl Fn(&B) -> bool, test: impl Fn(&T) -> bool) -> bool {
        self.items.chunks(BLOCK).enumerate().all(|(j, block)| {
            self.blocks.get(j).is_some_and(&inside)
                || block.chunks(CHUNK).enumerate().all(|(i, chunk)| {
                    self.chunks
                        .get(j * (BLOCK / CHUNK) + i)
                        .is_some_and(&inside)
                        || chunk.iter().all(&test)
                })
        })
    }
}

/// A part's vertices, with the centre and half-extent of each chunk's and block's box.
#[derive(Default)]
struct PointChunks(Bounded<Vec3, (DVec3, DVec3)>);

impl PointChunks {
    fn push(&mut self, p: Vec3, curve: &Curve) {
        self.0.push(
            p,
            |points| {
                let (lo, hi) = bounds(points.iter().copied());
                let (lo, hi) = (lo.as_dvec3(), hi.as_dvec3());
                ((lo + hi) * 0.5, (hi - lo) * 0.5)
            },
            |&p| curve.key(p),
        );
    }

    /// Whether every point lies on or below the plane n·x = d within `tolerance`: the answer
    /// of testing each point in f32, since a box is passed whole only when its highest corner
    /// lies `margin` (the f32 rounding) below the tolerance.
    fn all_below(&self, n: Vec3, d: f32, tolerance: f32, margin: f64) -> bool {
        let nd = n.as_dvec3();
        self.0.all(
            |&(centre, half)| {
                nd.dot(centre) + nd.abs().dot(half) - d as f64 <= tolerance as f64 - margin
            },
            |&p| n.dot(p) - d <= tolerance,
        )
    }
}

/// A part's planes (unit normal, offset) with a point of each plane's triangle (its centroid),
/// and a bound per chunk and block.
#[derive(Default)]
struct PlaneChunks(Bounded<(Vec3, f32, Vec3), PlaneBound>);

/// For every plane i of a chunk and every point p: n_i·p − d_i ≤ normal·(p − centre) +
/// spread·|p − centre| + offset, where normal is the chunk's mean normal, spread the largest
/// |n_i − normal| and offset the largest n_i·centre − d_i.
struct PlaneBound {
    normal: DVec3,
    centre: DVec3,
    spread: f64,
    offset: f64,
}

impl PlaneBound {
    fn of(planes: &[(Vec3, f32, Vec3)]) -> PlaneBound {
        let count = planes.len() as f64;
        let normal = planes.iter().map(|p| p.0.as_dvec3()).sum::<DVec3>() / count;
        let centre = planes.iter().map(|p| p.2.as_dvec3()).sum::<DVec3>() / count;
        let spread = planes
            .iter()
            .map(|p| (p.0.as_dvec3() - normal).length())
            .fold(0.0, f64::max);
        let offset = planes
            .iter()
            .map(|p| p.0.as_dvec3().dot(centre) - p.1 as f64)
            .fold(f64::NEG_INFINITY, f64::max);
        PlaneBound {
            normal,
            centre,
            spread,
            offset,
        }
    }
}

impl PlaneChunks {
    fn push(&mut self, (n, d): (Vec3, f32), anchor: Vec3, curve: &Curve) {
        self.0
            .push((n, d, anchor), PlaneBound::of, |&(_, _, a)| curve.key(a));
    }

    /// Whether `p` lies on or below every plane within `tolerance`: the answer of testing each
    /// plane in f32 (a bound passes its planes only when it lies `margin` below the tolerance).
    fn holds(&self, p: Vec3, tolerance: f32, margin: f64) -> bool {
        let pd = p.as_dvec3();
        self.0.all(
            |b| {
                let r = pd - b.centre;
                b.normal.dot(r) + b.spread * r.length() + b.offset <= tolerance as f64 - margin
            },
            |&(n, d, _)| n.dot(p) - d <= tolerance,
        )
    }
}

/// The region growing as first written — each candidate tested against every plane and vertex
/// of the part in one sequential sweep — that [`grow_parts`] must reproduce exactly.
#[cfg(test)]
pub(crate) fn grow_parts_plainly(triangles: &[[Vec3; 3]], tolerance: f32) -> Vec<Vec<u32>> {
    let mesh = Mesh::new(triangles);

    const NONE: u32 = u32::MAX;
    let n = mesh.corners.len();
    let mut part_of = vec![NONE; n];
    // Per-part stamps: which part a vertex belongs to, which part rejected a triangle.
    let mut vertex_in = vec![NONE; mesh.positions.len()];
    let mut rejected_by = vec![NONE; n];
    let mut parts: Vec<Vec<u32>> = Vec::new();
    for seed in 0..n {
        if part_of[seed] != NONE {
            continue;
        }
        let id = parts.len() as u32;
        part_of[seed] = id;
        let mut faces = vec![seed as u32];
        let Some(seed_plane) = mesh.planes[seed] else {
            // Without area a triangle has no plane to grow from: a part of its own.
            parts.push(faces);
            continue;
        };
        let mut planes = vec![seed_plane];
        let mut vertices: Vec<u32> = Vec::new();
        for &v in &mesh.corners[seed] {
            if vertex_in[v as usize] != id {
                vertex_in[v as usize] = id;
                vertices.push(v);
            }
        }
        let mut queue =
            std::collections::VecDeque::from_iter(mesh.neighbours[seed].iter().copied());
        while let Some(g) = queue.pop_front() {
            if faces.len() >= MAX_PART_TRIANGLES {
                break;
            }
            let gi = g as usize;
            if part_of[gi] != NONE || rejected_by[gi] == id {
                continue;
            }
            let Some((gn, gd)) = mesh.planes[gi] else {
                continue;
            };
            let overlaps_member = mesh.neighbours[gi]
                .iter()
                .any(|&h| part_of[h as usize] == id && mesh.overlap_in_plane(g, h, tolerance));
            if overlaps_member {
                rejected_by[gi] = id;
                continue;
            }
            let new_below_part = mesh.corners[gi].iter().all(|&v| {
                vertex_in[v as usize] == id || {
                    let p = mesh.positions[v as usize];
                    planes.iter().all(|&(n, d)| n.dot(p) - d <= tolerance)
                }
            });
            let part_below_new = new_below_part
                && vertices
                    .iter()
                    .all(|&v| gn.dot(mesh.positions[v as usize]) - gd <= tolerance);
            if !part_below_new {
                rejected_by[gi] = id;
                continue;
            }
            part_of[gi] = id;
            faces.push(g);
            planes.push((gn, gd));
            for &v in &mesh.corners[gi] {
                if vertex_in[v as usize] != id {
                    vertex_in[v as usize] = id;
                    vertices.push(v);
                }
            }
            queue.extend(mesh.neighbours[gi].iter().copied());
        }
        parts.push(faces);
    }
    parts
}

/// For every ordered pair of `triangles`' convex parts whose boxes overlap: whether the second
/// part's vertices lie below the first's planes, as [`Pair`] answers it (by chunks for large
/// parts) and as the plain test of every plane against every point answers it; and whether
/// the first part was large enough for the chunks.
#[cfg(test)]
pub(crate) fn containment_twins(
    triangles: &[[Vec3; 3]],
    tolerance: f32,
) -> Vec<(bool, bool, bool)> {
    let mesh = Mesh::new(triangles);
    let groups: Vec<Group> = grow_parts(&mesh, tolerance)
        .into_iter()
        .map(|p| group(triangles, p, 1))
        .collect();
    let curve = Curve::new(&mesh);
    let pair = Pair {
        triangles,
        mesh: &mesh,
        group_of: &[],
        tolerance,
        margin: rounding_margin(&mesh),
        curve: &curve,
    };
    let mut twins = Vec::new();
    for a in &groups {
        for b in groups.iter().filter(|b| boxes_overlap(a, b)) {
            let plain = a.triangles.iter().all(|&f| {
                mesh.planes[f as usize]
                    .is_none_or(|(n, d)| b.points.iter().all(|&p| n.dot(p) - d <= tolerance))
            });
            twins.push((
                pair.holds(a, &b.points),
                plain,
                a.triangles.len() >= 4 * CHUNK,
            ));
        }
    }
    twins
}

/// Whether every vertex of `faces` lies on or below every plane of `faces` (within
/// `tolerance`): the definition of a convex part.
pub fn is_convex_part(triangles: &[[Vec3; 3]], faces: &[u32], tolerance: f32) -> bool {
    faces.iter().all(|&f| {
        let t = triangles[f as usize];
        let n = (t[1] - t[0]).cross(t[2] - t[0]);
        let len = n.length();
        if len == 0.0 {
            return faces.len() == 1;
        }
        let (n, d) = (n / len, (n / len).dot(t[0]));
        faces
            .iter()
            .flat_map(|&g| triangles[g as usize])
            .all(|p| n.dot(p) - d <= tolerance)
    })
}

impl Decomposition {
    /// Decomposes `triangles` (in primitive order). `progress` is told the fraction done.
    pub fn new(triangles: &[[Vec3; 3]], progress: &dyn Fn(f32)) -> Decomposition {
        let start = std::time::Instant::now();
        let (lo, hi) = bounds(triangles.iter().flatten().copied());
        let tolerance = ((hi - lo).length() * 1e-6).max(f32::MIN_POSITIVE);
        let mesh = Mesh::new(triangles);
        progress(0.1);
        let parts = grow_parts(&mesh, tolerance);
        progress(0.6);
        let part_count = parts.len() as u32;
        let mut groups: Vec<Group> = parts.into_iter().map(|p| group(triangles, p, 1)).collect();
        // Inseparable neighbours, neither inside the other, become one group of two parts; each
        // part joins at most one.
        let relations = relate(triangles, &mesh, &groups, tolerance);
        let mut partner = vec![u32::MAX; groups.len()];
        // In pair order, so the groups are the same every run.
        let inseparable = relations
            .iter()
            .filter(|&(_, r)| r == Relation::Inseparable)
            .map(|(pair, _)| pair);
        for (a, b) in inseparable {
            if partner[a as usize] == u32::MAX && partner[b as usize] == u32::MAX {
                partner[a as usize] = b;
                partner[b as usize] = a;
            }
        }
        progress(0.8);
        let mut joined = Vec::with_capacity(groups.len());
        let mut paired = 0;
        for i in 0..groups.len() {
            let p = partner[i] as usize;
            if partner[i] == u32::MAX {
                joined.push((std::mem::take(&mut groups[i].triangles), 1));
            } else if p > i {
                let mut t = std::mem::take(&mut groups[i].triangles);
                t.append(&mut groups[p].triangles);
                joined.push((t, 2));
                paired += 1;
            }
        }
        let groups: Vec<Group> = joined
            .into_iter()
            .map(|(t, parts)| group(triangles, t, parts))
            .collect();
        let relations = if paired == 0 {
            relations
        } else {
            relate(triangles, &mesh, &groups, tolerance)
        };
        progress(1.0);
        let count = |r: Relation| relations.iter().filter(|&(_, x)| x == r).count() as u64;
        let layers_per_group = 2 * groups.iter().map(|g| g.parts).max().unwrap_or(1);
        let stats = DecompositionStats {
            triangles: triangles.len() as u64,
            parts: part_count,
            groups: groups.len() as u32,
            paired,
            overlapping_pairs: relations.len() as u64,
            nested: count(Relation::Contains) + count(Relation::Inside),
            unseparated: count(Relation::Inseparable),
            layers_per_group,
            preprocess_ms: start.elapsed().as_secs_f64() * 1e3,
            read_from_cache_ms: None,
        };
        Decomposition::from_parts(groups, relations, tolerance, stats)
    }

    /// A decomposition from its groups and their relations (containers derived).
    pub fn from_parts(
        groups: Vec<Group>,
        relations: Relations,
        tolerance: f32,
        stats: DecompositionStats,
    ) -> Decomposition {
        let mut container = vec![false; groups.len()];
        for ((i, j), r) in relations.iter() {
            match r {
                Relation::Contains => container[i as usize] = true,
                Relation::Inside => container[j as usize] = true,
                _ => {}
            }
        }
        Decomposition {
            groups,
            relations,
            container,
            tolerance,
            stats,
        }
    }

    /// The lowest primitive of group `g` (the order of coincident groups).
    pub fn first_primitive(&self, g: u32) -> u32 {
        self.groups[g as usize]
            .triangles
            .iter()
            .copied()
            .min()
            .unwrap_or(u32::MAX)
    }

    /// How groups `a` and `b` relate, seen from `a`: a plane with `a` below it (pairs whose
    /// boxes overlap, when one was found; along an axis when the boxes are apart), nesting, or
    /// nothing found.
    pub fn relation(&self, a: u32, b: u32) -> Relation {
        let (i, j) = (a.min(b), a.max(b));
        let r = match self.relations.get(i, j) {
            Some(r) => r,
            None => {
                let (gi, gj) = (&self.groups[i as usize], &self.groups[j as usize]);
                match axis_separation(gi, gj) {
                    None => Relation::Inseparable,
                    Some(s)
                        if coplanar_in(&s, gi.points.iter().chain(&gj.points), self.tolerance) =>
                    {
                        Relation::Coplanar
                    }
                    Some(s) => Relation::Plane(s),
                }
            }
        };
        if a == i {
            r
        } else {
            r.reversed()
        }
    }
}

fn group(triangles: &[[Vec3; 3]], faces: Vec<u32>, parts: u32) -> Group {
    let points = faces.iter().flat_map(|&f| triangles[f as usize]);
    let (lo, hi) = bounds(points.clone());
    let centroid = points.clone().sum::<Vec3>() / (3 * faces.len()).max(1) as f32;
    let mut distinct: Vec<Vec3> = points.collect();
    distinct.sort_by_key(|p| p.to_array().map(f32::to_bits));
    distinct.dedup();
    Group {
        parts,
        triangles: faces,
        lo,
        hi,
        centroid,
        points: distinct,
    }
}

fn bounds(points: impl Iterator<Item = Vec3>) -> (Vec3, Vec3) {
    points.fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(lo, hi), p| {
        (lo.min(p), hi.max(p))
    })
}
