//! The recorder's frame-sized targets: the size check, the resolved colors, the depth of
//! "nothing opaque", and the depth clear.

use crate::error::{Error, Result};
use crate::frame::{RenderOptions, RESOLVED_BYTES};
use crate::gpu::Gpu;

/// Refuses, before anything is allocated, a picture size the device cannot hold: a side over
/// its texture limit, or more pixels than one storage binding of resolved colors holds.
pub(super) fn check_size(gpu: &Gpu, options: &RenderOptions) -> Result<()> {
    let (w, h) = (options.frame.width, options.frame.height);
    let max_dim = gpu.limits.max_texture_dimension_2d;
    if w > max_dim || h > max_dim {
        return Err(Error::unsupported(format!(
            "--size {w}x{h} exceeds the device's texture limit of {max_dim} pixels a side"
        )));
    }
    let max_pixels = max_resolved_pixels(gpu);
    if options.pixels() > max_pixels {
        let side = (max_pixels as f64).sqrt() as u64;
        return Err(Error::unsupported(format!(
            "--size {w}x{h} is {} pixels; this device binds {:.0} MiB in one buffer, which holds the resolved colors of at most {max_pixels} pixels ({side}x{side})",
            options.pixels(),
            gpu.max_storage_binding() as f64 / 1048576.0
        )));
    }
    Ok(())
}

/// The most pixels whose resolved colors one storage binding holds.
pub(crate) fn max_resolved_pixels(gpu: &Gpu) -> u64 {
    gpu.max_storage_binding() / RESOLVED_BYTES
}

/// A method's buffer that outgrows one binding grows with the picture: say at which size.
pub(super) fn per_pixel_context(e: Error, (w, h): (u32, u32)) -> Error {
    match e {
        Error::Unsupported(msg) if msg.contains(crate::error::OVER_BINDING) => Error::unsupported(
            format!("{msg} at {w}x{h} (a smaller --size or --k needs less)"),
        ),
        other => other,
    }
}

pub(super) fn output_buffer(gpu: &Gpu, options: &RenderOptions) -> Result<wgpu::Buffer> {
    gpu.storage_buffer(
        "strata.frame.resolved",
        options.pixels() * RESOLVED_BYTES,
        wgpu::BufferUsages::COPY_SRC,
    )
}

/// The depth of "nothing opaque": cleared once when it is made (a setup step, not a frame).
pub(super) fn no_opaque_depth(gpu: &Gpu, options: &RenderOptions) -> wgpu::Texture {
    let texture = gpu.texture_2d(
        "strata.frame.no_opaque_depth",
        (options.frame.width, options.frame.height),
        wgpu::TextureFormat::Depth32Float,
        wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::TEXTURE_BINDING,
    );
    crate::render::clear_depth(gpu, &texture.create_view(&Default::default()), 1.0);
    texture
}
