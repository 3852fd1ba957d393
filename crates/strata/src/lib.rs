//! strata — multi-fragment rendering on the GPU with wgpu: order-independent transparency,
//! translucency and depth complexity, with every family of technique (depth peeling,
//! A-buffers, k-buffers, multi-depth-test atomics, a compute rasterizer, convex ordering), a
//! deferred many-light pipeline and an exact CPU reference.
//!
//! # From a wgpu renderer to an exact transparent pass
//! 1. **Wrap your device.** [`gpu::Gpu::from_device`] takes your `wgpu::Device` and `Queue`.
//!    Request [`gpu::wanted_features`] (as far as the adapter has them) when you create the
//!    device: 64-bit atomics, timestamps and coherent storage widen the methods you can use.
//! 2. **Describe what is transparent.** A [`scene::Scene`] holds the meshes, materials and
//!    lights strata draws; build one, or (feature `scenes`) load a file or a built-in with
//!    `scene::loaders::load_scene`.
//! 3. **Make a recorder** with [`FrameRecorder::new`]: the scene, a method ([`MethodId`]; or
//!    let [`methods::choice::choose`] pick the best one your adapter runs for a [`methods::choice::Goal`])
//!    and [`RenderOptions`] (`build`: fixed for the recorder; `frame`: may change between frames
//!    with [`FrameRecorder::set_frame_options`]).
//! 4. **Every frame**, after your opaque pass has written your color target and a depth
//!    texture (any depth format, with `TEXTURE_BINDING` usage), call [`FrameRecorder::record`] with
//!    your encoder. strata tests its fragments against your depth and composites OVER your
//!    color, premultiplied; it records into your encoder and never submits or waits.
//! 5. **Read the statistics** with [`FrameRecorder::poll_stats`]: a frame or more later, each
//!    frame's [`FrameStats`] (milliseconds per pass, fragments generated, stored and dropped,
//!    whether the frame was exact, overflow and what grew for the next frame).
//!
//! ```no_run
//! use strata::{frame::FrameTargets, gpu::Gpu, scene::loaders, FrameRecorder, MethodId};
//!
//! fn transparent_pass(
//!     device: &wgpu::Device,
//!     queue: &wgpu::Queue,
//!     color: &wgpu::TextureView, // your color target, already holding the opaque scene
//!     depth: &wgpu::TextureView, // its depth (TEXTURE_BINDING usage)
//! ) -> strata::Result<()> {
//!     let gpu = Gpu::from_device(device.clone(), queue.clone());
//!     let scene = loaders::load_scene("builtin:spheres?layers=8")?;
//!     let options = strata::RenderOptions::sized(1280, 720);
//!     let mut oit = FrameRecorder::new(&gpu, &scene, MethodId::AbufferLl, &options)?;
//!     // Every frame (and `oit.set_camera(&camera)` when the camera moves):
//!     let mut encoder = device.create_command_encoder(&Default::default());
//!     let format = wgpu::TextureFormat::Rgba8UnormSrgb;
//!     let targets = FrameTargets { color: Some((color, format)), opaque_depth: Some(depth) };
//!     oit.record(&mut encoder, &targets, None)?;
//!     queue.submit([encoder.finish()]);
//!     for stats in oit.poll_stats() {
//!         println!("frame {}: {:?} fragments dropped", stats.frame, stats.fragments_dropped);
//!     }
//!     Ok(())
//! }
//! ```
//!
//! **Your own shaders and buffers** instead of a scene: [`FrameRecorder::for_application`]
//! takes your WGSL ([`frame::application::AppShader`]: your vertex stage, and a fragment stage
//! that calls `strata_capture`), builds every geometry pass of the method from it, and
//! [`FrameRecorder::record`] calls your draw callback once per pass (see
//! [`frame::application`]). Every method but `sorted`, `convex` and `tiled` takes it; the capture tests your opaque depth
//! itself, whatever depth state you would have set. `examples/own_shaders.rs`,
//! `examples/minimal.rs` and `examples/host.rs` in the repository are complete headless
//! applications, checked in its tests. For one picture in one call,
//! [`FrameRecorder::render_once`] renders until a frame is complete.
//!
//! **Exact methods** equal the CPU reference (`strata::reference`, feature `reference`) in (depth, primitive) order;
//! approximate ones (weighted, moment-based) publish their error. `ARCHITECTURE.md` in the
//! repository describes the layers and the path of a frame.

#![warn(missing_docs)]

pub mod animation;
pub mod deferred;
pub mod error;
pub mod frame;
pub mod gpu;
mod keyword;
pub mod methods;
pub mod metrics;
pub mod order;
#[cfg(feature = "png")]
pub mod output;
pub mod raster;
#[cfg(feature = "reference")]
pub mod reference;
pub mod render;
pub mod resolve;
pub mod scene;
#[cfg(test)]
pub(crate) mod testing;

pub use error::{Error, Result};
pub use frame::{BuildOptions, Effect, FrameOptions, FrameStats, FrameTargets, RenderOptions};
/// The math types strata's API names (camera, lights, meshes), at the version strata builds with.
pub use glam;
pub use methods::downlevel::DownlevelFrame;
pub use methods::kbuffer::{KBufferOptions, StorageLayout, Tail, DEFAULT_MAX_TRIES};
pub use methods::peeling::{BucketSplit, PeelingOptions};
pub use methods::weighted::{Moments, Opacity, Weight, WeightedOptions};
pub use methods::MethodId;
pub use render::{FrameRecorder, LinearImage, Renderer};
