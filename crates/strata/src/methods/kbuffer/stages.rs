//! The k-buffer family's shader stages: its WGSL modules, the storage layouts whose accessors
//! a stage imports, and the definitions every stage of the family is composed with.

use crate::gpu::shader::{Defs, Library, Stage};
use crate::gpu::Gpu;

/// The family's WGSL modules (`strata::kbuffer::…`): storage and its accessors, each method's
/// capture steps and entry points, the shared resolve.
pub const LIBRARY: Library = &[
    super::PARAMS_WGSL,
    super::COUNTERS_WGSL,
    super::WORDS_WGSL,
    include_str!("storage.wgsl"),
    super::temporal::PARAMS_WGSL,
    include_str!("temporal.wgsl"),
    include_str!("slots.wgsl"),
    include_str!("slot_access.wgsl"),
    include_str!("access.wgsl"),
    include_str!("slots_resolve.wgsl"),
    include_str!("kplus_capture.wgsl"),
    include_str!("kb_capture.wgsl"),
    include_str!("fixed_capture.wgsl"),
    include_str!("semiheap_capture.wgsl"),
    include_str!("semiheap_resolve.wgsl"),
    include_str!("slots_entries.wgsl"),
    include_str!("list.wgsl"),
    include_str!("list_entries.wgsl"),
    include_str!("list_resolve.wgsl"),
    include_str!("mdt.wgsl"),
    include_str!("mdt32_resolve.wgsl"),
    include_str!("pack_resolve.wgsl"),
    include_str!("mdt64.wgsl"),
    include_str!("keys.wgsl"),
    include_str!("keys_resolve.wgsl"),
    include_str!("sbuffer.wgsl"),
    include_str!("sbuffer_resolve.wgsl"),
    super::sbuffer::SCAN_LEVEL_WGSL,
    include_str!("sbuffer_scan.wgsl"),
    include_str!("kplus_sbuffer.wgsl"),
    include_str!("kplus_sbuffer_resolve.wgsl"),
    include_str!("kplus_sbuffer_entries.wgsl"),
    include_str!("kpeel_state.wgsl"),
    include_str!("kpeel_capture.wgsl"),
    include_str!("kpeel_cascade.wgsl"),
    include_str!("kpeel_resolve.wgsl"),
    include_str!("resolve.wgsl"),
];

/// The k-buffers' shared resolve.
pub const RESOLVE_WGSL: &str = include_str!("resolve.wgsl");
/// The slot-array methods' capture entries.
pub const SLOTS_ENTRIES_WGSL: &str = include_str!("slots_entries.wgsl");

/// Where a method keeps its fragments, which picks the accessors its stages import
/// (`STORAGE_*` in resolve.wgsl, slot_access.wgsl and sbuffer_scan.wgsl).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Layout {
    /// Fixed per-pixel slot arrays.
    Slots,
    /// kplus-semiheap's heap and rest.
    Semiheap,
    /// Linked lists from a node pool.
    List,
    /// 32-bit depth cascade.
    Mdt32,
    /// Packed depth and color cascades.
    Pack,
    /// 64-bit depth and color keys.
    Mdt64,
    /// 64-bit (depth, primitive) keys and stored payloads.
    Keys,
    /// S-buffer regions.
    Sbuffer,
    /// kplus-sbuffer's min(f, k) regions.
    KplusSbuffer,
}

impl Layout {
    /// Every layout.
    pub const ALL: [Layout; 9] = [
        Layout::Slots,
        Layout::Semiheap,
        Layout::List,
        Layout::Mdt32,
        Layout::Pack,
        Layout::Mdt64,
        Layout::Keys,
        Layout::Sbuffer,
        Layout::KplusSbuffer,
    ];

    fn definition(self) -> &'static str {
        match self {
            Layout::Slots => "STORAGE_SLOTS",
            Layout::Semiheap => "STORAGE_SEMIHEAP",
            Layout::List => "STORAGE_LIST",
            Layout::Mdt32 => "STORAGE_MDT32",
            Layout::Pack => "STORAGE_PACK",
            Layout::Mdt64 => "STORAGE_MDT64",
            Layout::Keys => "STORAGE_KEYS",
            Layout::Sbuffer => "STORAGE_SBUFFER",
            Layout::KplusSbuffer => "STORAGE_KPLUS_SBUFFER",
        }
    }
}

/// The family's definitions: the storage layout (and `KEYS64` where it holds 64-bit keys), the
/// method's bind group (`KBUFFER_GROUP`: 1 in strata's own passes, the application's choice for
/// its capture), and `COHERENT` where the adapter takes `@coherent` on the fragment storage and
/// the per-pixel words (see module docs).
pub fn definitions(layout: Layout, group: u32, coherent: bool) -> Defs {
    Defs::default()
        .flag(layout.definition())
        .flag_if("KEYS64", matches!(layout, Layout::Mdt64 | Layout::Keys))
        .value("KBUFFER_GROUP", group)
        .flag_if("COHERENT", coherent)
}

/// A capture stage's definitions from the scene it draws: `MULTISAMPLED` with `--msaa` (else
/// the loops over a fragment's storage samples compile away), and `INVARIANT_DEPTH` on the
/// hardware rasterizer, which gives a fragment the same depth in every pass (`position` is
/// `@invariant`), so a second pass may find a fragment's key by its depth; the compute
/// rasterizer's passes are separate pipelines that may round an interpolated depth differently.
pub fn capture_definitions(scene: &crate::frame::SceneGpu) -> Defs {
    crate::gpu::shader::target_samples(scene.samples)
        .flag_if("INVARIANT_DEPTH", scene.raster_layout.is_none())
}

/// A stage of the family: `source` with the family's modules and definitions on `gpu`.
pub fn stage(gpu: &Gpu, label: impl Into<String>, source: &'static str, layout: Layout) -> Stage {
    let coherent = gpu.has(wgpu::Features::MEMORY_DECORATION_COHERENT);
    Stage::new(label, source)
        .with(LIBRARY)
        .defs(&definitions(layout, 1, coherent))
}
