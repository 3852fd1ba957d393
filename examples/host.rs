//! An application that uses strata inside its own renderer: its own device and queue, its own
//! opaque pipeline and depth buffer, its own transparent meshes, vertex layout and shader whose
//! fragment stage calls strata's capture (strata builds each geometry pass's pipeline from it),
//! and strata resolving OVER its color target. Headless: it renders a few frames into an
//! offscreen texture and writes the last one as a PNG.
//!
//! ```sh
//! cargo run --release -p strata --example host -- host.png kb-ab-ll
//! ```
//!
//! The scene is `builtin:demo` with unlit materials (the application's shader does no
//! lighting): its opaque floor goes through the application's opaque pipeline, its transparent
//! models through strata's passes, made from the application's shader. `tests/host.rs` compares the picture
//! with strata's CPU reference of the same scene.

use std::borrow::Cow;

use strata::frame::application::{AppShader, VertexLayout};
use strata::frame::FrameTargets;
use strata::gpu::Gpu;
use strata::scene::{loaders, Background, Scene, Shading};
use strata::FrameRecorder;
use strata::{FrameStats, MethodId, RenderOptions};
use wgpu::util::DeviceExt;

/// The application's color target.
pub const COLOR_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba8UnormSrgb;
/// The application's background, sRGB `#203040`.
pub const BACKGROUND_SRGB: [u8; 3] = [0x20, 0x30, 0x40];

/// What a run produces: the application's picture, the last frame's statistics, and the scene
/// it drew (for the reference).
pub struct HostRun {
    pub picture: image::RgbaImage,
    pub stats: FrameStats,
    pub scene: Scene,
    pub background: Background,
}

/// The application's own vertex: position, straight (not premultiplied) linear color, and the
/// triangle's index in the scene (the tie-break strata's capture takes).
#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct AppVertex {
    position: [f32; 3],
    color: [f32; 4],
    triangle: u32,
}

/// The application's shader: its camera, vertex stage and opaque fragment stage.
const OPAQUE_SHADER: &str = "
struct Camera { view_proj: mat4x4<f32> }
@group(0) @binding(0) var<uniform> camera: Camera;

struct Varying {
    @builtin(position) @invariant position: vec4<f32>,
    @location(0) color: vec4<f32>,
    @location(1) @interpolate(flat) triangle: u32,
}

@vertex
fn vs_main(@location(0) position: vec3<f32>, @location(1) color: vec4<f32>, @location(2) triangle: u32) -> Varying {
    var out: Varying;
    out.position = camera.view_proj * vec4<f32>(position, 1.0);
    out.color = color;
    out.triangle = triangle;
    return out;
}

@fragment
fn fs_opaque(v: Varying) -> @location(0) vec4<f32> {
    return vec4<f32>(v.color.rgb, 1.0);
}
";

/// Its transparent fragment stage, appended to the same source for strata's passes.
const TRANSPARENT_FRAGMENT: &str = "
// The transparent surfaces: strata's capture stores them; strata defines strata_capture and
// StrataOut for each of its passes.
@fragment
fn fs_transparent(v: Varying, @builtin(front_facing) front_facing: bool, @builtin(sample_mask) mask: u32) -> StrataOut {
    let premultiplied = vec4<f32>(v.color.rgb * v.color.a, v.color.a);
    return strata_capture(v.position, premultiplied, v.triangle, front_facing, mask);
}
";

/// Renders `frames` frames of the demo at `size`² with `method`; returns the last picture.
pub fn run(method: MethodId, size: u32, frames: u32) -> strata::Result<HostRun> {
    let runtime = |e: String| strata::Error::runtime(e);
    // The application's own device: any adapter.
    let instance = wgpu::Instance::new(wgpu::InstanceDescriptor {
        backends: wgpu::Backends::from_env().unwrap_or(wgpu::Backends::VULKAN),
        ..wgpu::InstanceDescriptor::new_without_display_handle()
    });
    let adapter = pollster::block_on(instance.request_adapter(&Default::default()))
        .map_err(|e| strata::Error::unsupported(format!("no adapter: {e}")))?;
    // The features strata can use, as far as the adapter has them: 64-bit atomics (kb-keys),
    // SPIR-V passthrough (the ordered atomics of the locking k-buffers), timestamps.
    let (device, queue) = pollster::block_on(adapter.request_device(&wgpu::DeviceDescriptor {
        label: Some("host.device"),
        required_features: adapter.features() & strata::gpu::wanted_features(),
        required_limits: adapter.limits(),
        ..Default::default()
    }))
    .map_err(|e| runtime(format!("cannot open the device: {e}")))?;

    // The scene, split into what the application draws opaque and what goes through strata.
    let mut scene = loaders::load_scene("builtin:demo")?;
    scene.override_shading(Shading::Unlit);
    let camera = scene.camera_or_framing();
    scene.camera = Some(camera);
    let mut opaque_vertices = Vec::new();
    let mut transparent_vertices = Vec::new();
    let mut triangle = 0u32;
    for object in &scene.objects {
        let m = &scene.materials[object.material];
        let color = [m.color[0], m.color[1], m.color[2], m.opacity];
        let out = if m.opacity >= 1.0 {
            &mut opaque_vertices
        } else {
            &mut transparent_vertices
        };
        for t in object.mesh.indices.chunks_exact(3) {
            for &i in t {
                out.push(AppVertex {
                    position: object.mesh.positions[i as usize],
                    color,
                    triangle,
                });
            }
            triangle += 1;
        }
    }

    let gpu = Gpu::from_device(device.clone(), queue.clone());
    let background =
        Background::Color(BACKGROUND_SRGB.map(|c| strata::scene::srgb_to_linear(c as f32 / 255.0)));
    let mut options = RenderOptions::sized(size, size);
    options.frame.background = background;
    if method.descriptor().reads(strata::methods::options::K) {
        options.frame.k = Some(16);
    }

    // The application's resources: camera, vertex buffers, target and depth, two pipelines.
    let view_proj = camera.view_projection(1.0).to_cols_array();
    let camera_buffer = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
        label: Some("host.camera"),
        contents: bytemuck::cast_slice(&view_proj),
        usage: wgpu::BufferUsages::UNIFORM,
    });
    let buffer = |label: &str, v: &[AppVertex]| {
        device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some(label),
            contents: bytemuck::cast_slice(v),
            usage: wgpu::BufferUsages::VERTEX,
        })
    };
    let opaque_buffer = buffer("host.opaque", &opaque_vertices);
    let transparent_buffer = buffer("host.transparent", &transparent_vertices);
    let texture = |label: &str, format, usage| {
        device.create_texture(&wgpu::TextureDescriptor {
            label: Some(label),
            size: wgpu::Extent3d {
                width: size,
                height: size,
                depth_or_array_layers: 1,
            },
            mip_level_count: 1,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D2,
            format,
            usage,
            view_formats: &[],
        })
    };
    let color = texture(
        "host.color",
        COLOR_FORMAT,
        wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::COPY_SRC,
    );
    let color_view = color.create_view(&Default::default());
    let depth = texture(
        "host.depth",
        wgpu::TextureFormat::Depth32Float,
        // strata's passes read the opaque depth in their shaders.
        wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::TEXTURE_BINDING,
    );
    let depth_view = depth.create_view(&Default::default());

    let camera_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
        label: Some("host.camera"),
        entries: &[wgpu::BindGroupLayoutEntry {
            binding: 0,
            visibility: wgpu::ShaderStages::VERTEX,
            ty: wgpu::BindingType::Buffer {
                ty: wgpu::BufferBindingType::Uniform,
                has_dynamic_offset: false,
                min_binding_size: None,
            },
            count: None,
        }],
    });
    let camera_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some("host.camera"),
        layout: &camera_layout,
        entries: &[wgpu::BindGroupEntry {
            binding: 0,
            resource: camera_buffer.as_entire_binding(),
        }],
    });
    // The opaque pipeline is the application's own; strata builds the transparent passes'
    // pipelines from the same shader's vertex stage and `fs_transparent`, after the
    // application's group 0.
    let attributes = wgpu::vertex_attr_array![0 => Float32x3, 1 => Float32x4, 2 => Uint32];
    let stride = std::mem::size_of::<AppVertex>() as u64;
    let source = format!("{OPAQUE_SHADER}{TRANSPARENT_FRAGMENT}");
    let shader = AppShader::new(source, "vs_main", "fs_transparent")
        .vertex_buffer(VertexLayout::new(stride, &attributes))
        .bind_group_layout(&camera_layout);
    let mut oit = FrameRecorder::for_application(&gpu, method, &options, shader)?;
    let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
        label: Some("host.opaque"),
        source: wgpu::ShaderSource::Wgsl(Cow::Borrowed(OPAQUE_SHADER)),
    });
    let layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
        label: Some("host.opaque"),
        bind_group_layouts: &[Some(&camera_layout)],
        immediate_size: 0,
    });
    let opaque_pipeline = device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
        label: Some("host.opaque"),
        layout: Some(&layout),
        vertex: wgpu::VertexState {
            module: &module,
            entry_point: Some("vs_main"),
            compilation_options: Default::default(),
            buffers: &[Some(wgpu::VertexBufferLayout {
                array_stride: stride,
                step_mode: wgpu::VertexStepMode::Vertex,
                attributes: &attributes,
            })],
        },
        primitive: wgpu::PrimitiveState {
            cull_mode: None,
            ..Default::default()
        },
        depth_stencil: Some(wgpu::DepthStencilState {
            format: wgpu::TextureFormat::Depth32Float,
            depth_write_enabled: Some(true),
            depth_compare: Some(wgpu::CompareFunction::Less),
            stencil: Default::default(),
            bias: Default::default(),
        }),
        multisample: Default::default(),
        fragment: Some(wgpu::FragmentState {
            module: &module,
            entry_point: Some("fs_opaque"),
            compilation_options: Default::default(),
            targets: &[Some(COLOR_FORMAT.into())],
        }),
        multiview_mask: None,
        cache: None,
    });

    let bg = background_linear(background);
    let views = (&color_view, &depth_view);
    let mut stats = Vec::new();
    for _ in 0..frames {
        let mut encoder = device.create_command_encoder(&Default::default());
        {
            let clear = wgpu::Color {
                r: bg[0] as f64,
                g: bg[1] as f64,
                b: bg[2] as f64,
                a: 1.0,
            };
            let mut pass = target_pass(&mut encoder, "host.opaque", views, Some((clear, 1.0)));
            pass.set_pipeline(&opaque_pipeline);
            pass.set_bind_group(0, Some(&camera_group), &[]);
            pass.set_vertex_buffer(0, opaque_buffer.slice(..));
            pass.draw(0..opaque_vertices.len() as u32, 0..1);
        }
        // strata records its passes, calling the application back to draw its transparent
        // meshes in each geometry pass, then resolves OVER the target.
        let draw = |pass: &mut wgpu::RenderPass<'_>| {
            pass.set_bind_group(0, Some(&camera_group), &[]);
            pass.set_vertex_buffer(0, transparent_buffer.slice(..));
            pass.draw(0..transparent_vertices.len() as u32, 0..1);
        };
        let targets = FrameTargets {
            color: Some((&color_view, COLOR_FORMAT)),
            opaque_depth: Some(&depth_view),
        };
        oit.record(&mut encoder, &targets, Some(&draw))?;
        queue.submit([encoder.finish()]);
        stats.extend(oit.poll_stats());
    }

    // The application's own readback of its target (rows padded to 256 bytes).
    let row = (size * 4).next_multiple_of(wgpu::COPY_BYTES_PER_ROW_ALIGNMENT);
    let staging = device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("host.readback"),
        size: (row * size) as u64,
        usage: wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::MAP_READ,
        mapped_at_creation: false,
    });
    let mut encoder = device.create_command_encoder(&Default::default());
    encoder.copy_texture_to_buffer(
        color.as_image_copy(),
        wgpu::TexelCopyBufferInfo {
            buffer: &staging,
            layout: wgpu::TexelCopyBufferLayout {
                offset: 0,
                bytes_per_row: Some(row),
                rows_per_image: Some(size),
            },
        },
        color.size(),
    );
    queue.submit([encoder.finish()]);
    staging.slice(..).map_async(wgpu::MapMode::Read, |_| {});
    device
        .poll(wgpu::PollType::wait_indefinitely())
        .map_err(|e| runtime(format!("GPU wait failed: {e}")))?;
    let data = staging
        .slice(..)
        .get_mapped_range()
        .map_err(|e| runtime(format!("readback failed: {e}")))?
        .to_vec();
    let mut picture = image::RgbaImage::new(size, size);
    for y in 0..size {
        let start = (y * row) as usize;
        for x in 0..size {
            let p = &data[start + 4 * x as usize..start + 4 * x as usize + 4];
            picture.put_pixel(x, y, image::Rgba([p[0], p[1], p[2], 255]));
        }
    }
    // The last frame's statistics, unless an earlier poll already collected them.
    if let Ok(report) = oit.wait_stats() {
        stats.push(report.stats);
    }
    Ok(HostRun {
        picture,
        stats: stats
            .pop()
            .ok_or_else(|| runtime("no frame statistics arrived".into()))?,
        scene,
        background,
    })
}

/// A pass drawing into the application's color and depth targets: both cleared first
/// (`clear`: the color and the depth) or drawn over as they are.
fn target_pass<'e>(
    encoder: &'e mut wgpu::CommandEncoder,
    label: &str,
    (color, depth): (&wgpu::TextureView, &wgpu::TextureView),
    clear: Option<(wgpu::Color, f32)>,
) -> wgpu::RenderPass<'e> {
    encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
        label: Some(label),
        color_attachments: &[Some(wgpu::RenderPassColorAttachment {
            view: color,
            depth_slice: None,
            resolve_target: None,
            ops: wgpu::Operations {
                load: clear.map_or(wgpu::LoadOp::Load, |(c, _)| wgpu::LoadOp::Clear(c)),
                store: wgpu::StoreOp::Store,
            },
        })],
        depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
            view: depth,
            depth_ops: Some(wgpu::Operations {
                load: clear.map_or(wgpu::LoadOp::Load, |(_, d)| wgpu::LoadOp::Clear(d)),
                store: wgpu::StoreOp::Store,
            }),
            stencil_ops: None,
        }),
        ..Default::default()
    })
}

fn background_linear(b: Background) -> [f32; 3] {
    b.at(0, 0)
}

#[allow(dead_code)]
fn main() {
    let mut args = std::env::args().skip(1);
    let out = args.next().unwrap_or_else(|| "host.png".into());
    let method = args.next().unwrap_or_else(|| "kb-ab-ll".into());
    let result = method
        .parse::<MethodId>()
        .and_then(|m| run(m, 512, 3))
        .and_then(|r| {
            strata::render::save_png(&r.picture, std::path::Path::new(&out))?;
            Ok(r.stats)
        });
    match result {
        Ok(stats) => eprintln!(
            "{}: frame {}, {} fragments, {} ms GPU → {out}",
            stats.method,
            stats.frame,
            stats.fragments_generated.unwrap_or(0),
            stats
                .gpu_ms_total
                .map(|t| format!("{t:.2}"))
                .unwrap_or_else(|| "untimed".into())
        ),
        Err(e) => {
            eprintln!("error: {e}");
            std::process::exit(2);
        }
    }
}
