//! The recorder's frame-sized targets: the size check, the resolved colors, the depth of
//! "nothing opaque", and the depth clear.

use crate::error::{Error, Result};
use crate::frame::{FrameTargets, RenderOptions, RESOLVED_BYTES};
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

/// Refuses, before a frame is recorded, targets that do not fit it: a size other than the
/// frame's, a texture without the usage strata needs, a format it cannot composite into or
/// test against, multisampled targets.
pub(super) fn check_targets(
    gpu: &Gpu,
    options: &RenderOptions,
    targets: &FrameTargets<'_>,
) -> Result<()> {
    let frame = (options.frame.width, options.frame.height);
    let size_of = |what: &str, texture: &wgpu::Texture| {
        let size = (texture.width(), texture.height());
        match size == frame {
            true => Ok(()),
            false => Err(Error::input(format!(
                "{what} is {}x{} and the frame {}x{}: make the recorder for the target's size (RenderOptions::sized) or resize it",
                size.0, size.1, frame.0, frame.1
            ))),
        }
    };
    if let Some((view, format)) = targets.color {
        let texture = view.texture();
        size_of("the color target", texture)?;
        if !texture
            .usage()
            .contains(wgpu::TextureUsages::RENDER_ATTACHMENT)
        {
            return Err(Error::input(
                "the color target lacks RENDER_ATTACHMENT usage: strata composites into it with a render pass",
            ));
        }
        let base = |f: wgpu::TextureFormat| f.remove_srgb_suffix();
        if base(format) != base(texture.format()) {
            return Err(Error::input(format!(
                "the color target's format is given as {format:?}, and its texture is {:?}",
                texture.format()
            )));
        }
        let features = match &gpu.adapter {
            Some(adapter) => adapter.get_texture_format_features(format),
            None => format.guaranteed_format_features(gpu.features),
        };
        if format.is_depth_stencil_format()
            || !features
                .flags
                .contains(wgpu::TextureFormatFeatureFlags::BLENDABLE)
        {
            return Err(Error::input(format!(
                "the color target's format {format:?} is not a blendable color format: strata composites over it with blending"
            )));
        }
        if texture.sample_count() != 1 {
            return Err(Error::input(format!(
                "the color target has {} samples: strata composites into a single-sampled target (resolve yours first, or give its resolve target)",
                texture.sample_count()
            )));
        }
    }
    if let Some(view) = targets.opaque_depth {
        let texture = view.texture();
        size_of("the opaque depth", texture)?;
        if !texture
            .usage()
            .contains(wgpu::TextureUsages::TEXTURE_BINDING)
        {
            return Err(Error::input(
                "the opaque depth lacks TEXTURE_BINDING usage: strata's passes read it in their shaders (add it where the depth texture is made)",
            ));
        }
        if !texture.format().has_depth_aspect() {
            return Err(Error::input(format!(
                "the opaque depth's format {:?} has no depth: give a depth texture (Depth32Float, Depth24Plus, …)",
                texture.format()
            )));
        }
        if texture.sample_count() != 1 {
            return Err(Error::input(format!(
                "the opaque depth has {} samples: strata tests fragments against a single-sampled opaque depth",
                texture.sample_count()
            )));
        }
    }
    Ok(())
}

/// Refuses the options an application's recorder cannot take: what needs strata's own
/// geometry or materials.
pub(super) fn check_application_options(options: &RenderOptions) -> Result<()> {
    let refuse = |what: &str, why: &str| {
        Err(Error::unsupported(format!(
            "{what} with the application's own shaders: {why}"
        )))
    };
    if options.build.raster != crate::raster::Raster::Hw {
        return refuse(
            "--raster compute",
            "the compute rasterizer draws strata's own triangles",
        );
    }
    if options.build.lighting.pipeline.is_some() {
        return refuse(
            "a lit pipeline",
            "the pipeline draws strata's own opaque scene; draw yours and pass its depth",
        );
    }
    if let Some(order) = options.frame.order {
        return refuse(
            &format!("--order {}", order.name()),
            "it resubmits strata's own triangles",
        );
    }
    if options.frame.temporal.is_some() {
        return refuse(
            "--temporal on",
            "it reprojects strata's own world positions",
        );
    }
    if options.frame.k_auto.is_some() {
        return refuse(
            "--k auto",
            "its histogram counts strata's own geometry; give k",
        );
    }
    if options.frame.effect == crate::frame::Effect::Translucency {
        return refuse(
            "the translucency effect",
            "it reads strata's materials (index of refraction, absorption); composite your colours with transparency",
        );
    }
    Ok(())
}
