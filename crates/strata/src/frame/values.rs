//! Value types the layers above share: the rasterizer a frame uses, and what the compute
//! rasterizer and temporal culling put into a frame's statistics. They live here,
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
