//! Renders a glTF scene written by `strata export` with Bevy's order-independent transparency,
//! headless, and writes the last frame as a PNG and the timings as JSON.
//!
//! Used by `strata bench peers`, like `peers/pygfx_oit.py`; runnable by hand:
//!
//!     peers/bevy-oit/target/release/bevy-oit scene.glb --size 256x256 --background '#333333' \
//!         --frames 10 --warmup 2 --layers 8 -o picture.png --json timings.json
//!
//! The file is read here with the `gltf` crate, not with Bevy's glTF loader: triangle positions
//! and indices, node transforms, each material's linear base colour and alpha mode and the first
//! camera node (its aspect ratio from `--size`). Every material is a `StandardMaterial`, unlit,
//! double-sided, with the file's linear base colour and opacity: BLEND materials are
//! `AlphaMode::Blend`, which Bevy draws through its OIT when the camera has
//! `OrderIndependentTransparencySettings`; every other material is `AlphaMode::Opaque`.
//! The camera draws into an Rgba8UnormSrgb image of the output's size, without MSAA (Bevy's OIT
//! rejects it), HDR, tonemapping or deband dithering, cleared to `--background`.
//!
//! Timing: the app is driven one `App::update` at a time (no pipelined rendering: this build
//! leaves out Bevy's `multi_threaded` feature), so one update runs the main world, extracts,
//! prepares, encodes and submits one frame. Wall ms per frame is the time from the start of that
//! update to the end of `Device::poll(Wait)` after it, i.e. until the GPU has finished the frame.
//! GPU ms per frame is the sum of the per-pass GPU times (`render/<pass>/elapsed_gpu`) that
//! Bevy's `RenderDiagnosticsPlugin` measures with timestamp queries; null when the adapter has
//! none. Before the warm-up frames, untimed frames run until Bevy's pipeline cache has settled
//! (`prime_frames` in the JSON): Bevy specialises and compiles pipelines over the first few frames
//! after the scene is spawned, which would otherwise land in the timed frames. The picture is read back once, after the timed frames, with Bevy's `Screenshot`.
//!
//! Errors are one line on stderr starting `error: ` and exit status 2.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::time::Instant;

use bevy::app::PluginsState;
use bevy::asset::RenderAssetUsages;
use bevy::camera::{ClearColorConfig, RenderTarget, ScalingMode};
use bevy::core_pipeline::oit::OrderIndependentTransparencySettings;
use bevy::core_pipeline::tonemapping::{DebandDither, Tonemapping};
use bevy::diagnostic::DiagnosticsStore;
use bevy::log::{Level, LogPlugin};
use bevy::mesh::Indices;
use bevy::prelude::*;
use bevy::render::diagnostic::RenderDiagnosticsPlugin;
use bevy::render::render_resource::PipelineCache;
use bevy::render::render_resource::{
    Extent3d, PollType, PrimitiveTopology, TextureDimension, TextureFormat, TextureUsages,
};
use bevy::render::renderer::{RenderAdapterInfo, RenderDevice};
use bevy::render::view::screenshot::{Screenshot, ScreenshotCaptured};
use bevy::render::view::Msaa;
use bevy::render::{RenderApp, RenderPlugin};
use bevy::window::ExitCondition;

const USAGE: &str = "usage: bevy-oit SCENE.glb [--size WxH] [--background '#rrggbb'] [--frames N] \
[--warmup N] [--layers K] [--fragments-per-pixel F] -o PICTURE.png [--json TIMINGS.json]";

/// Frames between a frame's submission and its GPU times reaching `DiagnosticsStore`: the
/// timestamps are mapped while the frame is waited on, handed over by the next frame's render
/// and copied into the store by the `PreUpdate` of the frame after that.
const DIAGNOSTICS_LAG: usize = 2;

/// Prints `error: message` and exits with status 2.
fn fail(message: impl std::fmt::Display) -> ! {
    eprintln!("error: {message}");
    std::process::exit(2);
}

struct Args {
    scene: PathBuf,
    width: u32,
    height: u32,
    background: [u8; 3],
    frames: usize,
    warmup: usize,
    layers: u32,
    fragments_per_pixel: f32,
    output: PathBuf,
    json: Option<PathBuf>,
}

fn parse_size(text: &str) -> (u32, u32) {
    let parsed = text
        .to_ascii_lowercase()
        .split_once('x')
        .and_then(|(w, h)| Some((w.trim().parse::<i64>().ok()?, h.trim().parse::<i64>().ok()?)));
    match parsed {
        None => fail(format!("--size '{text}' is not WxH")),
        Some((w, h)) if w <= 0 || h <= 0 => fail(format!("--size '{text}' must be positive")),
        Some((w, h)) if w > 16384 || h > 16384 => fail(format!("--size '{text}' is too large")),
        Some((w, h)) => (w as u32, h as u32),
    }
}

fn parse_color(text: &str) -> [u8; 3] {
    let hex = text.strip_prefix('#').unwrap_or(text);
    if hex.len() != 6 || !hex.chars().all(|c| c.is_ascii_hexdigit()) {
        fail(format!("--background '{text}' is not #rrggbb"));
    }
    let byte = |i: usize| u8::from_str_radix(&hex[i..i + 2], 16).unwrap();
    [byte(0), byte(2), byte(4)]
}

fn parse_number<T: std::str::FromStr>(flag: &str, text: &str) -> T {
    text.trim()
        .parse()
        .unwrap_or_else(|_| fail(format!("{flag} '{text}' is not a number")))
}

fn parse_args() -> Args {
    let mut scene = None;
    let (mut width, mut height) = (256, 256);
    let mut background = [0x33, 0x33, 0x33];
    let (mut frames, mut warmup, mut layers, mut fragments_per_pixel) = (10i64, 2i64, 8i64, 4.0f32);
    let mut output = None;
    let mut json = None;
    let mut args = std::env::args().skip(1);
    while let Some(arg) = args.next() {
        if arg == "-h" || arg == "--help" {
            println!("{USAGE}");
            std::process::exit(0);
        }
        let (flag, inline) = match arg.split_once('=') {
            Some((f, v)) if f.starts_with("--") => (f.to_string(), Some(v.to_string())),
            _ => (arg.clone(), None),
        };
        let known = [
            "--size",
            "--background",
            "--frames",
            "--warmup",
            "--layers",
            "--fragments-per-pixel",
            "-o",
            "--output",
            "--json",
        ];
        if !known.contains(&flag.as_str()) {
            if flag.starts_with('-') && flag.len() > 1 {
                fail(format!("unknown option '{flag}' ({USAGE})"));
            }
            if scene.replace(PathBuf::from(&arg)).is_some() {
                fail(format!("more than one scene given ({USAGE})"));
            }
            continue;
        }
        let value = match inline.or_else(|| args.next()) {
            Some(v) => v,
            None => fail(format!("{flag} needs a value")),
        };
        match flag.as_str() {
            "--size" => (width, height) = parse_size(&value),
            "--background" => background = parse_color(&value),
            "--frames" => frames = parse_number(&flag, &value),
            "--warmup" => warmup = parse_number(&flag, &value),
            "--layers" => layers = parse_number(&flag, &value),
            "--fragments-per-pixel" => fragments_per_pixel = parse_number(&flag, &value),
            "-o" | "--output" => output = Some(PathBuf::from(value)),
            "--json" => json = Some(PathBuf::from(value)),
            _ => unreachable!(),
        }
    }
    let Some(scene) = scene else {
        fail(format!("no scene given ({USAGE})"))
    };
    let Some(output) = output else {
        fail(format!("no output picture given (-o PICTURE.png; {USAGE})"))
    };
    if frames < 1 || warmup < 0 {
        fail("--frames must be at least 1 and --warmup at least 0");
    }
    if !(1..=64).contains(&layers) {
        fail(format!("--layers {layers} must be between 1 and 64"));
    }
    if !(fragments_per_pixel > 0.0 && fragments_per_pixel <= 256.0) {
        fail(format!(
            "--fragments-per-pixel {fragments_per_pixel} must be in (0, 256]"
        ));
    }
    Args {
        scene,
        width,
        height,
        background,
        frames: frames as usize,
        warmup: warmup as usize,
        layers: layers as u32,
        fragments_per_pixel,
        output,
        json,
    }
}

/// One triangle list, placed in the world.
struct MeshData {
    positions: Vec<[f32; 3]>,
    indices: Vec<u32>,
    material: Option<usize>,
    transform: Mat4,
}

struct MaterialData {
    /// Linear RGB and opacity.
    color: [f32; 4],
    blend: bool,
}

enum CameraProjection {
    Perspective {
        yfov: f32,
        znear: f32,
        zfar: Option<f32>,
    },
    Orthographic {
        ymag: f32,
        znear: f32,
        zfar: f32,
    },
}

struct SceneData {
    meshes: Vec<MeshData>,
    materials: Vec<MaterialData>,
    camera: (CameraProjection, Mat4),
}

/// The binary data of each buffer: the GLB's chunk or an embedded base64 data URI.
fn buffers(path: &Path, gltf: &gltf::Gltf) -> Vec<Vec<u8>> {
    use base64::Engine;
    gltf.buffers()
        .map(|buffer| {
            let data = match buffer.source() {
                gltf::buffer::Source::Bin => gltf.blob.clone().unwrap_or_else(|| {
                    fail(format!("{}: the GLB has no binary chunk", path.display()))
                }),
                gltf::buffer::Source::Uri(uri) => {
                    let payload = uri
                        .strip_prefix("data:")
                        .and_then(|rest| rest.split_once(";base64,"))
                        .map(|(_, data)| data)
                        .unwrap_or_else(|| {
                            fail(format!(
                                "{}: only .glb files and .gltf files with an embedded buffer are read",
                                path.display()
                            ))
                        });
                    base64::engine::general_purpose::STANDARD
                        .decode(payload)
                        .unwrap_or_else(|e| fail(format!("{}: bad embedded buffer: {e}", path.display())))
                }
            };
            if data.len() < buffer.length() {
                fail(format!("{}: truncated buffer {}", path.display(), buffer.index()));
            }
            data
        })
        .collect()
}

fn read_scene(path: &Path) -> SceneData {
    let bytes = std::fs::read(path).unwrap_or_else(|e| fail(format!("{}: {e}", path.display())));
    let gltf = gltf::Gltf::from_slice(&bytes)
        .unwrap_or_else(|e| fail(format!("{}: not a glTF file: {e}", path.display())));
    let data = buffers(path, &gltf);

    let materials = gltf
        .materials()
        .map(|m| MaterialData {
            color: m.pbr_metallic_roughness().base_color_factor(),
            blend: m.alpha_mode() == gltf::material::AlphaMode::Blend,
        })
        .collect();

    let scene = gltf
        .default_scene()
        .or_else(|| gltf.scenes().next())
        .unwrap_or_else(|| fail(format!("{}: no scene", path.display())));
    let mut meshes = Vec::new();
    let mut camera = None;
    // Depth first, in the file's order; strata writes every node at the top level.
    let mut stack: Vec<(gltf::Node, Mat4)> = scene.nodes().map(|n| (n, Mat4::IDENTITY)).collect();
    stack.reverse();
    while let Some((node, parent)) = stack.pop() {
        let matrix = parent * Mat4::from_cols_array_2d(&node.transform().matrix());
        if let Some(mesh) = node.mesh() {
            for primitive in mesh.primitives() {
                if primitive.mode() != gltf::mesh::Mode::Triangles {
                    fail(format!(
                        "{}: mesh {} has a {:?} primitive; only triangles are drawn",
                        path.display(),
                        mesh.index(),
                        primitive.mode()
                    ));
                }
                let reader = primitive.reader(|b| data.get(b.index()).map(|d| d.as_slice()));
                let positions: Vec<[f32; 3]> = match reader.read_positions() {
                    Some(p) => p.collect(),
                    None => fail(format!(
                        "{}: mesh {} has no positions",
                        path.display(),
                        mesh.index()
                    )),
                };
                let indices: Vec<u32> = match reader.read_indices() {
                    Some(i) => i.into_u32().collect(),
                    None => (0..positions.len() as u32).collect(),
                };
                if !indices.len().is_multiple_of(3)
                    || indices.iter().any(|&i| i as usize >= positions.len())
                {
                    fail(format!(
                        "{}: mesh {} has bad indices",
                        path.display(),
                        mesh.index()
                    ));
                }
                meshes.push(MeshData {
                    positions,
                    indices,
                    material: primitive.material().index(),
                    transform: matrix,
                });
            }
        }
        if let (Some(c), None) = (node.camera(), &camera) {
            let projection = match c.projection() {
                gltf::camera::Projection::Perspective(p) => CameraProjection::Perspective {
                    yfov: p.yfov(),
                    znear: p.znear(),
                    zfar: p.zfar(),
                },
                gltf::camera::Projection::Orthographic(o) => CameraProjection::Orthographic {
                    ymag: o.ymag(),
                    znear: o.znear(),
                    zfar: o.zfar(),
                },
            };
            camera = Some((projection, matrix));
        }
        for child in node.children().collect::<Vec<_>>().into_iter().rev() {
            stack.push((child, matrix));
        }
    }
    let Some(camera) = camera else {
        fail(format!(
            "{}: no camera node (write it with strata export)",
            path.display()
        ))
    };
    SceneData {
        meshes,
        materials,
        camera,
    }
}

/// The picture read back by the screenshot observer.
#[derive(Resource, Default)]
struct Picture(Option<Image>);

fn on_screenshot(captured: On<ScreenshotCaptured>, mut picture: ResMut<Picture>) {
    picture.0 = Some(captured.image.clone());
}

fn build_app() -> App {
    let mut app = App::new();
    app.add_plugins(
        DefaultPlugins
            .set(WindowPlugin {
                primary_window: None,
                exit_condition: ExitCondition::DontExit,
                close_when_requested: false,
                ..default()
            })
            .set(RenderPlugin {
                synchronous_pipeline_compilation: true,
                ..default()
            })
            .set(LogPlugin {
                // RUST_LOG, when set, replaces this.
                level: Level::WARN,
                filter: "wgpu=error,naga=warn".into(),
                ..default()
            }),
    )
    .add_plugins(RenderDiagnosticsPlugin)
    .init_resource::<Picture>();
    // What App::run's runners do before the first update: wait for the renderer, then finish.
    while app.plugins_state() == PluginsState::Adding {
        bevy::tasks::tick_global_task_pools_on_main_thread();
    }
    app.finish();
    app.cleanup();
    app
}

/// Spawns the camera, rendering into a new image, and the meshes; the image's handle.
fn spawn_scene(app: &mut App, args: &Args, scene: &SceneData) -> Handle<Image> {
    let world = app.world_mut();
    let mut target = Image::new_uninit(
        Extent3d {
            width: args.width,
            height: args.height,
            depth_or_array_layers: 1,
        },
        TextureDimension::D2,
        TextureFormat::Rgba8UnormSrgb,
        RenderAssetUsages::RENDER_WORLD,
    );
    target.texture_descriptor.usage |=
        TextureUsages::RENDER_ATTACHMENT | TextureUsages::COPY_SRC | TextureUsages::TEXTURE_BINDING;
    let image = world.resource_mut::<Assets<Image>>().add(target);

    let aspect = args.width as f32 / args.height as f32;
    let (projection, camera_matrix) = &scene.camera;
    let projection = match *projection {
        CameraProjection::Perspective { yfov, znear, zfar } => {
            Projection::Perspective(PerspectiveProjection {
                fov: yfov,
                aspect_ratio: aspect,
                near: znear,
                // Bevy's perspective is reverse-Z with an infinite far plane: zfar only culls.
                far: zfar.unwrap_or(znear * 1e4),
                near_clip_plane: Vec4::new(0.0, 0.0, -1.0, -znear),
            })
        }
        CameraProjection::Orthographic { ymag, znear, zfar } => {
            Projection::Orthographic(OrthographicProjection {
                near: znear,
                far: zfar,
                scaling_mode: ScalingMode::Fixed {
                    width: 2.0 * ymag * aspect,
                    height: 2.0 * ymag,
                },
                ..OrthographicProjection::default_3d()
            })
        }
    };
    let [r, g, b] = args.background;
    world.spawn((
        Camera3d::default(),
        Camera {
            clear_color: ClearColorConfig::Custom(Color::srgb_u8(r, g, b)),
            ..default()
        },
        RenderTarget::Image(image.clone().into()),
        projection,
        Transform::from_matrix(*camera_matrix),
        Msaa::Off,
        Tonemapping::None,
        DebandDither::Disabled,
        OrderIndependentTransparencySettings {
            sorted_fragment_max_count: args.layers,
            fragments_per_pixel_average: args.fragments_per_pixel,
            ..default()
        },
    ));

    let materials: Vec<Handle<StandardMaterial>> = {
        let mut assets = world.resource_mut::<Assets<StandardMaterial>>();
        scene
            .materials
            .iter()
            .map(|m| {
                let [r, g, b, a] = m.color;
                assets.add(StandardMaterial {
                    base_color: Color::linear_rgba(r, g, b, a),
                    alpha_mode: if m.blend {
                        AlphaMode::Blend
                    } else {
                        AlphaMode::Opaque
                    },
                    unlit: true,
                    double_sided: true,
                    cull_mode: None,
                    ..default()
                })
            })
            .collect()
    };
    let default_material = world
        .resource_mut::<Assets<StandardMaterial>>()
        .add(StandardMaterial {
            base_color: Color::WHITE,
            unlit: true,
            double_sided: true,
            cull_mode: None,
            ..default()
        });
    for data in &scene.meshes {
        let mut mesh = Mesh::new(
            PrimitiveTopology::TriangleList,
            RenderAssetUsages::RENDER_WORLD,
        );
        mesh.insert_attribute(Mesh::ATTRIBUTE_POSITION, data.positions.clone());
        mesh.insert_indices(Indices::U32(data.indices.clone()));
        let mesh = world.resource_mut::<Assets<Mesh>>().add(mesh);
        let material = match data.material {
            Some(i) => materials.get(i).cloned().unwrap_or_else(|| {
                fail(format!(
                    "{}: material {i} does not exist",
                    args.scene.display()
                ))
            }),
            None => default_material.clone(),
        };
        world.spawn((
            Mesh3d(mesh),
            MeshMaterial3d(material),
            Transform::from_matrix(data.transform),
        ));
    }
    image
}

/// Runs one frame and waits for the GPU to finish it.
fn frame(app: &mut App) {
    app.update();
    if let Some(AppExit::Error(code)) = app.should_exit() {
        fail(format!(
            "Bevy stopped rendering (exit code {code}); run with RUST_LOG=info for its log"
        ));
    }
    let device = app.world().resource::<RenderDevice>().wgpu_device().clone();
    if let Err(e) = device.poll(PollType::Wait {
        submission_index: None,
        timeout: None,
    }) {
        fail(format!("waiting for the GPU: {e}"));
    }
}

/// The GPU times that reached `DiagnosticsStore` since the last call, summed per pass set:
/// (total ms, pass names), or None when none arrived; clears them.
fn drain_gpu_times(app: &mut App) -> Option<(f64, Vec<String>)> {
    let mut store = app.world_mut().resource_mut::<DiagnosticsStore>();
    // Measurements of one frame share the time they were synced at.
    let mut by_sync: BTreeMap<Instant, (f64, Vec<String>)> = BTreeMap::new();
    for diagnostic in store.iter_mut() {
        let path = diagnostic.path().as_str().to_string();
        if !(path.starts_with("render/") && path.ends_with("/elapsed_gpu")) {
            continue;
        }
        for m in diagnostic.measurements() {
            let entry = by_sync.entry(m.time).or_default();
            entry.0 += m.value;
            let pass = path
                .trim_start_matches("render/")
                .trim_end_matches("/elapsed_gpu")
                .to_string();
            entry.1.push(pass);
        }
        diagnostic.clear_history();
    }
    // One frame's times per update; more would mean frames were merged.
    by_sync.into_values().last().map(|(ms, mut passes)| {
        passes.sort();
        (ms, passes)
    })
}

/// Runs untimed frames until Bevy has every pipeline the scene needs: none waiting to compile
/// and the same number cached three frames running (meshes and materials become ready, and their
/// pipelines are specialised, a few frames after they are spawned). The number of frames run.
fn prime(app: &mut App) -> usize {
    const MAX: usize = 120;
    let mut last = usize::MAX;
    let mut stable = 0;
    for i in 1..=MAX {
        frame(app);
        let _ = drain_gpu_times(app);
        let cache = app.sub_app(RenderApp).world().resource::<PipelineCache>();
        let (cached, waiting) = (cache.pipelines().count(), cache.waiting_pipelines().count());
        stable = if waiting == 0 && cached == last {
            stable + 1
        } else {
            0
        };
        last = cached;
        if stable >= 3 {
            return i;
        }
    }
    fail(format!(
        "Bevy's pipelines were still changing after {MAX} frames"
    ));
}

fn median(values: &[f64]) -> Option<f64> {
    if values.is_empty() {
        return None;
    }
    let mut v = values.to_vec();
    v.sort_by(|a, b| a.total_cmp(b));
    let n = v.len();
    Some(if n % 2 == 1 {
        v[n / 2]
    } else {
        (v[n / 2 - 1] + v[n / 2]) / 2.0
    })
}

/// An 8-bit RGBA PNG, written whole or not at all.
fn write_png(path: &Path, width: u32, height: u32, rgba: &[u8]) {
    let tmp = path.with_extension("png.tmp");
    let result = (|| -> Result<(), String> {
        let file = std::fs::File::create(&tmp).map_err(|e| e.to_string())?;
        let mut encoder = png::Encoder::new(std::io::BufWriter::new(file), width, height);
        encoder.set_color(png::ColorType::Rgba);
        encoder.set_depth(png::BitDepth::Eight);
        let mut writer = encoder.write_header().map_err(|e| e.to_string())?;
        writer.write_image_data(rgba).map_err(|e| e.to_string())?;
        writer.finish().map_err(|e| e.to_string())?;
        std::fs::rename(&tmp, path).map_err(|e| e.to_string())
    })();
    if let Err(e) = result {
        let _ = std::fs::remove_file(&tmp);
        fail(format!("cannot write '{}': {e}", path.display()));
    }
}

fn main() {
    // A panic anywhere (Bevy's included) is reported as one error line, status 2.
    std::panic::set_hook(Box::new(|info| {
        let message = info
            .payload()
            .downcast_ref::<&str>()
            .map(|s| s.to_string())
            .or_else(|| info.payload().downcast_ref::<String>().cloned())
            .unwrap_or_else(|| "unknown panic".into());
        let at = info
            .location()
            .map(|l| format!(" (at {}:{})", l.file(), l.line()))
            .unwrap_or_default();
        eprintln!("error: bevy panicked: {}{at}", message.replace('\n', " "));
        std::process::exit(2);
    }));

    let args = parse_args();
    let scene = read_scene(&args.scene);
    if let Some(dir) = args.output.parent().filter(|d| !d.as_os_str().is_empty()) {
        if !dir.is_dir() {
            fail(format!(
                "cannot write '{}': no such directory",
                args.output.display()
            ));
        }
    }

    let mut app = build_app();
    if !app.world().contains_resource::<RenderDevice>() {
        fail("no GPU adapter: Bevy could not create a renderer");
    }
    let image = spawn_scene(&mut app, &args, &scene);
    let adapter = app.world().resource::<RenderAdapterInfo>().name.clone();

    let primed = prime(&mut app);

    // Warm-up, then timed frames, then the frames that bring the last timed frames' GPU times.
    let total = args.warmup + args.frames;
    let mut wall_ms = Vec::with_capacity(args.frames);
    let mut gpu_by_frame: Vec<Option<f64>> = vec![None; total];
    let mut passes: Vec<String> = Vec::new();
    for i in 0..total + DIAGNOSTICS_LAG {
        let start = Instant::now();
        frame(&mut app);
        let ms = start.elapsed().as_secs_f64() * 1e3;
        if (args.warmup..total).contains(&i) {
            wall_ms.push(ms);
        }
        if let Some((gpu, names)) = drain_gpu_times(&mut app) {
            if let Some(slot) = i
                .checked_sub(DIAGNOSTICS_LAG)
                .and_then(|f| gpu_by_frame.get_mut(f))
            {
                *slot = Some(gpu);
                passes = names;
            }
        }
    }
    let gpu_ms: Option<Vec<f64>> = gpu_by_frame[args.warmup..].iter().copied().collect();

    // The picture: one more frame, read back.
    app.world_mut()
        .spawn(Screenshot::image(image))
        .observe(on_screenshot);
    let mut picture = None;
    for _ in 0..16 {
        frame(&mut app);
        if let Some(p) = app.world_mut().resource_mut::<Picture>().0.take() {
            picture = Some(p);
            break;
        }
    }
    let Some(picture) = picture else {
        fail("Bevy's screenshot of the render target never arrived");
    };
    let (w, h) = (picture.width(), picture.height());
    let Some(mut data) = picture.data else {
        fail("Bevy's screenshot has no data");
    };
    if (w, h) != (args.width, args.height) || data.len() != (w * h * 4) as usize {
        fail(format!(
            "Bevy's screenshot is {w}x{h} ({} bytes), not {}x{}",
            data.len(),
            args.width,
            args.height
        ));
    }
    match picture.texture_descriptor.format {
        TextureFormat::Rgba8UnormSrgb | TextureFormat::Rgba8Unorm => {}
        TextureFormat::Bgra8UnormSrgb | TextureFormat::Bgra8Unorm => {
            data.chunks_exact_mut(4).for_each(|p| p.swap(0, 2))
        }
        other => fail(format!("Bevy's screenshot has format {other:?}, not RGBA8")),
    }
    write_png(&args.output, w, h, &data);

    if let Some(path) = &args.json {
        let result = serde_json::json!({
            "peer": "bevy",
            "version": env!("BEVY_VERSION"),
            "mode": "oit",
            "layers": args.layers,
            "fragments_per_pixel_average": args.fragments_per_pixel,
            "width": args.width,
            "height": args.height,
            "frames": args.frames,
            "warmup": args.warmup,
            "prime_frames": primed,
            "adapter": adapter,
            "wall_ms": wall_ms,
            "median_wall_ms": median(&wall_ms),
            "gpu_ms": gpu_ms,
            "median_gpu_ms": gpu_ms.as_deref().and_then(median),
            "gpu_passes": if gpu_ms.is_some() { Some(&passes) } else { None },
        });
        let text = serde_json::to_string_pretty(&result).unwrap() + "\n";
        if let Err(e) = std::fs::write(path, text) {
            fail(format!("cannot write '{}': {e}", path.display()));
        }
    }
    // Bevy's teardown is of no use here.
    std::process::exit(0);
}
