//! The application's own transparent geometry and shaders.
//!
//! A renderer with its own vertex format, bind groups and materials hands strata its shader
//! ([`AppShader`]: WGSL source, entry points, vertex buffer layouts, its bind group layouts), and
//! strata builds the pipeline of every geometry pass of the method from it: the application's
//! vertex stage, and its fragment stage calling the method's capture for that pass. Each frame the
//! recorder calls the application back once per geometry pass (the draw callback of
//! [`crate::FrameRecorder::record`]) to set its own bind groups and vertex buffers and draw.
//!
//! The application's fragment stage computes its colour and calls `strata_capture`:
//!
//! ```wgsl
//! @fragment
//! fn fs_transparent(v: Varying, @builtin(front_facing) front_facing: bool,
//!                   @builtin(sample_mask) sample_mask: u32) -> StrataOut {
//!     let premultiplied = vec4<f32>(v.color.rgb * v.color.a, v.color.a);
//!     return strata_capture(v.position, premultiplied, v.triangle, front_facing, sample_mask);
//! }
//! ```
//!
//! strata appends the definition of `strata_capture` and `StrataOut` for each pass (never write
//! them yourself):
//! - `position`: the fragment's `@builtin(position)`; the vertex stage's position must be
//!   `@invariant`, since a method's passes compare depths across pipelines;
//! - `premultiplied`: its linear colour with premultiplied alpha;
//! - `id`: orders fragments at exactly equal depth in one pixel (give each triangle its own,
//!   such as its index; with `--msaa S` it must stay below 2^(31 − S));
//! - `front_facing`, `sample_mask`: the fragment's builtins. On wgpu's GL backend naga's GLSL
//!   output cannot read `@builtin(sample_mask)` (wgpu 30): declare no such parameter there and
//!   pass `1u`, the single-sampled mask (GL takes no `--msaa`; `strata methods --backend gl`).
//!
//! The capture tests the opaque depth ([`crate::frame::FrameTargets::opaque_depth`]) itself,
//! so the picture is right whatever depth state the application would have chosen: strata's
//! passes have no depth attachment, and a fragment at or behind the opaque depth is never
//! stored. Your bind groups keep their numbers (`@group(0)` …); strata's follow them, so your
//! groups and strata's (up to three) must fit the device's `max_bind_groups`.
//!
//! The pieces strata composes are checked when the recorder is made: a shader that does not
//! parse with the capture appended, a missing entry point, a position that is not invariant, a
//! fragment stage that never calls `strata_capture`, or too many bind groups is a one-line
//! error naming what is wrong.

use std::borrow::Cow;

use crate::error::{Error, Result};
use crate::gpu::shader::{capture_entries, color_entries, Defs, Stage};
use crate::gpu::Gpu;
use crate::scene::{Camera, Projection};

/// The camera an application's recorder starts with. strata never transforms the
/// application's vertices; its camera only turns a window depth into a view distance, which the
/// weighted methods' weights read (`--weight eq7..eq9`): orthographic from 0 to 1, the distance
/// is the window depth itself. An application with a perspective projection gives its own
/// near and far planes with [`crate::FrameRecorder::set_camera`] (a [`Camera`] whose
/// `projection` is perspective: only `projection`, `near` and `far` are read).
pub fn depth_camera() -> Camera {
    Camera {
        eye: glam::Vec3::Z,
        target: glam::Vec3::ZERO,
        up: glam::Vec3::Y,
        projection: Projection::Orthographic { height: 2.0 },
        near: 0.0,
        far: 1.0,
    }
}

/// The capture function strata defines for the application's fragment stage.
pub const CAPTURE_FUNCTION: &str = "strata_capture";
/// The type `strata_capture` returns, which the application's fragment stage returns.
pub const CAPTURE_OUTPUT: &str = "StrataOut";

/// One vertex buffer of the application's vertex stage (an owned [`wgpu::VertexBufferLayout`]).
#[derive(Clone, Debug)]
pub struct VertexLayout {
    /// Bytes between consecutive elements.
    pub array_stride: u64,
    /// Per vertex or per instance.
    pub step_mode: wgpu::VertexStepMode,
    /// The attributes of one element.
    pub attributes: Vec<wgpu::VertexAttribute>,
}

impl VertexLayout {
    /// A per-vertex buffer of `array_stride` bytes with `attributes` (as
    /// `wgpu::vertex_attr_array!` makes them).
    pub fn new(array_stride: u64, attributes: &[wgpu::VertexAttribute]) -> VertexLayout {
        VertexLayout {
            array_stride,
            step_mode: wgpu::VertexStepMode::Vertex,
            attributes: attributes.to_vec(),
        }
    }

    fn as_wgpu(&self) -> wgpu::VertexBufferLayout<'_> {
        wgpu::VertexBufferLayout {
            array_stride: self.array_stride,
            step_mode: self.step_mode,
            attributes: &self.attributes,
        }
    }
}

/// The application's shader for its transparent geometry (see the module docs).
#[derive(Clone, Debug)]
pub struct AppShader {
    /// Plain WGSL: the vertex stage and the fragment stage that calls `strata_capture`.
    pub source: String,
    /// The vertex entry point.
    pub vertex_entry: String,
    /// The fragment entry point; it returns `StrataOut`.
    pub fragment_entry: String,
    /// The vertex buffers the vertex stage reads, slot by slot.
    pub vertex_buffers: Vec<VertexLayout>,
    /// The layouts of the application's bind groups, `@group(0)` upwards; strata's groups
    /// follow them.
    pub bind_group_layouts: Vec<wgpu::BindGroupLayout>,
    /// Topology, winding and culling of the transparent geometry (no culling by default: every
    /// surface layer counts).
    pub primitive: wgpu::PrimitiveState,
}

impl AppShader {
    /// The shader `source` with its vertex and fragment entry points, no vertex buffers and no
    /// bind groups yet.
    pub fn new(
        source: impl Into<String>,
        vertex_entry: impl Into<String>,
        fragment_entry: impl Into<String>,
    ) -> AppShader {
        AppShader {
            source: source.into(),
            vertex_entry: vertex_entry.into(),
            fragment_entry: fragment_entry.into(),
            vertex_buffers: Vec::new(),
            bind_group_layouts: Vec::new(),
            primitive: wgpu::PrimitiveState {
                cull_mode: None,
                ..Default::default()
            },
        }
    }

    /// Adds the vertex buffer of the next slot.
    pub fn vertex_buffer(mut self, layout: VertexLayout) -> AppShader {
        self.vertex_buffers.push(layout);
        self
    }

    /// Adds the layout of the application's next bind group.
    pub fn bind_group_layout(mut self, layout: &wgpu::BindGroupLayout) -> AppShader {
        self.bind_group_layouts.push(layout.clone());
        self
    }

    /// The bind group index of strata's first group: the number of the application's groups.
    pub fn first_strata_group(&self) -> u32 {
        self.bind_group_layouts.len() as u32
    }
}

/// The stage that defines `strata_capture` for the fragment stage `entry` of `stage` (a library
/// module declaring its step, as `crate::raster::capture_stage` reads it): a storage-only
/// capture step `{entry}_capture`, or a colour step `{entry}_step` whose outputs
/// `strata_capture` returns. The application's colour reaches the step through `shade`
/// (`APP_SHADING` in scene.wgsl), its position and id through the varying the step reads.
pub fn capture_stage(stage: &Stage, entry: &str) -> Result<Stage> {
    let storage = capture_entries(stage.source()).any(|e| e == entry);
    let color = color_entries(stage.source()).find(|(e, _)| *e == entry);
    let (step, out, storage_out) = match (storage, color) {
        (true, _) => (
            format!("{entry}_capture"),
            "StrataStorageOut",
            "// Nothing reaches the pass's target: the capture writes storage.\nstruct StrataStorageOut {\n    @location(0) unused: vec4<f32>,\n}\n",
        ),
        (false, Some((_, out))) => (format!("{entry}_step"), out, ""),
        (false, None) => {
            return Err(Error::unsupported(format!(
                "{}: {entry} declares no step an application's shader can call",
                stage.label
            )))
        }
    };
    let module = stage.module_name().ok_or_else(|| {
        Error::unsupported(format!(
            "{}: the stage names no module to import {step} from",
            stage.label
        ))
    })?;
    let (import, call) = match storage {
        true => (
            step.clone(),
            format!("{step}(v, front_facing, sample_mask);\n    return {out}(vec4<f32>(0.0));"),
        ),
        false => (
            format!("{step}, {out}"),
            format!("return {step}(v, front_facing, sample_mask);"),
        ),
    };
    let bridge = format!(
        "#import strata::scene::{{SceneVarying, set_app_surface}}
#import {module}::{{{import}}}

{storage_out}
// The application's fragment, handed to strata's step for this pass.
fn {CAPTURE_FUNCTION}(position: vec4<f32>, premultiplied: vec4<f32>, id: u32, front_facing: bool, sample_mask: u32) -> {out} {{
    let a = premultiplied.a;
    set_app_surface(vec4<f32>(select(vec3<f32>(0.0), premultiplied.rgb / a, a > 0.0), a));
    var v: SceneVarying;
    v.position = position;
    v.world = vec3<f32>(0.0);
    v.normal = vec3<f32>(0.0, 0.0, 1.0);
    v.prim = id;
    v.material = 0u;
    {call}
}}
"
    );
    let mut bridge = Stage::new(format!("{}.application", stage.label), bridge)
        .defs(stage.definitions())
        .defs(&Defs::default().flag("APP_SHADING"));
    // A stage made at run time (bucket's sort, sized by its targets) is no library's module:
    // the bridge registers it.
    let in_library = stage
        .libraries()
        .iter()
        .any(|library| library.contains(&stage.source()));
    if !in_library {
        bridge = bridge.with_module(stage.source().to_string());
    }
    Ok(stage
        .libraries()
        .iter()
        .fold(bridge, |bridge, library| bridge.with(library)))
}

/// What an application pass's pipeline is made of besides the shader: strata's bind group
/// layouts (placed after the application's), whether its atomics need acquire/release order,
/// and the pass's targets.
pub struct PassPipeline<'a> {
    /// Labels the pipeline.
    pub label: &'a str,
    /// strata's layouts, in the order its stage declares them (`@group(0)` upwards).
    pub layouts: &'a [&'a wgpu::BindGroupLayout],
    /// The capture orders its lock or links ([`crate::gpu::ordered`]).
    pub ordered: bool,
    /// The pass's colour targets.
    pub targets: &'a [Option<wgpu::ColorTargetState>],
    /// The pass's depth attachment's state (peeling's and stochastic's depth tests).
    pub depth: Option<wgpu::DepthStencilState>,
    /// Samples per pixel (`--msaa`).
    pub samples: u32,
}

/// The render pipeline of one geometry pass: the application's shader with `capture` (a stage
/// from [`capture_stage`]) appended, strata's groups moved after the application's.
pub fn pipeline(
    gpu: &Gpu,
    app: &AppShader,
    capture: &Stage,
    pass: &PassPipeline<'_>,
) -> Result<wgpu::RenderPipeline> {
    let groups = app.bind_group_layouts.len() + pass.layouts.len();
    let max = gpu.limits.max_bind_groups as usize;
    if groups > max {
        return Err(Error::unsupported(format!(
            "the application's shader uses {} bind groups and {} needs {} more, over the device's max_bind_groups of {max}",
            app.bind_group_layouts.len(),
            pass.label,
            pass.layouts.len()
        )));
    }
    let module = composed(app, capture)?;
    let label = pass.label;
    // The fragment stage with ordered atomics is SPIR-V passed through; the vertex stage stays
    // wgpu's own translation, which places the picture's y axis as wgpu does.
    let fragment = match pass.ordered && crate::gpu::ordered::available(gpu) {
        true => {
            let compiled = crate::gpu::ordered::spirv_of(label, &module).map_err(|e| {
                Error::runtime(format!(
                    "{label}: the application's shader with ordered atomics: {e}"
                ))
            })?;
            Some(crate::gpu::ordered::passthrough(gpu, label, compiled))
        }
        false => None,
    };
    let shader = gpu
        .device
        .create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some(label),
            source: wgpu::ShaderSource::Naga(Cow::Owned(module)),
        });
    let layouts: Vec<Option<&wgpu::BindGroupLayout>> = app
        .bind_group_layouts
        .iter()
        .chain(pass.layouts.iter().copied())
        .map(Some)
        .collect();
    let layout = gpu
        .device
        .create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some(label),
            bind_group_layouts: &layouts,
            immediate_size: 0,
        });
    let buffers: Vec<Option<wgpu::VertexBufferLayout<'_>>> = app
        .vertex_buffers
        .iter()
        .map(|b| Some(b.as_wgpu()))
        .collect();
    Ok(gpu
        .device
        .create_render_pipeline(&wgpu::RenderPipelineDescriptor {
            label: Some(label),
            layout: Some(&layout),
            vertex: wgpu::VertexState {
                module: &shader,
                entry_point: Some(&app.vertex_entry),
                compilation_options: Default::default(),
                buffers: &buffers,
            },
            primitive: app.primitive,
            depth_stencil: pass.depth.clone(),
            multisample: wgpu::MultisampleState {
                count: pass.samples,
                ..Default::default()
            },
            fragment: Some(wgpu::FragmentState {
                module: fragment.as_ref().unwrap_or(&shader),
                entry_point: Some(&app.fragment_entry),
                compilation_options: Default::default(),
                targets: pass.targets,
            }),
            multiview_mask: None,
            cache: None,
        }))
}

/// The application's source with `capture` written after it, strata's bind groups renumbered
/// to follow the application's, parsed and checked.
pub fn composed(app: &AppShader, capture: &Stage) -> Result<naga::Module> {
    let mut strata = capture
        .compose()
        .map_err(|e| Error::runtime(format!("{}: {e}", capture.label)))?;
    let first = app.first_strata_group();
    for (_, global) in strata.global_variables.iter_mut() {
        if let Some(binding) = &mut global.binding {
            binding.group += first;
        }
    }
    let info = validator()
        .validate(&strata)
        .map_err(|e| Error::runtime(format!("{}: {e}", capture.label)))?;
    let capture_wgsl =
        naga::back::wgsl::write_string(&strata, &info, naga::back::wgsl::WriterFlags::empty())
            .map_err(|e| Error::runtime(format!("{}: {e}", capture.label)))?;
    let output = output_name(&capture_wgsl).ok_or_else(|| {
        Error::runtime(format!(
            "{}: the capture defines no {CAPTURE_FUNCTION} returning a struct",
            capture.label
        ))
    })?;
    let source = format!(
        "{}\n\n// strata's capture for this pass (appended by strata)\n{capture_wgsl}\nalias {CAPTURE_OUTPUT} = {output};\n",
        app.source
    );
    let module = naga::front::wgsl::parse_str(&source).map_err(|e| {
        let line = e
            .location(&source)
            .map(|l| format!(" (line {})", l.line_number))
            .unwrap_or_default();
        Error::input(format!(
            "the application's shader does not parse with strata's capture appended{line}: {}",
            e.message()
        ))
    })?;
    validator().validate(&module).map_err(|e| {
        Error::input(format!(
            "the application's shader with strata's capture appended is invalid: {}",
            e.as_inner()
        ))
    })?;
    check_entries(app, &module)?;
    Ok(module)
}

/// The name the written capture gives the struct `strata_capture` returns (the step's output,
/// named as its module's decorated name).
fn output_name(capture_wgsl: &str) -> Option<String> {
    let module = naga::front::wgsl::parse_str(capture_wgsl).ok()?;
    let (_, function) = module
        .functions
        .iter()
        .find(|(_, f)| f.name.as_deref() == Some(CAPTURE_FUNCTION))?;
    module.types[function.result.as_ref()?.ty].name.clone()
}

fn validator() -> naga::valid::Validator {
    naga::valid::Validator::new(
        naga::valid::ValidationFlags::all(),
        naga::valid::Capabilities::all(),
    )
}

/// The entry points exist with their stages, the position is invariant, and something calls
/// `strata_capture`.
fn check_entries(app: &AppShader, module: &naga::Module) -> Result<()> {
    let entry = |name: &str, stage: naga::ShaderStage| {
        module
            .entry_points
            .iter()
            .find(|e| e.name == name && e.stage == stage)
            .ok_or_else(|| {
                Error::input(format!(
                    "the application's shader has no {stage:?} entry point '{name}'"
                ))
            })
    };
    let vertex = entry(&app.vertex_entry, naga::ShaderStage::Vertex)?;
    entry(&app.fragment_entry, naga::ShaderStage::Fragment)?;
    let position_invariant = |binding: &Option<naga::Binding>| {
        matches!(
            binding,
            Some(naga::Binding::BuiltIn(naga::BuiltIn::Position {
                invariant: true
            }))
        )
    };
    let invariant = match &vertex.function.result {
        Some(result) => match &module.types[result.ty].inner {
            naga::TypeInner::Struct { members, .. } => {
                members.iter().any(|m| position_invariant(&m.binding))
            }
            _ => position_invariant(&result.binding),
        },
        None => false,
    };
    if !invariant {
        return Err(Error::input(format!(
            "the application's vertex stage '{}' must write @builtin(position) @invariant: strata's passes compare a fragment's depth across pipelines",
            app.vertex_entry
        )));
    }
    let capture = module
        .functions
        .iter()
        .find(|(_, f)| f.name.as_deref() == Some(CAPTURE_FUNCTION))
        .map(|(h, _)| h);
    let calls = |f: &naga::Function| {
        f.expressions
            .iter()
            .any(|(_, e)| matches!(e, naga::Expression::CallResult(h) if Some(*h) == capture))
    };
    let called = module.functions.iter().any(|(_, f)| calls(f))
        || module.entry_points.iter().any(|e| calls(&e.function));
    if !called {
        return Err(Error::input(format!(
            "the application's fragment stage '{}' never calls {CAPTURE_FUNCTION}: nothing would be captured",
            app.fragment_entry
        )));
    }
    Ok(())
}
