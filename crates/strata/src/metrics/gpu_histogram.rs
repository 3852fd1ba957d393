//! The depth-complexity histogram on the GPU: one count geometry pass and one binning pass,
//! recorded into a frame; the bins come back with the frame's statistics
//! (`FrameStats::depth_histogram`). 1024 bins: bin i counts the pixels with exactly i fragments,
//! the last one the pixels with 1023 or more (reported as `depth_histogram_clipped`). Memory:
//! 4·W·H + 4 KiB. The CPU reference's histogram (`metrics::depth_complexity_histogram` of its
//! counts) is the check.

use crate::error::Result;
use crate::frame::passes::{
    capture_pipeline, compute_pipeline, dispatch_pixels, storage_geometry_pass, GeometryStage,
    NullTarget,
};
use crate::frame::{FrameContext, SceneGpu};
use crate::gpu::binding::{self, Slot};
use crate::gpu::shader::{Library, Stage};
use crate::gpu::twin::wgsl_constants;
use crate::gpu::{Gpu, ResourceCache};

/// Bins of the histogram: the last one holds the pixels of HISTOGRAM_BINS − 1 fragments or more.
pub const HISTOGRAM_BINS: u64 = 1024;

/// `strata::metrics::histogram_bins`: [`HISTOGRAM_BINS`] for the shader.
const BINS: Library = &[wgsl_constants!(
    "strata::metrics::histogram_bins",
    HISTOGRAM_BINS = HISTOGRAM_BINS
)];

/// The GPU depth-complexity histogram a frame can record: a counting pass over the scene, then a pass that bins each pixel's count.
pub struct GpuHistogram {
    layout: wgpu::BindGroupLayout,
    count: GeometryStage,
    bin: wgpu::ComputePipeline,
    null_target: Option<NullTarget>,
    cache: ResourceCache,
}

impl GpuHistogram {
    /// The histogram's layout and pipelines for `scene`'s device and rasterizer.
    pub fn new(gpu: &Gpu, scene: &SceneGpu) -> GpuHistogram {
        let layout = binding::layout(
            &gpu.device,
            "strata.histogram.layout",
            &[Slot::StorageRw, Slot::StorageRw],
        );
        let module = Stage::new("strata.histogram", include_str!("gpu_histogram.wgsl"))
            .with(BINS)
            .module(&gpu.device);
        let layouts = [&scene.frame_layout, &layout];
        GpuHistogram {
            // Always the GPU's rasterizer: coverage is the same on both paths (tested), and
            // the histogram only counts.
            count: GeometryStage::Hw(capture_pipeline(
                gpu,
                "strata.histogram.count",
                (&module, "fs_histogram_count"),
                &layouts,
                &[NullTarget::target_state()],
                None,
                scene.samples,
            )),
            bin: compute_pipeline(
                gpu,
                "strata.histogram.bins",
                (&module, "cs_histogram_bins"),
                &layouts,
            ),
            layout,
            null_target: None,
            cache: ResourceCache::default(),
        }
    }

    /// Records the count and binning passes and asks for the bins (HISTOGRAM_BINS words).
    pub fn record(&mut self, ctx: &mut FrameContext<'_>) -> Result<()> {
        let gpu = ctx.gpu;
        let counts = self
            .cache
            .storage(gpu, "strata.histogram.counts", ctx.pixels() * 4)?;
        let bins = self
            .cache
            .readable(gpu, "strata.histogram.bins", HISTOGRAM_BINS * 4)?;
        let group = binding::group(
            &gpu.device,
            "strata.histogram.group",
            &self.layout,
            &[counts.as_entire_binding(), bins.as_entire_binding()],
        );
        let target = ctx.null_target(&mut self.null_target, "strata.histogram.null_target");
        ctx.encoder.clear_buffer(&counts, 0, None);
        ctx.encoder.clear_buffer(&bins, 0, None);
        let frame_group = ctx.frame_group;
        storage_geometry_pass(
            ctx,
            "histogram",
            target,
            &self.count,
            &[frame_group, &group],
        );
        dispatch_pixels(ctx, "histogram", &self.bin, &[frame_group, &group]);
        ctx.readback.words(&bins, 0, HISTOGRAM_BINS);
        Ok(())
    }
}

/// The bins as `depth_complexity_histogram` gives them: up to the last non-empty bin.
pub fn trim(bins: &[u32]) -> Vec<u64> {
    let last = bins.iter().rposition(|&b| b > 0).map_or(0, |i| i + 1);
    bins[..last].iter().map(|&b| b as u64).collect()
}

#[cfg(test)]
mod tests {
    use crate::frame::FrameStats;
    use crate::scene::loaders;
    use crate::testing::gpu;
    use crate::{FrameRecorder, MethodId, RenderOptions};

    fn gpu_histogram(spec: &str, size: u32) -> (FrameStats, Vec<u64>) {
        let scene = loaders::load_scene(spec).unwrap();
        let options = RenderOptions::sized(size, size);
        let g = gpu();
        let mut rec = FrameRecorder::new(g, &scene, MethodId::Unsorted, &options).unwrap();
        rec.set_histogram(true);
        let mut enc = g.device.create_command_encoder(&Default::default());
        rec.record(&mut enc, &Default::default(), None).unwrap();
        g.queue.submit([enc.finish()]);
        let stats = rec.wait_stats().unwrap().stats;
        let (image, _) = crate::reference::render(&scene, &options).unwrap();
        (
            stats,
            crate::metrics::depth_complexity_histogram(&image.counts()),
        )
    }

    /// The GPU histogram equals the CPU reference's per-pixel counts, but for the few edge
    /// pixels where lavapipe's f32 setup and the reference's exact integers disagree on coverage
    /// (the exact-method bar: 0.1% of pixels, each moving between two bins).
    #[test]
    fn gpu_histogram_matches_the_reference() {
        for (spec, size) in [
            ("builtin:nvpro?objects=96&subdiv=10&seed=2", 64),
            ("builtin:dragon", 96),
        ] {
            let (stats, cpu) = gpu_histogram(spec, size);
            let gpu = stats.depth_histogram.unwrap();
            assert_eq!(gpu.iter().sum::<u64>(), (size * size) as u64, "{spec}");
            let moved: u64 = (0..gpu.len().max(cpu.len()))
                .map(|i| gpu.get(i).unwrap_or(&0).abs_diff(*cpu.get(i).unwrap_or(&0)))
                .sum();
            assert!(
                moved as f64 <= 2.0 * 0.001 * (size * size) as f64,
                "{spec}: {gpu:?} vs {cpu:?}"
            );
            assert_eq!(stats.depth_histogram_clipped, Some(0));
        }
    }

    /// Pixels deeper than the last bin are counted there and reported, never lost.
    #[test]
    fn deeper_pixels_land_in_the_last_bin() {
        let (stats, _) = gpu_histogram("builtin:layers?n=1024&coverage=1&order=front", 8);
        let bins = stats.depth_histogram.unwrap();
        assert_eq!(bins.len(), super::HISTOGRAM_BINS as usize);
        assert_eq!(bins[bins.len() - 1], 64);
        assert_eq!(stats.depth_histogram_clipped, Some(64));
    }
}
