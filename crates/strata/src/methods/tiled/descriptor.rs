//! `tiled`'s entry in the method table.

use crate::methods::kbuffer::options::TAIL;
use crate::methods::options::K;
use crate::methods::table::{Descriptor, Family, Setup, Support};
use crate::methods::{Method, MethodId};

fn create(_: MethodId, made: &Setup<'_>) -> crate::error::Result<Box<dyn Method>> {
    let tiled = super::Tiled::new(made.gpu, made.scene, made.options)?;
    Ok(Box::new(tiled))
}

/// `tiled`.
pub const TILED: Descriptor = Descriptor {
    exact: true,
    geometry_passes: "1 (binning), then one pass over each tile's list whose fragments fit the workgroup's memory (whole, or by 4×4 quarters), and R = ⌈N/16⌉ rounds for the tiles that do not (N: their deepest pixel last frame)",
    memory: "20·I + 88·T + 20·⌈W/8⌉·⌈H/8⌉ + 40·W·H + 256 (with --msaa S: 20 + 36·S bytes per pixel instead of 40); I (triangle, 8×8 tile) items and T set-up triangles, each sized from the last frame's need",
    summary: "exact OIT in compute: triangles binned into 8×8 tiles; a tile's workgroup evaluates and shades its fragments once, one thread per fragment, sorts each pixel's and composites them (tiles past its memory: rounds of each pixel's 16 nearest); no per-pixel global atomics or locks, deterministic",
    compute_raster: Support::Yes,
    app_shaders: Support::No(
        "it rasterizes and shades triangles in compute from strata's own vertex buffer, where an application's vertex and fragment stages cannot run",
    ),
    draw_callback: Support::No("it rasterizes the scene's triangles itself, in compute"),
    samples_in_compute: true,
    reads: &[K, TAIL],
    traffic: crate::methods::traffic::TrafficModel::Tiled,
    // Its fragments are ordered by (depth, primitive) inside each tile, whatever the list order.
    takes_order: false,
    ..Descriptor::new(MethodId::Tiled, "tiled", Family::Tiled, create)
};
