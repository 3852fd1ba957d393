//! A frame's statistics from its readback: each stage's words are its own segment
//! ([`crate::gpu::readback::Segment`]) and each stage reads its own ([`Method::stats`], and the
//! recorder's stages in `stages.rs`); here they are put together and the frame's exactness is
//! decided ([`crate::methods::Descriptor::exactness`]).

use super::*;

impl FrameReport {
    /// Marks the frame incomplete (`incomplete`) or never completable (`why`, the first reason
    /// kept).
    pub(super) fn refuse(&mut self, incomplete: bool, why: Option<crate::frame::Shortfall>) {
        self.incomplete |= incomplete;
        self.cannot_complete = self.cannot_complete.take().or(why);
    }
}

impl FrameRecorder {
    pub(super) fn decode(
        &mut self,
        mut done: Vec<(Pending, Option<Vec<u32>>)>,
    ) -> Vec<FrameReport> {
        done.sort_by_key(|(p, _)| p.frame);
        done.into_iter()
            .map(|(pending, words)| self.report(pending, words))
            .collect()
    }

    fn report(&mut self, p: Pending, words: Option<Vec<u32>>) -> FrameReport {
        let mut report = FrameReport {
            stats: self.recorded_stats(&p),
            incomplete: false,
            cannot_complete: None,
        };
        let Some(words) = words.as_deref() else {
            report.stats.family = p.recorded.family.clone();
            return report;
        };
        let totals = self.read_totals(&p, words);
        let method = self.methods.get_mut(&p.method).expect("a recorded method");
        let ms = method.stats(&p.recorded, &totals, p.words.method.of(words));
        report.refuse(ms.incomplete, ms.cannot_complete.clone());
        if totals.cut_short > 0 {
            report.refuse(true, Some(cut_short(p.method, totals)));
        }
        let culled = ms.culled_temporal.unwrap_or(0);
        let stats = &mut report.stats;
        stats.fragments_generated = Some(totals.generated + culled);
        stats.fragments_stored = Some(totals.stored);
        stats.fragments_dropped = Some(totals.dropped + culled);
        stats.max_depth_complexity = Some(totals.max_depth);
        stats.culled_temporal = ms.culled_temporal;
        stats.lock_failures = ms.lock_failures;
        stats.overflow = ms.overflow;
        stats.family = ms.family.clone();
        if let Some(raster) = &ms.compute_raster {
            stats.raster = Raster::Compute.name().to_string();
            stats.compute_raster = Some(raster.clone());
        }
        self.read_stages(&p, words, &mut report);
        self.read_histogram(&p, words, totals, &mut report);
        let stats = &mut report.stats;
        let kept = ms.lock_failures.unwrap_or(0) == 0
            && culled == 0
            && stats.overflow != Some(true)
            && stats
                .family
                .as_ref()
                .is_none_or(|f| f.stat().kept_promise());
        let dropped = totals.dropped + culled;
        let (exact, k_nearest) = p.method.descriptor().exactness(p.recorded.k, dropped, kept);
        stats.exact = Some(exact);
        stats.exact_k_nearest = k_nearest;
        report
    }

    /// What the frame's statistics say before its words are read: what it was recorded with.
    fn recorded_stats(&self, p: &Pending) -> FrameStats {
        FrameStats {
            frame: p.frame,
            method: p.method.as_str().to_string(),
            width: p.options.width,
            height: p.options.height,
            k: p.recorded.k,
            effect: p.options.effect.name().to_string(),
            geometry_passes: p.recorded.geometry_passes,
            bytes_allocated: p.recorded.bytes_allocated
                + p.words.order.map_or(0, |o| o.1)
                + self.scene.animation.as_ref().map_or(0, |a| a.bytes()),
            memory_ordering: p.recorded.memory_ordering.map(String::from),
            k_auto: p.auto_k.clone(),
            lighting: self.lit.as_ref().map(LitFrame::stats),
            raster: self.options.build.raster.name().to_string(),
            order: p.options.order.map(|o| o.name().to_string()),
            adapter: Some(self.gpu.info.name.clone()),
            backend: Some(self.gpu.backend_name()),
            ..Default::default()
        }
    }
}

/// Why a frame whose resolves ran past their step budget is refused.
fn cut_short(method: MethodId, totals: Totals) -> crate::frame::Shortfall {
    crate::frame::Shortfall {
        why: format!(
            "{method}: {} pixels' resolves ended early (the deepest pixel has {} fragments): a resolve takes at most 65535 data-bound loop steps a pixel, so that no dispatch nears a display watchdog, and lavapipe ends an invocation's loops after 65535 iterations in all, counting more of them: render fewer layers per pixel here, or use tiled",
            totals.cut_short, totals.max_depth
        ),
        binding: None,
    }
}
