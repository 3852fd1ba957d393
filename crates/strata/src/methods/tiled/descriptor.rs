//! `tiled`'s entry in the method table.

use crate::methods::table::{Descriptor, Family, MethodOption, Setup, Support};
use crate::methods::{Method, MethodId};

fn create(_: MethodId, made: &Setup<'_>) -> crate::error::Result<Box<dyn Method>> {
    let tiled = super::Tiled::new(made.gpu, made.scene, made.options)?;
    Ok(Box::new(tiled))
}

/// `tiled`.
pub const TILED: Descriptor = Descriptor {
    exact: true,
    geometry_passes: "1 (binning), then R = ⌈N/16⌉ rounds over the tile lists (N: the last frame's depth complexity), each run only by tiles with fragments left",
    memory: "20·I + 12·⌈W/8⌉·⌈H/8⌉ + 40·W·H + 204; I (triangle, 8×8 tile) items, sized from the last frame's need",
    summary: "exact OIT in compute: triangles binned into 8×8 tiles, each tile's pixels sorted and composited inside one workgroup in rounds of 16 nearest fragments; no per-pixel atomics or locks, deterministic",
    compute_raster: Support::Yes,
    app_shaders: Support::No(
        "it rasterizes and shades triangles in compute from strata's own vertex buffer, where an application's vertex and fragment stages cannot run",
    ),
    draw_callback: Support::No("it rasterizes the scene's triangles itself, in compute"),
    msaa: Support::No("it samples pixel centers in compute, as the compute rasterizer does"),
    reads: &[MethodOption::K],
    traffic: crate::methods::traffic::TrafficModel::Tiled,
    // Its fragments are ordered by (depth, primitive) inside each tile, whatever the list order.
    takes_order: false,
    ..Descriptor::new(MethodId::Tiled, "tiled", Family::Tiled, create)
};
