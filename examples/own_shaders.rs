//! strata in a renderer that keeps its own shaders: the application's device, vertex format
//! (clip-space position, straight-alpha colour, triangle id), bind group, opaque pass and
//! transparent fragment stage, with strata ordering what that stage draws. Headless:
//!
//! ```sh
//! cargo run --release -p strata --example own_shaders -- out/   # one PNG per method
//! ```
//!
//! The scene: a yellow opaque wall over the right half at depth 0.5; a red quad at depth 0.3,
//! a blue one at 0.7 (half of it behind the wall) and a green one tilted from depth 0.1 on the
//! left to 0.7 on the right (it crosses the red quad and goes behind the wall), submitted
//! green, blue, red. `tests/own_shaders.rs` holds every pixel to values computed by hand.

use std::borrow::Cow;

use strata::frame::application::{AppShader, VertexLayout};
use strata::frame::FrameTargets;
use strata::gpu::Gpu;
use strata::{FrameRecorder, MethodId, RenderOptions};
use wgpu::util::DeviceExt;

/// The picture's side in pixels.
pub const SIZE: u32 = 64;
/// The application's target format.
pub const FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba8UnormSrgb;
/// What the application clears its target to (linear).
pub const BACKGROUND: [f32; 3] = [0.05, 0.05, 0.1];
/// The opaque wall: x from 0 to 1 in clip space, at depth 0.5, linear yellow.
pub const WALL: ([f32; 4], f32, [f32; 3]) = ([0.0, -1.0, 1.0, 1.0], 0.5, [0.8, 0.8, 0.0]);

/// A translucent quad: its clip-space rectangle (x0, y0, x1, y1), depth at x = −1 and at
/// x = +1 (linear in between), and straight-alpha linear colour.
#[derive(Clone, Copy, Debug)]
pub struct Quad {
    pub rect: [f32; 4],
    pub depth: [f32; 2],
    pub color: [f32; 4],
}

/// The translucent quads in the order the application submits them.
pub const QUADS: [Quad; 3] = [
    // Green, tilted: in front of the red quad left of x = −1/3, behind the wall right of 1/3.
    Quad {
        rect: [-0.75, -0.25, 0.75, 0.25],
        depth: [0.1, 0.7],
        color: [0.1, 0.9, 0.2, 0.5],
    },
    // Blue, behind the wall where the wall is.
    Quad {
        rect: [-0.75, -0.75, 0.75, 0.0],
        depth: [0.7, 0.7],
        color: [0.1, 0.2, 0.9, 0.6],
    },
    // Red.
    Quad {
        rect: [-0.75, -0.5, 0.75, 0.5],
        depth: [0.3, 0.3],
        color: [0.9, 0.1, 0.1, 0.4],
    },
];

/// The application's vertex.
#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct Vertex {
    clip: [f32; 4],
    color: [f32; 4],
    triangle: u32,
}

/// The application's shader. Its transparent fragment stage returns `StrataOut` from
/// `strata_capture`, which strata defines for each of its passes; its position is `@invariant`.
const SHADER: &str = "
struct Tint { scale: vec4<f32> }
@group(0) @binding(0) var<uniform> tint: Tint;

struct Varying {
    @builtin(position) @invariant position: vec4<f32>,
    @location(0) color: vec4<f32>,
    @location(1) @interpolate(flat) triangle: u32,
}

@vertex
fn vs_main(@location(0) clip: vec4<f32>, @location(1) color: vec4<f32>, @location(2) triangle: u32) -> Varying {
    return Varying(clip, color * tint.scale, triangle);
}
";

const OPAQUE_FRAGMENT: &str = "
@fragment
fn fs_opaque(v: Varying) -> @location(0) vec4<f32> {
    return vec4<f32>(v.color.rgb, 1.0);
}
";

const TRANSPARENT_FRAGMENT: &str = "
@fragment
fn fs_transparent(v: Varying, @builtin(front_facing) front_facing: bool,
                  @builtin(sample_mask) mask: u32) -> StrataOut {
    let premultiplied = vec4<f32>(v.color.rgb * v.color.a, v.color.a);
    return strata_capture(v.position, premultiplied, v.triangle, front_facing, mask);
}
";

/// The same on wgpu's GL backend, whose GLSL cannot read `@builtin(sample_mask)` (naga, wgpu
/// 30): a single-sampled frame's mask is 1, and GL takes no `--msaa`.
const TRANSPARENT_FRAGMENT_GL: &str = "
@fragment
fn fs_transparent(v: Varying, @builtin(front_facing) front_facing: bool) -> StrataOut {
    let premultiplied = vec4<f32>(v.color.rgb * v.color.a, v.color.a);
    return strata_capture(v.position, premultiplied, v.triangle, front_facing, 1u);
}
";

/// Two triangles of `rect` with depths at x = ±1, both with `id` (they never overlap, so they
/// may share the id that orders fragments at equal depth).
fn quad(rect: [f32; 4], depth: [f32; 2], color: [f32; 4], id: u32) -> Vec<Vertex> {
    let [x0, y0, x1, y1] = rect;
    let z = |x: f32| depth[0] + (depth[1] - depth[0]) * (x + 1.0) / 2.0;
    let v = |x: f32, y: f32| Vertex {
        clip: [x, y, z(x), 1.0],
        color,
        triangle: id,
    };
    vec![
        v(x0, y0),
        v(x1, y0),
        v(x1, y1),
        v(x0, y0),
        v(x1, y1),
        v(x0, y1),
    ]
}

/// Opens a device on any adapter with the features strata can use.
pub fn device() -> Result<(wgpu::Device, wgpu::Queue), String> {
    let instance = wgpu::Instance::new(wgpu::InstanceDescriptor {
        backends: wgpu::Backends::from_env().unwrap_or(wgpu::Backends::VULKAN),
        ..wgpu::InstanceDescriptor::new_without_display_handle()
    });
    let adapter = pollster::block_on(instance.request_adapter(&Default::default()))
        .map_err(|e| format!("no adapter: {e}"))?;
    pollster::block_on(adapter.request_device(&wgpu::DeviceDescriptor {
        label: Some("app.device"),
        required_features: adapter.features() & strata::gpu::wanted_features(),
        required_limits: adapter.limits(),
        ..Default::default()
    }))
    .map_err(|e| format!("cannot open the device: {e}"))
}

/// Renders the scene with `method` (k = 16 where it reads k), strata's passes rasterizing
/// `samples` samples per pixel (`--msaa`; the application's targets stay single-sampled), and
/// reads the picture back.
pub fn run(
    device: &wgpu::Device,
    queue: &wgpu::Queue,
    method: MethodId,
    samples: u32,
) -> Result<(image::RgbaImage, strata::FrameStats), Box<dyn std::error::Error>> {
    // The application's resources.
    let (wall_rect, wall_depth, wall_color) = WALL;
    let wall = quad(
        wall_rect,
        [wall_depth; 2],
        [wall_color[0], wall_color[1], wall_color[2], 1.0],
        0,
    );
    let glass: Vec<Vertex> = QUADS
        .iter()
        .enumerate()
        .flat_map(|(i, q)| quad(q.rect, q.depth, q.color, i as u32))
        .collect();
    let buffer = |label, vertices: &[Vertex]| {
        device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some(label),
            contents: bytemuck::cast_slice(vertices),
            usage: wgpu::BufferUsages::VERTEX,
        })
    };
    let (wall_buffer, glass_buffer) = (buffer("app.wall", &wall), buffer("app.glass", &glass));
    let tint = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
        label: Some("app.tint"),
        contents: bytemuck::cast_slice(&[1.0f32; 4]),
        usage: wgpu::BufferUsages::UNIFORM,
    });
    let tint_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
        label: Some("app.tint"),
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
    let tint_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some("app.tint"),
        layout: &tint_layout,
        entries: &[wgpu::BindGroupEntry {
            binding: 0,
            resource: tint.as_entire_binding(),
        }],
    });
    let texture = |label, format, usage| {
        device.create_texture(&wgpu::TextureDescriptor {
            label: Some(label),
            size: wgpu::Extent3d {
                width: SIZE,
                height: SIZE,
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
    let attachment = wgpu::TextureUsages::RENDER_ATTACHMENT;
    let color = texture(
        "app.color",
        FORMAT,
        attachment | wgpu::TextureUsages::COPY_SRC,
    );
    // strata reads the opaque depth in its shaders: TEXTURE_BINDING.
    let depth = texture(
        "app.depth",
        wgpu::TextureFormat::Depth32Float,
        attachment | wgpu::TextureUsages::TEXTURE_BINDING,
    );
    let (color_view, depth_view) = (
        color.create_view(&Default::default()),
        depth.create_view(&Default::default()),
    );
    let attributes = wgpu::vertex_attr_array![0 => Float32x4, 1 => Float32x4, 2 => Uint32];
    let stride = std::mem::size_of::<Vertex>() as u64;
    let opaque_pipeline = opaque_pipeline(device, &tint_layout, stride, &attributes);

    // The opaque pass: background and wall, with depth.
    let mut encoder = device.create_command_encoder(&Default::default());
    {
        let [r, g, b] = BACKGROUND.map(f64::from);
        let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
            label: Some("app.opaque"),
            color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                view: &color_view,
                depth_slice: None,
                resolve_target: None,
                ops: wgpu::Operations {
                    load: wgpu::LoadOp::Clear(wgpu::Color { r, g, b, a: 1.0 }),
                    store: wgpu::StoreOp::Store,
                },
            })],
            depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
                view: &depth_view,
                depth_ops: Some(wgpu::Operations {
                    load: wgpu::LoadOp::Clear(1.0),
                    store: wgpu::StoreOp::Store,
                }),
                stencil_ops: None,
            }),
            ..Default::default()
        });
        pass.set_pipeline(&opaque_pipeline);
        pass.set_bind_group(0, Some(&tint_group), &[]);
        pass.set_vertex_buffer(0, wall_buffer.slice(..));
        pass.draw(0..wall.len() as u32, 0..1);
    }
    queue.submit([encoder.finish()]);

    // ---- strata: the transparent geometry through the application's own shader ----
    let gpu = Gpu::from_device(device.clone(), queue.clone());
    let mut options = RenderOptions::sized(SIZE, SIZE);
    options.build.msaa = samples;
    if method.descriptor().reads(strata::methods::options::K) {
        options.frame.k = Some(16);
    }
    let shader = AppShader::new(
        match device.adapter_info().backend {
            wgpu::Backend::Gl => format!("{SHADER}{TRANSPARENT_FRAGMENT_GL}"),
            _ => format!("{SHADER}{TRANSPARENT_FRAGMENT}"),
        },
        "vs_main",
        "fs_transparent",
    )
    .vertex_buffer(VertexLayout::new(stride, &attributes))
    .bind_group_layout(&tint_layout);
    let mut oit = FrameRecorder::for_application(&gpu, method, &options, shader)?;
    // strata calls this in each geometry pass of the method, its pipeline and groups set (once
    // per band of rows, under its scissor, when a frame is heavy): draw the same every time.
    let draw = |pass: &mut wgpu::RenderPass<'_>| {
        pass.set_bind_group(0, Some(&tint_group), &[]);
        pass.set_vertex_buffer(0, glass_buffer.slice(..));
        pass.draw(0..glass.len() as u32, 0..1);
    };
    let targets = FrameTargets {
        color: Some((&color_view, FORMAT)),
        opaque_depth: Some(&depth_view),
    };
    // One call renders a complete first frame; in real time, `oit.record(&mut encoder,
    // &targets, Some(&draw))` every frame instead, and `oit.poll_stats()`.
    let stats = oit.render_once(&targets, Some(&draw))?;
    // ---- end of strata ----

    Ok((read_back(device, queue, &color)?, stats))
}

fn opaque_pipeline(
    device: &wgpu::Device,
    tint_layout: &wgpu::BindGroupLayout,
    stride: u64,
    attributes: &[wgpu::VertexAttribute],
) -> wgpu::RenderPipeline {
    let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
        label: Some("app.opaque"),
        source: wgpu::ShaderSource::Wgsl(Cow::Owned(format!("{SHADER}{OPAQUE_FRAGMENT}"))),
    });
    let layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
        label: Some("app.opaque"),
        bind_group_layouts: &[Some(tint_layout)],
        immediate_size: 0,
    });
    device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
        label: Some("app.opaque"),
        layout: Some(&layout),
        vertex: wgpu::VertexState {
            module: &module,
            entry_point: Some("vs_main"),
            compilation_options: Default::default(),
            buffers: &[Some(wgpu::VertexBufferLayout {
                array_stride: stride,
                step_mode: wgpu::VertexStepMode::Vertex,
                attributes,
            })],
        },
        primitive: Default::default(),
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
            targets: &[Some(FORMAT.into())],
        }),
        multiview_mask: None,
        cache: None,
    })
}

/// The application's readback of its target (rows padded to 256 bytes).
fn read_back(
    device: &wgpu::Device,
    queue: &wgpu::Queue,
    color: &wgpu::Texture,
) -> Result<image::RgbaImage, String> {
    let row = (SIZE * 4).next_multiple_of(wgpu::COPY_BYTES_PER_ROW_ALIGNMENT);
    let staging = device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("app.readback"),
        size: (row * SIZE) as u64,
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
                rows_per_image: Some(SIZE),
            },
        },
        color.size(),
    );
    queue.submit([encoder.finish()]);
    staging.slice(..).map_async(wgpu::MapMode::Read, |_| {});
    device
        .poll(wgpu::PollType::wait_indefinitely())
        .map_err(|e| format!("GPU wait failed: {e}"))?;
    let data = staging
        .slice(..)
        .get_mapped_range()
        .map_err(|e| format!("readback failed: {e}"))?
        .to_vec();
    Ok(image::RgbaImage::from_fn(SIZE, SIZE, |x, y| {
        let i = (y * row + 4 * x) as usize;
        image::Rgba([data[i], data[i + 1], data[i + 2], 255])
    }))
}

#[allow(dead_code)]
fn main() {
    let out = std::path::PathBuf::from(std::env::args().nth(1).unwrap_or_else(|| ".".into()));
    let result = device().map_err(|e| e.into()).and_then(|(device, queue)| {
        // What this device's backend runs (`strata methods --backend NAME`).
        let offer = strata::methods::backends::Offer::of_gpu(&strata::gpu::Gpu::from_device(
            device.clone(),
            queue.clone(),
        ));
        // A single-pass list, a locking k+-buffer, two-pass kb-keys, depth peeling, and
        // weighted blended OIT; every method with `app_shaders` in `strata methods` runs so.
        for method in [
            MethodId::AbufferLl,
            MethodId::KplusHeap,
            MethodId::KbKeys,
            MethodId::F2b,
            MethodId::Wboit,
        ] {
            let verdict = strata::methods::backends::verdict(method.descriptor(), &offer);
            if !verdict.runs() {
                eprintln!("{method}: not on this device: {verdict}");
                continue;
            }
            let (picture, stats) = run(&device, &queue, method, 1)?;
            let path = out.join(format!("own_shaders-{method}.png"));
            picture.save(&path)?;
            eprintln!(
                "{method}: {} fragments, {} submits → {}",
                stats.fragments_generated.unwrap_or(0),
                stats.submits,
                path.display()
            );
        }
        Ok::<(), Box<dyn std::error::Error>>(())
    });
    if let Err(e) = result {
        eprintln!("error: {e}");
        std::process::exit(2);
    }
}
