//! The tail a k-buffer keeps of the fragments past its k (`--tail blend|weighted`): the
//! parameters its capture reads, from the frame's options and camera.

use crate::frame::RenderOptions;
use crate::methods::kbuffer::KBufferOptions;
use crate::methods::weighted::WeightedOptions;

/// `KParams::tail_weight`'s flag for an orthographic view.
pub const TAIL_ORTHOGRAPHIC: u32 = 0x100;

/// (p, q) that take a window depth d to its view distance times `scale`, as the weighted tail's
/// weight reads it: p / (q − d) in a perspective view, p + q·d in an orthographic one. The
/// capture computes it from these two numbers instead of the scene's uniforms, which an
/// application's capture does not bind.
pub fn tail_depth(camera: &crate::scene::Camera, scale: f64) -> (f32, f32) {
    let (n, f) = (camera.near as f64, camera.far as f64);
    let (p, q) = match camera.projection {
        crate::scene::Projection::Orthographic { .. } => (scale * n, scale * (f - n)),
        crate::scene::Projection::Perspective { .. } => (scale * n * f / (f - n), f / (f - n)),
    };
    (p as f32, q as f32)
}

/// A frame's tail parameters (`TailParams` in `strata::tail`): `--tail`, the weight function
/// with [`TAIL_ORTHOGRAPHIC`] for an orthographic view, and [`tail_depth`]'s p and q.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TailSettings {
    /// [`crate::Tail::index`].
    pub mode: u32,
    /// [`crate::Weight::index`], with [`TAIL_ORTHOGRAPHIC`] for an orthographic view.
    pub weight: u32,
    /// p of [`tail_depth`].
    pub depth_p: f32,
    /// q of [`tail_depth`].
    pub depth_q: f32,
}

/// The tail parameters of a frame with `options` of `scene`.
pub fn tail_settings(options: &RenderOptions, scene: &crate::frame::SceneGpu) -> TailSettings {
    let (depth_p, depth_q) = tail_depth(
        &scene.camera,
        options.frame.family::<WeightedOptions>().depth_scale,
    );
    TailSettings {
        mode: options.frame.family::<KBufferOptions>().tail.index(),
        weight: options.frame.family::<WeightedOptions>().weight.index()
            | match scene.camera.projection {
                crate::scene::Projection::Orthographic { .. } => TAIL_ORTHOGRAPHIC,
                crate::scene::Projection::Perspective { .. } => 0,
            },
        depth_p,
        depth_q,
    }
}
