//! The baselines' entries in the method table.

use crate::methods::table::{Descriptor, Family, Setup, Support};
use crate::methods::{Method, MethodId};

fn create(id: MethodId, made: &Setup<'_>) -> crate::error::Result<Box<dyn Method>> {
    let Setup { gpu, scene, .. } = *made;
    Ok(Box::new(super::Blend::new(
        gpu,
        scene,
        id == MethodId::Sorted,
    )?))
}

/// The baselines' blend modes.
const HARDWARE_OVER: Support =
    Support::No("it blends every triangle with one fixed-function over blend state");

/// `unsorted`.
pub const UNSORTED: Descriptor = Descriptor {
    memory: "(8·S + 4)·W·H; S samples per pixel (--msaa, else 1)",
    summary: "alpha blending in submission order (no OIT)",
    blend_modes: HARDWARE_OVER,
    app_shaders: Support::Yes,
    ..Descriptor::new(MethodId::Unsorted, "unsorted", Family::Baseline, create)
};

/// `sorted`.
pub const SORTED: Descriptor = Descriptor {
    memory: "(8·S + 4)·W·H + 12·triangles; S samples per pixel (--msaa, else 1)",
    summary: "alpha blending after a back-to-front sort of triangle centroids",
    // Its own order: triangle centroids, sorted each frame.
    takes_order: false,
    sorts_centroids: true,
    app_shaders: Support::No(
        "it sorts the scene's own triangles by centroid every frame, and an application's buffers are opaque to it",
    ),
    draw_callback: Support::No("it orders every triangle of the scene itself"),
    blend_modes: HARDWARE_OVER,
    ..Descriptor::new(MethodId::Sorted, "sorted", Family::Baseline, create)
};
