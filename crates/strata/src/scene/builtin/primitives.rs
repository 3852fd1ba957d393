//! Mesh primitives: quad, cube, UV sphere. All are centred at the origin, wound counter-clockwise
//! seen from outside (the side their normals point to).

use std::f32::consts::{PI, TAU};

use glam::Vec3;

use crate::scene::Mesh;

/// The square [-1,1]² in the XY plane at z = 0, facing +Z (CCW seen from +Z).
pub fn quad() -> Mesh {
    Mesh {
        positions: vec![
            [-1.0, -1.0, 0.0],
            [1.0, -1.0, 0.0],
            [1.0, 1.0, 0.0],
            [-1.0, 1.0, 0.0],
        ],
        normals: vec![[0.0, 0.0, 1.0]; 4],
        indices: vec![0, 1, 2, 0, 2, 3],
    }
}

/// The cube [-1,1]³: 6 faces of 4 vertices each (24 vertices) with flat outward normals, 12
/// triangles wound CCW seen from outside.
pub fn cube() -> Mesh {
    let mut m = Mesh::default();
    // (normal, u, v) with u × v = normal, so corners n−u−v, n+u−v, n+u+v, n−u+v go CCW seen
    // from outside.
    let faces = [
        (Vec3::X, Vec3::NEG_Z, Vec3::Y),
        (Vec3::NEG_X, Vec3::Z, Vec3::Y),
        (Vec3::Y, Vec3::X, Vec3::NEG_Z),
        (Vec3::NEG_Y, Vec3::X, Vec3::Z),
        (Vec3::Z, Vec3::X, Vec3::Y),
        (Vec3::NEG_Z, Vec3::NEG_X, Vec3::Y),
    ];
    for (n, u, v) in faces {
        debug_assert!(u.cross(v).abs_diff_eq(n, 1e-6));
        let base = m.positions.len() as u32;
        for (su, sv) in [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)] {
            m.positions.push((n + u * su + v * sv).to_array());
            m.normals.push(n.to_array());
        }
        m.indices
            .extend_from_slice(&[base, base + 1, base + 2, base, base + 2, base + 3]);
    }
    m
}

/// The unit sphere, Y up: `segments` vertices around (at least 3), `segments / 2` rings from
/// pole to pole (at least 2). Each pole is a single vertex joined to its neighbouring ring by
/// `segments` triangles, so there are no zero-area triangles. Smooth normals (= positions),
/// CCW seen from outside. `2 · segments · (rings − 1)` triangles.
pub fn uv_sphere(segments: u32) -> Mesh {
    debug_assert!(
        segments < 1 << 15,
        "uv_sphere({segments}) would overflow its indices"
    );
    let segments = segments.max(3);
    let rings = (segments / 2).max(2);
    let mut m = Mesh::default();
    m.positions.push([0.0, 1.0, 0.0]);
    for k in 1..rings {
        let theta = PI * k as f32 / rings as f32;
        let (r, y) = (theta.sin(), theta.cos());
        for j in 0..segments {
            let phi = TAU * j as f32 / segments as f32;
            m.positions.push([r * phi.sin(), y, r * phi.cos()]);
        }
    }
    m.positions.push([0.0, -1.0, 0.0]);
    m.normals = m.positions.clone();

    let top = 0u32;
    let bottom = m.positions.len() as u32 - 1;
    // Vertex j of intermediate ring k (1-based).
    let at = |k: u32, j: u32| 1 + (k - 1) * segments + j % segments;
    for j in 0..segments {
        m.indices.extend_from_slice(&[top, at(1, j), at(1, j + 1)]);
    }
    for k in 1..rings - 1 {
        for j in 0..segments {
            let (a, b) = (at(k, j), at(k, j + 1));
            let (c, d) = (at(k + 1, j), at(k + 1, j + 1));
            m.indices.extend_from_slice(&[a, c, d, a, d, b]);
        }
    }
    for j in 0..segments {
        m.indices
            .extend_from_slice(&[bottom, at(rings - 1, j + 1), at(rings - 1, j)]);
    }
    m
}

/// The triangles of [`uv_sphere`]`(segments)`, known before it is built.
pub fn uv_sphere_triangles(segments: u32) -> u64 {
    let segments = segments.max(3) as u64;
    let rings = (segments / 2).max(2);
    2 * segments * (rings - 1)
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use std::collections::HashMap;

    /// Signed volume of a closed mesh (positive when faces wind CCW seen from outside).
    pub(crate) fn signed_volume(m: &Mesh) -> f32 {
        m.indices
            .chunks_exact(3)
            .map(|t| {
                let [a, b, c] = [t[0], t[1], t[2]].map(|i| Vec3::from(m.positions[i as usize]));
                a.dot(b.cross(c)) / 6.0
            })
            .sum()
    }

    /// Every undirected edge is used by exactly two triangles, once in each direction.
    fn assert_closed(m: &Mesh) {
        let mut edges: HashMap<(u32, u32), i32> = HashMap::new();
        for t in m.indices.chunks_exact(3) {
            for (a, b) in [(t[0], t[1]), (t[1], t[2]), (t[2], t[0])] {
                *edges.entry((a, b)).or_default() += 1;
            }
        }
        for (&(a, b), &n) in &edges {
            assert_eq!(n, 1, "edge {a}->{b} used {n} times");
            assert_eq!(edges.get(&(b, a)), Some(&1), "edge {a}->{b} has no twin");
        }
    }

    fn assert_outward(m: &Mesh) {
        // Face normal agrees with the direction from the centre, and with the vertex normals.
        for t in m.indices.chunks_exact(3) {
            let [a, b, c] = [t[0], t[1], t[2]].map(|i| Vec3::from(m.positions[i as usize]));
            let n = (b - a).cross(c - a);
            assert!(n.length() > 1e-7, "degenerate triangle {t:?}");
            let centre = (a + b + c) / 3.0;
            assert!(n.dot(centre) > 0.0, "inward triangle {t:?}");
            for &i in t {
                assert!(n.dot(Vec3::from(m.normals[i as usize])) > 0.0);
            }
        }
    }

    #[test]
    fn quad_faces_plus_z() {
        let q = quad();
        q.validate("quad").unwrap();
        assert_eq!(q.triangle_count(), 2);
        for t in q.indices.chunks_exact(3) {
            let [a, b, c] = [t[0], t[1], t[2]].map(|i| Vec3::from(q.positions[i as usize]));
            assert!((b - a).cross(c - a).z > 0.0);
        }
        assert_eq!(
            q.bounds(),
            (Vec3::new(-1.0, -1.0, 0.0), Vec3::new(1.0, 1.0, 0.0))
        );
    }

    #[test]
    fn cube_is_closed_and_outward() {
        let c = cube();
        c.validate("cube").unwrap();
        assert_eq!(c.positions.len(), 24);
        assert_eq!(c.triangle_count(), 12);
        assert!((signed_volume(&c) - 8.0).abs() < 1e-4);
        assert_eq!(c.bounds(), (Vec3::splat(-1.0), Vec3::splat(1.0)));
        assert_outward(&c);
    }

    #[test]
    fn sphere_is_closed_and_outward() {
        for segments in [3, 4, 5, 12, 16, 48] {
            let s = uv_sphere(segments);
            s.validate("sphere").unwrap();
            let rings = (segments / 2).max(2);
            assert_eq!(s.triangle_count() as u32, 2 * segments * (rings - 1));
            assert_closed(&s);
            assert_outward(&s);
            let v = signed_volume(&s);
            assert!(v > 0.0 && v <= 4.0 / 3.0 * PI + 1e-4, "{segments}: {v}");
            for p in &s.positions {
                assert!((Vec3::from(*p).length() - 1.0).abs() < 1e-5);
            }
        }
        // Fine tessellation approaches the sphere's volume.
        let v = signed_volume(&uv_sphere(64));
        assert!((v - 4.0 / 3.0 * PI).abs() < 0.05, "{v}");
    }
}
