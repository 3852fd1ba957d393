//! The entries in the method table of everything built on the k-buffer machinery (storage.wgsl):
//! the A-buffers, the k-buffers, the k+-buffers and kpeel.

use crate::methods::options::{MethodOption, K, LAYERS_PER_PASS};
use crate::methods::peeling::options::LAYERS;
use crate::methods::table::{Descriptor, Family, Ordering, Setup, Support};
use crate::methods::traffic::TrafficModel;
use crate::methods::{Method, MethodId};

use super::list::{ListKBuffer, ListKind};
use super::mdt::{Mdt, MdtKBuffer};
use super::options::{CULLING, HEAP_SIZE, MAX_TRIES, STORAGE_LAYOUT, TAIL};
use super::sbuffer::{RegionKind, SBuffer};
use super::{predict, SlotKBuffer, Variant};

type Made = crate::error::Result<Box<dyn Method>>;

/// A builder of this family's storage kind `$kind` (a typed value whose `id()` names its one
/// method): each entry names its own builder, so no id falls through to another method. A
/// builder an entry inherited from another (`..KPLUS_ARRAY`) refuses the entry's id.
macro_rules! builders {
    ($($name:ident => $storage:ident($kind:expr);)*) => {
        $(
            fn $name(id: MethodId, made: &Setup<'_>) -> Made {
                $storage(id, made, $kind)
            }
        )*

        /// The storage layout of the method `id` of this family's typed data (what the
        /// contention harness lays out for it), `None` for a method not built over one.
        pub(crate) fn layout_of(id: MethodId) -> Option<super::Layout> {
            $(
                if $kind.id() == id {
                    return Some($kind.layout());
                }
            )*
            None
        }
    };
}

builders! {
    kplus_array => slots(Variant::KplusArray);
    kplus_bitonic => slots(Variant::KplusBitonic);
    kplus_array_r => slots(Variant::KplusArrayR);
    kplus_heap => slots(Variant::KplusHeap);
    kplus_semiheap => slots(Variant::KplusSemiheap);
    kb => slots(Variant::Kb);
    kb_ps => slots(Variant::KbPs);
    mlab => slots(Variant::Mlab);
    abuffer_fixed => slots(Variant::AbufferFixed);
    kb_ab_fixed => slots(Variant::KbAbFixed);
    kb_mdt32 => cascade(Mdt::Mdt32);
    kb_mdt64 => cascade(Mdt::Mdt64);
    kb_mdt_pack => cascade(Mdt::Pack);
    kb_keys => cascade(Mdt::Keys);
    abuffer_ll => list(ListKind::Abuffer);
    kb_ab_ll => list(ListKind::KNearest);
    kb_ll => list(ListKind::Sorted);
    sbuffer => regions(RegionKind::Abuffer);
    kb_sbuffer => regions(RegionKind::KNearest);
    kplus_sbuffer => regions(RegionKind::Kplus);
}

/// Refuses an entry wired to a builder of another method.
fn check_builder(id: MethodId, builds: MethodId) -> crate::error::Result<()> {
    match id == builds {
        true => Ok(()),
        false => Err(crate::error::Error::unsupported(format!(
            "strata's method table wires {id} to the builder of {builds}"
        ))),
    }
}

fn slots(id: MethodId, made: &Setup<'_>, variant: Variant) -> Made {
    check_builder(id, variant.id())?;
    Ok(Box::new(SlotKBuffer::new(
        made.gpu, made.scene, id, variant,
    )?))
}

fn cascade(id: MethodId, made: &Setup<'_>, mdt: Mdt) -> Made {
    check_builder(id, mdt.id())?;
    Ok(Box::new(MdtKBuffer::new(made.gpu, made.scene, id, mdt)?))
}

fn list(id: MethodId, made: &Setup<'_>, kind: ListKind) -> Made {
    check_builder(id, kind.id())?;
    let method = ListKBuffer::new(made.gpu, made.scene, kind, made.options)?;
    Ok(Box::new(method))
}

fn regions(id: MethodId, made: &Setup<'_>, kind: RegionKind) -> Made {
    check_builder(id, kind.id())?;
    Ok(Box::new(SBuffer::new(
        made.gpu,
        made.scene,
        kind,
        made.options,
    )?))
}

fn kpeel(_: MethodId, made: &Setup<'_>) -> Made {
    Ok(Box::new(super::kpeel::KPeel::new(made.gpu, made.scene)?))
}

/// Memory of the k-slot methods; `SLOT_BYTES` etc. keep it true.
pub(crate) const KB_MEMORY: &str = "16·(k+1)·W·H + 116 + 40·(W·H with --tail blend, else 1)";

/// An entry of this family, made by `build`, on either rasterizer.
const fn entry(
    id: MethodId,
    name: &'static str,
    family: Family,
    build: crate::methods::table::Constructor,
) -> Descriptor {
    Descriptor {
        compute_raster: Support::Yes,
        app_shaders: Support::Yes,
        ..Descriptor::new(id, name, family, build)
    }
}

/// An entry whose capture takes a per-pixel spin lock: acquire/release atomics needed (on
/// either rasterizer; refused where the adapter has none), per-sample storage, `--max-tries`
/// read, k up to 256.
const fn locked(
    id: MethodId,
    name: &'static str,
    family: Family,
    build: crate::methods::table::Constructor,
) -> Descriptor {
    Descriptor {
        per_sample_storage: true,
        ordering: Ordering::Locks,
        reads: K_LOCKED_READS,
        max_k: 256,
        ..entry(id, name, family, build)
    }
}

/// A k-buffer proper: reads `--k`, `--tail`, `--culling` and `--storage-layout`; a locking one
/// `--max-tries` too. Every method of this family lays out its per-pixel arrays by
/// `--storage-layout`.
const K_READS: &[MethodOption] = &[K, TAIL, CULLING, STORAGE_LAYOUT];
const K_LOCKED_READS: &[MethodOption] = &[K, TAIL, CULLING, MAX_TRIES, STORAGE_LAYOUT];

/// The method table's entry for `abuffer-ll`.
pub const ABUFFER_LL: Descriptor = Descriptor {
    contended: true,
    exact: true,
    geometry_passes: "1 (+1 when the node pool overflows)",
    memory: "20·nodes + 16·W·H + 156 (nodes ≥ F)",
    summary: "A-buffer of per-pixel linked lists; a pool that overflowed grows for the next frame (exact mode re-renders)",
    capture_step: Some("strata::kbuffer::list::capture_list(p, f)"),
    traffic: TrafficModel::Lists,
    reads: &[STORAGE_LAYOUT],
    ..entry(MethodId::AbufferLl, "abuffer-ll", Family::Abuffer, abuffer_ll)
};

/// The method table's entry for `sbuffer`.
pub const SBUFFER: Descriptor = Descriptor {
    exact: true,
    geometry_passes: "2 (+2 when the pool overflows)",
    memory: "16·F + 16·W·H + 4·(W·H + W·H/256 + …) + 156",
    summary: "S-buffer: a count pass, a GPU prefix sum over the pixels, every pixel's fragments stored in one contiguous region (no per-pixel slack)",
    traffic: TrafficModel::Sbuffers,
    reads: &[STORAGE_LAYOUT],
    ..entry(MethodId::Sbuffer, "sbuffer", Family::Abuffer, sbuffer)
};

/// The method table's entry for `kpeel`.
pub const KPEEL: Descriptor = Descriptor {
    exact: true,
    geometry_passes: "ceil(N/k), twice that with the lock-free capture (N: the last frame's depth complexity, or --layers)",
    memory: "(16·(k+1) + 4)·W·H + 156, +8·k·W·H with the lock-free capture",
    summary: "k-depth peeling: the k nearest fragments behind the last composited (depth, primitive) per pass, by a lock-free cascade of 64-bit keys (a keys and a colors geometry pass; single-sampled, SHADER_INT64_ATOMIC_ALL_OPS) or else a k+-buffer capture under a lock; A-buffer results in bounded memory, equal-depth fragments included",
    per_sample_storage: true,
    ordering: Ordering::LockedFallback,
    reads: &[
        K,
        LAYERS,
        LAYERS_PER_PASS,
        STORAGE_LAYOUT,
    ],
    max_k: 1024,
    traffic: TrafficModel::Kpeel,
    ..entry(MethodId::Kpeel, "kpeel", Family::Peeling, kpeel)
};

/// The method table's entry for `abuffer-fixed`.
pub const ABUFFER_FIXED: Descriptor = Descriptor {
    in_k_comparison: true,
    k_memory: Some(predict::slot_array),
    exact_without_drops: true,
    memory: KB_MEMORY,
    summary: "A-buffer of fixed per-pixel arrays of k slots (FABS); fragments past k are counted as dropped",
    capture_step: Some("strata::kbuffer::fixed_capture::capture_fixed(p, f)"),
    reads: &[
        K,
        TAIL,
        STORAGE_LAYOUT,
    ],
    traffic: TrafficModel::Slots { atomics: true },
    ..entry(MethodId::AbufferFixed, "abuffer-fixed", Family::Abuffer, abuffer_fixed)
};

/// The method table's entry for `kb-keys`.
pub const KB_KEYS: Descriptor = Descriptor {
    contended: true,
    in_k_comparison: true,
    k_memory: Some(|id, k, _, o| predict::k_slots(id, k, o, Mdt::Keys.slot_bytes())),
    needs: wgpu::Features::SHADER_INT64_ATOMIC_ALL_OPS,
    exact: true,
    geometry_passes: "2",
    memory: KB_MEMORY,
    summary: "lock-free exact k-buffer: an atomicMax cascade of 64-bit (depth, primitive) keys keeps the k nearest sorted, payloads stored by tag in a second geometry pass; nothing spins or fails (SHADER_INT64_ATOMIC_ALL_OPS)",
    per_sample_storage: true,
    reads: K_READS,
    max_k: 512,
    // Keys cleared and cascaded, payloads written once and read by the resolve.
    traffic: TrafficModel::Keys { bytes: 16 },
    ..entry(MethodId::KbKeys, "kb-keys", Family::Kbuffer, kb_keys)
};

/// The method table's entry for `kb`.
pub const KB: Descriptor = Descriptor {
    contended: true,
    in_k_comparison: true,
    k_memory: Some(predict::slot_array),
    memory: KB_MEMORY,
    summary: "original k-buffer: sorted insertion with no lock (read-modify-write hazards between fragments of a pixel)",
    per_sample_storage: true,
    temporal: true,
    capture_step: Some("strata::kbuffer::kb_capture::capture_sorted_unlocked(p, f)"),
    reads: K_READS,
    max_k: 256,
    traffic: TrafficModel::Slots { atomics: false },
    ..entry(MethodId::Kb, "kb", Family::Kbuffer, kb)
};

/// The method table's entry for `kb-ps`.
pub const KB_PS: Descriptor = Descriptor {
    contended: true,
    in_k_comparison: true,
    k_memory: Some(predict::slot_array),
    exact: true,
    memory: KB_MEMORY,
    summary: "k-buffer with sorted insertion inside a per-pixel spin lock (pixel synchronisation emulated)",
    temporal: true,
    capture_step: Some("strata::kbuffer::kb_capture::capture_sorted_locked(p, f)"),
    traffic: TrafficModel::Slots { atomics: true },
    ..locked(MethodId::KbPs, "kb-ps", Family::Kbuffer, kb_ps)
};

/// The method table's entry for `mlab`.
pub const MLAB: Descriptor = Descriptor {
    k_memory: Some(predict::slot_array),
    exact_without_drops: true,
    memory: "16·(k+1)·W·H + 156",
    summary: "multi-layer alpha blending: k layers in depth order under a per-pixel spin lock, the two farthest merged when a fragment makes k + 1 (exact up to k fragments; merges vary with arrival order)",
    capture_step: Some("strata::kbuffer::kb_capture::capture_mlab(p, f)"),
    reads: &[
        K,
        MAX_TRIES,
        STORAGE_LAYOUT,
    ],
    past_k: Some("beyond k were merged into the farthest layers (approximate where a pixel has more than k + 1)"),
    // MLAB-4, the published comparison's; the critical section is kb-ps's, so is the limit.
    default_k: 4,
    traffic: TrafficModel::Slots { atomics: true },
    blend_modes: Support::No("its merge of the two farthest layers is the over operator's"),
    ..locked(MethodId::Mlab, "mlab", Family::Kbuffer, mlab)
};

/// The method table's entry for `kb-ab-fixed`.
pub const KB_AB_FIXED: Descriptor = Descriptor {
    in_k_comparison: true,
    k_memory: Some(predict::every_fragment),
    exact: true,
    geometry_passes: "1 (+1 when the array overflows)",
    memory: "16·(n+1)·W·H + 116 + 40·(W·H with --tail blend, else 1); n: max depth complexity",
    summary:
        "every fragment in fixed arrays sized from measured need, the k nearest selected in resolve",
    capture_step: Some("strata::kbuffer::fixed_capture::capture_fixed(p, f)"),
    reads: K_READS,
    traffic: TrafficModel::Slots { atomics: true },
    ..entry(
        MethodId::KbAbFixed,
        "kb-ab-fixed",
        Family::Kbuffer,
        kb_ab_fixed,
    )
};

/// The method table's entry for `kplus-array`.
pub const KPLUS_ARRAY: Descriptor = Descriptor {
    contended: true,
    in_k_comparison: true,
    k_memory: Some(predict::slot_array),
    exact: true,
    memory: KB_MEMORY,
    summary:
        "k+-buffer max-array: k nearest captured unsorted under a spin lock, max in slot 0, culling",
    temporal: true,
    capture_step: Some("strata::kbuffer::kplus_capture::capture_locked(p, f, strata::kbuffer::kplus_capture::VARIANT_ARRAY)"),
    traffic: TrafficModel::Slots { atomics: true },
    ..locked(MethodId::KplusArray, "kplus-array", Family::Kplus, kplus_array)
};

/// The method table's entry for `kplus-array-r`.
pub const KPLUS_ARRAY_R: Descriptor = Descriptor {
    summary: "k+-buffer revised max-array: the first k fragments stored without the lock",
    capture_step: Some("strata::kbuffer::kplus_capture::capture_array_r(p, f)"),
    ..Descriptor {
        id: MethodId::KplusArrayR,
        name: "kplus-array-r",
        create: kplus_array_r,
        ..KPLUS_ARRAY
    }
};

/// The method table's entry for `kplus-bitonic`.
pub const KPLUS_BITONIC: Descriptor = Descriptor {
    contended: false,
    in_k_comparison: false,
    summary: "k+-buffer max-array whose resolve sorts by the bitonic network at every k (the others sort up to 16 fragments by insertion)",
    ..Descriptor {
        id: MethodId::KplusBitonic,
        name: "kplus-bitonic",
        create: kplus_bitonic,
        ..KPLUS_ARRAY
    }
};

/// The method table's entry for `kplus-heap`.
pub const KPLUS_HEAP: Descriptor = Descriptor {
    summary:
        "k+-buffer max-heap: sift-up while filling, replace-root and sift-down when full, culling",
    capture_step: Some("strata::kbuffer::kplus_capture::capture_locked(p, f, strata::kbuffer::kplus_capture::VARIANT_HEAP)"),
    max_k: 1024,
    ..Descriptor {
        id: MethodId::KplusHeap,
        name: "kplus-heap",
        create: kplus_heap,
        ..KPLUS_ARRAY
    }
};

/// The method table's entry for `kplus-sbuffer`.
pub const KPLUS_SBUFFER: Descriptor = Descriptor {
    k_memory: Some(predict::pooled_regions),
    exact: true,
    geometry_passes: "2 (+2 when the pool overflows)",
    memory: "16·Σmin(f,k) + 20·W·H + 4·(W·H + W·H/256 + …) + 116 + 40·(W·H with --tail blend, else 1); f: a pixel's fragments",
    summary: "memory-aware k+-buffer: a count pass, a GPU prefix sum giving each pixel exactly min(f, k) slots, then lock-free appends (f ≤ k) or a max-array (k ≤ 16) / max-heap under a spin lock",
    max_k: 1024,
    traffic: TrafficModel::Sbuffers,
    ..locked(MethodId::KplusSbuffer, "kplus-sbuffer", Family::Kplus, kplus_sbuffer)
};

/// The method table's entry for `kplus-semiheap`.
pub const KPLUS_SEMIHEAP: Descriptor = Descriptor {
    in_k_comparison: false,
    summary: "semi-heap k-buffer (seed 000): a max-heap of the h farthest (--heap-size, default 1) and an unordered rest; the first k - h fragments stored without the lock, culling against the heap top",
    capture_step: Some("strata::kbuffer::semiheap_capture::capture_semiheap(p, f)"),
    reads: &[
        K,
        TAIL,
        CULLING,
        MAX_TRIES,
        HEAP_SIZE,
        STORAGE_LAYOUT,
    ],
    ..Descriptor {
        id: MethodId::KplusSemiheap,
        name: "kplus-semiheap",
        create: kplus_semiheap,
        ..KPLUS_ARRAY
    }
};

/// The method table's entry for `kb-mdt32`.
pub const KB_MDT32: Descriptor = Descriptor {
    in_k_comparison: true,
    k_memory: Some(|id, k, _, o| predict::k_slots(id, k, o, Mdt::Mdt32.slot_bytes())),
    exact: true,
    geometry_passes: "2",
    memory: "20·k·W·H + 16·W·H + 116 + 40·(W·H with --tail blend, else 1)",
    summary: "multi-depth test: atomicMax cascade of depth keys, colors fetched in a second geometry pass (ties beyond k share keys)",
    per_sample_storage: true,
    reads: K_READS,
    max_k: 512,
    traffic: TrafficModel::Keys { bytes: 4 + 16 },
    ..entry(MethodId::KbMdt32, "kb-mdt32", Family::Kbuffer, kb_mdt32)
};

/// Why the multi-depth tests with 8-byte keys refuse `--msaa`.
const EIGHT_BYTE_KEYS: Support = Support::No(
    "its 8-byte keys hold depth and color but no primitive or coverage mask, so per-sample storage could not count a fragment once over the samples it covers; use kb-mdt32",
);

/// kb-mdt64's and kb-mdt-pack's blend modes.
const KEYS_WITHOUT_PRIMITIVE: Support = Support::No(
    "its keys hold depth and color but no primitive, so the resolve cannot find a fragment's material",
);

/// The method table's entry for `kb-mdt64`.
pub const KB_MDT64: Descriptor = Descriptor {
    in_k_comparison: true,
    k_memory: Some(|id, k, _, o| predict::k_slots(id, k, o, Mdt::Mdt64.slot_bytes())),
    needs: wgpu::Features::SHADER_INT64_ATOMIC_ALL_OPS,
    memory: "8·k·W·H + 16·W·H + 116 + 40·(W·H with --tail blend, else 1)",
    summary: "multi-depth test on 64-bit keys: depth and 8-bit sRGB color in one cascade (SHADER_INT64_ATOMIC_ALL_OPS)",
    msaa: EIGHT_BYTE_KEYS,
    reads: K_READS,
    max_k: 512,
    traffic: TrafficModel::Keys { bytes: 8 },
    blend_modes: KEYS_WITHOUT_PRIMITIVE,
    ..entry(MethodId::KbMdt64, "kb-mdt64", Family::Kbuffer, kb_mdt64)
};

/// The method table's entry for `kb-mdt-pack`.
pub const KB_MDT_PACK: Descriptor = Descriptor {
    in_k_comparison: true,
    k_memory: Some(|id, k, _, o| predict::k_slots(id, k, o, Mdt::Pack.slot_bytes())),
    memory: "8·k·W·H + 16·W·H + 156",
    summary:
        "multi-depth test packing: 20 depth bits + 12 color bits in two 32-bit cascades (seed 002)",
    msaa: EIGHT_BYTE_KEYS,
    reads: K_READS,
    max_k: 512,
    traffic: TrafficModel::Keys { bytes: 8 },
    blend_modes: KEYS_WITHOUT_PRIMITIVE,
    ..entry(
        MethodId::KbMdtPack,
        "kb-mdt-pack",
        Family::Kbuffer,
        kb_mdt_pack,
    )
};

/// The method table's entry for `kb-ab-ll`.
pub const KB_AB_LL: Descriptor = Descriptor {
    in_k_comparison: true,
    k_memory: Some(predict::every_fragment),
    exact: true,
    geometry_passes: "1 (+1 when the node pool overflows)",
    memory: "20·nodes + 16·W·H + 116 + 40·(W·H with --tail blend, else 1); nodes ≥ F",
    summary: "A-buffer linked lists, the k nearest selected in resolve",
    capture_step: Some("strata::kbuffer::list::capture_list(p, f)"),
    reads: K_READS,
    traffic: TrafficModel::Lists,
    ..entry(MethodId::KbAbLl, "kb-ab-ll", Family::Kbuffer, kb_ab_ll)
};

/// The method table's entry for `kb-sbuffer`.
pub const KB_SBUFFER: Descriptor = Descriptor {
    k_memory: Some(predict::every_fragment),
    exact: true,
    geometry_passes: "2 (+2 when the pool overflows)",
    memory: "16·F + 16·W·H + 4·(W·H + W·H/256 + …) + 116 + 40·(W·H with --tail blend, else 1)",
    summary: "every fragment in S-buffer regions, the k nearest selected in resolve",
    reads: K_READS,
    traffic: TrafficModel::Sbuffers,
    ..entry(
        MethodId::KbSbuffer,
        "kb-sbuffer",
        Family::Kbuffer,
        kb_sbuffer,
    )
};

/// The method table's entry for `kb-ll`.
pub const KB_LL: Descriptor = Descriptor {
    contended: true,
    in_k_comparison: true,
    k_memory: Some(predict::every_fragment),
    geometry_passes: "1 (+1 when the node pool overflows)",
    memory: "20·nodes + 16·W·H + 116 + 40·(W·H with --tail blend, else 1); nodes ≤ F",
    summary: "sorted linked-list insertion by compare-exchange, bounded retries, losses counted",
    capture_step: Some("strata::kbuffer::list::capture_sorted_list(p, f)"),
    traffic: TrafficModel::Lists,
    ..locked(MethodId::KbLl, "kb-ll", Family::Kbuffer, kb_ll)
};
