//! The viewer's egui panel: every option of `strata render` (greyed out where the method does
//! not read it), the live statistics, the reference comparison, and the mouse and keys of the
//! 3D area.

use std::collections::BTreeMap;

use egui::{Color32, Key, PointerButton, Sense, Stroke};
use strata::frame::{FrameStats, Raster};
use strata::methods::MethodId;
use strata::scene::Shading;

use super::state::{applies, families, value_name, Opt, ViewState};
use crate::args::{BackgroundArg, KArg, MethodArg};
use crate::{PipelineArg, Toggle};

/// Width of the panel, points.
pub const PANEL_WIDTH: f32 = 340.0;

/// What the window shows in its 3D area.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Shown {
    Image,
    Reference,
    Diff,
}

/// Asked of the window by the panel or the keys.
#[derive(Clone, Debug, PartialEq)]
pub enum Action {
    Screenshot,
    Compare,
    LoadScene(String),
}

/// The comparison with the reference as the panel shows it.
#[derive(Default)]
pub enum CompareStatus {
    #[default]
    Idle,
    Running {
        seconds: f32,
    },
    Done {
        rmse: f64,
        flip: f64,
        pct_over_2: f64,
        stale: bool,
    },
    Failed(String),
}

/// The panel's own state between frames.
pub struct Panel {
    pub scene_text: String,
    /// The last message (text, whether it is an error).
    pub message: Option<(String, bool)>,
    /// CPU time between frames, smoothed, ms.
    pub frame_ms: f32,
    pub shown: Shown,
    pub compare: CompareStatus,
}

/// What the panel reads of the frame.
pub struct Readouts<'a> {
    pub history: &'a std::collections::VecDeque<FrameStats>,
    pub histogram: Option<&'a [u64]>,
    pub target_size: (u32, u32),
}

impl Panel {
    pub fn new(scene: &str) -> Panel {
        Panel {
            scene_text: scene.to_string(),
            message: None,
            frame_ms: 0.0,
            shown: Shown::Image,
            compare: CompareStatus::Idle,
        }
    }
}

/// Draws the panel and the 3D area; returns the actions asked for and the 3D area (points).
pub fn show(
    ui: &mut egui::Ui,
    state: &mut ViewState,
    panel: &mut Panel,
    readouts: &Readouts<'_>,
) -> (Vec<Action>, egui::Rect) {
    let mut actions = Vec::new();
    egui::Panel::left("strata.view.panel")
        .exact_size(PANEL_WIDTH)
        .resizable(false)
        .show(ui, |ui| {
            egui::ScrollArea::vertical().show(ui, |ui| {
                controls(ui, state, panel, readouts, &mut actions);
            });
        });
    let area = egui::CentralPanel::no_frame()
        .show(ui, |ui| {
            let rect = ui.max_rect();
            let response = ui.interact(rect, ui.scope_id().with("3d"), Sense::click_and_drag());
            navigate(ui, state, &response, rect);
            rect
        })
        .inner;
    if !ui.ctx().egui_wants_keyboard_input() {
        keys(ui, state, &mut actions);
    }
    (actions, area)
}

fn navigate(ui: &egui::Ui, state: &mut ViewState, response: &egui::Response, rect: egui::Rect) {
    let d = response.drag_delta();
    if response.dragged_by(PointerButton::Primary) && !ui.input(|i| i.modifiers.shift) {
        state.orbit.rotate(d.x, d.y);
    } else if response.dragged_by(PointerButton::Secondary)
        || response.dragged_by(PointerButton::Middle)
        || response.dragged_by(PointerButton::Primary)
    {
        state.orbit.pan(d.x, d.y, rect.height());
    }
    if response.hovered() {
        let scroll = ui.input(|i| i.smooth_scroll_delta.y);
        if scroll != 0.0 {
            state.orbit.zoom(scroll / 50.0);
        }
    }
    if response.double_clicked() {
        state.reset_view();
    }
}

fn keys(ui: &egui::Ui, state: &mut ViewState, actions: &mut Vec<Action>) {
    ui.input(|i| {
        let step = 300.0 * i.stable_dt.min(0.1);
        let held = |k| i.key_down(k);
        let (mut dx, mut dy) = (0.0, 0.0);
        if held(Key::ArrowLeft) || held(Key::A) {
            dx -= step;
        }
        if held(Key::ArrowRight) || held(Key::D) {
            dx += step;
        }
        if held(Key::ArrowUp) || held(Key::W) {
            dy -= step;
        }
        if held(Key::ArrowDown) || held(Key::S) {
            dy += step;
        }
        if dx != 0.0 || dy != 0.0 {
            state.orbit.rotate(dx, dy);
        }
        if held(Key::Plus) || held(Key::Equals) || held(Key::PageUp) {
            state.orbit.zoom(step / 100.0);
        }
        if held(Key::Minus) || held(Key::PageDown) {
            state.orbit.zoom(-step / 100.0);
        }
        if i.key_pressed(Key::R) {
            state.reset_view();
        }
        if i.key_pressed(Key::Space) && state.animated() {
            state.playing = !state.playing;
        }
        if i.key_pressed(Key::Period) && state.animated() {
            state.set_time(state.time() + 1.0);
        }
        if i.key_pressed(Key::P) || i.key_pressed(Key::F12) {
            actions.push(Action::Screenshot);
        }
    });
}

fn controls(
    ui: &mut egui::Ui,
    state: &mut ViewState,
    panel: &mut Panel,
    readouts: &Readouts<'_>,
    actions: &mut Vec<Action>,
) {
    ui.heading("strata view");
    if let Some((text, error)) = &panel.message {
        let color = if *error {
            Color32::from_rgb(230, 90, 80)
        } else {
            ui.visuals().text_color()
        };
        ui.colored_label(color, text);
    }
    ui.horizontal(|ui| {
        ui.add(egui::TextEdit::singleline(&mut panel.scene_text).desired_width(220.0));
        if ui.button("Load").clicked() {
            actions.push(Action::LoadScene(panel.scene_text.trim().to_string()));
        }
    });
    egui::CollapsingHeader::new("Method")
        .default_open(true)
        .show(ui, |ui| method_controls(ui, state));
    egui::CollapsingHeader::new("Picture and camera").show(ui, |ui| {
        picture_controls(ui, state, readouts);
        camera_controls(ui, state);
    });
    egui::CollapsingHeader::new("Lighting").show(ui, |ui| lighting_controls(ui, state));
    if state.animated() {
        animation_controls(ui, state);
    }
    ui.separator();
    statistics(ui, panel, readouts);
    ui.separator();
    compare_controls(ui, panel, actions);
    ui.separator();
    ui.horizontal(|ui| {
        if ui.button("Screenshot (P)").clicked() {
            actions.push(Action::Screenshot);
        }
        ui.checkbox(&mut state.histogram, "depth histogram");
    });
    ui.label("View as command:");
    let mut line = state.command_line();
    ui.add(
        egui::TextEdit::multiline(&mut line)
            .desired_rows(3)
            .font(egui::TextStyle::Monospace),
    );
    ui.small("Drag: orbit · right/shift-drag: pan · wheel, +/-: zoom · arrows/WASD: orbit · R or double-click: reset · Space: play · . : step · P/F12: screenshot");
}

/// A combo box over a clap value enum.
fn choice<T: clap::ValueEnum + PartialEq + Clone>(ui: &mut egui::Ui, label: &str, value: &mut T) {
    egui::ComboBox::from_label(label)
        .selected_text(value_name(value))
        .show_ui(ui, |ui| {
            for v in T::value_variants() {
                ui.selectable_value(value, v.clone(), value_name(v));
            }
        });
}

/// An optional number: a checkbox to give it, the number when given.
fn optional<T: egui::emath::Numeric>(
    ui: &mut egui::Ui,
    label: &str,
    value: &mut Option<T>,
    default: T,
    range: std::ops::RangeInclusive<T>,
) {
    ui.horizontal(|ui| {
        let mut on = value.is_some();
        ui.checkbox(&mut on, label);
        let mut v = value.unwrap_or(default);
        ui.add_enabled(on, egui::DragValue::new(&mut v).range(range));
        *value = on.then_some(v);
    });
}

/// A family option's widget, as its spec describes its values.
fn option_widget(
    ui: &mut egui::Ui,
    flag: &strata::methods::options::Flag,
    value: strata::methods::options::FlagValue,
    frame: &mut strata::frame::FrameOptions,
) {
    use strata::methods::options::ValueKind;
    let label = flag.name().replace('-', " ");
    let current = (value.get)(frame);
    // A value the spec offers always sets; the refusal of one is a bug the spec's tests catch.
    let mut set = |text: Option<String>| {
        if text != current {
            let _ = (value.set)(frame, text.as_deref());
        }
    };
    match value.kind {
        ValueKind::Choice(words) => {
            let mut chosen = current.clone().unwrap_or_default();
            egui::ComboBox::from_label(label)
                .selected_text(chosen.clone())
                .show_ui(ui, |ui| {
                    for w in words {
                        ui.selectable_value(&mut chosen, w.to_string(), *w);
                    }
                });
            set(Some(chosen));
        }
        ValueKind::Count { min, max } => {
            let mut n: u32 = current
                .as_deref()
                .and_then(|t| t.parse().ok())
                .unwrap_or(min);
            ui.horizontal(|ui| {
                ui.label(label);
                ui.add(egui::DragValue::new(&mut n).range(min..=max));
            });
            set(Some(n.to_string()));
        }
        ValueKind::Optional { min, max, start } => {
            let mut n = current.as_deref().and_then(|t| t.parse().ok());
            optional(ui, &label, &mut n, start, min..=max);
            set(n.map(|n: u32| n.to_string()));
        }
        ValueKind::Number { min, max } => {
            let mut x: f64 = current
                .as_deref()
                .and_then(|t| t.parse().ok())
                .unwrap_or(min);
            ui.horizontal(|ui| {
                ui.label(label);
                ui.add(egui::DragValue::new(&mut x).range(min..=max));
            });
            set(Some(x.to_string()));
        }
    }
}

fn method_controls(ui: &mut egui::Ui, state: &mut ViewState) {
    let m = &mut state.method;
    let pipeline = state.picture.pipeline;
    egui::ComboBox::from_label("method")
        .selected_text(m.id().as_str())
        .height(600.0)
        .show_ui(ui, |ui| {
            for (family, ids) in families() {
                ui.label(egui::RichText::new(family).strong());
                for id in ids {
                    ui.selectable_value(&mut m.method, MethodArg::Id(id), format!("  {id}"));
                }
            }
        });
    let id = m.id();
    // A method that cannot take MSAA renders single-sampled rather than failing.
    if !applies(Opt::Msaa, id, pipeline) || m.raster != Raster::Hw {
        state.picture.msaa = 1;
    }
    ui.add_enabled_ui(applies(Opt::RasterCompute, id, pipeline), |ui| {
        choice(ui, "raster", &mut m.raster);
    });
    ui.add_enabled_ui(
        applies(Opt::Msaa, id, pipeline) && m.raster == Raster::Hw,
        |ui| {
            let msaa = &mut state.picture.msaa;
            egui::ComboBox::from_label("MSAA samples")
                .selected_text(msaa.to_string())
                .show_ui(ui, |ui| {
                    for n in strata::frame::msaa::SAMPLE_COUNTS {
                        ui.selectable_value(msaa, n, n.to_string());
                    }
                });
        },
    );
    ui.add_enabled_ui(applies(Opt::K, id, pipeline), |ui| {
        let k = &mut state.picture.k;
        ui.horizontal(|ui| {
            let mut auto = *k == Some(KArg::Auto);
            let mut n: u32 = match *k {
                Some(KArg::Count(n)) => n,
                _ => id.descriptor().default_k,
            };
            let bucket = id == MethodId::Bucket;
            let label = if id == MethodId::Kpeel {
                "k (layers per pass)"
            } else if bucket {
                "k (two per bucket)"
            } else {
                "k"
            };
            ui.label(label);
            if bucket {
                // bucket takes even k up to its 32-bit claim word (--k auto does not apply).
                auto = false;
                ui.add(egui::DragValue::new(&mut n).range(2..=32));
                n = n / 2 * 2;
            } else {
                let max = id.descriptor().max_k.min(256);
                ui.add_enabled(!auto, egui::DragValue::new(&mut n).range(1..=max));
                ui.checkbox(&mut auto, "auto");
            }
            let new = Some(if auto { KArg::Auto } else { KArg::Count(n) });
            if new != *k && (k.is_some() || n != id.descriptor().default_k || auto) {
                *k = new;
            }
        });
    });
    ui.add_enabled_ui(applies(Opt::Budget, id, pipeline), |ui| {
        optional(ui, "budget MiB", &mut m.budget_mb, 64.0, 0.01..=65536.0);
        if state.picture.k == Some(KArg::Auto) {
            optional(ui, "robustness", &mut m.robustness, 0.95, 0.01..=1.0);
        }
    });
    // Each family option's widget from its spec (`strata::methods::options`), enabled where
    // the method reads it with these options (`Descriptor::reads_with`).
    let family = &mut m.family.frame;
    for (flag, option) in strata::methods::options::flags() {
        let enabled = id.descriptor().reads_with(option, family);
        if let Some(value) = flag.value {
            ui.add_enabled_ui(enabled, |ui| option_widget(ui, flag, value, family));
        }
    }
    ui.add_enabled_ui(applies(Opt::Temporal, id, pipeline), |ui| {
        ui.horizontal(|ui| {
            let mut on = m.temporal == Toggle::On;
            ui.checkbox(&mut on, "temporal culling");
            m.temporal = if on { Toggle::On } else { Toggle::Off };
            ui.add_enabled_ui(on, |ui| {
                ui.label("refresh");
                ui.add(egui::DragValue::new(&mut m.temporal_refresh).range(0..=256));
            });
        });
    });
    ui.add_enabled_ui(
        applies(Opt::Order, id, pipeline) && m.raster == Raster::Hw,
        |ui| {
            ui.horizontal(|ui| {
                let mut on = m.order.is_some();
                ui.checkbox(&mut on, "triangle order");
                let mut order = m.order.unwrap_or(strata::order::Order::Front);
                ui.add_enabled_ui(on, |ui| choice(ui, "", &mut order));
                m.order = on.then_some(order);
            });
            if m.order == Some(strata::order::Order::Random) {
                ui.horizontal(|ui| {
                    ui.label("seed");
                    ui.add(egui::DragValue::new(&mut m.seed));
                });
            }
        },
    );
}

fn picture_controls(ui: &mut egui::Ui, state: &mut ViewState, readouts: &Readouts<'_>) {
    let p = &mut state.picture;
    choice(ui, "effect", &mut p.effect);
    ui.horizontal(|ui| {
        let (mut w, mut h) = readouts.target_size;
        ui.label("size");
        ui.add(egui::DragValue::new(&mut w).range(1..=4096));
        ui.label("x");
        ui.add(egui::DragValue::new(&mut h).range(1..=4096));
        if (w, h) != readouts.target_size {
            p.size = Some(crate::Size::new(w, h));
        }
    });
    ui.horizontal(|ui| {
        let mut override_alpha = p.alpha.is_some();
        ui.checkbox(&mut override_alpha, "opacity");
        let mut a = p.alpha.unwrap_or(0.5);
        ui.add_enabled(override_alpha, egui::Slider::new(&mut a, 0.0..=1.0));
        p.alpha = override_alpha.then_some(a);
    });
    ui.horizontal(|ui| {
        ui.label("background");
        let (mut checker, mut color) = match p.background {
            None | Some(BackgroundArg::Checker) => (true, [32, 48, 64]),
            Some(BackgroundArg::Srgb(c)) => (false, c),
        };
        if ui.radio(checker, "checker").clicked() {
            checker = true;
            p.background = Some(BackgroundArg::Checker);
        }
        if ui.radio(!checker, "color").clicked() {
            checker = false;
            p.background = Some(BackgroundArg::Srgb(color));
        }
        if !checker && ui.color_edit_button_srgb(&mut color).changed() {
            p.background = Some(BackgroundArg::Srgb(color));
        }
    });
    egui::ComboBox::from_label("shading")
        .selected_text(p.shading.map_or("scene's".into(), |s| value_name(&s)))
        .show_ui(ui, |ui| {
            ui.selectable_value(&mut p.shading, None, "scene's");
            ui.selectable_value(&mut p.shading, Some(Shading::Unlit), "unlit");
            ui.selectable_value(&mut p.shading, Some(Shading::Lit), "lit");
        });
}

fn animation_controls(ui: &mut egui::Ui, state: &mut ViewState) {
    ui.horizontal(|ui| {
        let label = if state.playing { "Pause" } else { "Play" };
        if ui.button(label).clicked() {
            state.playing = !state.playing;
        }
        if ui.button("Step").clicked() {
            state.set_time(state.time() + 1.0);
        }
        let mut t = state.time();
        if ui
            .add(egui::Slider::new(&mut t, 0.0..=900.0).text("frame"))
            .changed()
        {
            state.set_time(t);
        }
    });
}

fn camera_controls(ui: &mut egui::Ui, state: &mut ViewState) {
    ui.horizontal(|ui| {
        if let strata::scene::Projection::Perspective { fov_y_deg } = state.home.projection {
            let mut fov = state.picture.camera.fov.unwrap_or(fov_y_deg);
            ui.label("field of view");
            if ui
                .add(egui::Slider::new(&mut fov, 5.0..=120.0).suffix("°"))
                .changed()
            {
                state.picture.camera.fov = Some(fov);
            }
        }
        if ui.button("Reset view").clicked() {
            state.reset_view();
        }
    });
}

fn lighting_controls(ui: &mut egui::Ui, state: &mut ViewState) {
    let p = &mut state.picture;
    let m = &mut state.method;
    choice(ui, "pipeline", p.pipeline.get_or_insert(PipelineArg::None));
    let pipeline = p.pipeline;
    let mut lights = p.lights.unwrap_or(0);
    ui.horizontal(|ui| {
        ui.label("added lights");
        ui.add(egui::DragValue::new(&mut lights).range(0..=4096));
    });
    p.lights = (lights > 0).then_some(lights);
    ui.add_enabled_ui(applies(Opt::Tonemap, m.id(), pipeline), |ui| {
        choice(ui, "tone map", &mut p.tonemap);
    });
    ui.add_enabled_ui(applies(Opt::Deferred, m.id(), pipeline), |ui| {
        ui.checkbox(&mut m.ssao, "SSAO");
        choice(ui, "normal encoding", &mut m.normal_encoding);
        egui::ComboBox::from_label("G-buffer view")
            .selected_text(
                m.gbuffer_debug
                    .map(|v| value_name(&v))
                    .unwrap_or("off".into()),
            )
            .show_ui(ui, |ui| {
                ui.selectable_value(&mut m.gbuffer_debug, None, "off");
                for v in <strata::frame::GbufferView as clap::ValueEnum>::value_variants() {
                    ui.selectable_value(&mut m.gbuffer_debug, Some(*v), value_name(v));
                }
            });
    });
    if pipeline != Some(PipelineArg::Deferred) {
        m.ssao = false;
        m.gbuffer_debug = None;
    }
}

fn statistics(ui: &mut egui::Ui, panel: &Panel, readouts: &Readouts<'_>) {
    let fps = if panel.frame_ms > 0.0 {
        1000.0 / panel.frame_ms
    } else {
        0.0
    };
    ui.label(format!("frame {:.2} ms · {fps:.1} fps", panel.frame_ms));
    let Some(s) = readouts.history.back() else {
        ui.label("statistics: waiting for the first frame");
        return;
    };
    let n = |v: Option<u64>| v.map(|v| v.to_string()).unwrap_or_else(|| "—".into());
    egui::Grid::new("strata.view.stats")
        .num_columns(2)
        .striped(true)
        .show(ui, |ui| {
            let mut row = |k: &str, v: String| {
                ui.label(k);
                ui.label(v);
                ui.end_row();
            };
            row("method", format!("{} ({} raster)", s.method, s.raster));
            row(
                "GPU total",
                s.gpu_ms_total
                    .map(|t| format!("{t:.3} ms"))
                    .unwrap_or_else(|| "untimed".into()),
            );
            row("geometry passes", n(Some(u64::from(s.geometry_passes))));
            row("k", n(s.k.map(u64::from)));
            row("fragments", n(s.fragments_generated));
            row("stored", n(s.fragments_stored));
            row("dropped", n(s.fragments_dropped));
            row("lock failures", n(s.lock_failures));
            if let Some(culled) = s.culled_temporal {
                row("culled (temporal)", culled.to_string());
            }
            if let (Some(order), Some(tau)) = (&s.order, s.kendall_tau) {
                row("order (Kendall τ)", format!("{order} ({tau:.3})"));
            }
            row(
                "overflow",
                s.overflow
                    .map(|o| if o { "yes" } else { "no" }.into())
                    .unwrap_or_else(|| "—".into()),
            );
            row(
                "memory",
                format!("{:.2} MiB", s.bytes_allocated as f64 / 1048576.0),
            );
            row(
                "max depth complexity",
                n(s.max_depth_complexity.map(u64::from)),
            );
            for (name, value) in family_rows(s) {
                row(&name, value);
            }
        });
    if let Some(t) = s.family::<strata::methods::tiled::TiledStats>() {
        egui::CollapsingHeader::new("tiles by rounds run (log)")
            .default_open(true)
            .show(ui, |ui| {
                histogram_chart(ui, &t.tile_rounds, "rounds", "tiles")
            });
    }
    if let Some(passes) = &s.gpu_ms {
        egui::CollapsingHeader::new("GPU ms per pass")
            .default_open(true)
            .show(ui, |ui| {
                egui::Grid::new("strata.view.passes")
                    .num_columns(2)
                    .show(ui, |ui| {
                        for (i, (name, ms)) in passes.iter().enumerate() {
                            ui.colored_label(series_color(i), name);
                            ui.label(format!("{ms:.3}"));
                            ui.end_row();
                        }
                    });
                pass_graph(ui, readouts, passes);
            });
    }
    if let Some(hist) = readouts.histogram {
        egui::CollapsingHeader::new("depth complexity (pixels per fragment count, log)")
            .default_open(true)
            .show(ui, |ui| histogram_chart(ui, hist, "fragments", "pixels"));
    }
}

/// A family's own statistics as rows (`tiled rounds`, `wavg opacity gap max`): each plain
/// field of its JSON, so that a family's new statistic shows with no line here (lists, such as
/// tiled's rounds per tile, get their charts below).
fn family_rows(s: &strata::FrameStats) -> Vec<(String, String)> {
    use serde_json::Value;
    let Some(stat) = s.family.as_ref().map(|f| f.stat()) else {
        return Vec::new();
    };
    let Value::Object(fields) = stat.to_json() else {
        return Vec::new();
    };
    fields
        .into_iter()
        .filter_map(|(name, value)| {
            let text = match value {
                Value::Number(n) if n.is_f64() => format!("{:.4}", n.as_f64()?),
                Value::Number(n) => n.to_string(),
                Value::Bool(b) => if b { "yes" } else { "no" }.to_string(),
                Value::String(text) => text,
                Value::Null => "—".to_string(),
                Value::Array(_) | Value::Object(_) => return None,
            };
            Some((format!("{} {}", stat.key(), name.replace('_', " ")), text))
        })
        .collect()
}

fn series_color(i: usize) -> Color32 {
    const COLORS: [Color32; 8] = [
        Color32::from_rgb(230, 159, 0),
        Color32::from_rgb(86, 180, 233),
        Color32::from_rgb(0, 158, 115),
        Color32::from_rgb(240, 228, 66),
        Color32::from_rgb(0, 114, 178),
        Color32::from_rgb(213, 94, 0),
        Color32::from_rgb(204, 121, 167),
        Color32::from_rgb(200, 200, 200),
    ];
    COLORS[i % COLORS.len()]
}

/// Each pass's GPU ms over the last frames, one line each, scrolling left.
fn pass_graph(ui: &mut egui::Ui, readouts: &Readouts<'_>, passes: &BTreeMap<String, f64>) {
    let size = egui::vec2(ui.available_width(), 90.0);
    let (response, painter) = ui.allocate_painter(size, Sense::hover());
    let rect = response.rect;
    painter.rect_filled(rect, 2.0, ui.visuals().extreme_bg_color);
    let history = readouts.history;
    let max = history
        .iter()
        .flat_map(|s| s.gpu_ms.iter().flat_map(|m| m.values()))
        .fold(0.0f64, |a, &b| a.max(b))
        .max(1e-3);
    let step = rect.width() / super::viewport::HISTORY as f32;
    for (i, name) in passes.keys().enumerate() {
        let points: Vec<egui::Pos2> = history
            .iter()
            .enumerate()
            .filter_map(|(j, s)| {
                let ms = *s.gpu_ms.as_ref()?.get(name)?;
                let x = rect.right() - (history.len() - 1 - j) as f32 * step;
                let y = rect.bottom() - (ms / max) as f32 * rect.height();
                Some(egui::pos2(x, y))
            })
            .collect();
        painter.add(egui::Shape::line(points, Stroke::new(1.5, series_color(i))));
    }
    painter.text(
        rect.left_top() + egui::vec2(4.0, 2.0),
        egui::Align2::LEFT_TOP,
        format!("{max:.3} ms"),
        egui::FontId::monospace(10.0),
        ui.visuals().weak_text_color(),
    );
}

/// Bars of `hist` on a log scale: bin i counts the `counted` (pixels, tiles) with i `binned`
/// (fragments, rounds).
fn histogram_chart(ui: &mut egui::Ui, hist: &[u64], binned: &str, counted: &str) {
    let size = egui::vec2(ui.available_width(), 80.0);
    let (response, painter) = ui.allocate_painter(size, Sense::hover());
    let rect = response.rect;
    painter.rect_filled(rect, 2.0, ui.visuals().extreme_bg_color);
    let bins = hist.len().max(1);
    let top = hist.iter().copied().max().unwrap_or(1).max(1) as f32;
    let w = rect.width() / bins as f32;
    for (i, &count) in hist.iter().enumerate().filter(|(_, &c)| c > 0) {
        let h = (1.0 + count as f32).ln() / (1.0 + top).ln() * rect.height();
        let x = rect.left() + i as f32 * w;
        painter.rect_filled(
            egui::Rect::from_min_max(
                egui::pos2(x, rect.bottom() - h),
                egui::pos2(x + w.max(1.0), rect.bottom()),
            ),
            0.0,
            Color32::from_rgb(86, 180, 233),
        );
    }
    ui.small(format!(
        "0 … {} {binned}; {} {counted} at the tallest bar",
        bins - 1,
        top as u64
    ));
}

fn compare_controls(ui: &mut egui::Ui, panel: &mut Panel, actions: &mut Vec<Action>) {
    ui.horizontal(|ui| {
        let running = matches!(panel.compare, CompareStatus::Running { .. });
        if ui
            .add_enabled(!running, egui::Button::new("Compare with reference"))
            .clicked()
        {
            actions.push(Action::Compare);
        }
        if let CompareStatus::Running { seconds } = panel.compare {
            ui.spinner();
            ui.label(format!("CPU reference… {seconds:.1} s"));
        }
    });
    match &panel.compare {
        CompareStatus::Done {
            rmse,
            flip,
            pct_over_2,
            stale,
        } => {
            ui.label(format!(
                "RMSE {rmse:.5} · FLIP {flip:.5} · {pct_over_2:.3}% pixels > 2/255"
            ));
            if *stale {
                ui.small("the view changed since: compare again");
            }
            ui.horizontal(|ui| {
                ui.radio_value(&mut panel.shown, Shown::Image, "image");
                ui.radio_value(&mut panel.shown, Shown::Reference, "reference");
                ui.radio_value(&mut panel.shown, Shown::Diff, "diff");
            });
        }
        CompareStatus::Failed(e) => {
            ui.colored_label(Color32::from_rgb(230, 90, 80), e);
        }
        _ => {}
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A family's statistics show as rows of their plain fields, whatever the family.
    #[test]
    fn family_statistics_show_as_rows() {
        use strata::methods::weighted::wavg::WavgStats;
        let stats = strata::FrameStats {
            family: Some(strata::frame::FamilyStats::new(WavgStats {
                opacity_gap_max: 0.25,
                opacity_gap_pixels: 7,
            })),
            ..Default::default()
        };
        let rows = super::family_rows(&stats);
        assert_eq!(
            rows,
            vec![
                ("wavg opacity gap max".to_string(), "0.2500".to_string()),
                ("wavg opacity gap pixels".to_string(), "7".to_string()),
            ]
        );
        assert!(super::family_rows(&strata::FrameStats::default()).is_empty());
    }

    /// Drawing the method controls with no input changes no option: each family option's widget,
    /// made from its spec, shows the value it was given and sets nothing.
    #[test]
    fn the_method_controls_leave_every_option_as_given() {
        for args in crate::view::state::tests::FAMILY_OPTIONS {
            let mut words = vec!["builtin:spheres"];
            words.extend_from_slice(args);
            let mut state = crate::view::state::tests::state(&words);
            let given = state.method.family.clone();
            let ctx = egui::Context::default();
            let output = ctx.run_ui(egui::RawInput::default(), |ui| {
                method_controls(ui, &mut state);
            });
            output.drop_without_applying_deltas();
            assert_eq!(state.method.family, given, "{args:?}");
        }
    }
}
