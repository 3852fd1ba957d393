//! A frame's statistics from its readback: each stage's words are its own segment
//! ([`crate::gpu::readback::Segment`]); the method decodes its own (`Method::stats`), the
//! recorder the totals, timestamps, rasterizer, order and histogram, and decides what the frame
//! is from them (exactness: [`crate::methods::Descriptor::exactness`]).

use super::*;

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
        let totals = words.as_ref().map(|w| Totals::from_words(p.totals.of(w)));
        let gpu_ms = match (&words, &p.timestamps) {
            (Some(w), Some((segment, names))) => Some(self.timer.decode(names, segment.of(w))),
            _ => None,
        };
        let method_words = words.as_ref().map(|w| p.method_words.of(w));
        let histogram = match (&words, p.histogram_words) {
            (Some(w), Some(segment)) => Some(segment.of(w).to_vec()),
            _ => None,
        };
        let ms: MethodStats = match (self.methods.get_mut(&p.method), method_words) {
            (Some(m), Some(words)) => m.stats(&p.recorded, &totals.unwrap_or_default(), words),
            _ => MethodStats {
                family: p.recorded.family.clone(),
                ..Default::default()
            },
        };
        if let Some(t) = totals {
            // The next frames' draws are split by it (docs/watchdog.md, S2).
            self.scene.note_fragments(t.generated);
        }
        let mut incomplete = ms.incomplete;
        let mut cannot_complete = ms.cannot_complete.clone();
        if let Some(t) = totals.filter(|t| t.cut_short > 0) {
            incomplete = true;
            cannot_complete = cannot_complete.or(Some(crate::frame::Shortfall {
                why: format!(
                    "{}: {} pixels' resolves ended early (the deepest pixel has {} fragments): a resolve takes at most 65535 data-bound loop steps a pixel, so that no dispatch nears a display watchdog, and lavapipe ends an invocation's loops after 65535 iterations in all, counting more of them: render fewer layers per pixel here, or use tiled",
                    p.method, t.cut_short, t.max_depth
                ),
                binding: None,
            }));
        }
        let compute_raster = match (&words, p.raster_words, &mut self.raster) {
            (Some(w), Some((segment, capacity)), Some(raster)) => {
                let report = raster.feedback(&self.gpu, segment.of(w), capacity, 0);
                incomplete |= report.incomplete;
                cannot_complete = cannot_complete.or(report.cannot_complete);
                Some(report.stats)
            }
            _ => None,
        };
        // The frame's own rasterizer's memory is the recorder's to add; a method's own
        // rasterizer (tiled) counts in the method's bytes.
        let recorder_raster_bytes = compute_raster.as_ref().map_or(0, |r| r.bytes_allocated);
        let compute_raster = compute_raster.or_else(|| ms.compute_raster.clone());
        let mut auto_k = p.auto_k.map(|mut a| {
            a.achieved_robustness = totals.map(|t| match t.generated {
                0 => 1.0,
                n => t.stored as f64 / n as f64,
            });
            a
        });
        if let Some(bins) = &histogram {
            let bins = gpu_histogram::trim(bins);
            if let Some(a) = &mut auto_k {
                // Exact mode renders again when the frame's own histogram picks another k; a
                // guess it confirms gets its prediction from it.
                let again = predict::choose_k(
                    p.method,
                    Some(&bins),
                    a.robustness_target,
                    DEFAULT_K,
                    &self.options,
                );
                match again {
                    Ok(c) if Some(c.k) != p.recorded.k => incomplete = true,
                    Ok(c) if a.predicted_robustness.is_none() => {
                        a.predicted_robustness = Some(c.predicted_robustness);
                        a.histogram_frame = Some(p.frame);
                    }
                    _ => {}
                }
            }
            if self.last_histogram.as_ref().is_none_or(|h| h.0 < p.frame) {
                self.last_histogram = Some((p.frame, bins));
            }
        }
        let exact = frame_exact(
            p.method,
            p.recorded.k,
            totals.map_or(0, |t| t.dropped + ms.culled_temporal.unwrap_or(0)),
            &ms,
            compute_raster.as_ref().is_some_and(|r| r.overflow),
        );
        let stats = FrameStats {
            frame: p.frame,
            method: p.method.as_str().to_string(),
            method_choice: None,
            width: p.options.width,
            height: p.options.height,
            k: p.recorded.k,
            effect: p.options.effect.name().to_string(),
            geometry_passes: p.recorded.geometry_passes,
            exact: Some(exact.0),
            exact_k_nearest: exact.1,
            gpu_ms_total: gpu_ms.as_ref().map(|m| m.values().sum()),
            gpu_ms,
            fragments_generated: totals.map(|t| t.generated + ms.culled_temporal.unwrap_or(0)),
            fragments_stored: totals.map(|t| t.stored),
            fragments_dropped: totals.map(|t| t.dropped + ms.culled_temporal.unwrap_or(0)),
            culled_temporal: ms.culled_temporal,
            max_depth_complexity: totals.map(|t| t.max_depth),
            bytes_allocated: p.recorded.bytes_allocated
                + recorder_raster_bytes
                + p.order_words.map_or(0, |o| o.1)
                + self.scene.animation.as_ref().map_or(0, |a| a.bytes()),
            // The compute rasterizer's work items overflowing leaves fragments that no counter
            // saw: the frame says it overflowed (and is incomplete), its counts are lower bounds.
            overflow: match compute_raster.as_ref().filter(|r| r.overflow) {
                Some(_) => Some(true),
                None => ms.overflow,
            },
            lock_failures: ms.lock_failures,
            memory_ordering: p.recorded.memory_ordering.map(String::from),
            bands: None,
            depth_histogram: histogram.as_deref().map(gpu_histogram::trim),
            depth_histogram_clipped: histogram.map(|h| h[h.len() - 1] as u64),
            k_auto: auto_k,
            lighting: self.lit.as_ref().map(LitFrame::stats),
            raster: match ms.compute_raster {
                Some(_) => Raster::Compute,
                None => self.options.build.raster,
            }
            .name()
            .to_string(),
            compute_raster,
            family: ms.family.clone(),
            order: p.options.order.map(|o| o.name().to_string()),
            kendall_tau: match (&words, p.order_words) {
                (Some(w), Some((segment, _))) => Some(crate::order::kendall_tau(segment.of(w))),
                _ => None,
            },
            blocking_readbacks: 0,
            submits: 0,
            adapter: Some(self.gpu.info.name.clone()),
            backend: Some(self.gpu.backend_name()),
        };
        FrameReport {
            stats,
            incomplete,
            cannot_complete,
        }
    }
}

/// Whether a frame of `method` is exact (see `FrameStats::exact`), and whether it kept a
/// k-buffer's promise of each pixel's k nearest (`FrameStats::exact_k_nearest`), given the
/// fragments it dropped and what the method read back.
fn frame_exact(
    method: MethodId,
    k: Option<u32>,
    dropped: u64,
    ms: &MethodStats,
    raster_overflow: bool,
) -> (bool, Option<bool>) {
    let kept = ms.lock_failures.unwrap_or(0) == 0
        && ms.culled_temporal.unwrap_or(0) == 0
        && ms.overflow != Some(true)
        && !raster_overflow
        && ms.family.as_ref().is_none_or(|f| f.stat().kept_promise());
    method.descriptor().exactness(k, dropped, kept)
}
