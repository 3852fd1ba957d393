//! The smallest application using strata: its own device and opaque pass into its own targets,
//! then strata drawing a scene's transparent objects over them, exact. Headless: `cargo run
//! --release -p strata --example minimal -- minimal.png`; `tests/minimal.rs` checks the picture
//! against strata's CPU reference with the wall added as an opaque object.

use strata::frame::FrameTargets;

pub const SIZE: u32 = 128;
pub const SCENE: &str = "builtin:spheres?layers=4&segments=24";
/// The application's opaque wall through the spheres (two triangles), its linear color, and the
/// linear color it clears its target to.
#[rustfmt::skip]
pub const WALL: [[f32; 3]; 6] = [
    [-0.6, -2.0, -0.3], [2.0, -2.0, 0.3], [2.0, 2.0, 0.3],
    [-0.6, -2.0, -0.3], [2.0, 2.0, 0.3], [-0.6, 2.0, -0.3],
];
pub const WALL_COLOR: [f32; 3] = [0.05, 0.3, 0.1];
pub const BACKGROUND: [f32; 3] = [0.02, 0.02, 0.05];
const FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba8UnormSrgb;
const DEPTH: wgpu::TextureFormat = wgpu::TextureFormat::Depth32Float;

/// The scene strata draws, its camera fixed (the test adds the wall to it).
pub fn scene() -> strata::Result<strata::scene::Scene> {
    let mut scene = strata::scene::loaders::load_scene(SCENE)?;
    scene.camera = Some(scene.camera_or_framing());
    Ok(scene)
}

/// Renders three frames (a pool that overflowed grows for the next) and returns the last.
pub fn run() -> Result<image::RgbaImage, Box<dyn std::error::Error>> {
    let instance = wgpu::Instance::new(wgpu::InstanceDescriptor {
        backends: wgpu::Backends::from_env().unwrap_or(wgpu::Backends::VULKAN),
        ..wgpu::InstanceDescriptor::new_without_display_handle()
    });
    let adapter = pollster::block_on(instance.request_adapter(&Default::default()))?;
    let (device, queue) = pollster::block_on(adapter.request_device(&wgpu::DeviceDescriptor {
        required_features: adapter.features() & strata::gpu::wanted_features(),
        required_limits: adapter.limits(),
        ..Default::default()
    }))?;
    // strata: the application's device.
    let gpu = strata::gpu::Gpu::from_device(device.clone(), queue.clone());
    let attachment = wgpu::TextureUsages::RENDER_ATTACHMENT;
    let target = |format, usage| gpu.texture_2d("app", (SIZE, SIZE), format, attachment | usage);
    let color = target(FORMAT, wgpu::TextureUsages::COPY_SRC);
    // strata tests its fragments against this depth, so it is bindable.
    let depth = target(DEPTH, wgpu::TextureUsages::TEXTURE_BINDING);
    let color_view = color.create_view(&Default::default());
    let depth_view = depth.create_view(&Default::default());

    // strata: the scene, a recorder.
    let scene = scene()?;
    let options = strata::RenderOptions::sized(SIZE, SIZE);
    let mut oit = strata::FrameRecorder::new(&gpu, &scene, strata::MethodId::AbufferLl, &options)?;

    // The application's opaque wall, through strata's camera (its corners transformed here, to
    // keep the shader short).
    let view_proj = scene.camera_or_framing().view_projection(1.0);
    let corners: Vec<String> = WALL
        .iter()
        .map(|&p| {
            let [x, y, z, w] = (view_proj * glam::Vec3::from(p).extend(1.0)).to_array();
            format!("vec4<f32>({x}, {y}, {z}, {w})")
        })
        .collect();
    let ([r, g, b], corners) = (WALL_COLOR, corners.join(", "));
    let shader = format!(
        "@vertex fn vs(@builtin(vertex_index) i: u32) -> @builtin(position) vec4<f32> {{
            return array<vec4<f32>, 6>({corners})[i]; }}
        @fragment fn fs() -> @location(0) vec4<f32> {{ return vec4<f32>({r}, {g}, {b}, 1.0); }}"
    );
    let source = wgpu::ShaderSource::Wgsl(shader.into());
    let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
        label: None,
        source,
    });
    let pipeline = device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
        label: None,
        layout: None,
        vertex: wgpu::VertexState {
            module: &module,
            entry_point: Some("vs"),
            compilation_options: Default::default(),
            buffers: &[],
        },
        fragment: Some(wgpu::FragmentState {
            module: &module,
            entry_point: Some("fs"),
            compilation_options: Default::default(),
            targets: &[Some(FORMAT.into())],
        }),
        primitive: Default::default(),
        depth_stencil: Some(wgpu::DepthStencilState {
            format: DEPTH,
            depth_write_enabled: Some(true),
            depth_compare: Some(wgpu::CompareFunction::Less),
            stencil: Default::default(),
            bias: Default::default(),
        }),
        multisample: Default::default(),
        multiview_mask: None,
        cache: None,
    });
    let [r, g, b] = BACKGROUND.map(f64::from);
    let store = wgpu::StoreOp::Store;
    for _ in 0..3 {
        let mut encoder = device.create_command_encoder(&Default::default());
        let clear = wgpu::LoadOp::Clear(wgpu::Color { r, g, b, a: 1.0 });
        let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
            color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                view: &color_view,
                depth_slice: None,
                resolve_target: None,
                ops: wgpu::Operations { load: clear, store },
            })],
            depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
                view: &depth_view,
                depth_ops: Some(wgpu::Operations {
                    load: wgpu::LoadOp::Clear(1.0),
                    store,
                }),
                stencil_ops: None,
            }),
            ..Default::default()
        });
        pass.set_pipeline(&pipeline);
        pass.draw(0..6, 0..1);
        drop(pass);
        // strata: the transparent objects, tested against the wall's depth, OVER the target.
        let targets = FrameTargets {
            color: Some((&color_view, FORMAT)),
            opaque_depth: Some(&depth_view),
        };
        oit.record(&mut encoder, &targets, None)?;
        queue.submit([encoder.finish()]);
        oit.wait_stats()?; // headless: wait, so the next frame has this one's feedback
    }
    let pixels = strata::gpu::readback::read_texture(&gpu, &color)?;
    Ok(image::RgbaImage::from_raw(SIZE, SIZE, pixels).ok_or("readback size")?)
}

#[allow(dead_code)]
fn main() -> Result<(), Box<dyn std::error::Error>> {
    let out = std::env::args().nth(1).unwrap_or("minimal.png".into());
    Ok(run()?.save(out)?)
}
