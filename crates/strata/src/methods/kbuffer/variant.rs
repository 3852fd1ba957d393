//! The slot k-buffers (`SlotKBuffer`): which method each is, its capture's entry point and its
//! resolve's choices.

use super::Layout;
use crate::gpu::shader::Defs;
use crate::methods::MethodId;

/// The slot-array methods, which share one capture and resolve.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Variant {
    /// `kplus-array`.
    KplusArray,
    /// `kplus-heap`.
    KplusHeap,
    /// `kplus-array-r`.
    KplusArrayR,
    /// `kb`.
    Kb,
    /// `kb-ps`.
    KbPs,
    /// `abuffer-fixed`.
    AbufferFixed,
    /// `kb-ab-fixed`.
    KbAbFixed,
    /// `kplus-semiheap`.
    KplusSemiheap,
    /// `mlab`.
    Mlab,
    /// `kplus-bitonic`.
    KplusBitonic,
}

impl Variant {
    /// The fragment entry point of the built-in capture.
    pub(super) fn entry(self) -> &'static str {
        match self {
            Variant::KplusArray | Variant::KplusBitonic => "fs_kplus_array",
            Variant::KplusHeap => "fs_kplus_heap",
            Variant::KplusArrayR => "fs_kplus_array_r",
            Variant::Kb => "fs_kb",
            Variant::KbPs => "fs_kb_ps",
            Variant::AbufferFixed | Variant::KbAbFixed => "fs_fixed",
            Variant::KplusSemiheap => "fs_kplus_semiheap",
            Variant::Mlab => "fs_mlab",
        }
    }

    pub(super) fn fixed(self) -> bool {
        matches!(self, Variant::AbufferFixed | Variant::KbAbFixed)
    }

    /// The method this variant is.
    pub fn id(self) -> MethodId {
        match self {
            Variant::KplusArray => MethodId::KplusArray,
            Variant::KplusHeap => MethodId::KplusHeap,
            Variant::KplusArrayR => MethodId::KplusArrayR,
            Variant::Kb => MethodId::Kb,
            Variant::KbPs => MethodId::KbPs,
            Variant::AbufferFixed => MethodId::AbufferFixed,
            Variant::KbAbFixed => MethodId::KbAbFixed,
            Variant::KplusSemiheap => MethodId::KplusSemiheap,
            Variant::Mlab => MethodId::Mlab,
            Variant::KplusBitonic => MethodId::KplusBitonic,
        }
    }

    /// Its storage layout: the semi-heap's words, or plain slots.
    pub fn layout(self) -> Layout {
        match self {
            Variant::KplusSemiheap => Layout::Semiheap,
            _ => Layout::Slots,
        }
    }

    /// Its resolve's choices (resolve.wgsl): `kplus-bitonic` sorts by the bitonic network at
    /// every list length.
    pub(super) fn resolve_defs(self) -> Defs {
        match self {
            Variant::KplusBitonic => Defs::default().flag("BITONIC_RESOLVE"),
            _ => Defs::default(),
        }
    }
}
