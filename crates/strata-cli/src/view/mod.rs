//! `strata view`: a window to explore the methods live.
//!
//! A winit window with an egui panel on the left and the 3D area on the right. Each frame the
//! viewer records the method's frame into its own render target (the picture's size, not the
//! window's; [`viewport`]), then draws the window: the target at one texel per pixel, then the
//! panel. Statistics arrive asynchronously from the recorder and feed the readouts; the
//! reference comparison renders on a worker thread. `--screenshot FILE --frames N` renders N
//! frames, saves the window (panel included) and exits, for tests and docs.
//!
//! Changes from the panel go through [`state::ViewState`], the same options `strata render`
//! takes, so the "view as command" line reproduces the picture; a change the frame cannot take
//! (a scene that does not load, a budget too small) leaves the last good view and says why.

mod panel;
mod state;
mod viewport;

use std::path::{Path, PathBuf};
use std::sync::{mpsc, Arc, Mutex};
use std::time::Instant;

use strata::error::{Error, Result};
use strata::gpu::Gpu;
use strata::methods::MethodId;
use winit::application::ApplicationHandler;
use winit::dpi::PhysicalSize;
use winit::event::WindowEvent;
use winit::event_loop::{ActiveEventLoop, ControlFlow, EventLoop};
use winit::window::{Window, WindowId};

use crate::args::ViewArgs;
use crate::PipelineArg;
use panel::{Action, CompareStatus, Panel, Readouts, Shown, PANEL_WIDTH};
use state::{Change, Orbit, ViewState};
use viewport::{Blit, Viewport};

pub fn run(args: ViewArgs) -> Result<()> {
    // Everything that can fail without a window fails before one opens.
    if args.method.id() == MethodId::Reference {
        return Err(Error::input(
            "strata view shows the GPU methods; the reference is its \"Compare with reference\" button",
        ));
    }
    let (scene, options) = crate::prepare_render(&args.method, &args.picture)?;
    if args.frames == 0 {
        return Err(Error::input("--frames must be at least 1"));
    }
    if let Some(path) = &args.screenshot {
        check_output(path)?;
    }
    if std::env::var_os("DISPLAY").is_none_or(|d| d.is_empty()) {
        return Err(Error::unsupported(
            "strata view opens a window and DISPLAY is not set (no X display; without one run it under xvfb-run, or use strata render)",
        ));
    }
    let mut picture = args.picture.clone();
    // The scene's default pipeline, made explicit so the panel and the command line show it.
    picture.pipeline = Some(match options.build.lighting.pipeline {
        None => PipelineArg::None,
        Some(strata::frame::Pipeline::Forward) => PipelineArg::Forward,
        Some(strata::frame::Pipeline::Deferred) => PipelineArg::Deferred,
    });
    let mut state = ViewState::new(picture, args.method.clone(), scene.camera_or_framing());
    state.camera_path = scene.camera_path.clone();
    let event_loop = EventLoop::new()
        .map_err(|e| Error::unsupported(format!("strata view cannot reach the display: {e}")))?;
    event_loop.set_control_flow(ControlFlow::Poll);
    let mut app = App {
        panel: Panel::new(&state.picture.scene),
        good: state.clone(),
        state,
        screenshot: args.screenshot.map(|p| (p, args.frames)),
        frames_drawn: 0,
        gfx: None,
        outcome: Ok(()),
        last_frame: None,
        compare: None,
    };
    event_loop
        .run_app(&mut app)
        .map_err(|e| Error::runtime(format!("the window's event loop failed: {e}")))?;
    app.outcome
}

/// A PNG path whose directory exists.
fn check_output(path: &Path) -> Result<()> {
    let dir = path.parent().filter(|d| !d.as_os_str().is_empty());
    if let Some(dir) = dir {
        if !dir.is_dir() {
            return Err(Error::input(format!(
                "--screenshot {}: the directory {} does not exist",
                path.display(),
                dir.display()
            )));
        }
    }
    Ok(())
}

/// The window and everything drawn into it.
struct Gfx {
    window: Arc<Window>,
    surface: wgpu::Surface<'static>,
    config: wgpu::SurfaceConfiguration,
    gpu: Gpu,
    egui: egui::Context,
    egui_state: egui_winit::State,
    renderer: egui_wgpu::Renderer,
    blit: Blit,
    viewport: Viewport,
    /// The first device error or loss, which ends the viewer.
    device_error: Arc<Mutex<Option<String>>>,
}

enum CompareJob {
    Running {
        started: Instant,
        image: image::RgbaImage,
        result: mpsc::Receiver<Result<image::RgbaImage>>,
    },
    Done {
        reference: wgpu::Texture,
        diff: wgpu::Texture,
    },
}

struct App {
    state: ViewState,
    /// The last state whose frame recorded.
    good: ViewState,
    panel: Panel,
    /// Headless: where to save the window, after how many frames.
    screenshot: Option<(PathBuf, u32)>,
    frames_drawn: u32,
    gfx: Option<Gfx>,
    outcome: Result<()>,
    last_frame: Option<Instant>,
    compare: Option<CompareJob>,
}

impl ApplicationHandler for App {
    fn resumed(&mut self, event_loop: &ActiveEventLoop) {
        if self.gfx.is_some() {
            return;
        }
        match Gfx::new(event_loop, &self.state) {
            Ok(gfx) => self.gfx = Some(gfx),
            Err(e) => self.fail(event_loop, e),
        }
    }

    fn window_event(&mut self, event_loop: &ActiveEventLoop, _: WindowId, event: WindowEvent) {
        let Some(gfx) = self.gfx.as_mut() else {
            return;
        };
        let _ = gfx.egui_state.on_window_event(&gfx.window, &event);
        match event {
            WindowEvent::CloseRequested => event_loop.exit(),
            WindowEvent::Resized(size) => gfx.resize(size),
            WindowEvent::RedrawRequested => {
                if let Err(e) = self.redraw(event_loop) {
                    self.fail(event_loop, e);
                }
            }
            _ => {}
        }
    }

    fn about_to_wait(&mut self, _: &ActiveEventLoop) {
        if let Some(gfx) = &self.gfx {
            gfx.window.request_redraw();
        }
    }
}

impl Gfx {
    fn new(event_loop: &ActiveEventLoop, state: &ViewState) -> Result<Gfx> {
        let (_, options) = viewport::prepared(state)?;
        let attributes = Window::default_attributes()
            .with_title("strata view")
            .with_inner_size(PhysicalSize::new(
                PANEL_WIDTH as u32 + options.frame.width.max(320),
                options.frame.height.max(800),
            ));
        let window = Arc::new(
            event_loop
                .create_window(attributes)
                .map_err(|e| Error::unsupported(format!("cannot open a window: {e}")))?,
        );
        let instance = wgpu::Instance::new(Gpu::instance_descriptor());
        let surface = instance
            .create_surface(window.clone())
            .map_err(|e| Error::unsupported(format!("cannot draw into the window: {e}")))?;
        let gpu = Gpu::for_surface(&instance, &surface)?;
        let device_error = Arc::new(Mutex::new(None));
        let errors = device_error.clone();
        gpu.device.on_uncaptured_error(Arc::new(move |e| {
            let mut slot = errors.lock().unwrap_or_else(|p| p.into_inner());
            slot.get_or_insert_with(|| format!("GPU error: {e}"));
        }));
        let lost = device_error.clone();
        gpu.device.set_device_lost_callback(move |reason, message| {
            let mut slot = lost.lock().unwrap_or_else(|p| p.into_inner());
            slot.get_or_insert_with(|| format!("the GPU device was lost ({reason:?}): {message}"));
        });
        let size = window.inner_size();
        let adapter = gpu.adapter.as_ref().expect("strata opened the adapter");
        let mut config = surface
            .get_default_config(adapter, size.width.max(1), size.height.max(1))
            .ok_or_else(|| Error::unsupported("the adapter cannot present to this window"))?;
        let formats = surface.get_capabilities(adapter).formats;
        if let Some(srgb) = formats.iter().find(|f| f.is_srgb()) {
            config.format = *srgb;
        }
        config.present_mode = wgpu::PresentMode::AutoVsync;
        surface.configure(&gpu.device, &config);
        let egui = egui::Context::default();
        let egui_state = egui_winit::State::new(
            egui.clone(),
            egui::ViewportId::ROOT,
            &window,
            Some(window.scale_factor() as f32),
            None,
            Some(gpu.limits.max_texture_dimension_2d as usize),
        );
        let renderer = egui_wgpu::Renderer::new(
            &gpu.device,
            config.format,
            egui_wgpu::RendererOptions {
                dithering: false,
                ..Default::default()
            },
        );
        Ok(Gfx {
            blit: Blit::new(&gpu, config.format),
            viewport: Viewport::new(&gpu, state)?,
            window,
            surface,
            config,
            gpu,
            egui,
            egui_state,
            renderer,
            device_error,
        })
    }

    fn resize(&mut self, size: PhysicalSize<u32>) {
        if size.width > 0 && size.height > 0 {
            self.config.width = size.width;
            self.config.height = size.height;
            self.surface.configure(&self.gpu.device, &self.config);
        }
    }

    fn device_error(&self) -> Option<String> {
        self.device_error
            .lock()
            .unwrap_or_else(|p| p.into_inner())
            .clone()
    }

    /// Draws the window (an image in the 3D area, then the panel) into `view`.
    #[allow(clippy::too_many_arguments)]
    fn draw_window(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        view: &wgpu::TextureView,
        image: &wgpu::Texture,
        area: Area,
        jobs: &[egui::ClippedPrimitive],
        screen: &egui_wgpu::ScreenDescriptor,
    ) {
        let bg = self.egui.global_style().visuals.panel_fill;
        let c = |v: u8| strata::scene::srgb_to_linear(v as f32 / 255.0) as f64;
        let mut pass = encoder
            .begin_render_pass(&wgpu::RenderPassDescriptor {
                label: Some("strata.view.window"),
                color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                    view,
                    depth_slice: None,
                    resolve_target: None,
                    ops: wgpu::Operations {
                        load: wgpu::LoadOp::Clear(wgpu::Color {
                            r: c(bg.r()),
                            g: c(bg.g()),
                            b: c(bg.b()),
                            a: 1.0,
                        }),
                        store: wgpu::StoreOp::Store,
                    },
                })],
                ..Default::default()
            })
            .forget_lifetime();
        self.blit
            .draw(&self.gpu, &mut pass, image, area.origin, area.clip);
        pass.set_scissor_rect(0, 0, screen.size_in_pixels[0], screen.size_in_pixels[1]);
        self.renderer.render(&mut pass, jobs, screen);
    }
}

/// Where the 3D area's image lies in the window, pixels.
#[derive(Clone, Copy, Debug)]
struct Area {
    origin: [i32; 2],
    /// The visible part: x, y, width, height.
    clip: [u32; 4],
}

impl Area {
    fn new(rect: egui::Rect, ppp: f32, image: (u32, u32), window: (u32, u32)) -> Area {
        let x0 = (rect.min.x * ppp).round().max(0.0) as u32;
        let y0 = (rect.min.y * ppp).round().max(0.0) as u32;
        let x1 = ((rect.max.x * ppp).round() as u32)
            .min(window.0)
            .min(x0 + image.0);
        let y1 = ((rect.max.y * ppp).round() as u32)
            .min(window.1)
            .min(y0 + image.1);
        Area {
            origin: [x0 as i32, y0 as i32],
            clip: [x0, y0, x1.saturating_sub(x0), y1.saturating_sub(y0)],
        }
    }
}

impl App {
    fn fail(&mut self, event_loop: &ActiveEventLoop, e: Error) {
        self.outcome = Err(e);
        event_loop.exit();
    }

    fn redraw(&mut self, event_loop: &ActiveEventLoop) -> Result<()> {
        let App {
            state,
            good,
            panel,
            gfx,
            compare,
            ..
        } = self;
        let Some(gfx) = gfx.as_mut() else {
            return Ok(());
        };
        if let Some(message) = gfx.device_error() {
            return Err(Error::runtime(message));
        }
        let size = gfx.window.inner_size();
        if size.width == 0 || size.height == 0 {
            return Ok(()); // minimized
        }
        let now = Instant::now();
        if let Some(last) = self.last_frame.replace(now) {
            let ms = now.duration_since(last).as_secs_f32() * 1000.0;
            panel.frame_ms = if panel.frame_ms == 0.0 {
                ms
            } else {
                0.9 * panel.frame_ms + 0.1 * ms
            };
        }
        poll_compare(gfx, compare, panel);

        let old = state.clone();
        if state.playing {
            state.set_time(state.time() + 1.0);
        }
        let raw = gfx.egui_state.take_egui_input(&gfx.window);
        let target = gfx.viewport.target();
        let readouts = Readouts {
            history: &gfx.viewport.history,
            histogram: gfx.viewport.histogram.as_deref(),
            target_size: (target.width(), target.height()),
        };
        let mut actions = Vec::new();
        let mut rect = egui::Rect::NOTHING;
        let mut output = gfx.egui.run_ui(raw, |ui| {
            (actions, rect) = panel::show(ui, state, panel, &readouts);
        });
        // Taken out at once: a delta dropped unapplied (on an error below) is a panic in egui.
        let textures_set = std::mem::take(&mut output.textures_delta.set);
        let textures_free = std::mem::take(&mut output.textures_delta.free);
        gfx.egui_state
            .handle_platform_output(&gfx.window, output.platform_output);
        if state.orbit != old.orbit {
            state.commit_camera();
        }
        for action in &actions {
            if let Action::LoadScene(spec) = action {
                load_scene(state, spec);
            }
        }
        let change = state.change_from(&old);
        if change != Change::None {
            if let Err(e) = gfx.viewport.apply(state, change) {
                panel.message = Some((e.to_string(), true));
                *state = old;
            } else {
                if let CompareStatus::Done { stale, .. } = &mut panel.compare {
                    *stale = true;
                }
                panel.shown = Shown::Image;
                if change == Change::Rebuild {
                    panel.scene_text = state.picture.scene.clone();
                }
                if panel.message.as_ref().is_some_and(|m| m.1) {
                    panel.message = None;
                }
            }
        }

        let mut encoder = gfx
            .gpu
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                label: Some("strata.view.frame"),
            });
        if let Err(e) = gfx.viewport.record(&mut encoder) {
            // Back to the last view that recorded, and say why.
            panel.message = Some((e.to_string(), true));
            *state = good.clone();
            gfx.viewport.apply(state, Change::Rebuild)?;
            encoder = gfx.gpu.device.create_command_encoder(&Default::default());
            gfx.viewport.record(&mut encoder)?;
        } else {
            *good = state.clone();
        }

        let ppp = output.pixels_per_point;
        let jobs = gfx.egui.tessellate(output.shapes, ppp);
        let (device, queue) = (&gfx.gpu.device, &gfx.gpu.queue);
        for (id, deltas) in &textures_set {
            for delta in deltas {
                gfx.renderer.update_texture(device, queue, *id, delta);
            }
        }
        let screen = egui_wgpu::ScreenDescriptor {
            size_in_pixels: [gfx.config.width, gfx.config.height],
            pixels_per_point: ppp,
        };
        let callbacks = gfx
            .renderer
            .update_buffers(device, queue, &mut encoder, &jobs, &screen);
        let image = match (panel.shown, compare.as_ref()) {
            (Shown::Reference, Some(CompareJob::Done { reference, .. })) => reference,
            (Shown::Diff, Some(CompareJob::Done { diff, .. })) => diff,
            _ => gfx.viewport.target(),
        };
        let area = Area::new(
            rect,
            ppp,
            (image.width(), image.height()),
            (gfx.config.width, gfx.config.height),
        );
        let headless_last = self
            .screenshot
            .as_ref()
            .is_some_and(|(_, n)| self.frames_drawn + 1 >= *n);
        let window_copy = headless_last.then(|| {
            let copy = gfx.gpu.texture_2d(
                "strata.view.window_copy",
                (gfx.config.width, gfx.config.height),
                gfx.config.format,
                wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::COPY_SRC,
            );
            let view = copy.create_view(&Default::default());
            gfx.draw_window(&mut encoder, &view, image, area, &jobs, &screen);
            copy
        });
        let surface_texture = match gfx.surface.get_current_texture() {
            wgpu::CurrentSurfaceTexture::Success(t)
            | wgpu::CurrentSurfaceTexture::Suboptimal(t) => Some(t),
            wgpu::CurrentSurfaceTexture::Timeout | wgpu::CurrentSurfaceTexture::Occluded => None,
            wgpu::CurrentSurfaceTexture::Outdated | wgpu::CurrentSurfaceTexture::Lost => {
                gfx.surface.configure(&gfx.gpu.device, &gfx.config);
                None
            }
            wgpu::CurrentSurfaceTexture::Validation => {
                return Err(Error::runtime("the window's surface failed validation"))
            }
        };
        if let Some(t) = &surface_texture {
            let view = t.texture.create_view(&Default::default());
            gfx.draw_window(&mut encoder, &view, image, area, &jobs, &screen);
        }
        gfx.gpu
            .queue
            .submit(callbacks.into_iter().chain([encoder.finish()]));
        if let Some(t) = surface_texture {
            gfx.window.pre_present_notify();
            gfx.gpu.queue.present(t);
        }
        for id in &textures_free {
            gfx.renderer.free_texture(id);
        }
        gfx.viewport.poll();

        for action in actions {
            match action {
                Action::Screenshot => {
                    panel.message = Some(match save_screenshot(&gfx.viewport) {
                        Ok(path) => (format!("saved {}", path.display()), false),
                        Err(e) => (e.to_string(), true),
                    })
                }
                Action::Compare => start_compare(gfx, compare, panel),
                Action::LoadScene(_) => {}
            }
        }
        self.frames_drawn += 1;
        if let (Some(copy), Some((path, _))) = (window_copy, &self.screenshot) {
            let picture = viewport::texture_image(&gfx.gpu, &copy)?;
            strata::render::save_png(&picture, path)?;
            println!(
                "3d-area: {} {} {} {}",
                area.clip[0], area.clip[1], area.clip[2], area.clip[3]
            );
            println!("command: {}", state.command_line());
            event_loop.exit();
        }
        Ok(())
    }
}

/// Another scene from the panel: its own camera, the animation at its start.
fn load_scene(state: &mut ViewState, spec: &str) {
    let mut picture = state.picture.clone();
    picture.scene = spec.to_string();
    picture.camera = Default::default();
    picture.frame = None;
    if let Ok((scene, _)) = crate::prepare_render(&state.method, &picture) {
        state.home = scene.camera_or_framing();
        state.orbit = Orbit::from_camera(&state.home);
        state.camera_path = scene.camera_path.clone();
        state.playing = false;
    }
    // A scene that does not load fails in the viewport, which keeps the last one and says why.
    state.picture = picture;
}

/// Saves the render target as `strata-view-N.png` in the current directory.
fn save_screenshot(viewport: &Viewport) -> Result<PathBuf> {
    let image = viewport.read_target()?;
    let path = (1..100000)
        .map(|n| PathBuf::from(format!("strata-view-{n:03}.png")))
        .find(|p| !p.exists())
        .ok_or_else(|| Error::runtime("no free strata-view-N.png name here"))?;
    strata::render::save_png(&image, &path)?;
    Ok(path)
}

/// Reads the current picture back and renders the same view with the CPU reference on a
/// worker thread.
fn start_compare(gfx: &Gfx, compare: &mut Option<CompareJob>, panel: &mut Panel) {
    let image = match gfx.viewport.comparable_picture() {
        Ok(image) => image,
        Err(e) => {
            panel.compare = CompareStatus::Failed(e.to_string());
            return;
        }
    };
    let (scene, options) = gfx.viewport.picture();
    let (send, result) = mpsc::channel();
    std::thread::spawn(move || {
        let rendered = strata::reference::render(&scene, &options)
            .map(|(image, _)| image.to_rgba8(options.frame.effect));
        let _ = send.send(rendered);
    });
    *compare = Some(CompareJob::Running {
        started: Instant::now(),
        image,
        result,
    });
    panel.compare = CompareStatus::Running { seconds: 0.0 };
}

fn poll_compare(gfx: &Gfx, compare: &mut Option<CompareJob>, panel: &mut Panel) {
    let Some(CompareJob::Running {
        started,
        image,
        result,
    }) = compare.as_ref()
    else {
        return;
    };
    let reference = match result.try_recv() {
        Err(mpsc::TryRecvError::Empty) => {
            panel.compare = CompareStatus::Running {
                seconds: started.elapsed().as_secs_f32(),
            };
            return;
        }
        Err(mpsc::TryRecvError::Disconnected) => {
            Err(Error::runtime("the reference render stopped"))
        }
        Ok(r) => r,
    };
    let done = reference.and_then(|reference| {
        let c = strata::metrics::compare(image, &reference)?;
        let diff = strata::metrics::diff_heatmap(image, &reference);
        Ok((c, reference, diff))
    });
    match done {
        Ok((c, reference, diff)) => {
            panel.compare = CompareStatus::Done {
                rmse: c.rmse,
                flip: c.flip_mean,
                pct_over_2: c.pct_over_2,
                stale: false,
            };
            *compare = Some(CompareJob::Done {
                reference: viewport::image_texture(&gfx.gpu, "strata.view.reference", &reference),
                diff: viewport::image_texture(&gfx.gpu, "strata.view.diff", &diff),
            });
        }
        Err(e) => {
            panel.compare = CompareStatus::Failed(e.to_string());
            *compare = None;
        }
    }
}
