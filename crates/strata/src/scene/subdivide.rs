//! Loop subdivision (Loop 1987): each triangle becomes four and every vertex moves toward a
//! smooth limit surface, so a scanned model can be made denser *and still curved* — a stand-in
//! for the larger scans the papers measure (flat midpoint splits would keep the facets and make
//! the mesh easier than a real dense scan for methods that exploit flatness, such as `convex`).
//!
//! Vertices at the same position are welded first (OBJ files split them at seams), so seams do
//! not open. Edges with one face, or more than two, keep their midpoint and their vertices follow
//! the boundary rule; a vertex with other than two such edges stays where it is. Normals are
//! recomputed from the new faces.

use std::collections::HashMap;

use glam::Vec3;

use super::Mesh;

/// One subdivision step of `mesh` (triangle order and winding kept: triangle `t` becomes
/// triangles `4t..4t+4`).
pub fn loop_subdivide(mesh: &Mesh) -> Mesh {
    let (positions, triangles) = welded(mesh);
    let n = positions.len();
    // Every undirected edge: its new vertex's index, faces using it, and their opposite corners.
    struct Edge {
        index: u32,
        faces: u32,
        opposite: [u32; 2],
    }
    let mut edges: HashMap<(u32, u32), Edge> = HashMap::new();
    let key = |a: u32, b: u32| (a.min(b), a.max(b));
    let mut next = n as u32;
    for t in &triangles {
        for c in 0..3 {
            let (a, b, opposite) = (t[c], t[(c + 1) % 3], t[(c + 2) % 3]);
            let e = edges.entry(key(a, b)).or_insert_with(|| {
                next += 1;
                Edge {
                    index: next - 1,
                    faces: 0,
                    opposite: [opposite; 2],
                }
            });
            if e.faces < 2 {
                e.opposite[e.faces as usize] = opposite;
            }
            e.faces += 1;
        }
    }
    let p = |i: u32| Vec3::from(positions[i as usize]);
    let mut out = vec![[0.0f32; 3]; next as usize];
    let mut ring_sum = vec![Vec3::ZERO; n];
    let mut ring_count = vec![0u32; n];
    let mut border_sum = vec![Vec3::ZERO; n];
    let mut border_count = vec![0u32; n];
    // In the edges' creation order: the sums below must not depend on the map's order.
    let mut ordered: Vec<(&(u32, u32), &Edge)> = edges.iter().collect();
    ordered.sort_unstable_by_key(|(_, e)| e.index);
    for (&(a, b), e) in ordered {
        let interior = e.faces == 2;
        out[e.index as usize] = if interior {
            (0.375 * (p(a) + p(b)) + 0.125 * (p(e.opposite[0]) + p(e.opposite[1]))).to_array()
        } else {
            (0.5 * (p(a) + p(b))).to_array()
        };
        for (v, w) in [(a, b), (b, a)] {
            ring_sum[v as usize] += p(w);
            ring_count[v as usize] += 1;
            if !interior {
                border_sum[v as usize] += p(w);
                border_count[v as usize] += 1;
            }
        }
    }
    for v in 0..n {
        let here = Vec3::from(positions[v]);
        out[v] = match (border_count[v], ring_count[v]) {
            (0, 0) => here,
            (0, k) => {
                let beta = if k == 3 {
                    3.0 / 16.0
                } else {
                    3.0 / (8.0 * k as f32)
                };
                (1.0 - k as f32 * beta) * here + beta * ring_sum[v]
            }
            (2, _) => 0.75 * here + 0.125 * border_sum[v],
            _ => here,
        }
        .to_array();
    }
    let mut indices = Vec::with_capacity(triangles.len() * 12);
    for t in &triangles {
        let mid = |c: usize| edges[&key(t[c], t[(c + 1) % 3])].index;
        let (ab, bc, ca) = (mid(0), mid(1), mid(2));
        indices.extend_from_slice(&[t[0], ab, ca, t[1], bc, ab, t[2], ca, bc, ab, bc, ca]);
    }
    let mut subdivided = Mesh {
        positions: out,
        normals: Vec::new(),
        indices,
    };
    subdivided.compute_normals();
    subdivided
}

/// The mesh's distinct positions (by exact value) and its triangles over them.
fn welded(mesh: &Mesh) -> (Vec<[f32; 3]>, Vec<[u32; 3]>) {
    let mut seen: HashMap<[u32; 3], u32> = HashMap::new();
    let mut positions = Vec::new();
    let remap: Vec<u32> = mesh
        .positions
        .iter()
        .map(|p| {
            *seen.entry(p.map(f32::to_bits)).or_insert_with(|| {
                positions.push(*p);
                positions.len() as u32 - 1
            })
        })
        .collect();
    let triangles = mesh
        .indices
        .chunks_exact(3)
        .map(|t| [t[0], t[1], t[2]].map(|i| remap[i as usize]))
        .collect();
    (positions, triangles)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tetrahedron() -> Mesh {
        Mesh {
            positions: vec![
                [1.0, 1.0, 1.0],
                [1.0, -1.0, -1.0],
                [-1.0, 1.0, -1.0],
                [-1.0, -1.0, 1.0],
            ],
            normals: Vec::new(),
            indices: vec![0, 1, 2, 0, 3, 1, 0, 2, 3, 1, 3, 2],
        }
    }

    #[test]
    fn a_step_makes_four_triangles_of_each_and_keeps_a_closed_mesh_closed() {
        let once = loop_subdivide(&tetrahedron());
        assert_eq!(once.triangle_count(), 16);
        // 4 vertices + 6 edges; every edge of the result is shared by exactly two faces.
        assert_eq!(once.positions.len(), 10);
        let mut uses: HashMap<(u32, u32), u32> = HashMap::new();
        for t in once.indices.chunks_exact(3) {
            for c in 0..3 {
                let (a, b) = (t[c], t[(c + 1) % 3]);
                *uses.entry((a.min(b), a.max(b))).or_default() += 1;
            }
        }
        assert!(uses.values().all(|&u| u == 2), "{uses:?}");
        once.validate("subdivided").unwrap();
    }

    #[test]
    fn the_surface_shrinks_toward_its_smooth_limit_and_winding_is_kept() {
        let mesh = tetrahedron();
        let twice = loop_subdivide(&loop_subdivide(&mesh));
        let (lo, hi) = twice.bounds();
        assert!(
            hi.max_element() < 1.0 && lo.min_element() > -1.0,
            "{lo} {hi}"
        );
        // Outward winding stays outward: every face normal points away from the centre.
        for t in twice.indices.chunks_exact(3) {
            let [a, b, c] = [t[0], t[1], t[2]].map(|i| Vec3::from(twice.positions[i as usize]));
            assert!((b - a).cross(c - a).dot(a + b + c) > 0.0);
        }
    }

    #[test]
    fn subdivision_is_deterministic() {
        let mesh = crate::scene::builtin::build("teapot").unwrap().objects[0]
            .mesh
            .clone();
        let a = loop_subdivide(&mesh);
        for _ in 0..3 {
            assert_eq!(loop_subdivide(&mesh), a);
        }
    }

    #[test]
    fn a_seam_of_duplicated_vertices_does_not_open_and_a_border_stays_on_its_line() {
        // Two triangles of a flat square, the diagonal's ends duplicated as an OBJ seam would.
        let square = Mesh {
            positions: vec![
                [0.0, 0.0, 0.0],
                [1.0, 0.0, 0.0],
                [1.0, 1.0, 0.0],
                [0.0, 0.0, 0.0],
                [1.0, 1.0, 0.0],
                [0.0, 1.0, 0.0],
            ],
            normals: Vec::new(),
            indices: vec![0, 1, 2, 3, 4, 5],
        };
        let once = loop_subdivide(&square);
        // Welded: 4 corners + 5 edges.
        assert_eq!(once.positions.len(), 9);
        for p in &once.positions {
            assert_eq!(p[2], 0.0);
            assert!(
                (0.0..=1.0).contains(&p[0]) && (0.0..=1.0).contains(&p[1]),
                "{p:?}"
            );
        }
    }
}
