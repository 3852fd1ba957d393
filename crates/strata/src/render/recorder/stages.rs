//! The stages of a frame beside the method: the totals every resolve adds to, the pass timer,
//! the compute rasterizer, the submission order and the depth-complexity histogram (with the k
//! `--k auto` chooses from it). Each appends its own words to the frame's readback (a
//! [`Segment`] of it) and reads its own statistics back from them; the method does the same
//! through [`Method::stats`].

use super::*;

/// Each stage's words in one frame's readback, with what reading them needs that the stage
/// does not keep between frames.
pub(super) struct StageWords {
    totals: Segment,
    /// The timestamps, and the passes they time.
    timestamps: Option<(Segment, Vec<&'static str>)>,
    pub(super) method: Segment,
    /// With `--raster compute`: its counters, and the item capacity the frame ran with.
    raster: Option<(Segment, u64)>,
    /// With `--order`: its Kendall pair counts, and its bytes.
    pub(super) order: Option<(Segment, u64)>,
    histogram: Option<Segment>,
}

impl FrameRecorder {
    /// With `--k auto`: sets the frame's k from the latest histogram that came back (the first
    /// frame guesses within the budget) and keeps the histogram on.
    pub(super) fn choose_k(&mut self) -> Result<Option<AutoKStats>> {
        let Some(robustness) = self.options.frame.k_auto else {
            self.frame_k = self.options.frame.k;
            return Ok(None);
        };
        if self.histogram.is_none() {
            self.histogram = Some(GpuHistogram::new(&self.gpu, &self.scene));
        }
        let last = self.last_histogram.as_ref();
        let choice = predict::choose_k(
            self.method,
            last.map(|h| h.1.as_slice()),
            robustness,
            DEFAULT_K,
            &self.options,
        )?;
        self.frame_k = Some(choice.k);
        Ok(Some(AutoKStats {
            robustness_target: robustness,
            budget_mb: self.options.frame.budget_mb,
            k_budget: choice.k_budget,
            histogram_frame: last.map(|h| h.0),
            predicted_robustness: last.map(|_| choice.predicted_robustness),
            achieved_robustness: None,
        }))
    }

    /// The histogram's passes, when it is on (returns whether it ran); its bins are the last
    /// words read back.
    pub(super) fn record_histogram(
        &mut self,
        encoder: &mut wgpu::CommandEncoder,
        frame: &OpenFrame,
        draw: Option<&DrawCallback<'_>>,
    ) -> Result<Option<ReadbackList>> {
        let Some(histogram) = self.histogram.as_mut() else {
            return Ok(None);
        };
        let mut readback = ReadbackList::default();
        let mut ctx = frame_context!(self, "histogram", encoder, frame, draw, &mut readback, None);
        histogram.record(&mut ctx)?;
        Ok(Some(readback))
    }

    /// Every stage's readback of the frame being finished, in segments: the totals, the
    /// timestamps, the rasterizer's and the order's counters, the method's `method` words, the
    /// histogram's bins.
    pub(super) fn read_back(
        &mut self,
        encoder: &mut wgpu::CommandEncoder,
        method: ReadbackList,
        histogram: Option<ReadbackList>,
    ) -> (Segments, StageWords) {
        let mut segments = Segments::default();
        let totals = segments.read(|list| list.words(&self.scene.totals, 0, TOTAL_WORDS));
        let timestamps = self.timer.resolve(encoder).map(|((buffer, at, n), names)| {
            (segments.read(|list| list.words(&buffer, at, n)), names)
        });
        // The rasterizer has counters only once it has binned this frame.
        let raster = self.raster.as_ref().and_then(|raster| {
            let mut list = ReadbackList::default();
            raster
                .read_counters(&mut list)
                .then(|| (segments.push(list), raster.frame_capacity()))
        });
        let order = self.order.as_ref().map(|order| {
            (
                segments.read(|list| order.read_counters(list)),
                order.bytes(),
            )
        });
        let method = segments.push(method);
        let histogram = histogram.map(|list| segments.push(list));
        let words = StageWords {
            totals,
            timestamps,
            method,
            raster,
            order,
            histogram,
        };
        (segments, words)
    }

    /// The frame's totals (the next frames' draws are split by them: docs/watchdog.md, S2).
    pub(super) fn read_totals(&mut self, p: &Pending, words: &[u32]) -> Totals {
        let totals = Totals::from_words(p.words.totals.of(words));
        self.scene.note_fragments(totals.generated);
        totals
    }

    /// The timer's, the compute rasterizer's and the order's words: milliseconds per pass;
    /// the rasterizer's work items (grown or shrunk for the next frame) and its memory; the
    /// order's Kendall tau.
    pub(super) fn read_stages(&mut self, p: &Pending, words: &[u32], report: &mut FrameReport) {
        let stats = &mut report.stats;
        if let Some((segment, names)) = &p.words.timestamps {
            let ms = self.timer.decode(names, segment.of(words));
            stats.gpu_ms_total = Some(ms.values().sum());
            stats.gpu_ms = Some(ms);
        }
        if let Some((segment, _)) = p.words.order {
            stats.kendall_tau = Some(crate::order::kendall_tau(segment.of(words)));
        }
        if let (Some((segment, capacity)), Some(raster)) = (p.words.raster, &mut self.raster) {
            let read = raster.feedback(&self.gpu, segment.of(words), capacity, 0);
            // The frame's own rasterizer's memory is the recorder's to add; a method's own
            // rasterizer (tiled) counts in the method's bytes.
            report.stats.bytes_allocated += read.stats.bytes_allocated;
            if read.stats.overflow {
                // Its work items overflowing leaves fragments that no counter saw: the frame
                // says it overflowed (and is incomplete), its counts are lower bounds.
                report.stats.overflow = Some(true);
            }
            report.stats.compute_raster = Some(read.stats);
            report.refuse(read.incomplete, read.cannot_complete);
        }
    }

    /// The histogram's bins (kept for `--k auto`'s next choice); with `--k auto`, what the
    /// frame achieved, and whether its own histogram picks another k (exact mode renders again).
    pub(super) fn read_histogram(
        &mut self,
        p: &Pending,
        words: &[u32],
        totals: Totals,
        report: &mut FrameReport,
    ) {
        if let Some(a) = &mut report.stats.k_auto {
            a.achieved_robustness = Some(match totals.generated {
                0 => 1.0,
                n => totals.stored as f64 / n as f64,
            });
        }
        let Some(segment) = p.words.histogram else {
            return;
        };
        let raw = segment.of(words);
        let bins = gpu_histogram::trim(raw);
        if let Some(a) = &mut report.stats.k_auto {
            let again = predict::choose_k(
                p.method,
                Some(&bins),
                a.robustness_target,
                DEFAULT_K,
                &self.options,
            );
            match again {
                Ok(c) if Some(c.k) != p.recorded.k => report.incomplete = true,
                Ok(c) if a.predicted_robustness.is_none() => {
                    // A guess its own histogram confirms gets its prediction from it.
                    a.predicted_robustness = Some(c.predicted_robustness);
                    a.histogram_frame = Some(p.frame);
                }
                _ => {}
            }
        }
        report.stats.depth_histogram_clipped = raw.last().map(|&n| n as u64);
        report.stats.depth_histogram = Some(bins.clone());
        if self.last_histogram.as_ref().is_none_or(|h| h.0 < p.frame) {
            self.last_histogram = Some((p.frame, bins));
        }
    }
}
