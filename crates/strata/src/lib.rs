//! strata — multi-fragment rendering on the GPU with wgpu.
//!
//! See `ARCHITECTURE.md` at the repository root for the layout and the path of a frame.

pub mod animation;
pub mod deferred;
pub mod error;
pub mod frame;
pub mod gpu;
pub mod methods;
pub mod metrics;
pub mod order;
pub mod output;
pub mod raster;
pub mod reference;
pub mod render;
pub mod resolve;
pub mod scene;
#[cfg(test)]
pub(crate) mod testing;

pub use error::{Error, Result};
pub use frame::{
    BucketSplit, BuildOptions, Effect, FrameOptions, FrameStats, FrameTargets, RenderOptions, Tail,
    Weight,
};
pub use methods::kbuffer::DEFAULT_MAX_TRIES;
pub use methods::MethodId;
pub use render::{FrameRecorder, LinearImage, Renderer};
