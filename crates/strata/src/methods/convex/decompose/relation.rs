//! How two groups of the decomposition relate: apart along an axis, separated by a plane found
//! among candidate normals, one nested in the other, or inseparable (see the module docs of
//! `decompose`).

use super::*;

/// Whether the boxes share interior: pairs that do are related by [`relate`]; the others
/// are apart along an axis ([`axis_separation`]).
pub(super) fn boxes_overlap(a: &Group, b: &Group) -> bool {
    a.lo.cmplt(b.hi).all() && b.lo.cmplt(a.hi).all()
}

/// The axis-aligned plane between two groups whose boxes are apart along an axis.
pub(super) fn axis_separation(a: &Group, b: &Group) -> Option<Separation> {
    (0..3).find_map(|k| {
        let axis = Vec3::AXES[k];
        if a.hi[k] <= b.lo[k] {
            Some(Separation {
                normal: axis,
                offset: 0.5 * (a.hi[k] + b.lo[k]),
            })
        } else if b.hi[k] <= a.lo[k] {
            Some(Separation {
                normal: -axis,
                offset: -0.5 * (b.hi[k] + a.lo[k]),
            })
        } else {
            None
        }
    })
}

/// Whether every point lies on the plane `s` (within `tolerance`).
pub(super) fn coplanar_in<'a>(
    s: &Separation,
    mut points: impl Iterator<Item = &'a Vec3>,
    tolerance: f32,
) -> bool {
    points.all(|p| (s.normal.dot(*p) - s.offset).abs() <= tolerance)
}

/// How two groups `(a, b)` relate, from `a`'s side.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Relation {
    /// A plane with `a` on or below it and `b` on or above it.
    Plane(Separation),
    /// `b` lies inside the convex hull of `a` (a single convex part): every ray meets `a`'s
    /// front-facing layer before `b` and its back-facing layer after.
    Contains,
    /// `a` lies inside `b`'s hull.
    Inside,
    /// No candidate plane separates them and neither holds the other.
    Inseparable,
    /// Both lie in one plane (coincident surfaces: decals, doubled faces): wherever they share
    /// a pixel their fragments have one depth, which the reference orders by primitive, so the
    /// group holding the lower primitives comes first from either side.
    Coplanar,
}

impl Relation {
    pub(super) fn reversed(self) -> Relation {
        match self {
            Relation::Plane(s) => Relation::Plane(Separation {
                normal: -s.normal,
                offset: -s.offset,
            }),
            Relation::Contains => Relation::Inside,
            Relation::Inside => Relation::Contains,
            Relation::Inseparable => Relation::Inseparable,
            Relation::Coplanar => Relation::Coplanar,
        }
    }
}

/// Every pair (i < j) of groups whose boxes overlap, in order. The boxes are binned into a
/// uniform grid of cells about twice the mean box size (coarser where large boxes would fill
/// too many cells); a pair is examined in the one cell holding its boxes' intersection's lowest
/// corner.
pub(crate) fn overlapping_pairs(groups: &[Group]) -> Vec<(u32, u32)> {
    if groups.len() < 2 {
        return Vec::new();
    }
    let (lo, hi) = bounds(groups.iter().flat_map(|g| [g.lo, g.hi]));
    let span = (hi - lo).max(Vec3::splat(f32::MIN_POSITIVE));
    let mean_extent = groups.iter().map(|g| g.hi - g.lo).sum::<Vec3>() / groups.len() as f32;
    const MAX_CELLS_PER_AXIS: f32 = 1024.0;
    let mut cell = (2.0 * mean_extent).max(span / MAX_CELLS_PER_AXIS);
    let dims = |cell: Vec3| (span / cell).ceil().max(Vec3::ONE).as_uvec3();
    let cell_of =
        |p: Vec3, cell: Vec3, dims: glam::UVec3| ((p - lo) / cell).as_uvec3().min(dims - 1);
    let range =
        |g: &Group, cell: Vec3, dims| (cell_of(g.lo, cell, dims), cell_of(g.hi, cell, dims));
    let entries = |cell: Vec3| {
        let d = dims(cell);
        groups
            .par_iter()
            .map(|g| {
                let (a, b) = range(g, cell, d);
                (b - a + 1).as_u64vec3().element_product()
            })
            .sum::<u64>()
    };
    // Bounded memory: a scene of many large boxes gets coarser cells.
    while entries(cell) > 32 * groups.len() as u64 {
        cell *= 2.0;
    }
    let d = dims(cell);
    let index = |c: glam::UVec3| c.x as u64 + d.x as u64 * (c.y as u64 + d.y as u64 * c.z as u64);
    let mut binned: Vec<(u64, u32)> = groups
        .par_iter()
        .enumerate()
        .flat_map_iter(|(g, group)| {
            let (a, b) = range(group, cell, d);
            (a.z..=b.z).flat_map(move |z| {
                (a.y..=b.y).flat_map(move |y| {
                    (a.x..=b.x).map(move |x| (index(glam::UVec3::new(x, y, z)), g as u32))
                })
            })
        })
        .collect();
    binned.par_sort_unstable();
    let cells: Vec<&[(u64, u32)]> = binned.chunk_by(|a, b| a.0 == b.0).collect();
    let mut pairs: Vec<(u32, u32)> = cells
        .par_iter()
        .flat_map_iter(|members| {
            let here = members[0].0;
            members.iter().enumerate().flat_map(move |(i, &(_, a))| {
                let ga = &groups[a as usize];
                members[i + 1..].iter().filter_map(move |&(_, b)| {
                    let gb = &groups[b as usize];
                    (boxes_overlap(ga, gb) && index(cell_of(ga.lo.max(gb.lo), cell, d)) == here)
                        .then_some((a.min(b), a.max(b)))
                })
            })
        })
        .collect();
    pairs.par_sort_unstable();
    pairs
}

/// Every pair (i < j) of groups whose boxes overlap, with how they relate.
pub(super) fn relate(
    triangles: &[[Vec3; 3]],
    mesh: &Mesh,
    groups: &[Group],
    tolerance: f32,
) -> Relations {
    let pairs = overlapping_pairs(groups);
    let mut group_of = vec![0u32; triangles.len()];
    for (g, group) in groups.iter().enumerate() {
        for &t in &group.triangles {
            group_of[t as usize] = g as u32;
        }
    }
    let (margin, curve) = (rounding_margin(mesh), Curve::new(mesh));
    let relations: Vec<Relation> = pairs
        .par_iter()
        .map(|&(a, b)| {
            let pair = Pair {
                triangles,
                mesh,
                group_of: &group_of,
                tolerance,
                margin,
                curve: &curve,
            };
            pair.relate((a, &groups[a as usize]), (b, &groups[b as usize]))
        })
        .collect();
    Relations::from_pairs(pairs.into_iter().zip(relations).collect())
}

pub(super) struct Pair<'a> {
    pub(super) triangles: &'a [[Vec3; 3]],
    pub(super) mesh: &'a Mesh,
    pub(super) group_of: &'a [u32],
    pub(super) tolerance: f32,
    pub(super) margin: f64,
    pub(super) curve: &'a Curve,
}

impl Pair<'_> {
    fn relate(&self, (ia, a): (u32, &Group), (ib, b): (u32, &Group)) -> Relation {
        let (pa, pb) = (&a.points, &b.points);
        if let Some(s) = self.separate((ia, a, pa), (ib, b, pb)) {
            if coplanar_in(&s, pa.iter().chain(pb), self.tolerance) {
                return Relation::Coplanar;
            }
            return Relation::Plane(s);
        }
        let boxed = |outer: &Group, inner: &Group| {
            outer.parts == 1 && inner.lo.cmpge(outer.lo).all() && inner.hi.cmple(outer.hi).all()
        };
        if boxed(a, b) && self.holds(a, pb) {
            return Relation::Contains;
        }
        if boxed(b, a) && self.holds(b, pa) {
            return Relation::Inside;
        }
        Relation::Inseparable
    }

    /// Whether `points` lie below every plane of the convex part `container`.
    pub(super) fn holds(&self, container: &Group, points: &[Vec3]) -> bool {
        if container.triangles.len() < 4 * CHUNK {
            return container.triangles.iter().all(|&f| {
                self.mesh.planes[f as usize]
                    .is_none_or(|(n, d)| points.iter().all(|&p| n.dot(p) - d <= self.tolerance))
            });
        }
        let mut planes = PlaneChunks::default();
        for &f in &container.triangles {
            if let Some(plane) = self.mesh.planes[f as usize] {
                planes.push(plane, self.mesh.centroid(f), self.curve);
            }
        }
        points
            .iter()
            .all(|&p| planes.holds(p, self.tolerance, self.margin))
    }

    /// A plane with `a` below and `b` above among the candidate normals: the line between
    /// the centroids, the axes, the normals of triangles reaching into the other's box, and
    /// for triangles sharing an edge across the pair the difference of their normals (a plane
    /// through that edge between the two faces).
    fn separate(
        &self,
        (ia, a, pa): (u32, &Group, &[Vec3]),
        (ib, b, pb): (u32, &Group, &[Vec3]),
    ) -> Option<Separation> {
        let normal = |f: u32| self.mesh.planes[f as usize].map(|(n, _)| n);
        let touching = |g: &Group, other: &Group| -> Vec<u32> {
            let (lo, hi) = (other.lo - self.tolerance, other.hi + self.tolerance);
            let near: Vec<u32> = g
                .triangles
                .iter()
                .copied()
                .filter(|&f| {
                    self.triangles[f as usize]
                        .iter()
                        .any(|p| p.cmpge(lo).all() && p.cmple(hi).all())
                })
                .collect();
            let step = near.len().div_ceil(TOUCHING_CANDIDATES).max(1);
            near.into_iter().step_by(step).collect()
        };
        let across = |n: Vec3| {
            if n == Vec3::ZERO {
                return None;
            }
            let ((a_lo, a_hi), (b_lo, b_hi)) = if pa.len() <= pb.len() {
                let a = extent(pa, n);
                (a, extent_unless_overlapping(pb, n, a, self.tolerance)?)
            } else {
                let b = extent(pb, n);
                (extent_unless_overlapping(pa, n, b, self.tolerance)?, b)
            };
            if a_hi <= b_lo + self.tolerance {
                Some(Separation {
                    normal: n,
                    offset: 0.5 * (a_hi + b_lo),
                })
            } else if b_hi <= a_lo + self.tolerance {
                Some(Separation {
                    normal: -n,
                    offset: -0.5 * (b_hi + a_lo),
                })
            } else {
                None
            }
        };
        // The candidates in turn, each gathered only when those before it failed.
        if let Some(s) = across((b.centroid - a.centroid).normalize_or_zero()) {
            return Some(s);
        }
        let (ta, tb) = (touching(a, b), touching(b, a));
        let edge_planes = ta
            .iter()
            .map(|&f| (f, ib))
            .chain(tb.iter().map(|&f| (f, ia)))
            .filter_map(|(f, other)| Some((normal(f)?, f, other)))
            .flat_map(|(nf, f, other)| {
                self.mesh.neighbours[f as usize]
                    .iter()
                    .filter(move |&&g| self.group_of[g as usize] == other)
                    .filter_map(move |&g| Some((nf - normal(g)?).normalize_or_zero()))
            });
        let own_normals = ta.iter().chain(&tb).filter_map(|&f| normal(f));
        edge_planes
            .chain(own_normals)
            .chain(Vec3::AXES)
            .find_map(across)
    }
}

/// The extent of `points` along `n`, or `None` as soon as they reach more than `tolerance`
/// past both ends of `other`, the extent of the other group (then neither lies on one side).
pub(crate) fn extent_unless_overlapping(
    points: &[Vec3],
    n: Vec3,
    (other_lo, other_hi): (f32, f32),
    tolerance: f32,
) -> Option<(f32, f32)> {
    let (mut lo, mut hi) = (f32::INFINITY, f32::NEG_INFINITY);
    for p in points {
        let d = n.dot(*p);
        lo = lo.min(d);
        hi = hi.max(d);
        if other_hi > lo + tolerance && hi > other_lo + tolerance {
            return None;
        }
    }
    Some((lo, hi))
}

pub(crate) fn extent(points: &[Vec3], n: Vec3) -> (f32, f32) {
    points
        .iter()
        .fold((f32::INFINITY, f32::NEG_INFINITY), |(lo, hi), p| {
            let d = n.dot(*p);
            (lo.min(d), hi.max(d))
        })
}
