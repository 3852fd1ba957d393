#define_import_path strata::metrics::gpu_histogram
#import strata::metrics::histogram_bins::{HISTOGRAM_BINS}
#import strata::scene::{SceneVarying, behind_opaque, frame, pixel_index, pixel_of}

// The GPU depth-complexity histogram: a count pass (every fragment of a pixel, as the frame's
// methods see them: tested against the opaque depth, no culling) and a binning pass over the
// pixels. Bin i counts the pixels with exactly i fragments; the last bin, the pixels with
// HISTOGRAM_BINS − 1 or more (so they are reported, never lost).

@group(1) @binding(0) var<storage, read_write> pixel_counts: array<atomic<u32>>;
@group(1) @binding(1) var<storage, read_write> bins: array<atomic<u32>>;

@fragment
fn fs_histogram_count(v: SceneVarying) {
    if behind_opaque(v.position) {
        discard;
    }
    atomicAdd(&pixel_counts[pixel_index(pixel_of(v.position))], 1u);
}

// cs_histogram_bins's pixel step: its made compute stage calls it for each pixel of the frame.
fn cs_histogram_bins_pixel(pixel: vec2<u32>) {
    let count = atomicLoad(&pixel_counts[pixel_index(pixel)]);
    atomicAdd(&bins[min(count, HISTOGRAM_BINS - 1u)], 1u);
}
