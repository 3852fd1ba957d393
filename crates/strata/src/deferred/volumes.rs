//! Light volumes: the unit meshes the lighting pass instances, and the per-camera split of the
//! lights into sphere, cone and full-screen draws after frustum culling.
//!
//! Each mesh *circumscribes* its volume (every face lies outside it), so rasterizing the mesh
//! covers every pixel the light can reach; the shader's window makes the light exactly zero
//! beyond its range, so a loose volume costs fragments, never correctness.

use glam::{Mat4, Vec3, Vec4};

use crate::frame::uniforms::GpuLight;
use crate::scene::Camera;

/// Subdivisions of the icosahedron (1: 80 faces).
const SPHERE_SUBDIVISIONS: u32 = 1;
/// Sides of the cone's base polygon.
const CONE_SIDES: u32 = 16;
/// Spots wider than this draw a sphere: a cone that wide bounds little and grows without limit
/// towards 90°.
pub const MAX_CONE_DEG: f32 = 75.0;

/// The unit meshes as one triangle list (xyz, w = 1): the sphere's vertices, then the cone's.
pub struct VolumeMeshes {
    /// Every vertex, the sphere's first.
    pub vertices: Vec<[f32; 4]>,
    /// Vertices of the sphere.
    pub sphere_vertices: u32,
    /// Index of the cone's first vertex.
    pub cone_first: u32,
    /// Vertices of the cone.
    pub cone_vertices: u32,
}

/// Triangles wound counter-clockwise seen from outside (outward normals), found from a point
/// inside the convex mesh.
fn orient_outward(triangles: &mut [[Vec3; 3]], inside: Vec3) {
    for t in triangles {
        let normal = (t[1] - t[0]).cross(t[2] - t[0]);
        if normal.dot(t[0] - inside) < 0.0 {
            t.swap(1, 2);
        }
    }
}

/// Distance from `point` to the plane of a triangle.
fn plane_distance(t: &[Vec3; 3], point: Vec3) -> f32 {
    let n = (t[1] - t[0]).cross(t[2] - t[0]).normalize();
    (t[0] - point).dot(n).abs()
}

/// A subdivided icosahedron scaled so that the unit sphere lies inside every face.
pub fn sphere_mesh() -> Vec<[Vec3; 3]> {
    let p = (1.0 + 5f32.sqrt()) / 2.0;
    let v = [
        [-1.0, p, 0.0],
        [1.0, p, 0.0],
        [-1.0, -p, 0.0],
        [1.0, -p, 0.0],
        [0.0, -1.0, p],
        [0.0, 1.0, p],
        [0.0, -1.0, -p],
        [0.0, 1.0, -p],
        [p, 0.0, -1.0],
        [p, 0.0, 1.0],
        [-p, 0.0, -1.0],
        [-p, 0.0, 1.0],
    ]
    .map(|c| Vec3::from(c).normalize());
    let faces: [[usize; 3]; 20] = [
        [0, 11, 5],
        [0, 5, 1],
        [0, 1, 7],
        [0, 7, 10],
        [0, 10, 11],
        [1, 5, 9],
        [5, 11, 4],
        [11, 10, 2],
        [10, 7, 6],
        [7, 1, 8],
        [3, 9, 4],
        [3, 4, 2],
        [3, 2, 6],
        [3, 6, 8],
        [3, 8, 9],
        [4, 9, 5],
        [2, 4, 11],
        [6, 2, 10],
        [8, 6, 7],
        [9, 8, 1],
    ];
    let mut tris: Vec<[Vec3; 3]> = faces.iter().map(|f| f.map(|i| v[i])).collect();
    for _ in 0..SPHERE_SUBDIVISIONS {
        tris = tris
            .iter()
            .flat_map(|&[a, b, c]| {
                let (ab, bc, ca) = (
                    (a + b).normalize(),
                    (b + c).normalize(),
                    (c + a).normalize(),
                );
                [[a, ab, ca], [ab, b, bc], [ca, bc, c], [ab, bc, ca]]
            })
            .collect();
    }
    let inradius = tris
        .iter()
        .map(|t| plane_distance(t, Vec3::ZERO))
        .fold(f32::INFINITY, f32::min);
    // A hair more than 1/inradius so that rounding never puts a face inside the sphere.
    let scale = 1.0001 / inradius;
    for t in &mut tris {
        *t = t.map(|p| p * scale);
    }
    orient_outward(&mut tris, Vec3::ZERO);
    tris
}

/// A cone with its apex at the origin, axis +Z, height 1 and a base polygon circumscribing the
/// unit circle at z = 1 (the vertex stage scales it by the spot's range and opening).
pub fn cone_mesh() -> Vec<[Vec3; 3]> {
    let radius = 1.0001 / (std::f32::consts::PI / CONE_SIDES as f32).cos();
    let ring: Vec<Vec3> = (0..CONE_SIDES)
        .map(|i| {
            let a = i as f32 / CONE_SIDES as f32 * std::f32::consts::TAU;
            Vec3::new(radius * a.cos(), radius * a.sin(), 1.0)
        })
        .collect();
    let center = Vec3::Z;
    let mut tris = Vec::new();
    for i in 0..CONE_SIDES as usize {
        let (a, b) = (ring[i], ring[(i + 1) % ring.len()]);
        tris.push([Vec3::ZERO, a, b]);
        tris.push([center, b, a]);
    }
    orient_outward(&mut tris, Vec3::new(0.0, 0.0, 0.6));
    tris
}

/// The unit sphere and cone that bound point and spot lights.
pub fn meshes() -> VolumeMeshes {
    let flat = |tris: Vec<[Vec3; 3]>| -> Vec<[f32; 4]> {
        tris.iter()
            .flat_map(|t| t.map(|p| p.extend(1.0).to_array()))
            .collect()
    };
    let sphere = flat(sphere_mesh());
    let cone = flat(cone_mesh());
    let sphere_vertices = sphere.len() as u32;
    let cone_vertices = cone.len() as u32;
    let mut vertices = sphere;
    vertices.extend(cone);
    VolumeMeshes {
        vertices,
        sphere_vertices,
        cone_first: sphere_vertices,
        cone_vertices,
    }
}

/// The lights one camera sees, by the volume each draws: `indices` holds the sphere lights,
/// then the cones, then the full-screen lights.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct VisibleLights {
    /// Indices of the visible lights: spheres, then cones, then full-screen ones.
    pub indices: Vec<u32>,
    /// Lights drawn as spheres.
    pub spheres: u32,
    /// Lights drawn as cones.
    pub cones: u32,
    /// Lights drawn as full-screen triangles.
    pub full_screen: u32,
    /// Lights whose volume lies wholly outside the view frustum.
    pub culled: u32,
}

/// The six frustum planes of `view_proj` (wgpu clip space, depth 0..1) as (normal, offset) with
/// inside ⇔ n·p + d ≥ 0, normalised: left, right, bottom, top, near, far.
fn frustum_planes(view_proj: Mat4) -> [Vec4; 6] {
    let r = [
        view_proj.row(0),
        view_proj.row(1),
        view_proj.row(2),
        view_proj.row(3),
    ];
    [
        r[3] + r[0],
        r[3] - r[0],
        r[3] + r[1],
        r[3] - r[1],
        r[2],
        r[3] - r[2],
    ]
    .map(|p| p / p.truncate().length().max(1e-30))
}

const KIND_POINT: u32 = 0;
const KIND_SPOT: u32 = 1;

/// Splits `lights` for a camera: directional lights draw full screen; point and spot lights are
/// culled when their range sphere lies outside a frustum plane, drawn full screen when it
/// reaches past the far plane (the volume's far side would be clipped away), else as a sphere or
/// (spots up to [`MAX_CONE_DEG`]) a cone.
pub fn classify(lights: &[GpuLight], camera: &Camera, aspect: f32) -> VisibleLights {
    let planes = frustum_planes(camera.view_projection(aspect));
    let (mut spheres, mut cones, mut full, mut culled) = (vec![], vec![], vec![], 0);
    let max_cone_cos = MAX_CONE_DEG.to_radians().cos();
    for (i, l) in lights.iter().enumerate() {
        let i = i as u32;
        if l.kind != KIND_POINT && l.kind != KIND_SPOT {
            full.push(i);
            continue;
        }
        let center = Vec3::from(l.position).extend(1.0);
        let distances: Vec<f32> = planes.iter().map(|p| p.dot(center)).collect();
        if distances.iter().any(|&d| d < -l.range) {
            culled += 1;
        } else if distances[5] < l.range {
            full.push(i);
        } else if l.kind == KIND_SPOT && l.cos_outer > max_cone_cos {
            cones.push(i);
        } else {
            spheres.push(i);
        }
    }
    let (s, c, f) = (spheres.len() as u32, cones.len() as u32, full.len() as u32);
    let mut indices = spheres;
    indices.extend(cones);
    indices.extend(full);
    VisibleLights {
        indices,
        spheres: s,
        cones: c,
        full_screen: f,
        culled,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn inside_all_faces(tris: &[[Vec3; 3]], p: Vec3) -> bool {
        tris.iter().all(|t| {
            let n = (t[1] - t[0]).cross(t[2] - t[0]);
            n.dot(p - t[0]) <= 0.0
        })
    }

    #[test]
    fn the_sphere_mesh_contains_the_unit_sphere() {
        let tris = sphere_mesh();
        assert_eq!(tris.len(), 80);
        let golden = std::f32::consts::PI * (3.0 - 5f32.sqrt());
        for i in 0..20_000 {
            let z = 1.0 - 2.0 * (i as f32 + 0.5) / 20_000.0;
            let r = (1.0 - z * z).sqrt();
            let a = golden * i as f32;
            let p = Vec3::new(r * a.cos(), r * a.sin(), z);
            assert!(inside_all_faces(&tris, p), "{p} pokes out");
        }
    }

    #[test]
    fn the_cone_mesh_contains_the_spot_region() {
        // The region of a spot with range 1 and half-angle θ, in the mesh's units (xy scaled by
        // 1 / tan θ): every point within distance 1 of the apex and θ of the axis.
        let tris = cone_mesh();
        let theta = 40f32.to_radians();
        for i in 0..2000 {
            let d = (i % 20) as f32 / 19.0;
            let polar = theta * ((i / 20) % 10) as f32 / 9.0;
            let azimuth = (i / 200) as f32 / 10.0 * std::f32::consts::TAU;
            let p = d * Vec3::new(
                polar.sin() * azimuth.cos(),
                polar.sin() * azimuth.sin(),
                polar.cos(),
            );
            let local = Vec3::new(p.x / theta.tan(), p.y / theta.tan(), p.z);
            assert!(
                inside_all_faces(&tris, local * 0.9999 + Vec3::new(0.0, 0.0, 1e-4)),
                "{p}"
            );
        }
    }

    fn point(position: [f32; 3], range: f32) -> GpuLight {
        GpuLight {
            position,
            kind: KIND_POINT,
            direction: [0.0, -1.0, 0.0],
            cos_outer: 0.5,
            radiance: [1.0; 3],
            range,
            cos_inner: 0.6,
            attenuation: [1.0, 0.0, 0.0],
        }
    }

    #[test]
    fn lights_outside_the_frustum_are_culled_and_those_past_the_far_plane_draw_full_screen() {
        let camera = Camera::toward_origin(Vec3::new(0.0, 0.0, 5.0), 20.0);
        let lights = [
            point([0.0, 0.0, 0.0], 1.0),   // in view
            point([50.0, 0.0, 0.0], 1.0),  // far to the side
            point([0.0, 0.0, 10.0], 1.0),  // behind the camera
            point([0.0, 0.0, -14.5], 1.0), // straddles the far plane
            point([0.0, 0.0, 5.0], 0.5),   // the camera is inside it
            GpuLight {
                kind: 2,
                ..point([0.0; 3], 1.0)
            },
        ];
        let v = classify(&lights, &camera, 1.0);
        assert_eq!(v.culled, 2);
        assert_eq!(v.indices, [0, 4, 3, 5]);
        assert_eq!((v.spheres, v.cones, v.full_screen), (2, 0, 2));
    }
}
