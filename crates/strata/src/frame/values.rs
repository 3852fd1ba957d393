//! Value types the layers above share: the rasterizer a frame uses, and what the compute
//! rasterizer, temporal culling and `convex` put into a frame's statistics. They live here,
//! below the code that produces them, so that options and statistics need nothing above `frame`.

#[cfg(feature = "serde")]
use serde::Serialize;

use crate::keyword::keyword_enum;

keyword_enum! {
    /// Which rasterizer turns triangles into fragments.
    #[derive(Default)]
    pub enum Raster ("--raster") {
        /// The GPU's fixed-function rasterizer.
        #[default]
        Hw = "hw",
        /// strata's compute-shader rasterizer (`crate::raster`).
        Compute = "compute",
    }
}

/// What the compute rasterizer reports about a frame.
#[derive(Clone, Debug, Default, PartialEq)]
#[cfg_attr(feature = "serde", derive(Serialize))]
pub struct ComputeRasterStats {
    /// Triangles of the scene the bin read (one thread each).
    pub triangles: u64,
    /// Triangles of the clipped polygons' fans that reached the viewport.
    pub triangles_set_up: u64,
    /// (Triangle, 8×8 tile) work items the frame needed.
    pub tile_items: u64,
    /// Work items the frame's buffer held.
    pub item_capacity: u64,
    /// More items were needed than held: fragments were lost and the frame is incomplete.
    pub overflow: bool,
    /// Bytes of the rasterizer's buffers (triangles, items).
    pub bytes_allocated: u64,
}

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

/// `--temporal on` and its settings.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TemporalCulling {
    /// Frames between refreshes of one tile (0: never refresh).
    pub refresh: u32,
    /// How far (window depth) behind the interface a fragment must lie to be culled.
    pub epsilon: f32,
}

impl Default for TemporalCulling {
    fn default() -> Self {
        TemporalCulling {
            refresh: DEFAULT_REFRESH,
            epsilon: DEFAULT_EPSILON,
        }
    }
}

/// Default frames between refreshes of a tile (`--temporal-refresh`).
pub const DEFAULT_REFRESH: u32 = 8;

/// Default depth margin of the culling test (`--temporal-epsilon`).
pub const DEFAULT_EPSILON: f32 = 1e-5;

/// What `convex` reports about a frame (`FrameStats::convex`).
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

/// The most tries `--max-tries` accepts: every waiting fragment spins at most this long, a bound
/// that keeps a starving pixel within a frame's time instead of the driver's reset.
pub const MAX_TRIES_LIMIT: u32 = 1 << 20;

keyword_enum! {
    /// The display transform of the lit pipelines (`--tonemap`).
    #[derive(Default)]
    pub enum Tonemap ("--tonemap") {
        /// Clamp only.
        None = "none",
        /// Khronos PBR Neutral's highlight compression without its toe: channels below 0.8 pass
        /// unchanged, brighter colors roll off towards 1 and desaturate (see `encoding::tone_map`).
        #[default]
        Neutral = "neutral",
        /// c / (1 + c) per channel.
        Reinhard = "reinhard",
    }
}

keyword_enum! {
    /// How the G-buffer stores normals (`--normal-encoding`).
    #[derive(Default)]
    pub enum NormalEncoding ("--normal-encoding") {
        /// Seed 004's spheremap transform of the view-space normal.
        #[default]
        Spheremap = "spheremap",
        /// Octahedral mapping (bounded error over every direction).
        Octahedral = "octahedral",
    }
}

/// A G-buffer view (`--gbuffer-debug`), written instead of the picture.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "serde", derive(Serialize))]
#[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
#[cfg_attr(feature = "serde", serde(rename_all = "kebab-case"))]
pub enum GbufferView {
    /// Base color.
    Albedo,
    /// The view-space normal as n·0.5 + 0.5.
    Normal,
    /// The specular exponent / 128.
    Specular,
    /// The material id as a hashed color.
    Material,
    /// The stored depth (view distance / far).
    Depth,
    /// The light buffers' diffuse + specular.
    Lights,
    /// The normal encoding's angular error per pixel: a heatmap in hundredths of a degree.
    NormalError,
    /// The ambient occlusion factor (with `--ssao`; white without).
    Occlusion,
}

impl GbufferView {
    /// The view's number as the debug shader reads it.
    pub fn index(self) -> u32 {
        self as u32
    }

    /// The view's name on the command line and in statistics.
    pub fn name(self) -> &'static str {
        match self {
            GbufferView::Albedo => "albedo",
            GbufferView::Normal => "normal",
            GbufferView::Specular => "specular",
            GbufferView::Material => "material",
            GbufferView::Depth => "depth",
            GbufferView::Lights => "lights",
            GbufferView::NormalError => "normal-error",
            GbufferView::Occlusion => "occlusion",
        }
    }
}

/// What a lit frame reports (`FrameStats::lighting`).
#[derive(Clone, Debug, Default, PartialEq)]
#[cfg_attr(feature = "serde", derive(Serialize))]
pub struct LightingStats {
    /// "forward" or "deferred".
    pub pipeline: String,
    /// Lights of the scene (ambient ones excluded: they are a term of the composite).
    pub lights: u32,
    /// Deferred: lights drawn as spheres, cones and full-screen triangles, and culled.
    pub sphere_volumes: Option<u32>,
    /// Spot lights drawn as cone volumes.
    pub cone_volumes: Option<u32>,
    /// Lights drawn as full-screen triangles (directional ones, and volumes reaching past the far plane).
    pub full_screen_lights: Option<u32>,
    /// Lights culled because their volume is outside the view.
    pub culled_lights: Option<u32>,
    /// Deferred: G-buffer bytes per pixel (compressed layout).
    pub gbuffer_bytes_per_pixel: Option<u64>,
    /// Bytes of the pipeline's targets.
    pub bytes_allocated: u64,
    /// The tone map applied to the HDR frame.
    pub tonemap: Tonemap,
    /// Screen-space ambient occlusion was on.
    pub ssao: bool,
}

#[cfg(test)]
mod tests {
    use super::GbufferView;

    /// Every view's name is its serialized name and its command-line value (the tests build
    /// with the `clap` feature, whose value list is every variant).
    #[test]
    fn gbuffer_view_names_are_their_serialized_names() {
        for &v in <GbufferView as clap::ValueEnum>::value_variants() {
            assert_eq!(serde_json::to_value(v).unwrap(), v.name());
            let value = clap::ValueEnum::to_possible_value(&v).unwrap();
            assert_eq!(value.get_name(), v.name());
        }
    }
}
