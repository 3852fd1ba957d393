//! The multi-fragment methods, one folder per family, their typed registry ([`MethodId`]) and
//! the catalogue `strata methods` prints.
//!
//! A [`Method`] records one frame into the caller's encoder (see [`crate::frame`]): its capture
//! and resolve passes, each pixel's [`crate::frame::Resolved`] value, the frame totals, and the
//! counters it wants back. It never submits and never waits: its counters come back a frame or
//! more later through [`Method::stats`], where feedback (a pool that overflowed, a layer count)
//! is applied to the next frame. Pipelines are built once when the method is created; per-pixel
//! buffers are (re)allocated when a frame needs more.

pub mod baseline;
pub mod capture;
pub mod convex;
pub mod kbuffer;
pub mod peeling;
pub mod traffic;
pub mod weighted;

use std::fmt;
use std::str::FromStr;

use serde::Serialize;

use crate::error::{Error, Result};
use crate::frame::{FrameContext, MethodStats, Recorded, RenderOptions, SceneGpu, Totals};
use crate::gpu::{Gpu, ResourceCache};

/// Every method id of the catalogue (with the `clap` feature, a `clap::ValueEnum` whose names
/// are the ids).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
#[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
pub enum MethodId {
    Reference,
    Unsorted,
    Sorted,
    F2b,
    Dual,
    AbufferLl,
    AbufferFixed,
    Kb,
    KbPs,
    KbAbFixed,
    KplusArray,
    KplusArrayR,
    KplusHeap,
    KbMdt32,
    KbMdt64,
    KbMdtPack,
    KbKeys,
    KbAbLl,
    KbLl,
    Sbuffer,
    KbSbuffer,
    KplusSbuffer,
    Kpeel,
    Wboit,
    Mboit,
    KplusSemiheap,
    Convex,
    Bucket,
}

impl MethodId {
    pub const ALL: [MethodId; 28] = [
        MethodId::Reference,
        MethodId::Unsorted,
        MethodId::Sorted,
        MethodId::F2b,
        MethodId::Dual,
        MethodId::AbufferLl,
        MethodId::AbufferFixed,
        MethodId::Kb,
        MethodId::KbPs,
        MethodId::KbAbFixed,
        MethodId::KplusArray,
        MethodId::KplusArrayR,
        MethodId::KplusHeap,
        MethodId::KbMdt32,
        MethodId::KbMdt64,
        MethodId::KbMdtPack,
        MethodId::KbKeys,
        MethodId::KbAbLl,
        MethodId::KbLl,
        MethodId::Sbuffer,
        MethodId::KbSbuffer,
        MethodId::KplusSbuffer,
        MethodId::Kpeel,
        MethodId::Wboit,
        MethodId::Mboit,
        MethodId::KplusSemiheap,
        MethodId::Convex,
        MethodId::Bucket,
    ];

    pub fn as_str(self) -> &'static str {
        match self {
            MethodId::Reference => "reference",
            MethodId::Unsorted => "unsorted",
            MethodId::Sorted => "sorted",
            MethodId::F2b => "f2b",
            MethodId::Dual => "dual",
            MethodId::AbufferLl => "abuffer-ll",
            MethodId::AbufferFixed => "abuffer-fixed",
            MethodId::Kb => "kb",
            MethodId::KbPs => "kb-ps",
            MethodId::KbAbFixed => "kb-ab-fixed",
            MethodId::KplusArray => "kplus-array",
            MethodId::KplusArrayR => "kplus-array-r",
            MethodId::KplusHeap => "kplus-heap",
            MethodId::KbMdt32 => "kb-mdt32",
            MethodId::KbMdt64 => "kb-mdt64",
            MethodId::KbMdtPack => "kb-mdt-pack",
            MethodId::KbKeys => "kb-keys",
            MethodId::KbAbLl => "kb-ab-ll",
            MethodId::KbLl => "kb-ll",
            MethodId::Sbuffer => "sbuffer",
            MethodId::KbSbuffer => "kb-sbuffer",
            MethodId::KplusSbuffer => "kplus-sbuffer",
            MethodId::Kpeel => "kpeel",
            MethodId::Wboit => "wboit",
            MethodId::Mboit => "mboit",
            MethodId::KplusSemiheap => "kplus-semiheap",
            MethodId::Convex => "convex",
            MethodId::Bucket => "bucket",
        }
    }

    /// The catalogue entry.
    pub fn info(self) -> MethodInfo {
        catalogue()
            .into_iter()
            .find(|m| m.id == self.as_str())
            .expect("every id is catalogued")
    }

    /// Every method that runs on the GPU.
    pub fn gpu_methods() -> impl Iterator<Item = MethodId> {
        Self::ALL.into_iter().filter(|m| *m != MethodId::Reference)
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
        MethodId::ALL
            .into_iter()
            .find(|m| m.as_str() == s)
            .ok_or_else(|| unknown_method(s))
    }
}

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

    /// Reads the counters a frame asked for (`None` when its statistics were skipped), with
    /// the frame totals, and applies feedback to the next frame.
    /// Methods without counters or feedback report nothing beyond the frame totals.
    fn stats(
        &mut self,
        recorded: &Recorded,
        totals: &Totals,
        words: Option<&[u32]>,
    ) -> MethodStats {
        let _ = (recorded, totals, words);
        MethodStats::default()
    }

    /// The buffers kept between frames (tests poison them).
    fn resources(&self) -> Vec<&ResourceCache>;

    /// Methods whose capture an application's shader calls (see [`capture`]): the group layout
    /// the application's pipeline places.
    fn capture_layout(&self) -> Option<&wgpu::BindGroupLayout> {
        None
    }

    /// Records what precedes the application's capture pass (clears) and returns the bind
    /// group it places; [`Method::end_capture`] follows the pass.
    fn begin_capture(&mut self, ctx: &mut FrameContext<'_>) -> Result<wgpu::BindGroup> {
        let _ = ctx;
        Err(Error::unsupported(
            "this method has no capture an application's shader can call",
        ))
    }

    /// Records the resolve after the application's capture pass.
    fn end_capture(&mut self, ctx: &mut FrameContext<'_>) -> Result<Recorded> {
        let _ = ctx;
        Err(Error::runtime("end_capture without begin_capture"))
    }
}

/// A catalogue entry.
#[derive(Clone, Debug, Serialize)]
pub struct MethodInfo {
    pub id: &'static str,
    pub family: &'static str,
    pub exact: bool,
    /// Geometry passes, N being the scene's depth complexity.
    pub geometry_passes: &'static str,
    /// Bytes the method allocates, W·H pixels, F fragments in the frame.
    pub memory: &'static str,
    pub summary: &'static str,
}

pub fn catalogue() -> Vec<MethodInfo> {
    vec![
        MethodInfo {
            id: "reference",
            family: "reference",
            exact: true,
            geometry_passes: "0 (CPU)",
            memory: "host: 64·F",
            summary: "CPU exact renderer: every fragment, sorted by depth then primitive, composited in f64",
        },
        MethodInfo {
            id: "unsorted",
            family: "baseline",
            exact: false,
            geometry_passes: "1",
            memory: "(8·S + 4)·W·H; S samples per pixel (--msaa, else 1)",
            summary: "alpha blending in submission order (no OIT)",
        },
        MethodInfo {
            id: "sorted",
            family: "baseline",
            exact: false,
            geometry_passes: "1",
            memory: "(8·S + 4)·W·H + 12·triangles; S samples per pixel (--msaa, else 1)",
            summary: "alpha blending after a back-to-front sort of triangle centroids",
        },
        MethodInfo {
            id: "wboit",
            family: "weighted",
            exact: false,
            geometry_passes: "1",
            memory: "(10·S + 4)·W·H; S samples per pixel (--msaa, else 1)",
            summary: "weighted blended OIT (McGuire & Bavoil 2013): weighted average color over exact coverage, weights of eqs. 7-10 (--weight, --depth-scale); what engines ship",
        },
        MethodInfo {
            id: "mboit",
            family: "weighted",
            exact: false,
            geometry_passes: "2",
            memory: "(28·S + 4)·W·H, +8·S with --moments 6, +16·S with 8; S samples per pixel (--msaa, else 1)",
            summary: "moment-based OIT (Münstermann et al. 2018): 4, 6 or 8 power moments of absorbance over log depth (--moments; 32-bit, bias 5e-7, 5e-7, 2e-6, overestimation 0.25), transmittance reconstructed per fragment; exact coverage",
        },
        MethodInfo {
            id: "f2b",
            family: "peeling",
            exact: true,
            geometry_passes: "N (the last frame's depth complexity, or --layers)",
            memory: "56·W·H",
            summary: "front-to-back depth peeling, one layer per geometry pass",
        },
        MethodInfo {
            id: "dual",
            family: "peeling",
            exact: true,
            geometry_passes: "ceil(N/2)+1 (N: the last frame's depth complexity, or --layers)",
            memory: "140·W·H with 64-bit atomics, else 124·W·H",
            summary: "dual depth peeling: nearest and farthest layer per pass; exact with ties given 64-bit atomic min/max (else fragments at exactly equal depth in one pixel collapse and are counted as dropped)",
        },
        MethodInfo {
            id: "bucket",
            family: "peeling",
            exact: false,
            geometry_passes: "3 (4 with --buckets adaptive)",
            memory: "(16·k + 16·ceil(k/4) + 16)·W·H + 16, +128·W·H with --buckets adaptive; with --msaa S: (S·(16·k + 16·ceil(k/4) + 4) + 8·S + 16)·W·H + 16; k even, at most 32 and 4 × the color targets the device blends at once",
            summary: "bucket depth peeling (Liu et al. 2009): each pixel's depth range split into k/2 buckets (uniform, or adaptive: shared among the occupied parts of a 1024-part histogram), every bucket's nearest and farthest depth kept by MAX blending into ceil(k/4) RGBA32F targets in one geometry pass, colors claimed in a second; a third fragment in a bucket collides and is counted as dropped",
        },
        MethodInfo {
            id: "abuffer-ll",
            family: "abuffer",
            exact: true,
            geometry_passes: "1 (+1 when the node pool overflows)",
            memory: "20·nodes + 16·W·H + 152 (nodes ≥ F)",
            summary: "A-buffer of per-pixel linked lists; a pool that overflowed grows for the next frame (exact mode re-renders)",
        },
        MethodInfo {
            id: "sbuffer",
            family: "abuffer",
            exact: true,
            geometry_passes: "2 (+2 when the pool overflows)",
            memory: "16·F + 16·W·H + 4·(W·H + W·H/256 + …) + 152",
            summary: "S-buffer: a count pass, a GPU prefix sum over the pixels, every pixel's fragments stored in one contiguous region (no per-pixel slack)",
        },
        MethodInfo {
            id: "kpeel",
            family: "peeling",
            exact: true,
            geometry_passes: "ceil(N/k), twice that with the lock-free capture (N: the last frame's depth complexity, or --layers)",
            memory: "16·(k+1)·W·H + 152, +8·k·W·H with the lock-free capture",
            summary: "k-depth peeling: the k nearest fragments behind the last composited (depth, primitive) per pass, by a lock-free cascade of 64-bit keys (a keys and a colors geometry pass; single-sampled, SHADER_INT64_ATOMIC_ALL_OPS) or else a k+-buffer capture under a lock; A-buffer results in bounded memory, equal-depth fragments included",
        },
        MethodInfo {
            id: "convex",
            family: "convex",
            exact: true,
            geometry_passes: "1 read of the geometry, split over P passes (P: groups in the deepest chain of groups whose screen footprints meet)",
            memory: "(16·L + 44)·W·H + 12·triangles + 64; L = 2, or 4 with paired groups",
            summary: "convex polyhedra (seed 001): convex parts by region growing, ordered per frame by separating planes and nesting; each pass captures groups that cannot share a pixel (2 layers per part) and merges them front to back; exact when the order holds, order_violations counted",
        },
        MethodInfo {
            id: "abuffer-fixed",
            family: "abuffer",
            exact: false,
            geometry_passes: "1",
            memory: KB_MEMORY,
            summary: "A-buffer of fixed per-pixel arrays of k slots (FABS); fragments past k are counted as dropped",
        },
        MethodInfo {
            id: "kb-keys",
            family: "kbuffer",
            exact: true,
            geometry_passes: "2",
            memory: KB_MEMORY,
            summary: "lock-free exact k-buffer: an atomicMax cascade of 64-bit (depth, primitive) keys keeps the k nearest sorted, payloads stored by tag in a second geometry pass; nothing spins or fails (SHADER_INT64_ATOMIC_ALL_OPS)",
        },
        MethodInfo {
            id: "kb",
            family: "kbuffer",
            exact: false,
            geometry_passes: "1",
            memory: KB_MEMORY,
            summary: "original k-buffer: sorted insertion with no lock (read-modify-write hazards between fragments of a pixel)",
        },
        MethodInfo {
            id: "kb-ps",
            family: "kbuffer",
            exact: true,
            geometry_passes: "1",
            memory: KB_MEMORY,
            summary: "k-buffer with sorted insertion inside a per-pixel spin lock (pixel synchronisation emulated)",
        },
        MethodInfo {
            id: "kb-ab-fixed",
            family: "kbuffer",
            exact: true,
            geometry_passes: "1 (+1 when the array overflows)",
            memory: "16·(n+1)·W·H + 112 + 40·(W·H with --tail blend, else 1); n: max depth complexity",
            summary: "every fragment in fixed arrays sized from measured need, the k nearest selected in resolve",
        },
        MethodInfo {
            id: "kplus-array",
            family: "kplus",
            exact: true,
            geometry_passes: "1",
            memory: KB_MEMORY,
            summary: "k+-buffer max-array: k nearest captured unsorted under a spin lock, max in slot 0, culling",
        },
        MethodInfo {
            id: "kplus-array-r",
            family: "kplus",
            exact: true,
            geometry_passes: "1",
            memory: KB_MEMORY,
            summary: "k+-buffer revised max-array: the first k fragments stored without the lock",
        },
        MethodInfo {
            id: "kplus-heap",
            family: "kplus",
            exact: true,
            geometry_passes: "1",
            memory: KB_MEMORY,
            summary: "k+-buffer max-heap: sift-up while filling, replace-root and sift-down when full, culling",
        },
        MethodInfo {
            id: "kplus-sbuffer",
            family: "kplus",
            exact: true,
            geometry_passes: "2 (+2 when the pool overflows)",
            memory: "16·Σmin(f,k) + 20·W·H + 4·(W·H + W·H/256 + …) + 112 + 40·(W·H with --tail blend, else 1); f: a pixel's fragments",
            summary: "memory-aware k+-buffer: a count pass, a GPU prefix sum giving each pixel exactly min(f, k) slots, then lock-free appends (f ≤ k) or a max-array (k ≤ 16) / max-heap under a spin lock",
        },
        MethodInfo {
            id: "kplus-semiheap",
            family: "kplus",
            exact: true,
            geometry_passes: "1",
            memory: KB_MEMORY,
            summary: "semi-heap k-buffer (seed 000): a max-heap of the h farthest (--heap-size, default 1) and an unordered rest; the first k - h fragments stored without the lock, culling against the heap top",
        },
        MethodInfo {
            id: "kb-mdt32",
            family: "kbuffer",
            exact: true,
            geometry_passes: "2",
            memory: "20·k·W·H + 16·W·H + 112 + 40·(W·H with --tail blend, else 1)",
            summary: "multi-depth test: atomicMax cascade of depth keys, colors fetched in a second geometry pass (ties beyond k share keys)",
        },
        MethodInfo {
            id: "kb-mdt64",
            family: "kbuffer",
            exact: false,
            geometry_passes: "1",
            memory: "8·k·W·H + 16·W·H + 112 + 40·(W·H with --tail blend, else 1)",
            summary: "multi-depth test on 64-bit keys: depth and 8-bit sRGB color in one cascade (SHADER_INT64_ATOMIC_ALL_OPS)",
        },
        MethodInfo {
            id: "kb-mdt-pack",
            family: "kbuffer",
            exact: false,
            geometry_passes: "1",
            memory: "8·k·W·H + 16·W·H + 152",
            summary: "multi-depth test packing: 20 depth bits + 12 color bits in two 32-bit cascades (seed 002)",
        },
        MethodInfo {
            id: "kb-ab-ll",
            family: "kbuffer",
            exact: true,
            geometry_passes: "1 (+1 when the node pool overflows)",
            memory: "20·nodes + 16·W·H + 112 + 40·(W·H with --tail blend, else 1); nodes ≥ F",
            summary: "A-buffer linked lists, the k nearest selected in resolve",
        },
        MethodInfo {
            id: "kb-sbuffer",
            family: "kbuffer",
            exact: true,
            geometry_passes: "2 (+2 when the pool overflows)",
            memory: "16·F + 16·W·H + 4·(W·H + W·H/256 + …) + 112 + 40·(W·H with --tail blend, else 1)",
            summary: "every fragment in S-buffer regions, the k nearest selected in resolve",
        },
        MethodInfo {
            id: "kb-ll",
            family: "kbuffer",
            exact: false,
            geometry_passes: "1 (+1 when the node pool overflows)",
            memory: "20·nodes + 16·W·H + 112 + 40·(W·H with --tail blend, else 1); nodes ≤ F",
            summary: "sorted linked-list insertion by compare-exchange, bounded retries, losses counted",
        },
    ]
}

/// Memory of the k-slot methods; `kbuffer::SLOT_BYTES` etc. keep it true.
const KB_MEMORY: &str = "16·(k+1)·W·H + 112 + 40·(W·H with --tail blend, else 1)";

pub fn info(id: &str) -> Option<MethodInfo> {
    catalogue().into_iter().find(|m| m.id == id)
}

pub fn unknown_method(id: &str) -> Error {
    let ids: Vec<_> = catalogue().iter().map(|m| m.id).collect();
    Error::input(format!(
        "unknown method '{id}' (available: {})",
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
    use kbuffer::{list::ListKBuffer, mdt::Mdt, mdt::MdtKBuffer, SlotKBuffer, Variant};
    crate::raster::check_method(id, options.raster)?;
    crate::frame::msaa::check_method(id, options, scene.triangle_count as u64)?;
    crate::frame::msaa::check_device(gpu, options.msaa)?;
    Ok(match id {
        MethodId::Unsorted => Box::new(baseline::Blend::new(gpu, scene, false)),
        MethodId::Sorted => Box::new(baseline::Blend::new(gpu, scene, true)),
        MethodId::F2b => Box::new(peeling::FrontToBack::new(gpu, scene)),
        MethodId::Wboit => Box::new(weighted::Wboit::new(gpu, scene)),
        MethodId::Mboit => Box::new(weighted::mboit::Mboit::new(gpu, scene)?),
        MethodId::Dual => Box::new(peeling::Dual::new(gpu, scene)),
        MethodId::Bucket => Box::new(peeling::bucket::Bucket::new(gpu, scene)?),
        MethodId::AbufferLl | MethodId::KbAbLl | MethodId::KbLl => {
            Box::new(ListKBuffer::new(gpu, scene, id, options))
        }
        MethodId::Sbuffer | MethodId::KbSbuffer | MethodId::KplusSbuffer => {
            Box::new(kbuffer::sbuffer::SBuffer::new(gpu, scene, id, options))
        }
        MethodId::Kpeel => Box::new(kbuffer::kpeel::KPeel::new(gpu, scene)?),
        MethodId::Convex => Box::new(convex::Convex::new(gpu, scene, options)?),
        MethodId::KbMdt32 => Box::new(MdtKBuffer::new(gpu, scene, id, Mdt::Mdt32)?),
        MethodId::KbMdt64 => Box::new(MdtKBuffer::new(gpu, scene, id, Mdt::Mdt64)?),
        MethodId::KbMdtPack => Box::new(MdtKBuffer::new(gpu, scene, id, Mdt::Pack)?),
        MethodId::KbKeys => Box::new(MdtKBuffer::new(gpu, scene, id, Mdt::Keys)?),
        MethodId::KplusArray => Box::new(SlotKBuffer::new(gpu, scene, id, Variant::KplusArray)),
        MethodId::KplusHeap => Box::new(SlotKBuffer::new(gpu, scene, id, Variant::KplusHeap)),
        MethodId::KplusArrayR => Box::new(SlotKBuffer::new(gpu, scene, id, Variant::KplusArrayR)),
        MethodId::KplusSemiheap => {
            Box::new(SlotKBuffer::new(gpu, scene, id, Variant::KplusSemiheap))
        }
        MethodId::Kb => Box::new(SlotKBuffer::new(gpu, scene, id, Variant::Kb)),
        MethodId::KbPs => Box::new(SlotKBuffer::new(gpu, scene, id, Variant::KbPs)),
        MethodId::AbufferFixed => Box::new(SlotKBuffer::new(gpu, scene, id, Variant::AbufferFixed)),
        MethodId::KbAbFixed => Box::new(SlotKBuffer::new(gpu, scene, id, Variant::KbAbFixed)),
        MethodId::Reference => {
            return Err(Error::input(
                "method 'reference' runs on the CPU: use strata::reference::render",
            ))
        }
    })
}

#[cfg(test)]
pub(crate) mod tests;
