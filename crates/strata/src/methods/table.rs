//! The method table: one [`Descriptor`] per method, holding everything the rest of strata
//! decides per method — its name, family, exactness, what it can run with (rasterizers,
//! `--msaa`, temporal culling, an application's capture, `--order`, blend modes), the memory ordering its
//! capture needs, the options it reads, its k range, its catalogue text and its constructor.
//!
//! Each family's folder defines its descriptors next to the code they describe; `methods/mod.rs`
//! registers them in catalogue order ([`super::TABLE`]). Code outside a method's folder asks the
//! descriptor ([`MethodId::descriptor`]) instead of matching on ids, and the lists in error
//! messages, `strata methods` and the CLI's option checks come from the table.

#[cfg(feature = "serde")]
use serde::Serialize;

use crate::error::{Error, Result};
use crate::frame::{FrameOptions, Raster, RenderOptions, SceneGpu};
use crate::gpu::Gpu;
use crate::methods::kbuffer::{KBufferOptions, Tail};
use crate::methods::options::MethodOption;
use crate::resolve::RefFragment;
use crate::scene::{Blend, Camera};

use super::traffic::TrafficModel;
use super::{Method, MethodId};

/// The family a method is listed under.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Family {
    /// The CPU reference.
    Reference,
    /// Alpha blending without a per-pixel order (unsorted, sorted).
    Baseline,
    /// Weighted blended and moment-based OIT.
    Weighted,
    /// Depth peeling (f2b, dual, bucket, kpeel).
    Peeling,
    /// A-buffers: every fragment stored (lists, fixed arrays, S-buffers).
    Abuffer,
    /// k-buffers: the k nearest kept, without a lock or with one per insertion.
    Kbuffer,
    /// k+-buffers: the k nearest kept under a lock, with culling.
    Kplus,
    /// Convex polyhedra ordering.
    Convex,
    /// Tiled compute: fragments sorted per screen tile inside a workgroup.
    Tiled,
}

impl Family {
    /// The family's name in `strata methods` and statistics.
    pub fn name(self) -> &'static str {
        match self {
            Family::Reference => "reference",
            Family::Baseline => "baseline",
            Family::Weighted => "weighted",
            Family::Peeling => "peeling",
            Family::Abuffer => "abuffer",
            Family::Kbuffer => "kbuffer",
            Family::Kplus => "kplus",
            Family::Convex => "convex",
            Family::Tiled => "tiled",
        }
    }

    /// The k-buffers proper (kbuffer and kplus): they read `--k`, `--tail` and `--culling`.
    pub fn is_kbuffer(self) -> bool {
        matches!(self, Family::Kbuffer | Family::Kplus)
    }
}

#[cfg(feature = "serde")]
impl Serialize for Family {
    fn serialize<S: serde::Serializer>(&self, s: S) -> std::result::Result<S::Ok, S::Error> {
        s.serialize_str(self.name())
    }
}

/// Whether a method can run with something, and if not, why (the reason completes "… is not
/// supported: ").
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Support {
    /// It can.
    Yes,
    /// It cannot, and why.
    No(&'static str),
}

impl Support {
    /// Whether it can.
    pub fn yes(self) -> bool {
        self == Support::Yes
    }
}

/// The memory ordering a method's capture needs between fragments of one pixel.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Ordering {
    /// Relaxed atomics suffice: nothing spins and no reader follows another fragment's writes.
    Relaxed,
    /// A per-pixel spin lock or compare-exchange chains of list links: acquire/release on the
    /// lock, the publication counts and the links, bounded by `--max-tries`.
    Locks,
    /// kpeel: its lock-free key cascade needs none, its fallback capture (the k+-buffer's, under
    /// a lock, for `--msaa` or without 64-bit atomics) does.
    LockedFallback,
}

/// A method's bytes at a k, its memory formula as code (`Descriptor::memory` is its text), for
/// `--k auto`'s budget bound: (the method, k, the frame's depth-complexity histogram — `None`:
/// every pixel as deep as k — and the options).
pub type KMemory = fn(MethodId, u32, Option<&[u64]>, &RenderOptions) -> u64;

/// Where an approximate method's closed form is worked out: the pixel and what its picture has.
pub struct PixelSite<'a> {
    /// The pixel's row-major index in the frame (stochastic's stipples hash it).
    pub index: u32,
    /// The linear color behind the fragments.
    pub background: [f64; 3],
    /// The frame's camera (mboit's depth warp).
    pub camera: &'a Camera,
    /// The frame's options: the samples per pixel and the family's options.
    pub options: &'a RenderOptions,
}

/// An approximate method's pixel computed on the CPU in f64 from the pixel's fragments (in any
/// order, with their sample coverage): what its pictures are held to, up to its targets'
/// precision (`methods::weighted::cpu`).
pub type ClosedForm = fn(&[RefFragment], &PixelSite<'_>) -> [f64; 3];

/// Builds a method's GPU state for a scene.
pub type Constructor = fn(MethodId, &Setup<'_>) -> Result<Box<dyn Method>>;

/// What a method is made with: the device, the scene on it and the options.
pub struct Setup<'a> {
    /// The device.
    pub gpu: &'a Gpu,
    /// The scene on the device.
    pub scene: &'a SceneGpu,
    /// The options the method is made with.
    pub options: &'a RenderOptions,
}

/// Everything strata knows about one method outside its own code.
#[derive(Clone, Copy, Debug)]
#[cfg_attr(feature = "serde", derive(Serialize))]
pub struct Descriptor {
    /// The method's name on the command line, in files and in statistics.
    #[cfg_attr(feature = "serde", serde(rename = "id"))]
    pub name: &'static str,
    /// The method's id.
    #[cfg_attr(feature = "serde", serde(skip))]
    pub id: MethodId,
    /// The family it is listed under.
    pub family: Family,
    /// Equal to the reference (in the sense its catalogue text states).
    pub exact: bool,
    /// Not exact by design, but equal to the reference whenever it drops nothing (a fixed
    /// array keeping the first k, mlab merging past k, bucket losing collisions).
    pub exact_without_drops: bool,
    /// Geometry passes, N being the scene's depth complexity.
    pub geometry_passes: &'static str,
    /// Bytes the method allocates, W·H pixels, F fragments in the frame.
    pub memory: &'static str,
    /// One line saying what the method does (the README's method table).
    pub summary: &'static str,
    /// Whether it runs on strata's compute rasterizer (`--raster compute`).
    #[cfg_attr(feature = "serde", serde(skip))]
    pub compute_raster: Support,
    /// Whether it takes `--msaa 4|8`.
    #[cfg_attr(feature = "serde", serde(skip))]
    pub msaa: Support,
    /// The fewest samples per pixel it runs with (stochastic's stipples are samples: 4); the
    /// CLI raises `--msaa 1` to it.
    #[cfg_attr(feature = "serde", serde(skip))]
    pub min_samples: u32,
    /// With `--msaa`, it finds each fragment's samples itself, in compute (tiled): any sample
    /// count strata takes, on any backend, whatever the device's render targets support.
    #[cfg_attr(feature = "serde", serde(skip))]
    pub samples_in_compute: bool,
    /// With `--msaa`, each sample keeps its own storage (capture-time k-buffers choose what to
    /// keep per sample); else fragments are stored per pixel with their coverage masks.
    #[cfg_attr(feature = "serde", serde(skip))]
    pub per_sample_storage: bool,
    /// Whether it takes `--temporal on` (the slot k-buffers that choose at capture time).
    #[cfg_attr(feature = "serde", serde(skip))]
    pub temporal: bool,
    /// The device features it cannot run without (`methods::create` refuses a device that
    /// lacks one; the per-backend table, [`super::backends`], reads them).
    #[cfg_attr(feature = "serde", serde(skip))]
    pub needs: wgpu::Features,
    /// The memory ordering its capture needs.
    #[cfg_attr(feature = "serde", serde(skip))]
    pub ordering: Ordering,
    /// The single-pass capture step of a slot or list k-buffer on pixel `p` and fragment `f`,
    /// which the contention harness drives from compute dispatches: a WGSL call whose names are
    /// module-qualified (`strata::kbuffer::list::capture_list(p, f)`), so that the harness needs
    /// no import list; `None` where there is no such step.
    #[cfg_attr(feature = "serde", serde(skip))]
    pub capture_step: Option<&'static str>,
    /// The contention harness drives its capture (`kbuffer::contention`): a capture of its own
    /// whose kept fragments the harness predicts (not a fixed array's first arrivals, mlab's
    /// merges, or a capture another subject already drives).
    #[cfg_attr(feature = "serde", serde(skip))]
    pub contended: bool,
    /// Whether it takes the application's own geometry and shaders
    /// ([`crate::FrameRecorder::for_application`]), and if not, why.
    #[cfg_attr(feature = "serde", serde(skip))]
    pub app_shaders: Support,
    /// Whether it takes an application's draw callback (it draws what the application issues),
    /// and if not, why: it draws the scene's triangles itself.
    #[cfg_attr(feature = "serde", serde(skip))]
    pub draw_callback: Support,
    /// It is one of the k-buffers the k+-buffer paper compares (seed 003, Table 1), which
    /// `strata bench`'s k-buffer experiments run.
    #[cfg_attr(feature = "serde", serde(skip))]
    pub in_k_comparison: bool,
    /// It sorts the scene's triangles by centroid each frame: the recorder refreshes the
    /// centroids (of an animated scene) before it records.
    #[cfg_attr(feature = "serde", serde(skip))]
    pub sorts_centroids: bool,
    /// Whether `--order` applies (every method but those with an order of their own).
    #[cfg_attr(feature = "serde", serde(skip))]
    pub takes_order: bool,
    /// Whether it composites add and multiply materials as they are defined
    /// ([`crate::scene::Blend`]), and if not, why; it then refuses scenes that have them.
    #[cfg_attr(feature = "serde", serde(skip))]
    pub blend_modes: Support,
    /// Whether it runs on a downlevel device (no storage buffers, no compute) through render
    /// targets alone ([`crate::methods::downlevel::DownlevelFrame`]).
    pub downlevel: bool,
    /// The method parameters it reads.
    #[cfg_attr(feature = "serde", serde(skip))]
    pub reads: &'static [MethodOption],
    /// Its memory-traffic model ([`super::traffic`]).
    #[cfg_attr(feature = "serde", serde(skip))]
    pub traffic: TrafficModel,
    /// What becomes of the fragments a frame's k leaves out where it is not dropping them or
    /// blending them into the tail: the render note's "N fragments …" (`None`: one of those).
    pub past_k: Option<&'static str>,
    /// The `--k` it uses when none is given.
    #[cfg_attr(feature = "serde", serde(skip))]
    pub default_k: u32,
    /// The largest `--k` it accepts (a pixel's fragments serialize on its lock or cascade).
    #[cfg_attr(feature = "serde", serde(skip))]
    pub max_k: u32,
    /// Its bytes at a k, where `--k auto` may choose its k (`None`: it may not).
    #[cfg_attr(feature = "serde", serde(skip))]
    pub k_memory: Option<KMemory>,
    /// An approximate method's pixel worked out on the CPU (`None`: exact methods, held to the
    /// reference, and the baselines).
    #[cfg_attr(feature = "serde", serde(skip))]
    pub closed_form: Option<ClosedForm>,
    /// Makes the method's GPU state for a scene.
    #[cfg_attr(feature = "serde", serde(skip))]
    pub create: Constructor,
}

/// The methods of the table for which `support` says yes, as a list for a refusal.
fn supporting(support: impl Fn(&Descriptor) -> Support) -> String {
    let names: Vec<&str> = super::TABLE
        .iter()
        .filter(|d| support(d).yes())
        .map(|d| d.name)
        .collect();
    names.join(", ")
}

impl Descriptor {
    /// A descriptor with the commonest answers: hardware rasterizer only, `--msaa` with
    /// per-pixel storage, no temporal culling, relaxed atomics, no application capture,
    /// `--order` taken, no parameters.
    pub const fn new(
        id: MethodId,
        name: &'static str,
        family: Family,
        create: Constructor,
    ) -> Descriptor {
        Descriptor {
            name,
            id,
            family,
            exact: false,
            exact_without_drops: false,
            geometry_passes: "1",
            memory: "",
            summary: "",
            compute_raster: Support::No(
                "it draws into color targets through the GPU's blending or depth test, which the compute rasterizer has no equivalent of",
            ),
            msaa: Support::Yes,
            min_samples: 1,
            samples_in_compute: false,
            per_sample_storage: false,
            temporal: false,
            needs: wgpu::Features::empty(),
            ordering: Ordering::Relaxed,
            capture_step: None,
            app_shaders: Support::No(
                "its geometry passes write colour targets through blending or a depth test, which strata does not compose with an application's shader yet",
            ),
            draw_callback: Support::Yes,
            in_k_comparison: false,
            contended: false,
            sorts_centroids: false,
            takes_order: true,
            blend_modes: Support::Yes,
            downlevel: false,
            reads: &[],
            past_k: None,
            default_k: crate::methods::kbuffer::DEFAULT_K,
            max_k: 4096,
            k_memory: None,
            closed_form: None,
            traffic: TrafficModel::PerPixelState {
                atomic_per_fragment: false,
            },
            create,
        }
    }

    /// What a frame of this method is, the one place strata decides it: (exact — the whole
    /// scene's picture, `FrameStats::exact`; its k nearest kept — `exact_k_nearest`, for an exact
    /// method run with a k). `kept`: nothing was lost on the way (no lock failure, temporal cull,
    /// pool or rasterizer overflow, convex order violation); `dropped`: fragments not composited.
    pub fn exactness(&self, k: Option<u32>, dropped: u64, kept: bool) -> (bool, Option<bool>) {
        let exact = (self.exact || self.exact_without_drops) && kept && dropped == 0;
        let k_nearest =
            (self.exact && self.reads(super::options::K) && k.is_some()).then_some(kept);
        (exact, k_nearest)
    }

    /// The rasterizers it runs on (`--raster`): `cpu`, `hw` or `hw,compute`.
    pub fn rasters(&self) -> &'static str {
        match (self.id, self.compute_raster) {
            (MethodId::Reference, _) => "cpu",
            (_, Support::Yes) => "hw,compute",
            _ => "hw",
        }
    }

    /// The `--msaa` sample counts it takes (none below its fewest, which `--msaa 1` is raised
    /// to).
    pub fn msaa_counts(&self) -> Vec<u32> {
        if self.msaa.yes() {
            crate::frame::msaa::SAMPLE_COUNTS
                .into_iter()
                .filter(|&n| n >= self.min_samples)
                .collect()
        } else {
            vec![1]
        }
    }

    /// The blend modes it composites (`blend` in scene files): `all`, or `over` alone.
    pub fn blend_names(&self) -> &'static str {
        match self.blend_modes.yes() {
            true => "all",
            false => "over",
        }
    }

    /// Whether it reads `option`.
    pub fn reads(&self, option: MethodOption) -> bool {
        self.reads.contains(&option)
    }

    /// Whether a frame of this method with `frame`'s options reads `option`: what it always
    /// reads, and `--weight` (with `--depth-scale`) where its fragments past k are weighted as
    /// wboit weighs them (`--tail weighted`).
    pub fn reads_with(&self, option: MethodOption, frame: &FrameOptions) -> bool {
        self.reads(option)
            || (option == crate::methods::weighted::options::WEIGHT
                && self.reads(crate::methods::kbuffer::options::TAIL)
                && frame.family::<KBufferOptions>().tail == Tail::Weighted)
    }

    /// Whether its capture needs acquire/release atomics (a lock, list links, or kpeel's
    /// fallback capture): without them it is unsound.
    pub fn orders(&self) -> bool {
        self.ordering != Ordering::Relaxed
    }

    /// Whether its capture spins on a lock or retries compare-exchange chains (`--max-tries`).
    pub fn locks(&self) -> bool {
        self.ordering == Ordering::Locks
    }

    /// Whether it takes frames of `options` for a scene of `triangles` with `blend_modes`: the
    /// one admission check of the rasterizer, the samples, the blend modes and temporal culling,
    /// made when the method or the options change (not every frame).
    pub fn admit(
        &self,
        options: &RenderOptions,
        blend_modes: &[Blend],
        triangles: u64,
    ) -> Result<()> {
        self.check_raster(options.build.raster)?;
        self.check_msaa(options.build.msaa, triangles)?;
        self.check_blend(blend_modes, options.frame.family::<KBufferOptions>().tail)?;
        self.check_temporal(options.frame.temporal.is_some())
    }

    /// Refuses `--temporal on` where its capture cannot cull, naming the methods that can.
    pub fn check_temporal(&self, temporal: bool) -> Result<()> {
        if !temporal || self.temporal {
            return Ok(());
        }
        let takers: Vec<&str> = super::TABLE
            .iter()
            .filter(|d| d.temporal)
            .map(|d| d.name)
            .collect();
        Err(Error::unsupported(format!(
            "--temporal on applies to {}, not {}",
            takers.join(", "),
            self.name
        )))
    }

    /// Refuses `--raster compute` where it cannot capture on the compute rasterizer, naming
    /// the methods that can.
    pub fn check_raster(&self, raster: Raster) -> Result<()> {
        match (raster, self.compute_raster) {
            (Raster::Compute, Support::No(why)) => Err(Error::unsupported(format!(
                "--raster compute: {} is not supported: {why}; use --raster hw, or one of {}",
                self.name,
                supporting(|d| d.compute_raster)
            ))),
            _ => Ok(()),
        }
    }

    /// Refuses the application's own shaders where the method cannot take them, naming the
    /// methods that can.
    pub fn check_app_shaders(&self) -> Result<()> {
        match self.app_shaders {
            Support::No(why) => Err(Error::unsupported(format!(
                "{} cannot take the application's own shaders: {why}; these can: {}",
                self.name,
                supporting(|d| d.app_shaders)
            ))),
            Support::Yes => Ok(()),
        }
    }

    /// Refuses an application's draw callback where the method draws the scene itself.
    pub fn check_draw_callback(&self) -> Result<()> {
        match self.draw_callback {
            Support::No(why) => Err(Error::unsupported(format!(
                "{} cannot take an application's draw callback: {why}; use an order-independent method",
                self.name
            ))),
            Support::Yes => Ok(()),
        }
    }

    /// Refuses a scene with add or multiply materials where the method composites only over,
    /// and a k-buffer tail that would blend them over.
    pub fn check_blend(&self, modes: &[Blend], tail: Tail) -> Result<()> {
        let Some(mode) = modes.first() else {
            return Ok(());
        };
        if let Support::No(why) = self.blend_modes {
            let honouring: Vec<&str> = super::TABLE
                .iter()
                .filter(|d| d.blend_modes.yes() && d.id != MethodId::Reference)
                .map(|d| d.name)
                .collect();
            return Err(Error::unsupported(format!(
                "{} cannot blend '{}' materials: {why}; the methods that can are {}",
                self.name,
                mode.name(),
                honouring.join(", ")
            )));
        }
        if tail != Tail::Drop && self.reads(crate::methods::kbuffer::options::TAIL) {
            return Err(Error::unsupported(format!(
                "{} --tail {}: the tail blends the fragments past k over one another, which '{}' materials do not; use --tail drop or a larger --k",
                self.name,
                tail.name(),
                mode.name()
            )));
        }
        Ok(())
    }

    /// Refuses `--msaa 4|8` where it cannot take it, and scenes too large for the samples' tags.
    pub fn check_msaa(&self, samples: u32, triangles: u64) -> Result<()> {
        if samples <= 1 {
            return Ok(());
        }
        if let Support::No(why) = self.msaa {
            return Err(Error::unsupported(format!(
                "{} does not support --msaa: {why}",
                self.name
            )));
        }
        crate::frame::msaa::check_triangles(samples, triangles)
    }
}

fn refuse_reference(_: MethodId, _: &Setup<'_>) -> Result<Box<dyn Method>> {
    Err(Error::input(
        "method 'reference' runs on the CPU: use strata::reference::render",
    ))
}

/// The CPU reference (`crate::reference`): what the exact methods are compared with.
pub const REFERENCE: Descriptor = Descriptor {
    exact: true,
    geometry_passes: "0 (CPU)",
    memory: "host: 64·F",
    summary:
        "CPU exact renderer: every fragment, sorted by depth then primitive, composited in f64",
    reads: &[super::options::K],
    traffic: TrafficModel::None,
    ..Descriptor::new(
        MethodId::Reference,
        "reference",
        Family::Reference,
        refuse_reference,
    )
};
