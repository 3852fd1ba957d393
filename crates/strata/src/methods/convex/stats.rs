//! What `convex` reports of a frame (its groups, passes and order), carried in the frame's
//! statistics as [`crate::frame::FamilyStats`] under `"convex"`.

#[cfg(feature = "serde")]
use serde::Serialize;

use crate::frame::FamilyStat;

/// What `convex` reports about a frame .
#[derive(Clone, Debug, Default)]
#[cfg_attr(feature = "serde", derive(Serialize))]
pub struct ConvexStats {
    /// Convex parts, and the groups they were drawn as.
    pub parts: u32,
    /// Groups the parts were drawn as.
    pub groups: u32,
    /// Groups outside the view this frame.
    pub culled: u32,
    /// Capture passes this frame (each followed by a merge).
    pub passes: u32,
    /// Draw calls over all passes.
    pub draws: u32,
    /// Pairs of groups whose screen rectangles overlap, and those of them ordered by centroid
    /// for want of a plane.
    pub overlapping_pairs: u64,
    /// Overlapping pairs ordered by centroid, without a separating plane.
    pub unseparated_pairs: u64,
    /// Cycles the sort broke.
    pub cycles_broken: u32,
    /// Fragments per pixel and pass the capture keeps (2 per convex part of a group).
    pub layers: u32,
    /// CPU milliseconds of this frame's order (0 when the view did not change).
    pub order_ms: f64,
    /// CPU milliseconds the convex decomposition took when it was made (a cached one keeps that time).
    pub preprocess_ms: f64,
    /// Pixel-passes whose nearest fragment lay in front of what was already merged (the order
    /// failed there).
    pub order_violations: Option<u64>,
    /// Pixel-passes that received more fragments than `layers` (the excess is dropped).
    pub overflowing_pixels: Option<u64>,
}

impl FamilyStat for ConvexStats {
    fn key(&self) -> &'static str {
        "convex"
    }

    #[cfg(feature = "serde")]
    fn to_json(&self) -> serde_json::Value {
        serde_json::to_value(self).unwrap_or_default()
    }

    /// The order held in every pixel-pass.
    fn kept_promise(&self) -> bool {
        self.order_violations.unwrap_or(0) == 0
    }

    /// Said only where the order failed: the picture is then not exact.
    fn note(&self) -> Option<String> {
        let violations = self.order_violations.filter(|&v| v > 0)?;
        Some(format!(
            "convex: the parts' order failed in {violations} pixel-passes (a nearer fragment arrived after farther ones were merged); the picture is not exact there"
        ))
    }
}
