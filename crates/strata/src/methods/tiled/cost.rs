//! A cost model of `tiled`'s frame on a GPU, from the work counters a CPU device counts
//! ([`TiledStats`]): each pass's time is its units of work times a cost per unit, and the costs
//! per unit are derived from one measured GPU frame — the H100's per-pass medians of
//! 2026-11-27 (`bench/results/nvidia-h100-80gb-hbm3/tiled.json`, nvpro at 1024²) over the work
//! that frame did (issue 64's count of it, made before the one-pass kernel). It predicts what
//! the redesigned passes take on that GPU, and the next lent run checks it: `bench tiled`
//! writes the prediction next to the measured times.
//!
//! The units, and where each cost comes from:
//! - a **triangle binned** (fetched, transformed, clipped, snapped, its items written; most
//!   of a scene's triangles at 1024² cover no pixel center and end there): the bin's time over
//!   the scene's triangles;
//! - a **triangle setup** after the bin (the old scatter's and rounds'): priced as a binned
//!   triangle;
//! - an **item counted** (read, one atomic on its tile's count): the count pass's time over the
//!   items;
//! - an **item's coverage** (64 pixel centers against 3 edges, and its list entry written): the
//!   old scatter's time over its items, less the setup it did for each;
//! - a **scan step** (one workgroup's threads each loading a tile's words, or one step of its
//!   prefix sum): the scan's time over its steps, 2·⌈tiles / threads⌉ + log₂ threads (256
//!   threads then, the H100's 1024 since);
//! - a **warp step** of the evaluation loops (a 32-lane warp evaluating and shading what its
//!   lanes cover of one list entry, or one fragment a lane): the old rounds' time, less their
//!   setups, over their warp steps (evaluations over 32 × lane occupancy);
//! - a **pixel finished** from its state (40 bytes read, 16 written, four same-address atomics):
//!   the finish pass's time over the pixels.
//!
//! Two units the measured frame did not have are priced by assumption, named here so that the
//! next GPU run can correct them: a **record load** (88 bytes from memory into workgroup memory)
//! at the bytes over [`ASSUMED_BANDWIDTH`], and a **sort step** (one compare-and-swap of a warp's
//! insertion sorts in workgroup memory) at [`SORT_STEP_SHARE`] of a warp step. A resolved pixel
//! costs the finish its progress word and the one-pass kernel its 16-byte result, both at that
//! bandwidth. The lists' memory traffic is small next to the evaluation (issue 64: about 0.1 GB a
//! round), so it is inside the per-unit costs rather than a term of its own.
//!
//! The counters of a CPU device are those of its workgroup memory: lavapipe's one-pass store
//! holds 1152 fragments where an H100's holds 1856, so counters from lavapipe leave more tiles
//! to the rounds than the H100 would, and the prediction errs high.

use super::TiledStats;
use crate::frame::ComputeRasterStats;

/// Bytes per second a record load and a resolved pixel's words are priced at: an H100's HBM3,
/// conservatively (it streams about 3 TB/s; L2 hits are faster).
pub const ASSUMED_BANDWIDTH: f64 = 2.0e12;
/// A sort step's cost as a share of a warp step's: a compare-and-swap is about 16 instructions
/// on workgroup memory, an evaluation and shading with the scene's lights about 250.
pub const SORT_STEP_SHARE: f64 = 16.0 / 250.0;
/// Threads of the scan's workgroup in the calibration frame, and on an H100 today
/// (`tiled::scan_threads`: its 1024 invocations per workgroup).
const CALIBRATION_SCAN_THREADS: u64 = 256;
const H100_SCAN_THREADS: u64 = 1024;

/// Steps of the scan's one workgroup of `threads` over `tiles`: each thread's two walks of its run
/// of tiles, one after another, and the prefix sum's steps.
fn scan_steps(tiles: u64, threads: u64) -> u64 {
    2 * tiles.div_ceil(threads) + threads.ilog2() as u64
}

/// Bytes of a setup record.
const RECORD_BYTES: f64 = crate::raster::SETUP_RECORD_BYTES as f64;

/// What one frame did, in the model's units.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Work {
    /// Pixels of the frame.
    pub pixels: u64,
    /// Triangles of the scene (the bin's threads).
    pub triangles: u64,
    /// 8×8 tiles of the frame.
    pub tiles: u64,
    /// Triangle setups, the bin's.
    pub bin_setups: u64,
    /// Setups after the bin (the old scatter's and rounds'; none since setup records).
    pub later_setups: u64,
    /// (Triangle, tile) items the bin wrote.
    pub items: u64,
    /// Setup records loaded by the tile passes.
    pub record_loads: u64,
    /// Warp steps of the evaluation loops.
    pub warp_steps: u64,
    /// Warp steps of the per-pixel sorts.
    pub sort_steps: u64,
    /// Pixels the one-pass kernel resolved (the finish passes them by).
    pub one_pass_pixels: u64,
}

impl Work {
    /// A frame's work from its statistics, `pixels` pixels.
    pub fn of_frame(tiled: &TiledStats, raster: &ComputeRasterStats, pixels: u64) -> Work {
        Work {
            pixels,
            triangles: raster.triangles,
            tiles: tiled.tile_rounds.iter().sum(),
            bin_setups: tiled.triangle_setups,
            later_setups: 0,
            items: raster.tile_items,
            record_loads: tiled.record_loads,
            warp_steps: tiled.warp_steps,
            sort_steps: tiled.sort_steps,
            one_pass_pixels: tiled.one_pass_pixels,
        }
    }
}

/// The frame the costs are derived from: nvpro (`objects=1024&subdiv=16&seed=0`, 10,395,914
/// fragments, depth 86) at 1024² on the H100, before issue 64's one-pass kernel. Its work is
/// issue 64's count (an independent re-implementation that reproduces the fragment count and
/// depth exactly): the bin's 229,376 threads (227,967 fan triangles set up, as counted here on
/// lavapipe), 1.2M setups again in the scatter and 2.23M in 6 rounds, 1,195,205 items, 27.7M
/// evaluations at 8.5 of 32 lanes.
pub const CALIBRATION_WORK: Work = Work {
    pixels: 1024 * 1024,
    triangles: NVPRO_TRIANGLES,
    tiles: 128 * 128,
    bin_setups: 227_967,
    later_setups: 1_195_205 + 2_230_000,
    items: 1_195_205,
    record_loads: 0,
    // 27.7M evaluations over 8.5 lanes a step.
    warp_steps: 3_258_824,
    sort_steps: 0,
    one_pass_pixels: 0,
};

/// Triangles of that scene.
pub const NVPRO_TRIANGLES: u64 = 229_376;

/// Its per-pass medians, ms (`bench/results/nvidia-h100-80gb-hbm3/tiled.json`).
pub const CALIBRATION_MS: PassTimes = PassTimes {
    bin: 0.091872,
    args: 0.0056,
    count: 0.034816,
    scan: 0.062656,
    scatter: 0.670848,
    tile_passes: 4.566432,
    finish: 0.124768,
    present: 0.1688,
};

/// Milliseconds per pass (the one-pass kernel and the rounds together: `tile_passes`).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize))]
pub struct PassTimes {
    /// The bin (the compute rasterizer's).
    pub bin: f64,
    /// The bin's indirect arguments.
    pub args: f64,
    /// The count pass (today: the items' coverage too).
    pub count: f64,
    /// The scan of the tiles' counts.
    pub scan: f64,
    /// The scatter into the tiles' lists.
    pub scatter: f64,
    /// The one-pass kernel and the rounds.
    pub tile_passes: f64,
    /// The finish.
    pub finish: f64,
    /// The frame's present pass (strata's, not tiled's; in the measured frame time).
    pub present: f64,
}

impl PassTimes {
    /// The frame: every pass.
    pub fn total(&self) -> f64 {
        self.bin
            + self.args
            + self.count
            + self.scan
            + self.scatter
            + self.tile_passes
            + self.finish
            + self.present
    }
}

/// Nanoseconds per unit of work on one GPU.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Costs {
    /// A triangle setup.
    pub setup: f64,
    /// A triangle binned (the bin's thread for one of the scene's triangles).
    pub binned: f64,
    /// An item counted.
    pub item_counted: f64,
    /// An item's coverage.
    pub coverage: f64,
    /// A step of the scan's one workgroup.
    pub scan_step: f64,
    /// A warp step of the evaluation loops.
    pub warp_step: f64,
    /// A pixel finished from its state.
    pub pixel_finished: f64,
    /// Fixed: the indirect arguments' pass.
    pub args_ms: f64,
    /// The present pass per pixel.
    pub present_pixel: f64,
}

impl Costs {
    /// The costs per unit that make `work`'s passes, as the design before issue 64 ran them,
    /// take `measured`.
    pub fn calibrated(work: &Work, measured: &PassTimes) -> Costs {
        let ns = |ms: f64| ms * 1e6;
        let per = |ms: f64, units: u64| ns(ms) / units.max(1) as f64;
        // The bin's time over its threads; a later setup redoes the same work for one fan
        // triangle, so it is priced the same.
        let binned = per(measured.bin, work.triangles);
        let setup = binned;
        let scatter_setups = work.items;
        let round_setups = work.later_setups - scatter_setups;
        Costs {
            setup,
            binned,
            item_counted: per(measured.count, work.items),
            coverage: (ns(measured.scatter) - setup * scatter_setups as f64) / work.items as f64,
            scan_step: per(
                measured.scan,
                scan_steps(work.tiles, CALIBRATION_SCAN_THREADS),
            ),
            warp_step: (ns(measured.tile_passes) - setup * round_setups as f64)
                / work.warp_steps as f64,
            pixel_finished: per(measured.finish, work.pixels),
            args_ms: measured.args,
            present_pixel: per(measured.present, work.pixels),
        }
    }

    /// The H100's, from [`CALIBRATION_WORK`] and [`CALIBRATION_MS`].
    pub fn h100() -> Costs {
        Costs::calibrated(&CALIBRATION_WORK, &CALIBRATION_MS)
    }

    /// The design before issue 64 on `work`: setups again in the scatter and the rounds, every
    /// pixel finished from its state.
    pub fn before_one_pass(&self, work: &Work) -> PassTimes {
        let ms = |ns: f64| ns / 1e6;
        let n = |units: u64| units as f64;
        let round_setups = work.later_setups.saturating_sub(work.items);
        PassTimes {
            bin: ms(self.binned * n(work.triangles)),
            args: self.args_ms,
            count: ms(self.item_counted * n(work.items)),
            scan: ms(self.scan_step * n(scan_steps(work.tiles, CALIBRATION_SCAN_THREADS))),
            scatter: ms((self.setup + self.coverage) * n(work.items)),
            tile_passes: ms(self.setup * n(round_setups) + self.warp_step * n(work.warp_steps)),
            finish: ms(self.pixel_finished * n(work.pixels)),
            present: ms(self.present_pixel * n(work.pixels)),
        }
    }

    /// Today's design on `work`: setup once, coverage in the count pass, the one-pass kernel
    /// (records loaded, fragments evaluated a lane each, sorted per pixel, resolved there) and
    /// rounds for what it leaves, the finish for the other pixels.
    pub fn predict(&self, work: &Work) -> PassTimes {
        let ms = |ns: f64| ns / 1e6;
        let n = |units: u64| units as f64;
        let bytes_ns = |bytes: f64| bytes / ASSUMED_BANDWIDTH * 1e9;
        let record_load = bytes_ns(RECORD_BYTES);
        let finished = work.pixels.saturating_sub(work.one_pass_pixels);
        PassTimes {
            bin: ms(self.binned * n(work.triangles)),
            args: self.args_ms,
            count: ms((self.coverage + self.item_counted) * n(work.items)),
            scan: ms(self.scan_step * n(scan_steps(work.tiles, H100_SCAN_THREADS))),
            scatter: ms(self.item_counted * n(work.items)),
            tile_passes: ms(record_load * n(work.record_loads)
                + self.warp_step * n(work.warp_steps)
                + SORT_STEP_SHARE * self.warp_step * n(work.sort_steps)
                + bytes_ns(16.0) * n(work.one_pass_pixels)),
            finish: ms(self.pixel_finished * n(finished) + bytes_ns(4.0) * n(work.one_pass_pixels)),
            present: ms(self.present_pixel * n(work.pixels)),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The costs reproduce the frame they were derived from, pass by pass, through the old
    /// design's formulas; the new design on the same work costs less where it removed work.
    #[test]
    fn the_calibration_reproduces_its_frame() {
        let costs = Costs::h100();
        let old = costs.before_one_pass(&CALIBRATION_WORK);
        for (name, got, measured) in [
            ("bin", old.bin, CALIBRATION_MS.bin),
            ("count", old.count, CALIBRATION_MS.count),
            ("scan", old.scan, CALIBRATION_MS.scan),
            ("scatter", old.scatter, CALIBRATION_MS.scatter),
            ("tile passes", old.tile_passes, CALIBRATION_MS.tile_passes),
            ("finish", old.finish, CALIBRATION_MS.finish),
            ("total", old.total(), CALIBRATION_MS.total()),
        ] {
            assert!((got - measured).abs() < 1e-9, "{name}: {got} vs {measured}");
        }
        assert!(costs.setup > 0.0 && costs.coverage > 0.0 && costs.warp_step > 0.0);
        // The same work without the setups after the bin, half the pixels resolved in one
        // pass: the scatter, the tile passes and the finish shrink.
        let once = Work {
            later_setups: 0,
            one_pass_pixels: CALIBRATION_WORK.pixels / 2,
            ..CALIBRATION_WORK
        };
        let new = costs.predict(&once);
        assert!(new.scatter < old.scatter && new.tile_passes < old.tile_passes);
        assert!(new.finish < old.finish, "{new:?} vs {old:?}");
    }
}
