//! The application's capture path in `bench soak`: a small application of its own — its own
//! vertex format, a bind group of its own, its own opaque depth and color target — renders its
//! translucent quads through [`FrameRecorder::for_application`] beside the scene's recorder,
//! every few frames into the same encoder, switching method as it goes. Its statistics are
//! matched to its frames as the scene's are, and at checkpoints its long-lived recorder renders
//! a complete frame that must equal, byte for byte, a fresh recorder's frame of the same method
//! (the fresh picture is the one `tests/own_shaders.rs` holds to hand-computed pixels for this
//! path).

use std::collections::HashMap;

use strata::error::{Error, Result};
use strata::frame::application::{AppShader, VertexLayout};
use strata::frame::{FrameStats, FrameTargets};
use strata::gpu::Gpu;
use strata::{FrameRecorder, MethodId, RenderOptions};
use wgpu::util::DeviceExt;

/// Exact methods that take the application's shaders: lists, S-buffer regions, a lock k-buffer
/// and peeling.
pub(super) const APP_METHODS: [MethodId; 4] = [
    MethodId::AbufferLl,
    MethodId::Sbuffer,
    MethodId::KplusHeap,
    MethodId::F2b,
];
/// Application frames between its method switches.
const APP_METHOD_EVERY: u64 = 3;
const APP_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba8UnormSrgb;
/// The application's opaque surface: the whole screen at this depth.
const OPAQUE_DEPTH: f32 = 0.6;

/// The application's vertex: clip position, straight-alpha colour and the quad's id.
#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct AppVertex {
    clip: [f32; 4],
    color: [f32; 4],
    id: u32,
}

const SHADER: &str = "
struct Tint { scale: vec4<f32> }
@group(0) @binding(0) var<uniform> tint: Tint;

struct Varying {
    @builtin(position) @invariant position: vec4<f32>,
    @location(0) color: vec4<f32>,
    @location(1) @interpolate(flat) id: u32,
}

@vertex
fn vs_quad(@location(0) clip: vec4<f32>, @location(1) color: vec4<f32>, @location(2) id: u32) -> Varying {
    return Varying(clip, color * tint.scale, id);
}
";

const FRAGMENT: &str = "
@fragment
fn fs_glass(v: Varying, @builtin(front_facing) front_facing: bool, @builtin(sample_mask) mask: u32) -> StrataOut {
    return strata_capture(v.position, vec4<f32>(v.color.rgb * v.color.a, v.color.a), v.id, front_facing, mask);
}
";

/// GL's GLSL has no sample mask input (naga, wgpu 30); GL frames are single-sampled.
const FRAGMENT_GL: &str = "
@fragment
fn fs_glass(v: Varying, @builtin(front_facing) front_facing: bool) -> StrataOut {
    return strata_capture(v.position, vec4<f32>(v.color.rgb * v.color.a, v.color.a), v.id, front_facing, 1u);
}
";

/// Two triangles over `rect` (clip x0, y0, x1, y1) with depth `depth[0]` at x = −1 and
/// `depth[1]` at x = +1.
fn quad(rect: [f32; 4], depth: [f32; 2], color: [f32; 4], id: u32) -> [AppVertex; 6] {
    let [x0, y0, x1, y1] = rect;
    let z = |x: f32| depth[0] + (depth[1] - depth[0]) * (x + 1.0) / 2.0;
    let v = |x: f32, y: f32| AppVertex {
        clip: [x, y, z(x), 1.0],
        color,
        id,
    };
    [
        v(x0, y0),
        v(x1, y0),
        v(x1, y1),
        v(x0, y0),
        v(x1, y1),
        v(x0, y1),
    ]
}

/// Overlapping quads: tilted ones that cross each other, one crossing the opaque depth and
/// one wholly behind it.
fn quads() -> Vec<AppVertex> {
    [
        quad([-0.8, -0.8, 0.6, 0.6], [0.2, 0.5], [0.1, 0.9, 0.2, 0.5], 0),
        quad([-0.5, -0.6, 0.8, 0.8], [0.4, 0.4], [0.9, 0.1, 0.1, 0.4], 1),
        quad([-0.9, -0.2, 0.9, 0.3], [0.3, 0.8], [0.1, 0.2, 0.9, 0.6], 2),
        quad([-0.6, -0.9, 0.2, 0.9], [0.7, 0.7], [1.0, 1.0, 1.0, 0.5], 3),
    ]
    .concat()
}

/// The application: its resources and its strata recorder.
pub(super) struct App {
    gpu: Gpu,
    options: RenderOptions,
    vertices: wgpu::Buffer,
    vertex_count: u32,
    tint_layout: wgpu::BindGroupLayout,
    tint_group: wgpu::BindGroup,
    color: wgpu::TextureView,
    depth: wgpu::TextureView,
    recorder: FrameRecorder,
    frames: u64,
    recorded: HashMap<u64, MethodId>,
    pub matched: u64,
    pub mismatched: u64,
}

impl App {
    pub fn new(gpu: &Gpu, size: (u32, u32)) -> Result<App> {
        let device = &gpu.device;
        let quads = quads();
        let vertices = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("soak.app.quads"),
            contents: bytemuck::cast_slice(&quads),
            usage: wgpu::BufferUsages::VERTEX,
        });
        let tint = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("soak.app.tint"),
            contents: bytemuck::cast_slice(&[1.0f32; 4]),
            usage: wgpu::BufferUsages::UNIFORM,
        });
        let tint_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("soak.app.tint"),
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
            label: Some("soak.app.tint"),
            layout: &tint_layout,
            entries: &[wgpu::BindGroupEntry {
                binding: 0,
                resource: tint.as_entire_binding(),
            }],
        });
        let target = |label, format, usage| {
            device
                .create_texture(&wgpu::TextureDescriptor {
                    label: Some(label),
                    size: wgpu::Extent3d {
                        width: size.0,
                        height: size.1,
                        depth_or_array_layers: 1,
                    },
                    mip_level_count: 1,
                    sample_count: 1,
                    dimension: wgpu::TextureDimension::D2,
                    format,
                    usage: wgpu::TextureUsages::RENDER_ATTACHMENT | usage,
                    view_formats: &[],
                })
                .create_view(&Default::default())
        };
        let color = target("soak.app.color", APP_FORMAT, wgpu::TextureUsages::empty());
        // strata samples the opaque depth: TEXTURE_BINDING.
        let depth = target(
            "soak.app.depth",
            wgpu::TextureFormat::Depth32Float,
            wgpu::TextureUsages::TEXTURE_BINDING,
        );
        // The application's opaque pass, once: a surface over the whole screen.
        let mut encoder = device.create_command_encoder(&Default::default());
        encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
            label: Some("soak.app.opaque"),
            color_attachments: &[],
            depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
                view: &depth,
                depth_ops: Some(wgpu::Operations {
                    load: wgpu::LoadOp::Clear(OPAQUE_DEPTH),
                    store: wgpu::StoreOp::Store,
                }),
                stencil_ops: None,
            }),
            ..Default::default()
        });
        gpu.queue.submit([encoder.finish()]);
        let mut options = RenderOptions::sized(size.0, size.1);
        options.frame.k = Some(8);
        let recorder = Self::recorder(gpu, &options, &tint_layout, APP_METHODS[0])?;
        Ok(App {
            gpu: gpu.clone(),
            options,
            vertices,
            vertex_count: quads.len() as u32,
            tint_layout,
            tint_group,
            color,
            depth,
            recorder,
            frames: 0,
            recorded: HashMap::new(),
            matched: 0,
            mismatched: 0,
        })
    }

    fn recorder(
        gpu: &Gpu,
        options: &RenderOptions,
        tint_layout: &wgpu::BindGroupLayout,
        method: MethodId,
    ) -> Result<FrameRecorder> {
        let fragment = match gpu.device.adapter_info().backend {
            wgpu::Backend::Gl => FRAGMENT_GL,
            _ => FRAGMENT,
        };
        let attributes = wgpu::vertex_attr_array![0 => Float32x4, 1 => Float32x4, 2 => Uint32];
        let stride = std::mem::size_of::<AppVertex>() as u64;
        let shader = AppShader::new(format!("{SHADER}{fragment}"), "vs_quad", "fs_glass")
            .vertex_buffer(VertexLayout::new(stride, &attributes))
            .bind_group_layout(tint_layout);
        FrameRecorder::for_application(gpu, method, options, shader)
    }

    /// Records the application's next frame into `encoder`, its method switched every few
    /// frames.
    pub fn record(&mut self, encoder: &mut wgpu::CommandEncoder) -> Result<()> {
        if self.frames.is_multiple_of(APP_METHOD_EVERY) {
            let at = (self.frames / APP_METHOD_EVERY) % APP_METHODS.len() as u64;
            self.recorder.set_method(APP_METHODS[at as usize])?;
        }
        self.frames += 1;
        self.record_frame(encoder)
    }

    fn record_frame(&mut self, encoder: &mut wgpu::CommandEncoder) -> Result<()> {
        let draw = draw_quads(&self.tint_group, &self.vertices, self.vertex_count);
        let targets = targets(&self.color, &self.depth);
        let n = self.recorder.record(encoder, &targets, Some(&draw))?;
        self.recorded.insert(n, self.recorder.method());
        Ok(())
    }

    /// Matches the statistics the ring handed back (after the frames were submitted).
    pub fn poll(&mut self) {
        let done = self.recorder.poll_stats();
        self.check(done);
    }

    fn check(&mut self, done: Vec<FrameStats>) {
        for stats in done {
            let recorded = self.recorded.remove(&stats.frame);
            let size = (self.options.frame.width, self.options.frame.height);
            match recorded
                .is_some_and(|m| m.as_str() == stats.method && (stats.width, stats.height) == size)
            {
                true => self.matched += 1,
                false => self.mismatched += 1,
            }
        }
    }

    /// A complete frame on the long-lived recorder, which must equal a fresh recorder's frame
    /// of the same method byte for byte.
    pub fn equals_fresh(&mut self) -> Result<bool> {
        self.gpu.wait()?;
        self.poll();
        let method = self.recorder.method();
        let draw = draw_quads(&self.tint_group, &self.vertices, self.vertex_count);
        let targets = targets(&self.color, &self.depth);
        let first = self.recorder.next_frame();
        self.recorder.render_once(&targets, Some(&draw))?;
        for n in first..self.recorder.next_frame() {
            self.recorded.insert(n, method);
        }
        let long_lived = self.recorder.picture()?;
        let mut fresh = Self::recorder(&self.gpu, &self.options, &self.tint_layout, method)?;
        fresh.render_once(&targets, Some(&draw))?;
        let effect = self.options.frame.effect;
        let fresh = fresh.picture()?.to_rgba8(effect);
        if fresh.pixels().all(|p| p.0 == fresh.get_pixel(0, 0).0) {
            return Err(Error::runtime(
                "soak: the application's quads left its picture flat".to_string(),
            ));
        }
        Ok(long_lived.to_rgba8(effect) == fresh)
    }

    /// Two frames of every application method, then back to the current one (the checkpoints'
    /// tour: the same state at each, so that growth between tours is a leak).
    pub fn tour(&mut self) -> Result<()> {
        let method = self.recorder.method();
        for m in APP_METHODS {
            self.recorder.set_method(m)?;
            for _ in 0..2 {
                let mut encoder = self.gpu.device.create_command_encoder(&Default::default());
                self.record_frame(&mut encoder)?;
                self.gpu.queue.submit([encoder.finish()]);
            }
        }
        self.gpu.wait()?;
        self.poll();
        self.recorder.set_method(method)
    }
}

/// The application's draw of its quads, which strata calls in each geometry pass.
fn draw_quads<'a>(
    group: &'a wgpu::BindGroup,
    vertices: &'a wgpu::Buffer,
    count: u32,
) -> impl Fn(&mut wgpu::RenderPass<'_>) + 'a {
    move |pass| {
        pass.set_bind_group(0, Some(group), &[]);
        pass.set_vertex_buffer(0, vertices.slice(..));
        pass.draw(0..count, 0..1);
    }
}

fn targets<'a>(color: &'a wgpu::TextureView, depth: &'a wgpu::TextureView) -> FrameTargets<'a> {
    FrameTargets {
        color: Some((color, APP_FORMAT)),
        opaque_depth: Some(depth),
    }
}
