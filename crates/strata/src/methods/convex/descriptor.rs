//! convex's entry in the method table.

use crate::methods::options::{kept_flag, MethodOption, OptionSpec};
use crate::methods::table::{Descriptor, Family, Setup, Support};
use crate::methods::traffic::TrafficModel;
use crate::methods::{Method, MethodId};

fn create(_: MethodId, made: &Setup<'_>) -> crate::error::Result<Box<dyn Method>> {
    let convex = super::Convex::new(made.gpu, made.scene, made.options)?;
    Ok(Box::new(convex))
}

/// `convex`.
pub const CONVEX: Descriptor = Descriptor {
    exact: true,
    geometry_passes: "1 read of the geometry, split over P passes (P: groups in the deepest chain of groups whose screen footprints meet)",
    memory: "(16·L + 60)·W·H + 12·triangles + 64; L = 2, or 4 with paired groups",
    summary: "convex polyhedra (seed 001): convex parts by region growing, ordered per frame by separating planes and nesting; each pass captures groups that cannot share a pixel (2 layers per part) and merges them front to back; exact when the order holds, order_violations counted",
    reads: &[CACHE_DIR],
    app_shaders: Support::No(
        "it decomposes the scene's meshes into convex parts on the CPU and draws them in visibility order, and an application's buffers give it no meshes",
    ),
    draw_callback: Support::No(
        "it draws its own groups pass by pass in visibility order",
    ),
    traffic: TrafficModel::Convex,
    // It submits its groups in visibility order itself.
    takes_order: false,
    compute_raster: Support::No(
        "it draws each pass's groups through their own index ranges, in an order made per frame",
    ),
    ..Descriptor::new(MethodId::Convex, "convex", Family::Convex, create)
};

/// `--cache-dir`.
pub const CACHE_DIR: MethodOption = MethodOption::named("cache-dir");

/// `convex`'s option: where its decompositions are kept between runs (a path the CLI makes
/// absolute).
pub const OPTIONS: &[OptionSpec] = &[OptionSpec {
    option: CACHE_DIR,
    flags: &[kept_flag(
        "cache_dir",
        "--cache-dir",
        "convex: the folder its decompositions are kept in between runs",
    )],
}];
