#define_import_path strata::raster::params

// The compute rasterizer's parameters, one struct for every stage that binds them.
// Keep in sync with `RasterParams` in crates/strata/src/raster/mod.rs.
struct RasterParams {
    triangles: u32,
    // Work items the item buffer holds.
    capacity: u32,
    guard: f32,
    _pad: u32,
}
