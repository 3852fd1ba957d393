//! Multi-depth-test k-buffers (seed 002's MDTS, seed 003's KB-MDT): atomic cascades keep each
//! pixel's k nearest keys sorted with no lock.
//!
//! - `kb-mdt32`: a depth pass cascades 32-bit depth keys; a color pass (second geometry pass)
//!   finds each fragment's key and stores its color and tag. Memory: 20 bytes per slot (key,
//!   claim, 3 color words). Exact but for depth ties beyond k, which share keys.
//! - `kb-mdt64`: one pass, 64-bit keys of depth and 8-bit sRGB color + alpha
//!   (SHADER_INT64_ATOMIC_ALL_OPS). 8 bytes per slot. Color quantized to 8 bits; no primitive or
//!   facing survives, so translucency is unsupported.
//! - `kb-mdt-pack`: one pass, two 32-bit cascades sharing the top 20 bits of the depth mapped to
//!   [0.5, 1), each with 12 bits of color (6 bits per sRGB channel and alpha). 8 bytes per slot.
//!   Depth quantized to 2⁻¹⁹; fragments tied in the top 20 bits can swap colors between the two
//!   arrays. Translucency and `--tail blend` are unsupported (no facing; a displaced key carries
//!   half a color).
//!
//! - `kb-keys`: the lock-free exact k-buffer (keys.wgsl). A keys pass cascades 64-bit keys of
//!   (depth bits, tag) — unique per pixel, so exact with ties — and a colors pass stores each
//!   kept fragment's payload in the slot holding its key, found by its tag; the rest join the
//!   tail. 16 bytes per slot (key, payload); SHADER_INT64_ATOMIC_ALL_OPS. Nothing spins, nothing
//!   fails, relaxed atomics suffice: what the seeds' spin-lock k-buffers keep, on any GPU.
//!   With culling on, a key reads the last slot (culled: one load), then a binary search finds
//!   where its atomics start. On the hardware rasterizer, which gives a fragment the same depth
//!   in both passes, the colors pass sends a fragment more than 4 ulps farther than a full
//!   pixel's k-th key to the tail after one load, where the compute rasterizer's walks the slots for its tag.
//!
//! Passes: clear; capture (1 or 2 geometry passes); the shared k resolve. Per pixel 16 bytes of
//! counters and 20 of tail sums with `--tail blend`, as the other k-buffers.

use super::{k_of, lock_failures, params_for, KFrame, Layout, Storage};
use crate::error::{Error, Result};
use crate::frame::passes::GeometryStage;
use crate::frame::{Effect, FrameContext, MethodStats, Recorded, SceneGpu, Totals};
use crate::gpu::{Gpu, ResourceCache};
use crate::methods::kbuffer::KBufferOptions;
use crate::methods::{Method, MethodId};

/// Which multi-depth test.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Mdt {
    /// `kb-mdt32`: 32-bit depth cascade, colors in a second pass.
    Mdt32,
    /// `kb-mdt64`: 64-bit keys of depth and 8-bit color.
    Mdt64,
    /// `kb-mdt-pack`: 20 depth bits and 12 color bits, two cascades.
    Pack,
    /// `kb-keys`: 64-bit (depth, primitive) keys, payloads stored by tag.
    Keys,
}

impl Mdt {
    /// The method this multi-depth test is.
    pub fn id(self) -> MethodId {
        match self {
            Mdt::Mdt32 => MethodId::KbMdt32,
            Mdt::Mdt64 => MethodId::KbMdt64,
            Mdt::Pack => MethodId::KbMdtPack,
            Mdt::Keys => MethodId::KbKeys,
        }
    }

    /// Bytes per slot.
    pub fn slot_bytes(self) -> u64 {
        match self {
            Mdt::Mdt32 => 20,
            Mdt::Mdt64 | Mdt::Pack => 8,
            Mdt::Keys => 16,
        }
    }
}

impl Mdt {
    /// The capture stage's source: its entry points and steps.
    pub fn capture_source(self) -> &'static str {
        match self {
            Mdt::Mdt64 => include_str!("mdt64.wgsl"),
            Mdt::Keys => include_str!("keys.wgsl"),
            Mdt::Mdt32 | Mdt::Pack => include_str!("mdt.wgsl"),
        }
    }

    /// How the resolve reads the stored keys.
    pub fn layout(self) -> Layout {
        match self {
            Mdt::Mdt32 => Layout::Mdt32,
            Mdt::Mdt64 => Layout::Mdt64,
            Mdt::Keys => Layout::Keys,
            Mdt::Pack => Layout::Pack,
        }
    }
}

/// The atomicMax-cascade methods.
pub struct MdtKBuffer {
    mdt: Mdt,
    frame: KFrame,
    /// Geometry passes in order: (pass name, pipeline).
    passes: Vec<(&'static str, GeometryStage)>,
}

impl MdtKBuffer {
    /// The method `id` of `mdt` for `scene` (kb-mdt64 and kb-keys on a device with 64-bit
    /// atomics: their descriptors' `needs`, which `methods::create` checks).
    pub fn new(gpu: &Gpu, scene: &SceneGpu, id: MethodId, mdt: Mdt) -> Result<MdtKBuffer> {
        let mut frame = KFrame::new(gpu, scene, id, mdt.layout());
        // No lock and no publication: the cascades need no ordering beyond atomicity.
        let module = frame.capture_module(gpu, scene, mdt.capture_source(), mdt.layout(), false);
        let pipeline = |entry: &str| frame.capture_pipeline(gpu, scene, &module, entry);
        let passes = match mdt {
            Mdt::Mdt32 => vec![
                ("capture_depth", pipeline("fs_mdt32_depth")?),
                ("capture_color", pipeline("fs_mdt32_color")?),
            ],
            Mdt::Mdt64 => vec![("capture", pipeline("fs_mdt64")?)],
            Mdt::Keys => vec![
                ("capture_keys", pipeline("fs_keys")?),
                ("capture_colors", pipeline("fs_keys_colors")?),
            ],
            Mdt::Pack => vec![("capture", pipeline("fs_mdt_pack")?)],
        };
        Ok(MdtKBuffer { mdt, frame, passes })
    }
}

impl Method for MdtKBuffer {
    fn record(&mut self, ctx: &mut FrameContext<'_>) -> Result<Recorded> {
        if matches!(self.mdt, Mdt::Mdt64 | Mdt::Pack)
            && ctx.options.frame.effect == Effect::Translucency
        {
            return Err(Error::unsupported(format!(
                "{} keeps no primitive or facing per fragment, which translucency needs; use kb-mdt32",
                self.frame.id
            )));
        }
        if self.mdt == Mdt::Pack && ctx.options.frame.family::<KBufferOptions>().tail.kept() {
            return Err(Error::unsupported("kb-mdt-pack cannot blend a tail: a displaced key carries half a color; use --tail drop"));
        }
        let k = k_of(ctx.k, self.frame.id)?;
        let sample_slots = super::sample_storage(self.frame.id, ctx.options.build.msaa);
        let storage = Storage {
            label: "strata.kbuffer.keys",
            bytes: ctx.pixels() * sample_slots as u64 * k as u64 * self.mdt.slot_bytes(),
            clear: true,
        };
        let passes: Vec<_> = self.passes.iter().map(|(name, p)| (*name, p)).collect();
        let params = super::KParams {
            sample_slots,
            ..params_for(ctx, k, k, false)
        };
        let bytes = self.frame.record(ctx, params, storage, &passes)?;
        Ok(Recorded {
            geometry_passes: self.passes.len() as u32,
            k: Some(k),
            bytes_allocated: bytes,
            capacity: k as u64,
            memory_ordering: Some(self.frame.memory_ordering()),
            temporal: false,
            family: None,
            setup_capacity: 0,
        })
    }

    fn stats(&mut self, _: &Recorded, _: &Totals, words: &[u32]) -> MethodStats {
        MethodStats {
            lock_failures: Some(lock_failures(words)),
            ..Default::default()
        }
    }

    fn resources(&self) -> Vec<&ResourceCache> {
        self.frame.resources()
    }
}
