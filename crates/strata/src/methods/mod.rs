//! The multi-fragment methods, one folder per family, their typed registry ([`MethodId`]) and
//! the catalogue `strata methods` prints.
//!
//! A [`Method`] records one frame into the caller's encoder (see [`crate::frame`]): its capture
//! and resolve passes, each pixel's [`crate::frame::Resolved`] value, the frame totals, and the
//! counters it wants back. It never submits and never waits: its counters come back a frame or
//! more later through [`Method::stats`], where feedback (a pool that overflowed, a layer count)
//! is applied to the next frame. Pipelines are built once when the method is created; per-pixel
//! buffers are (re)allocated when a frame needs more.

pub mod backends;
pub mod baseline;
pub mod choice;
pub mod convex;
pub mod downlevel;
pub mod kbuffer;
pub mod options;
pub mod peeling;
pub mod table;
pub mod tiled;
pub mod traffic;
pub mod weighted;

use std::fmt;
use std::str::FromStr;

#[cfg(feature = "serde")]
use serde::Serialize;

use crate::error::{Error, Result};
use crate::frame::{FrameContext, MethodStats, Recorded, RenderOptions, SceneGpu, Totals};
use crate::gpu::{Gpu, ResourceCache};
pub use options::MethodOption;
pub use table::{ClosedForm, Descriptor, Family, Ordering, PixelSite, Support};

/// Every method id of the catalogue (with the `clap` feature, a `clap::ValueEnum` whose names
/// are the ids).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
#[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
pub enum MethodId {
    /// The exact CPU reference (runs on the CPU, not as a GPU method).
    Reference,
    /// Alpha blending in submission order.
    Unsorted,
    /// Alpha blending after a back-to-front sort of the triangles' centroids.
    Sorted,
    /// Front-to-back depth peeling.
    F2b,
    /// Dual depth peeling: the nearest and farthest layer per pass.
    Dual,
    /// Per-pixel linked lists of every fragment, sorted at resolve.
    AbufferLl,
    /// Fixed arrays of k slots per pixel; fragments past k are counted and dropped.
    AbufferFixed,
    /// The original k-buffer: sorted insertion without a lock (its races kept).
    Kb,
    /// Sorted insertion inside a per-pixel spin lock (pixel synchronization emulated).
    KbPs,
    /// Every fragment in fixed arrays; the k nearest chosen at resolve.
    KbAbFixed,
    /// k+-buffer: the k nearest unsorted under a spin lock, with a max-array.
    KplusArray,
    /// k+-buffer with the revised max-array: the first k fragments stored without the lock.
    KplusArrayR,
    /// k+-buffer max-array whose resolve sorts by the bitonic network at every k.
    KplusBitonic,
    /// k+-buffer with a max-heap: O(log k) replacement.
    KplusHeap,
    /// Multi-depth test: an atomicMax cascade of 32-bit depths, colors in a second pass.
    KbMdt32,
    /// Multi-depth test with 64-bit keys of depth and 8-bit color.
    KbMdt64,
    /// Multi-depth test with 20 depth bits and 12 color bits packed, two cascades.
    KbMdtPack,
    /// Lock-free exact k-buffer: an atomicMax cascade of 64-bit (depth, primitive) keys.
    KbKeys,
    /// Every fragment in linked lists; the k nearest chosen at resolve.
    KbAbLl,
    /// Sorted linked-list insertion by compare-exchange; losses counted.
    KbLl,
    /// S-buffer: a count pass, a prefix sum, every pixel's fragments in one region.
    Sbuffer,
    /// Every fragment in S-buffer regions; the k nearest chosen at resolve.
    KbSbuffer,
    /// Memory-aware k+-buffer: min(f, k) slots per pixel from a prefix sum.
    KplusSbuffer,
    /// k-depth peeling: the k nearest behind the last composited fragment, per pass.
    Kpeel,
    /// Weighted blended OIT (approximate).
    Wboit,
    /// Moment-based OIT (approximate).
    Mboit,
    /// Semi-heap k-buffer: a max-heap of the farthest few and an unordered rest.
    KplusSemiheap,
    /// Convex polyhedra ordered per frame by separating planes and nesting.
    Convex,
    /// Bucket depth peeling: each pixel's depth range in buckets, one geometry pass.
    Bucket,
    /// Exact OIT in compute: each 8×8 tile's fragments sorted inside one workgroup.
    Tiled,
    /// Multi-layer alpha blending: k layers under a spin lock, the two farthest merged.
    Mlab,
    /// Stochastic transparency: stratified sample stipples, the alpha-corrected average.
    Stochastic,
    /// Wavelet OIT: Haar coefficients of each pixel's absorbance over depth.
    Wavelet,
    /// Weighted average OIT: the opacity-weighted average color over the average opacity.
    Wavg,
}

/// Every method option's spec ([`options::OptionSpec`]), family by family: each family's
/// folder declares its own (`OPTIONS` in its `options.rs`, convex's beside its descriptor),
/// this list registers them.
pub fn option_specs() -> impl Iterator<Item = &'static options::OptionSpec> {
    [
        options::SHARED,
        kbuffer::options::OPTIONS,
        peeling::options::OPTIONS,
        weighted::options::OPTIONS,
        convex::descriptor::OPTIONS,
    ]
    .into_iter()
    .flatten()
}

/// The method table in catalogue order (the order of `strata methods`): each family's folder
/// defines its descriptors, this list registers them.
pub static TABLE: &[&Descriptor] = &[
    &table::REFERENCE,
    &baseline::descriptor::UNSORTED,
    &baseline::descriptor::SORTED,
    &weighted::descriptor::WBOIT,
    &weighted::descriptor::MBOIT,
    &weighted::descriptor::WAVELET,
    &weighted::descriptor::WAVG,
    &weighted::descriptor::STOCHASTIC,
    &peeling::descriptor::F2B,
    &peeling::descriptor::DUAL,
    &peeling::descriptor::BUCKET,
    &kbuffer::descriptor::ABUFFER_LL,
    &kbuffer::descriptor::SBUFFER,
    &kbuffer::descriptor::KPEEL,
    &convex::descriptor::CONVEX,
    &tiled::descriptor::TILED,
    &kbuffer::descriptor::ABUFFER_FIXED,
    &kbuffer::descriptor::KB_KEYS,
    &kbuffer::descriptor::KB,
    &kbuffer::descriptor::KB_PS,
    &kbuffer::descriptor::MLAB,
    &kbuffer::descriptor::KB_AB_FIXED,
    &kbuffer::descriptor::KPLUS_ARRAY,
    &kbuffer::descriptor::KPLUS_ARRAY_R,
    &kbuffer::descriptor::KPLUS_BITONIC,
    &kbuffer::descriptor::KPLUS_HEAP,
    &kbuffer::descriptor::KPLUS_SBUFFER,
    &kbuffer::descriptor::KPLUS_SEMIHEAP,
    &kbuffer::descriptor::KB_MDT32,
    &kbuffer::descriptor::KB_MDT64,
    &kbuffer::descriptor::KB_MDT_PACK,
    &kbuffer::descriptor::KB_AB_LL,
    &kbuffer::descriptor::KB_SBUFFER,
    &kbuffer::descriptor::KB_LL,
];

impl MethodId {
    /// The method's entry in the table.
    pub fn descriptor(self) -> &'static Descriptor {
        TABLE
            .iter()
            .copied()
            .find(|d| d.id == self)
            .expect("every method id is registered in TABLE")
    }

    /// The method's name on the command line, in files and in statistics.
    pub fn as_str(self) -> &'static str {
        self.descriptor().name
    }

    /// Every method, in catalogue order.
    pub fn all() -> impl Iterator<Item = MethodId> {
        TABLE.iter().map(|d| d.id)
    }

    /// Every method that runs on the GPU.
    pub fn gpu_methods() -> impl Iterator<Item = MethodId> {
        Self::all().filter(|m| *m != MethodId::Reference)
    }
}

impl fmt::Display for MethodId {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.as_str())
    }
}

impl FromStr for MethodId {
    type Err = Error;
    fn from_str(s: &str) -> Result<MethodId> {
        MethodId::all()
            .find(|m| m.as_str() == s)
            .ok_or_else(|| unknown_method(s))
    }
}

#[cfg(feature = "serde")]
impl Serialize for MethodId {
    fn serialize<S: serde::Serializer>(&self, s: S) -> std::result::Result<S::Ok, S::Error> {
        s.serialize_str(self.as_str())
    }
}

/// One multi-fragment technique, recording frames into the caller's encoder.
pub trait Method {
    /// Records a frame: every pass into `ctx.encoder`, counters to read back into
    /// `ctx.readback`. Never submits, never waits.
    fn record(&mut self, ctx: &mut FrameContext<'_>) -> Result<Recorded>;

    /// Reads the counters a frame asked for, with the frame totals, and applies feedback to the
    /// next frame; not called for a frame whose statistics were skipped (it then reports what
    /// it recorded and nothing it read). Methods without counters or feedback report nothing
    /// beyond the frame totals.
    fn stats(&mut self, recorded: &Recorded, totals: &Totals, words: &[u32]) -> MethodStats {
        let _ = (recorded, totals, words);
        MethodStats::default()
    }

    /// The buffers kept between frames (tests poison them).
    fn resources(&self) -> Vec<&ResourceCache>;
}

/// The method table in catalogue order.
pub fn catalogue() -> impl Iterator<Item = &'static Descriptor> {
    TABLE.iter().copied()
}

/// The method table as Markdown, one row per method in the catalogue's order: what `strata
/// methods --markdown` prints and the README carries (a test holds them equal).
pub fn markdown_table() -> String {
    let yes = |b: bool| if b { "yes" } else { "no" };
    let mut out = String::from(
        "| id | family | exact | raster | msaa | blend | app shaders | k ≤ | geometry passes | memory (bytes) | what it is |\n|---|---|---|---|---|---|---|---|---|---|---|\n",
    );
    for d in catalogue() {
        let msaa: Vec<String> = d.msaa_counts().iter().map(u32::to_string).collect();
        out.push_str(&format!(
            "| `{}` | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} |\n",
            d.name,
            d.family.name(),
            yes(d.exact),
            d.rasters(),
            msaa.join(","),
            d.blend_names(),
            yes(d.app_shaders.yes()),
            match d.reads(crate::methods::options::K) {
                true => d.max_k.to_string(),
                false => "—".to_string(),
            },
            d.geometry_passes,
            d.memory,
            d.summary.replace('|', "\\|"),
        ));
    }
    out
}

/// The error for an id that names no method, listing the ones that exist.
pub fn unknown_method(id: &str) -> Error {
    let ids: Vec<_> = catalogue().map(|m| m.name).collect();
    Error::input(format!(
        "unknown method '{}' (available: {})",
        crate::error::quoted(id),
        ids.join(", ")
    ))
}

/// Creates a GPU method.
pub fn create(
    id: MethodId,
    gpu: &Gpu,
    scene: &SceneGpu,
    options: &RenderOptions,
) -> Result<Box<dyn Method>> {
    let descriptor = id.descriptor();
    backends::check_features(descriptor, gpu)?;
    descriptor.admit(options, &scene.blend_modes, scene.triangle_count as u64)?;
    if !descriptor.samples_in_compute {
        crate::frame::msaa::check_device(gpu, options.build.msaa)?;
    }
    crate::gpu::validated(gpu, id.as_str(), || {
        (descriptor.create)(
            id,
            &table::Setup {
                gpu,
                scene,
                options,
            },
        )
    })
}

#[cfg(test)]
pub(crate) mod tests;
