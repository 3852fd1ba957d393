//! Time in a scene: objects that move along circular orbits, and camera paths (an orbit about
//! the target, or keyframes from a scene file's `[[camera_key]]` list). Time is counted in
//! frames, the unit of `--frame T` and `--frames A..B`.
//!
//! The CPU moves a scene with [`Scene::set_time`] (the reference renders what it gives); the
//! GPU moves the same objects without rebuilding any mesh ([`crate::animation`]): each moving
//! object keeps its mesh in object space and a transform evaluated per frame by the same
//! formula, so both sides place every vertex at the same point.

use std::sync::Arc;

use glam::{Mat4, Quat, Vec3};

use super::{Camera, Mesh, Scene};
use crate::error::{Error, Result};

/// A circular path: `centre + radius·(cos a·u + sin a·v)` with `a = angular_speed·t + phase`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Orbit {
    /// The orbit's centre, world space.
    pub centre: Vec3,
    /// The orbit's radius.
    pub radius: f32,
    /// Orthonormal vectors spanning the orbit's plane.
    pub u: Vec3,
    /// The second vector of the plane, orthogonal to `u`.
    pub v: Vec3,
    /// Radians per frame.
    pub angular_speed: f32,
    /// Angle at time 0, in radians.
    pub phase: f32,
}

impl Orbit {
    /// The point on the orbit at time `t` (frames).
    pub fn position(&self, t: f32) -> Vec3 {
        let a = reduced_angle(self.angular_speed * t + self.phase);
        self.centre + self.radius * (a.cos() * self.u + a.sin() * self.v)
    }
}

/// 2π in two parts: `TAU_HI` has 8 significant bits, so `n·TAU_HI` is exact for |n| < 2^16.
const TAU_HI: f32 = 6.28125;
const TAU_LO: f32 = (std::f64::consts::TAU - 6.28125) as f32;
const INV_TAU: f32 = (1.0 / std::f64::consts::TAU) as f32;

/// `a` less the nearest multiple of 2π, in [−π, π] (Cody–Waite). A GPU's sin and cos lose
/// accuracy as their argument grows (an H100 placed balls 2.7e-6 from the CPU at frame 900,
/// angles near 66 rad), so both sides reduce the angle first, by these same f32 operations
/// (animate_objects.wgsl): the first subtraction is exact, and the second is small.
pub fn reduced_angle(a: f32) -> f32 {
    let n = (a * INV_TAU).round_ties_even();
    (a - n * TAU_HI) - n * TAU_LO
}

/// How one object moves: its mesh in object space, scaled uniformly and carried along an orbit.
#[derive(Clone, Debug, PartialEq)]
pub struct ObjectMotion {
    /// The object-space mesh (shared between objects that look alike).
    pub local: Arc<Mesh>,
    /// Uniform scale of the object-space mesh.
    pub scale: f32,
    /// The path the object's origin follows.
    pub orbit: Orbit,
}

impl ObjectMotion {
    /// Object space to world space at time `t`.
    pub fn transform(&self, t: f32) -> Mat4 {
        Mat4::from_scale_rotation_translation(
            Vec3::splat(self.scale),
            Quat::IDENTITY,
            self.orbit.position(t),
        )
    }

    /// The world-space mesh at time `t`.
    pub fn mesh_at(&self, t: f32) -> Mesh {
        self.local.transformed(self.transform(t))
    }
}

/// One keyframe of a camera path.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CameraKey {
    /// Frames.
    pub time: f32,
    /// Where the camera is at `time`.
    pub eye: Vec3,
    /// What it looks at then.
    pub target: Vec3,
}

/// A camera that moves with time; projection, up and planes stay those of `base`.
#[derive(Clone, Debug, PartialEq)]
pub enum CameraPath {
    /// The base camera turned about its up axis through its target, at `degrees_per_frame`.
    Orbit {
        /// The camera at time 0.
        base: Camera,
        /// Degrees the camera turns per frame.
        degrees_per_frame: f32,
    },
    /// Eye and target interpolated linearly between keys (sorted by time), held before the
    /// first and after the last.
    Keys {
        /// The camera whose projection, up and planes the path keeps.
        base: Camera,
        /// The keyframes, by increasing time.
        keys: Vec<CameraKey>,
    },
}

impl CameraPath {
    /// A checked keyframe path: at least one key, finite values, strictly increasing times,
    /// eye and target apart at every key.
    pub fn keys(base: Camera, keys: Vec<CameraKey>) -> Result<CameraPath> {
        if keys.is_empty() {
            return Err(Error::input("a camera path needs at least one key"));
        }
        for i in 0..keys.len() {
            check_key(&base, &keys, i)
                .map_err(|why| Error::input(format!("camera key {}: {why}", i + 1)))?;
        }
        Ok(CameraPath::Keys { base, keys })
    }

    /// An orbit of `degrees_per_frame` (finite) about the base camera's target.
    pub fn orbit(base: Camera, degrees_per_frame: f32) -> Result<CameraPath> {
        if !degrees_per_frame.is_finite() {
            return Err(Error::input(format!(
                "--orbit {degrees_per_frame} must be a finite number of degrees per frame"
            )));
        }
        Ok(CameraPath::Orbit {
            base,
            degrees_per_frame,
        })
    }

    /// The camera the path moves.
    pub fn base(&self) -> &Camera {
        match self {
            CameraPath::Orbit { base, .. } | CameraPath::Keys { base, .. } => base,
        }
    }

    /// The camera the path moves, to change its projection or planes.
    pub fn base_mut(&mut self) -> &mut Camera {
        match self {
            CameraPath::Orbit { base, .. } | CameraPath::Keys { base, .. } => base,
        }
    }

    /// The camera at time `t`.
    pub fn camera_at(&self, t: f32) -> Camera {
        match self {
            CameraPath::Orbit {
                base,
                degrees_per_frame,
            } => {
                // In f64 and reduced to one turn: a large rate times a late frame stays finite.
                let degrees = (f64::from(*degrees_per_frame) * f64::from(t)).rem_euclid(360.0);
                let turn =
                    Quat::from_axis_angle(base.up.normalize(), (degrees as f32).to_radians());
                Camera {
                    eye: base.target + turn * (base.eye - base.target),
                    ..*base
                }
            }
            CameraPath::Keys { base, keys } => {
                let after = keys.partition_point(|k| k.time <= t);
                let (eye, target) = if after == 0 {
                    (keys[0].eye, keys[0].target)
                } else if after == keys.len() {
                    (keys[after - 1].eye, keys[after - 1].target)
                } else {
                    let (a, b) = (keys[after - 1], keys[after]);
                    let s = (t - a.time) / (b.time - a.time);
                    (a.eye.lerp(b.eye, s), a.target.lerp(b.target, s))
                };
                Camera {
                    eye,
                    target,
                    ..*base
                }
            }
        }
    }
}

/// What is wrong with key `i` of `keys` for a path over `base`, if anything.
pub(crate) fn check_key(
    base: &Camera,
    keys: &[CameraKey],
    i: usize,
) -> std::result::Result<(), String> {
    let k = keys[i];
    if !(k.time.is_finite() && k.eye.is_finite() && k.target.is_finite()) {
        return Err("time, eye and target must be finite".into());
    }
    let forward = k.target - k.eye;
    if forward.length() < 1e-6 || forward.normalize().cross(base.up).length() < 1e-6 {
        return Err("eye and target coincide, or the view runs along up".into());
    }
    if i > 0 && k.time <= keys[i - 1].time {
        return Err(format!(
            "time {} does not come after the previous key's {}",
            k.time,
            keys[i - 1].time
        ));
    }
    Ok(())
}

impl Scene {
    /// Whether time moves any object.
    pub fn animated(&self) -> bool {
        self.motions.iter().any(Option::is_some)
    }

    /// Moves the scene to time `t` (frames): every moving object's mesh, and the camera along
    /// its path.
    pub fn set_time(&mut self, t: f32) {
        for (object, motion) in self.objects.iter_mut().zip(&self.motions) {
            if let Some(m) = motion {
                object.mesh = m.mesh_at(t);
            }
        }
        if let Some(path) = &self.camera_path {
            self.camera = Some(path.camera_at(t));
        }
        self.time = t;
    }

    /// The scene moved to time `t`.
    pub fn at_time(&self, t: f32) -> Scene {
        let mut s = self.clone();
        s.set_time(t);
        s
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_fast_orbit_late_in_time_stays_on_its_circle() {
        let path = CameraPath::orbit(base(), 1e30).unwrap();
        let eye = path.camera_at(1e30).eye;
        assert!(eye.is_finite(), "{eye}");
        assert!((eye.length() - 5.0).abs() < 1e-4, "{eye}");
        // A whole number of turns is the start.
        let turned = CameraPath::orbit(base(), 360.0).unwrap().camera_at(7.0).eye;
        assert!(turned.abs_diff_eq(base().eye, 1e-4), "{turned}");
    }

    fn base() -> Camera {
        Camera::toward_origin(Vec3::new(0.0, 0.0, 5.0), 20.0)
    }

    #[test]
    fn an_orbit_turns_the_eye_about_up_through_the_target() {
        let path = CameraPath::orbit(base(), 3.0).unwrap();
        assert_eq!(path.camera_at(0.0), base());
        let quarter = path.camera_at(30.0);
        assert!(
            (quarter.eye - Vec3::new(5.0, 0.0, 0.0)).length() < 1e-5,
            "{quarter:?}"
        );
        assert_eq!(quarter.target, Vec3::ZERO);
        assert_eq!(quarter.projection, base().projection);
        assert!(CameraPath::orbit(base(), f32::NAN).is_err());
    }

    #[test]
    fn keys_interpolate_and_hold_at_the_ends() {
        let key = |time: f32, x: f32| CameraKey {
            time,
            eye: Vec3::new(x, 0.0, 5.0),
            target: Vec3::new(x, 0.0, 0.0),
        };
        let path = CameraPath::keys(base(), vec![key(10.0, 0.0), key(20.0, 2.0)]).unwrap();
        assert_eq!(path.camera_at(0.0).eye.x, 0.0);
        assert!((path.camera_at(15.0).eye.x - 1.0).abs() < 1e-6);
        assert!((path.camera_at(15.0).target.x - 1.0).abs() < 1e-6);
        assert_eq!(path.camera_at(99.0).eye.x, 2.0);
        let e = CameraPath::keys(base(), vec![key(10.0, 0.0), key(10.0, 1.0)]).unwrap_err();
        assert!(e.to_string().contains("camera key 2"), "{e}");
        assert!(CameraPath::keys(base(), vec![]).is_err());
        let same = CameraKey {
            time: 0.0,
            eye: Vec3::ONE,
            target: Vec3::ONE,
        };
        assert!(CameraPath::keys(base(), vec![same]).is_err());
    }

    #[test]
    fn set_time_moves_objects_and_camera_and_is_repeatable() {
        let mut scene =
            crate::scene::loaders::load_scene("builtin:balls?count=12&frame=0").unwrap();
        assert!(scene.animated());
        scene.camera_path = Some(CameraPath::orbit(scene.camera.unwrap(), 1.0).unwrap());
        let start = scene.clone();
        scene.set_time(40.0);
        assert_ne!(scene.objects[0].mesh, start.objects[0].mesh);
        assert_ne!(scene.camera, start.camera);
        scene.set_time(0.0);
        assert_eq!(scene.objects[0].mesh, start.objects[0].mesh);
        assert_eq!(scene.camera, start.camera);
        let built = crate::scene::loaders::load_scene("builtin:balls?count=12&frame=40").unwrap();
        assert_eq!(start.at_time(40.0).objects[7].mesh, built.objects[7].mesh);
    }
}
