//! Memory-traffic floors: the least memory traffic and atomics a method's frame needs, from its
//! data layout and the frame's counters, and the time that takes on a device whose copy
//! bandwidth and atomic rates [`crate::gpu::bandwidth`] measured.
//!
//! The model counts what a method cannot avoid moving to and from memory, assuming perfect
//! caches within a pass and free shading and rasterization, so a measured frame divided by its
//! floor says how far the method is from its memory bound (1 = at the bound):
//! - **present**: every method's resolved pixel ([`crate::frame::RESOLVED_BYTES`]) is read once
//!   and the caller's 4-byte color target read and written once;
//! - **per-pixel state** (`unsorted`, `sorted`, `wboit`, `mboit`, `f2b`, `dual`): each geometry
//!   pass reads and writes the state the method allocates (its `bytes_allocated`) once; `dual`
//!   makes one atomic per fragment (its min/max keys);
//! - **lists** (`abuffer-ll`, `kb-ab-ll`, `kb-ll`): each stored node ([`NODE_BYTES`]) written
//!   once and read once, the head pointers cleared and read, one atomic per stored fragment on
//!   its pixel's head and one on the pool's single allocation counter;
//! - **S-buffers** (`sbuffer`, `kb-sbuffer`, `kplus-sbuffer`): a count pass of one atomic per
//!   fragment, a prefix sum reading and writing a word per pixel twice, then each stored
//!   fragment ([`FRAGMENT_BYTES`]) written and read once with one atomic per fragment;
//! - **slots** (`abuffer-fixed`, the `kb`/`kplus` arrays and heaps): each stored fragment
//!   ([`SLOT_BYTES`]) written and read once, the per-pixel word block ([`PIXEL_BYTES`])
//!   cleared and read, one atomic per stored fragment (counter or lock; `kb` takes none);
//! - **multi-depth tests**: each stored key written and read once (4 bytes for `kb-mdt32`, which
//!   also writes and reads a 16-byte color per stored fragment in its second pass; 8 for
//!   `kb-mdt64` and `kb-mdt-pack`), one atomic per stored fragment;
//! - `kpeel`: each fragment stored once over all passes, the per-pixel peel key
//!   ([`KEY_BYTES`]) read and written per pass, one atomic per stored fragment;
//! - `convex`: each fragment written into its layer once and read once by the merge, the
//!   per-pixel merge state read and written once;
//! - `bucket`: its bounds target (8 bytes), at least one bucket target layer (16), the count
//!   and the claim word (8) written and read once per pixel, each stored record written and
//!   read once, one atomic per fragment (its count) and one per stored fragment (its claim);
//! - `tiled`: each pixel's state ([`STATE_BYTES`]) written and read once, and at least one list
//!   entry (the rasterizer's item with its record and mask, [`RECORD_ITEM_BYTES`], and its index in
//!   the tile's list, [`LIST_ENTRY_BYTES`]) written
//!   and read per 64 stored fragments (an entry serves at most a tile's 64 pixels), with two
//!   atomics on its tile's count (count and scatter) — a loose floor: the lists' real length is not
//!   in the frame's counters.
//!
//! The floor time is the largest of bytes over bandwidth and atomics over their measured rates
//! (the resources work in parallel, so their sum would not be a lower bound). Stored counts
//! are lower bounds of what a capture writes (a k-buffer's replacements write more), so the
//! floor stays a floor.

#[cfg(feature = "serde")]
use serde::Serialize;

use crate::frame::RESOLVED_BYTES;
use crate::gpu::bandwidth::DeviceRates;
use crate::methods::kbuffer::{kpeel::KEY_BYTES, list::NODE_BYTES, sbuffer::FRAGMENT_BYTES};
use crate::methods::kbuffer::{PIXEL_BYTES, SLOT_BYTES};
use crate::methods::tiled::{LIST_ENTRY_BYTES, STATE_BYTES};
use crate::methods::MethodId;
use crate::raster::RECORD_ITEM_BYTES;

/// What one frame of a method did, from its [`crate::frame::FrameStats`].
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct FrameCounts {
    /// Pixels of the frame.
    pub pixels: u64,
    /// Fragments rasterized (after the opaque depth test).
    pub generated: u64,
    /// Fragments the method kept.
    pub stored: u64,
    /// Passes over the scene's geometry.
    pub geometry_passes: u64,
    /// Bytes the method allocated.
    pub bytes_allocated: u64,
}

/// A frame's unavoidable traffic.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "serde", derive(Serialize))]
pub struct Traffic {
    /// Bytes read plus bytes written.
    pub bytes: u64,
    /// Atomic operations on per-pixel words (heads, counters, locks, keys).
    pub pixel_atomics: u64,
    /// Atomic operations on one word shared by the whole frame (a pool's allocation counter).
    pub global_atomics: u64,
}

/// Which of the models above a method's frame follows (its descriptor's `traffic`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TrafficModel {
    /// The CPU reference: no GPU traffic.
    None,
    /// Per-pixel state read and written per geometry pass; with `atomic_per_fragment` one
    /// atomic per generated fragment (`dual`'s min/max keys).
    PerPixelState {
        /// One atomic per generated fragment.
        atomic_per_fragment: bool,
    },
    /// Linked lists: a node written and read per stored fragment, a head per pixel.
    Lists,
    /// S-buffers: a count and an offset per pixel, a fragment written and read per stored fragment.
    Sbuffers,
    /// Slot arrays; `atomics`: one per stored fragment (a counter or a lock; `kb` takes none).
    Slots {
        /// One atomic per stored fragment.
        atomics: bool,
    },
    /// Multi-depth tests: `bytes` per stored fragment written and read (key, and color where a
    /// second pass fetches it).
    Keys {
        /// Bytes per stored fragment.
        bytes: u64,
    },
    /// k-depth peeling: slots per stored fragment, the key array per pass.
    Kpeel,
    /// Convex: fragments per pass and the per-pixel merge state.
    Convex,
    /// Bucket peeling: per-bucket depths and colors per pixel.
    Bucket,
    /// `tiled`: per-pixel state, and list entries each serving up to a tile's pixels.
    Tiled,
}

/// The traffic model of `id` for a frame with `counts` (see the module docs); `None` for the
/// CPU reference.
pub fn traffic(id: MethodId, c: &FrameCounts) -> Option<Traffic> {
    let present = (RESOLVED_BYTES + 8) * c.pixels;
    let (bytes, pixel_atomics, global_atomics) = match id.descriptor().traffic {
        TrafficModel::None => return None,
        TrafficModel::PerPixelState {
            atomic_per_fragment,
        } => (
            2 * c.geometry_passes * c.bytes_allocated,
            if atomic_per_fragment { c.generated } else { 0 },
            0,
        ),
        TrafficModel::Lists => (
            2 * NODE_BYTES * c.stored + 2 * 4 * c.pixels,
            c.stored,
            c.stored,
        ),
        TrafficModel::Sbuffers => (
            2 * FRAGMENT_BYTES * c.stored + 2 * 2 * 4 * c.pixels,
            2 * c.generated,
            0,
        ),
        TrafficModel::Slots { atomics } => (
            2 * SLOT_BYTES * c.stored + 2 * PIXEL_BYTES * c.pixels,
            if atomics { c.stored } else { 0 },
            0,
        ),
        TrafficModel::Keys { bytes } => (2 * bytes * c.stored, c.stored, 0),
        TrafficModel::Kpeel => (
            2 * SLOT_BYTES * c.stored + 2 * KEY_BYTES * c.geometry_passes * c.pixels,
            c.stored,
            0,
        ),
        TrafficModel::Convex => (2 * 16 * c.stored + 2 * CONVEX_MERGE_BYTES * c.pixels, 0, 0),
        TrafficModel::Tiled => {
            let entries = c.stored.div_ceil(64);
            (
                2 * STATE_BYTES * c.pixels + 2 * (RECORD_ITEM_BYTES + LIST_ENTRY_BYTES) * entries,
                2 * entries,
                0,
            )
        }
        TrafficModel::Bucket => (
            2 * 16 * c.stored + 2 * (8 + 16 + 8) * c.pixels,
            c.generated + c.stored,
            0,
        ),
    };
    Some(Traffic {
        bytes: bytes + present,
        pixel_atomics,
        global_atomics,
    })
}

/// Per-pixel merge state `convex` reads and writes (its accumulated color, RGB transmittance
/// and last depth).
const CONVEX_MERGE_BYTES: u64 = 24 + 4;

/// A frame's floor on a device: the time its traffic takes at the measured rates.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "serde", derive(Serialize))]
pub struct Floor {
    /// Milliseconds the traffic takes at the device's rates.
    pub ms: f64,
    /// Which resource sets the floor: "bandwidth", "pixel atomics" or "global atomics".
    pub bound: &'static str,
}

/// The time `t` takes on a device with `rates`: the slowest of its bandwidth and atomic terms.
pub fn floor(t: &Traffic, rates: &DeviceRates) -> Floor {
    let candidates = [
        (t.bytes as f64 / rates.bandwidth_bytes_per_s(), "bandwidth"),
        (
            t.pixel_atomics as f64 / (rates.atomics_per_pixel_g_per_s * 1e9),
            "pixel atomics",
        ),
        (
            t.global_atomics as f64 / (rates.atomics_one_word_g_per_s * 1e9),
            "global atomics",
        ),
    ];
    let (seconds, bound) = candidates.into_iter().filter(|(s, _)| s.is_finite()).fold(
        (0.0, "bandwidth"),
        |best, c| if c.0 > best.0 { c } else { best },
    );
    Floor {
        ms: seconds * 1e3,
        bound,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::gpu::bandwidth::ProbeSizes;

    fn rates(gb_per_s: f64, pixel_g: f64, one_word_g: f64) -> DeviceRates {
        DeviceRates {
            copy_gb_per_s: gb_per_s,
            stream_gb_per_s: gb_per_s / 2.0,
            atomics_distinct_g_per_s: pixel_g * 2.0,
            atomics_per_pixel_g_per_s: pixel_g,
            atomics_one_word_g_per_s: one_word_g,
            sizes: ProbeSizes {
                copy_bytes: 0,
                increments: 0,
                repeats: 0,
            },
        }
    }

    const COUNTS: FrameCounts = FrameCounts {
        pixels: 1000,
        generated: 9000,
        stored: 8000,
        geometry_passes: 3,
        bytes_allocated: 56_000,
    };

    #[test]
    fn lists_move_their_nodes_twice_and_take_two_atomics_per_node() {
        let t = traffic(MethodId::AbufferLl, &COUNTS).unwrap();
        // 20-byte nodes written and read, 4-byte heads cleared and read, present 40 B/pixel.
        assert_eq!(t.bytes, 2 * 20 * 8000 + 2 * 4 * 1000 + 40 * 1000);
        assert_eq!((t.pixel_atomics, t.global_atomics), (8000, 8000));
        let f2b = traffic(MethodId::F2b, &COUNTS).unwrap();
        assert_eq!(f2b.bytes, 2 * 3 * 56_000 + 40 * 1000);
        assert_eq!(traffic(MethodId::Reference, &COUNTS), None);
    }

    #[test]
    fn tiled_moves_its_state_twice_and_an_entry_per_64_fragments() {
        let t = traffic(MethodId::Tiled, &COUNTS).unwrap();
        // 8000 fragments: at least 125 entries of 8 + 12 bytes, written and read; 40-byte state.
        assert_eq!(t.bytes, 2 * 40 * 1000 + 2 * 20 * 125 + 40 * 1000);
        assert_eq!((t.pixel_atomics, t.global_atomics), (250, 0));
    }

    #[test]
    fn every_gpu_method_has_a_model_that_grows_with_what_it_stores() {
        for id in MethodId::gpu_methods() {
            let t = traffic(id, &COUNTS).unwrap();
            let more = traffic(
                id,
                &FrameCounts {
                    stored: 2 * COUNTS.stored,
                    generated: 2 * COUNTS.generated,
                    bytes_allocated: 2 * COUNTS.bytes_allocated,
                    ..COUNTS
                },
            )
            .unwrap();
            assert!(t.bytes >= 40 * 1000, "{id}: {t:?}");
            assert!(more.bytes > t.bytes, "{id}: {t:?} -> {more:?}");
        }
    }

    #[test]
    fn the_floor_is_the_slowest_resource_not_their_sum() {
        let t = Traffic {
            bytes: 4_000_000_000,
            pixel_atomics: 1_000_000_000,
            global_atomics: 10_000_000,
        };
        // 4 GB at 2 TB/s = 2 ms; 1 G atomics at 1 G/s = 1000 ms; 10 M at 0.1 G/s = 100 ms.
        let f = floor(&t, &rates(2000.0, 1.0, 0.1));
        assert!((f.ms - 1000.0).abs() < 1e-9, "{f:?}");
        assert_eq!(f.bound, "pixel atomics");
        let f = floor(&t, &rates(2.0, 1000.0, 1000.0));
        assert!((f.ms - 2000.0).abs() < 1e-9, "{f:?}");
        assert_eq!(f.bound, "bandwidth");
        let f = floor(&t, &rates(2000.0, 1000.0, 0.001));
        assert_eq!(f.bound, "global atomics");
        assert!((f.ms - 10_000.0).abs() < 1e-6, "{f:?}");
    }
}
