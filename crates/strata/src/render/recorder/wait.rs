//! Reading statistics back: without blocking in real time ([`FrameRecorder::poll_stats`]), and
//! blocking for exact mode, tests and one-shot renders ([`FrameRecorder::wait_stats`],
//! [`FrameRecorder::render_once`]).

use super::*;

impl FrameRecorder {
    /// Statistics of every frame whose readback has completed, oldest first. Never blocks.
    pub fn poll_stats(&mut self) -> Vec<FrameStats> {
        let done = self.ring.poll(&self.gpu);
        self.decode(done).into_iter().map(|r| r.stats).collect()
    }

    /// Frames that recorded no statistics because every readback slot was still in flight.
    pub fn skipped_stats(&self) -> u64 {
        self.ring.skipped
    }

    /// A one-shot render (headless, a screenshot): records and submits frames, without
    /// touching `targets.color`, until one is complete — a pool or the peeled layers grown from
    /// what the previous frame measured, as exact mode does — then composites that frame OVER
    /// `targets.color` in one more submission and returns its statistics (`submits` and
    /// `blocking_readbacks` count what it took). Blocks; not for real time, where growth costs
    /// at most one frame and that frame says `complete: false`.
    pub fn render_once(
        &mut self,
        targets: &FrameTargets<'_>,
        draw: Option<&DrawCallback<'_>>,
    ) -> Result<FrameStats> {
        let hidden = FrameTargets {
            color: None,
            opaque_depth: targets.opaque_depth,
        };
        self.check_targets(targets)?;
        let mut submits = 0;
        for _ in 0..crate::render::MAX_EXACT_FRAMES {
            let mut encoder = self.gpu.device.create_command_encoder(&Default::default());
            self.record(&mut encoder, &hidden, draw)?;
            self.gpu.queue.submit([encoder.finish()]);
            submits += 1;
            let report = self.wait_stats()?;
            if let Some(shortfall) = report.cannot_complete {
                return Err(Error::unsupported(shortfall.why));
            }
            if report.incomplete {
                continue;
            }
            let mut stats = report.stats;
            if targets.color.is_some() {
                let mut encoder = self.gpu.device.create_command_encoder(&Default::default());
                self.present_into(&mut encoder, targets.color, stats.k, false);
                self.gpu.queue.submit([encoder.finish()]);
                submits += 1;
            }
            stats.submits = submits;
            stats.blocking_readbacks = submits;
            return Ok(stats);
        }
        Err(Error::runtime(format!(
            "{}: no complete frame in {} frames",
            self.method,
            crate::render::MAX_EXACT_FRAMES
        )))
    }

    /// Waits for every submitted frame's statistics and returns the last one (exact mode and
    /// tests; the wait is a blocking readback).
    pub fn wait_stats(&mut self) -> Result<FrameReport> {
        let gpu = self.gpu.clone();
        gpu.guarded("waiting for a frame's statistics", || self.wait_for_stats())
    }

    fn wait_for_stats(&mut self) -> Result<FrameReport> {
        // Another thread polling the same device may be running the mapping callbacks when the
        // wait returns: give them a bounded time to land.
        let deadline = std::time::Instant::now() + STATS_TIMEOUT;
        let mut idle_since = None;
        let mut last = None;
        loop {
            // A lost device completes nothing: its mappings never land.
            self.gpu.check_device()?;
            let idle = self.gpu.wait_idle()?;
            let done = self.ring.poll(&self.gpu);
            if let Some(r) = self.decode(done).pop() {
                last = Some(r);
            }
            if !self.ring.pending() {
                break;
            }
            // The queue did all its work and a mapping is still pending: its copy was never
            // submitted, or the device is lost (strata not told, on an application's device).
            let now = std::time::Instant::now();
            let idle_for = match idle {
                true => now - *idle_since.get_or_insert(now),
                false => std::time::Duration::ZERO,
            };
            if idle_for > STATS_IDLE_TIMEOUT {
                return Err(Error::runtime(
                    "the frame's statistics never arrived though the GPU queue is idle: the frame was not submitted, or the device was lost (an application tells strata with Gpu::device_lost)",
                ));
            }
            if now > deadline {
                return Err(Error::runtime(format!(
                    "the frame's statistics did not arrive within {} s",
                    STATS_TIMEOUT.as_secs()
                )));
            }
            std::thread::sleep(std::time::Duration::from_millis(1));
        }
        last.ok_or_else(|| Error::runtime("the frame recorded no statistics"))
    }
}
