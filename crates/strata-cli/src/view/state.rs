//! What the viewer shows, apart from any window: the command-line options it edits, the orbit
//! camera, which options the current method reads, what a change costs (new options, new
//! geometry or a new recorder) and the `strata render` line that reproduces the view.

use glam::Vec3;
use strata::frame::Raster;
use strata::methods::MethodId;
use strata::scene::{Camera, CameraPath, Projection};

use crate::{MethodArgs, PictureArgs, PipelineArg, Toggle};

pub use crate::method_options::{applies, Opt};

/// The family a method is listed under, and its methods in catalogue order (the reference
/// excluded: it renders on the CPU, through "Compare with reference").
pub fn families() -> Vec<(&'static str, Vec<MethodId>)> {
    let mut out: Vec<(&'static str, Vec<MethodId>)> = Vec::new();
    for id in MethodId::gpu_methods() {
        let family = id.descriptor().family.name();
        match out.iter_mut().find(|(f, _)| *f == family) {
            Some((_, list)) => list.push(id),
            None => out.push((family, vec![id])),
        }
    }
    out
}

/// An orbit around a target: drag to turn, pan the target, wheel to move closer.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Orbit {
    pub target: Vec3,
    pub up: Vec3,
    pub distance: f32,
    /// Radians around `up`, from where the camera started.
    pub yaw: f32,
    /// Radians above the plane normal to `up`.
    pub pitch: f32,
    back0: Vec3,
    right0: Vec3,
}

/// Pitch stays this far from the poles, so `up` never lines up with the view.
const MAX_PITCH: f32 = 1.55;

impl Orbit {
    pub fn from_camera(camera: &Camera) -> Orbit {
        let up = camera.up.normalize_or(Vec3::Y);
        let offset = camera.eye - camera.target;
        let distance = offset.length().max(1e-4);
        let dir = offset / distance;
        let flat = dir - up * dir.dot(up);
        let back0 = if flat.length_squared() > 1e-8 {
            flat.normalize()
        } else {
            up.any_orthonormal_vector()
        };
        Orbit {
            target: camera.target,
            up,
            distance,
            yaw: 0.0,
            pitch: dir.dot(up).clamp(-1.0, 1.0).asin(),
            back0,
            right0: up.cross(back0),
        }
    }

    pub fn eye(&self) -> Vec3 {
        let (sy, cy) = self.yaw.sin_cos();
        let (sp, cp) = self.pitch.sin_cos();
        self.target + self.distance * (cp * (cy * self.back0 + sy * self.right0) + sp * self.up)
    }

    /// Turns by a drag of (dx, dy) pixels.
    pub fn rotate(&mut self, dx: f32, dy: f32) {
        self.yaw -= dx * 0.01;
        self.pitch = (self.pitch + dy * 0.01).clamp(-MAX_PITCH, MAX_PITCH);
    }

    /// Moves the target by a drag of (dx, dy) pixels in a view `height` pixels tall.
    pub fn pan(&mut self, dx: f32, dy: f32, height: f32) {
        let forward = (self.target - self.eye()).normalize();
        let right = forward.cross(self.up).normalize();
        let up = right.cross(forward);
        let scale = self.distance / height.max(1.0);
        self.target += (-dx * right + dy * up) * scale;
    }

    /// Moves closer (steps > 0) or farther, 10% a step.
    pub fn zoom(&mut self, steps: f32) {
        self.distance = (self.distance * 0.9f32.powf(steps)).clamp(1e-3, 1e6);
    }
}

/// The viewer's editable state: the same options `strata render` takes, and the animation.
#[derive(Clone, Debug)]
pub struct ViewState {
    pub picture: PictureArgs,
    pub method: MethodArgs,
    pub orbit: Orbit,
    /// The camera of the scene with the command line's camera options, for "reset view".
    pub home: Camera,
    /// The scene's camera path (`[[camera_key]]` or `--orbit`), which playing follows.
    pub camera_path: Option<CameraPath>,
    pub playing: bool,
    /// Turn the GPU depth-complexity histogram on (one more count pass per frame).
    pub histogram: bool,
}

/// What a change of state asks of the frame.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Change {
    None,
    /// The camera moved.
    Camera,
    /// The method (and maybe the camera).
    Method,
    /// Options the recorder takes as they are (k, tail, size, effect, background, ...), and
    /// maybe the method and camera.
    Options,
    /// Another time step of the same scene (the GPU moves it), and maybe the camera or method.
    Time,
    /// Another time step of the same scene, and maybe any of the above.
    Geometry,
    /// Everything else: the scene is loaded again and a new recorder made.
    Rebuild,
}

impl ViewState {
    pub fn new(picture: PictureArgs, method: MethodArgs, home: Camera) -> ViewState {
        ViewState {
            orbit: Orbit::from_camera(&home),
            picture,
            method,
            home,
            camera_path: None,
            playing: false,
            histogram: true,
        }
    }

    /// The camera the frame uses: the orbit's, with the scene's projection and planes.
    pub fn camera(&self) -> Camera {
        let mut camera = self.home;
        camera.eye = self.orbit.eye();
        camera.target = self.orbit.target;
        camera.up = self.orbit.up;
        if let (Some(f), Projection::Perspective { fov_y_deg }) =
            (self.picture.camera.fov, &mut camera.projection)
        {
            *fov_y_deg = f;
        }
        camera
    }

    /// Writes the orbit into the picture's camera options, so the command line carries it.
    pub fn commit_camera(&mut self) {
        let c = self.camera();
        let picture = &mut self.picture.camera;
        picture.eye = Some(c.eye.into());
        picture.target = Some(c.target.into());
        picture.up = Some(c.up.into());
    }

    pub fn reset_view(&mut self) {
        self.orbit = Orbit::from_camera(&self.home);
        self.commit_camera();
    }

    /// Whether the scene animates (its time steps move geometry or the camera).
    pub fn animated(&self) -> bool {
        self.picture.scene.starts_with("builtin:balls") || self.camera_path.is_some()
    }

    /// The animation time, frames of the scene.
    pub fn time(&self) -> f32 {
        self.picture.frame.unwrap_or(0.0)
    }

    /// Moves to time `t`; a camera path moves the view with it.
    pub fn set_time(&mut self, t: f32) {
        let t = t.max(0.0);
        self.picture.frame = Some(t);
        if let Some(path) = &self.camera_path {
            self.orbit = Orbit::from_camera(&path.camera_at(t));
        }
    }

    /// What it takes to go from `old` to this state.
    pub fn change_from(&self, old: &ViewState) -> Change {
        if rebuild_key(self) != rebuild_key(old) {
            Change::Rebuild
        } else if self.picture.frame != old.picture.frame && options_key(self) == options_key(old) {
            Change::Time
        } else if self.picture.frame != old.picture.frame {
            Change::Geometry
        } else if options_key(self) != options_key(old) {
            Change::Options
        } else if self.method.id() != old.method.id() {
            Change::Method
        } else if self.orbit != old.orbit || self.picture.camera.fov != old.picture.camera.fov {
            Change::Camera
        } else {
            Change::None
        }
    }

    /// The `strata render` line that renders this view to a PNG.
    pub fn command_line(&self) -> String {
        let p = &self.picture;
        let m = &self.method;
        let mut args: Vec<String> = vec!["strata".into(), "render".into(), shell_quote(&p.scene)];
        let mut push = |name: &str, value: String| {
            args.push(format!("--{name}"));
            args.push(shell_quote(&value));
        };
        push("method", m.id().as_str().into());
        if let Some(s) = p.size {
            push("size", s.to_string());
        }
        push("effect", value_name(&p.effect));
        if let Some(s) = p.shading {
            push("shading", value_name(&s));
        }
        if let Some(b) = p.background {
            push("background", b.to_string());
        }
        if let Some(k) = p.k {
            push("k", k.to_string());
        }
        if let Some(a) = p.alpha {
            push("alpha", a.to_string());
        }
        if let Some(d) = p.orbit {
            push("orbit", d.to_string());
        }
        if let Some(f) = p.frame {
            push("frame", f.to_string());
        }
        if let Some(pl) = p.pipeline {
            push("pipeline", value_name(&pl));
        }
        if let Some(n) = p.lights {
            push("lights", n.to_string());
        }
        if p.pipeline.is_some_and(|pl| pl != PipelineArg::None) {
            push("tonemap", value_name(&p.tonemap));
        }
        let camera = &p.camera;
        for (name, v) in [
            ("eye", camera.eye),
            ("target", camera.target),
            ("up", camera.up),
        ] {
            if let Some([x, y, z]) = v {
                push(name, format!("{x},{y},{z}"));
            }
        }
        if let Some(f) = camera.fov {
            push("fov", f.to_string());
        }
        let id = m.id();
        if p.msaa != 1 {
            push("msaa", p.msaa.to_string());
        }
        if m.raster != Raster::Hw {
            push("raster", value_name(&m.raster));
        }
        if applies(Opt::LAYERS_PER_PASS, id, p.pipeline) {
            if let Some(n) = m.layers_per_pass {
                push("layers-per-pass", n.to_string());
            }
        }
        if let Some(b) = m.budget_mb.filter(|_| applies(Opt::Budget, id, p.pipeline)) {
            push("budget-mb", b.to_string());
        }
        if let Some(r) = m.robustness {
            push("robustness", r.to_string());
        }
        // The method's options, each written as its spec says where the method reads it with
        // these options (`Descriptor::reads_with`).
        let family = &m.family.frame;
        for spec in strata::methods::option_specs() {
            if id.descriptor().reads_with(spec.option, family) {
                for (name, value) in spec.written(family) {
                    push(name, value);
                }
            }
        }
        if applies(Opt::Temporal, id, p.pipeline) && m.temporal == Toggle::On {
            push("temporal", "on".into());
            push("temporal-refresh", m.temporal_refresh.to_string());
            push("temporal-epsilon", m.temporal_epsilon.to_string());
        }
        if let Some(o) = m.order {
            push("order", value_name(&o));
            if o == strata::order::Order::Random {
                push("seed", m.seed.to_string());
            }
        }
        if m.ssao {
            args.push("--ssao".into());
        }
        if p.pipeline == Some(PipelineArg::Deferred) {
            let mut push = |name: &str, value: String| {
                args.push(format!("--{name}"));
                args.push(value);
            };
            push("normal-encoding", value_name(&m.normal_encoding));
            if let Some(v) = m.gbuffer_debug {
                push("gbuffer-debug", value_name(&v));
            }
        }
        args.push("-o".into());
        args.push("view.png".into());
        args.join(" ")
    }
}

/// A clap value's command-line name.
pub fn value_name(v: &impl clap::ValueEnum) -> String {
    v.to_possible_value()
        .map(|p| p.get_name().to_string())
        .unwrap_or_default()
}

fn shell_quote(s: &str) -> String {
    let plain = |c: char| c.is_ascii_alphanumeric() || "-_./:,=+#".contains(c);
    if !s.is_empty() && s.chars().all(plain) {
        s.to_string()
    } else {
        format!("'{}'", s.replace('\'', r"'\''"))
    }
}

/// The options that need the scene loaded again and a new recorder: the scene's, and what a
/// recorder is built with (`strata::frame::BuildOptions`).
fn rebuild_key(s: &ViewState) -> impl PartialEq {
    let (p, m) = (&s.picture, &s.method);
    (
        (p.scene.clone(), p.shading, p.alpha, p.lights),
        (p.pipeline, p.tonemap, p.msaa, m.raster),
        (
            m.ssao,
            m.normal_encoding,
            m.gbuffer_debug,
            m.cache_dir.clone(),
        ),
    )
}

/// The options a recorder takes between frames (`strata::frame::FrameOptions`).
fn options_key(s: &ViewState) -> impl PartialEq {
    let (p, m) = (&s.picture, &s.method);
    (
        (p.size, p.effect, p.background, p.k),
        (m.family.clone(), m.layers_per_pass),
        (m.budget_mb, m.robustness, m.order, m.seed),
        (m.temporal, m.temporal_refresh, m.temporal_epsilon),
    )
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use clap::Parser;

    /// The view state of `strata view` with `args`.
    pub(crate) fn state(args: &[&str]) -> ViewState {
        let cli = crate::Cli::try_parse_from(["strata", "view"].iter().chain(args).copied())
            .expect("valid command line");
        let crate::Command::View(v) = cli.command else {
            panic!("not a view command")
        };
        let (scene, _) = crate::prepare_render(&v.method, &v.picture).expect("prepares");
        ViewState::new(v.picture, v.method, scene.camera_or_framing())
    }

    #[test]
    fn greying_follows_the_method_and_pipeline() {
        use MethodId::*;
        assert!(applies(Opt::K, KplusHeap, None));
        assert!(applies(Opt::K, Kpeel, None));
        assert!(!applies(Opt::K, AbufferLl, None));
        assert!(
            applies(Opt::K, Bucket, None)
                && applies(
                    Opt::Method(strata::methods::peeling::options::BUCKETS),
                    Bucket,
                    None
                )
        );
        assert!(!applies(Opt::TAIL, Wboit, None));
        assert!(applies(
            Opt::Method(strata::methods::kbuffer::options::MAX_TRIES),
            KplusArray,
            None
        ));
        assert!(
            !applies(
                Opt::Method(strata::methods::kbuffer::options::MAX_TRIES),
                KbMdt32,
                None
            ),
            "MDT takes no lock"
        );
        assert!(applies(
            Opt::Method(strata::methods::peeling::options::LAYERS),
            Dual,
            None
        ));
        assert!(
            applies(
                Opt::Method(strata::methods::peeling::options::LAYERS),
                Kpeel,
                None
            ),
            "kpeel's passes: ⌈layers / k⌉"
        );
        assert!(
            applies(Opt::TAIL, AbufferFixed, None)
                && !applies(
                    Opt::Method(strata::methods::kbuffer::options::CULLING),
                    AbufferFixed,
                    None
                )
        );
        assert!(applies(Opt::WEIGHT, Wboit, None));
        assert!(!applies(Opt::WEIGHT, Mboit, None));
        assert!(applies(Opt::Msaa, Sbuffer, None));
        assert!(applies(Opt::Msaa, KplusHeap, None));
        assert!(!applies(Opt::Msaa, KbMdt64, None));
        assert!(applies(Opt::Msaa, Wboit, Some(PipelineArg::Deferred)));
        assert!(applies(Opt::RasterCompute, KbMdt64, None));
        assert!(applies(Opt::RasterCompute, KplusHeap, None));
        assert!(!applies(Opt::RasterCompute, Wboit, None));
        assert!(!applies(Opt::Tonemap, Unsorted, None));
        assert!(applies(Opt::Tonemap, Unsorted, Some(PipelineArg::Forward)));
        assert!(!applies(
            Opt::Deferred,
            Unsorted,
            Some(PipelineArg::Forward)
        ));
        assert!(applies(
            Opt::Deferred,
            Unsorted,
            Some(PipelineArg::Deferred)
        ));
    }

    #[test]
    fn every_gpu_method_is_listed_once_under_its_family() {
        let listed: Vec<MethodId> = families().into_iter().flat_map(|(_, m)| m).collect();
        let gpu = strata::methods::catalogue().count() - 1;
        assert_eq!(listed.len(), gpu);
        assert!(!listed.contains(&MethodId::Reference));
        let mut unique = listed.clone();
        unique.sort();
        unique.dedup();
        assert_eq!(unique.len(), listed.len());
    }

    #[test]
    fn switching_method_keeps_the_camera_and_asks_for_no_rebuild() {
        let mut s = state(&["builtin:spheres"]);
        s.orbit.rotate(40.0, -25.0);
        s.orbit.zoom(2.0);
        s.commit_camera();
        let before = s.clone();
        s.method.method = crate::args::MethodArg::Id(MethodId::KplusHeap);
        assert_eq!(s.change_from(&before), Change::Method);
        assert_eq!(s.camera().eye, before.camera().eye);
        s.picture.k = Some(crate::args::KArg::Count(8));
        assert_eq!(s.change_from(&before), Change::Options);
        let moved = s.clone();
        s.method.raster = Raster::Compute;
        assert_eq!(s.change_from(&moved), Change::Rebuild);
        assert_eq!(s.camera().eye, before.camera().eye);
    }

    #[test]
    fn orbit_starts_at_the_scene_camera_and_resets_there() {
        let mut s = state(&["builtin:spheres", "--eye", "1,2,6", "--target", "0,0.5,0"]);
        let home = s.camera();
        assert!((home.eye - Vec3::new(1.0, 2.0, 6.0)).length() < 1e-5);
        s.orbit.rotate(100.0, 30.0);
        s.orbit.pan(10.0, 5.0, 512.0);
        s.commit_camera();
        assert!((s.camera().eye - home.eye).length() > 0.1);
        s.reset_view();
        assert!((s.camera().eye - home.eye).length() < 1e-5);
        for _ in 0..1000 {
            s.orbit.rotate(0.0, 50.0);
        }
        let c = s.camera();
        assert!((c.target - c.eye).normalize().cross(c.up).length() > 0.01);
    }

    #[test]
    fn command_line_parses_back_to_the_same_picture() {
        let mut s = state(&[
            "builtin:balls?count=50",
            "--method",
            "kplus-heap",
            "--k",
            "4",
            "--size",
            "96x64",
            "--background",
            "#102030",
        ]);
        s.orbit.rotate(33.0, 12.0);
        s.orbit.zoom(1.5);
        s.picture.camera.fov = Some(37.5);
        s.set_time(12.5);
        s.commit_camera();
        let line = s.command_line();
        assert!(line.contains("'builtin:balls?count=50'"), "{line}");
        let words = shell_words(&line);
        let cli = crate::Cli::try_parse_from(&words).expect("the line parses");
        let crate::Command::Render(r) = cli.command else {
            panic!("not a render command: {line}")
        };
        assert_eq!(r.method.id(), MethodId::KplusHeap);
        let (scene, options) = crate::prepare_render(&r.method, &r.picture).unwrap();
        let (_, view_options) = crate::prepare_render(&s.method, &s.picture).unwrap();
        assert_eq!(scene.camera_or_framing(), s.camera());
        assert_eq!(options, view_options);
        assert_eq!(scene.time, 12.5);
    }

    /// Arguments that set every family option away from its default.
    pub(crate) const FAMILY_OPTIONS: [&[&str]; 11] = [
        &["--method", "wavg", "--opacity", "product"],
        &[
            "--method",
            "kplus-semiheap",
            "--heap-size",
            "3",
            "--max-tries",
            "100",
        ],
        &[
            "--method",
            "kplus-array",
            "--tail",
            "weighted",
            "--weight",
            "eq9",
        ],
        &[
            "--method",
            "kb-ps",
            "--culling",
            "off",
            "--storage-layout",
            "slot",
        ],
        &[
            "--method",
            "wboit",
            "--weight",
            "eq8",
            "--depth-scale",
            "2.5",
        ],
        &["--method", "mboit", "--moments", "trig3"],
        &["--method", "wavelet", "--coefficients", "4"],
        &["--method", "stochastic", "--passes", "2"],
        &["--method", "bucket", "--buckets", "adaptive"],
        &["--method", "f2b", "--layers", "5"],
        &["--method", "abuffer-ll"],
    ];

    /// Each family's options come back from the command line as they were set (their specs
    /// write them: `strata::methods::options`).
    #[test]
    fn command_line_keeps_every_family_option() {
        for args in FAMILY_OPTIONS {
            let mut words = vec!["builtin:spheres"];
            words.extend_from_slice(args);
            let s = state(&words);
            let line = s.command_line();
            let cli = crate::Cli::try_parse_from(shell_words(&line)).expect("the line parses");
            let crate::Command::Render(r) = cli.command else {
                panic!("not a render command: {line}")
            };
            let (_, options) = crate::prepare_render(&r.method, &r.picture).unwrap();
            let (_, view_options) = crate::prepare_render(&s.method, &s.picture).unwrap();
            assert_eq!(options, view_options, "{args:?}: {line}");
        }
    }

    #[test]
    fn command_line_keeps_msaa() {
        let s = state(&["builtin:spheres", "--method", "sbuffer", "--msaa", "4"]);
        let line = s.command_line();
        assert!(line.contains("--msaa 4"), "{line}");
        let one = state(&["builtin:spheres", "--method", "sbuffer"]);
        assert!(!one.command_line().contains("--msaa"));
    }

    /// Splits a line of plain words and single-quoted ones.
    fn shell_words(line: &str) -> Vec<String> {
        let mut words = Vec::new();
        let mut word = String::new();
        let mut quoted = false;
        for c in line.chars() {
            match c {
                '\'' => quoted = !quoted,
                ' ' if !quoted => words.push(std::mem::take(&mut word)),
                c => word.push(c),
            }
        }
        words.push(word);
        words
    }
}
