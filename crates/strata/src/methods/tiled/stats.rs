//! What `tiled` reports of a frame (its rounds, lists and work counters), carried in the
//! frame's statistics as [`crate::frame::FamilyStats`] under `"tiled"`.

#[cfg(feature = "serde")]
use serde::Serialize;

use crate::frame::{FamilyStat, FamilyStats};

/// What `tiled` reports about a frame.
#[derive(Clone, Debug, Default, PartialEq)]
#[cfg_attr(feature = "serde", derive(Serialize))]
pub struct TiledStats {
    /// Rounds of the tile pass the frame recorded (from the last frame's deepest pixel).
    pub rounds: u32,
    /// Tiles by the rounds they ran: entry r counts the tiles that ran r rounds (0: no triangle
    /// met the tile, or the one-pass kernel took all of it), the last entry those that ran that
    /// many or more.
    pub tile_rounds: Vec<u64>,
    /// The most fragments one pixel had.
    pub deepest_pixel: u32,
    /// Pixels with fragments left after the last round (the frame is incomplete).
    pub unfinished_pixels: u64,
    /// The longest tile list (items).
    pub longest_list: u32,
    /// Bytes of the per-tile lists, their starts, counts and rounds, and the pixels' state.
    pub list_bytes: u64,
    /// Triangle setups (transform, clip, snap): the bin's, one per fan triangle it sets up and
    /// stores as a record for the passes after it.
    pub triangle_setups: u64,
    /// Setup records loaded into workgroup memory: by the one-pass kernel once per list entry
    /// that covers a pixel of its region, and by each round once per list entry that covers a
    /// pixel with fragments left.
    pub record_loads: u64,
    /// Compares of the one-pass kernel's per-pixel insertion sorts, each 32-lane warp counted
    /// as its longest (a warp waits for its last lane).
    pub sort_steps: u64,
    /// Pixels the one-pass kernel resolved, tiles no triangle meets included (the others are
    /// the rounds').
    pub one_pass_pixels: u64,
    /// Steps of the 32-lane warps through the evaluation loops (the one-pass kernel's and the
    /// rounds'): what [`TiledStats::evaluation_occupancy`] divides by.
    pub warp_steps: u64,
    /// Fragment evaluations (barycentrics and depth at a covered pixel center) in the rounds:
    /// every round evaluates again each fragment behind its pixel's bound.
    pub fragment_evaluations: u64,
    /// Fragments shaded in the rounds: before it is known whether a fragment stays among its
    /// pixel's nearest, so some are shaded and displaced.
    pub shadings: u64,
    /// Listed (triangle, tile) items that cover a pixel center of their tile.
    pub items_kept: u64,
    /// Listed items that cover none (their tile meets the triangle's bounds only).
    pub items_empty: u64,
    /// 4×4 quarters of tiles left to the rounds: the tile's covered pixel centers outgrew the
    /// one-pass kernel's workgroup memory, and so did the quarter's (a tile that fits whole
    /// counts none).
    pub tiles_past_capacity: u64,
    /// Lane occupancy of the evaluation loops: evaluations over 32 × the steps of the 32-lane
    /// warps that ran them (a warp with no pixel left skips a round's loop).
    pub evaluation_occupancy: f64,
}

impl TiledStats {
    /// These and the next band's of the same picture: tiles and pixels add up, the rest is the
    /// larger.
    pub fn with(&self, b: &TiledStats) -> TiledStats {
        let a = self;
        let bins = a.tile_rounds.len().max(b.tile_rounds.len());
        let at = |v: &[u64], i: usize| v.get(i).copied().unwrap_or(0);
        TiledStats {
            rounds: a.rounds.max(b.rounds),
            tile_rounds: (0..bins)
                .map(|i| at(&a.tile_rounds, i) + at(&b.tile_rounds, i))
                .collect(),
            deepest_pixel: a.deepest_pixel.max(b.deepest_pixel),
            unfinished_pixels: a.unfinished_pixels + b.unfinished_pixels,
            longest_list: a.longest_list.max(b.longest_list),
            list_bytes: a.list_bytes.max(b.list_bytes),
            triangle_setups: a.triangle_setups + b.triangle_setups,
            record_loads: a.record_loads + b.record_loads,
            sort_steps: a.sort_steps + b.sort_steps,
            one_pass_pixels: a.one_pass_pixels + b.one_pass_pixels,
            warp_steps: a.warp_steps + b.warp_steps,
            fragment_evaluations: a.fragment_evaluations + b.fragment_evaluations,
            shadings: a.shadings + b.shadings,
            items_kept: a.items_kept + b.items_kept,
            items_empty: a.items_empty + b.items_empty,
            tiles_past_capacity: a.tiles_past_capacity + b.tiles_past_capacity,
            // Weighted by each band's evaluations, as the whole frame's would be.
            evaluation_occupancy: {
                let (ea, eb) = (a.fragment_evaluations as f64, b.fragment_evaluations as f64);
                let steps = |e: f64, o: f64| if o > 0.0 { e / o } else { 0.0 };
                let total = steps(ea, a.evaluation_occupancy) + steps(eb, b.evaluation_occupancy);
                if total > 0.0 {
                    (ea + eb) / total
                } else {
                    0.0
                }
            },
        }
    }
}

impl FamilyStat for TiledStats {
    fn key(&self) -> &'static str {
        "tiled"
    }

    #[cfg(feature = "serde")]
    fn to_json(&self) -> serde_json::Value {
        serde_json::to_value(self).unwrap_or_default()
    }

    fn with_band(&self, next: &FamilyStats) -> Option<FamilyStats> {
        next.get::<TiledStats>()
            .map(|next| FamilyStats::new(self.with(next)))
    }
}
