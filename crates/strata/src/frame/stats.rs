//! Asynchronous statistics: a ring of staging slots. A frame copies its totals, timestamps and
//! method counters into a free slot inside the caller's encoder and asks wgpu to map the slot
//! once that submission has finished (`map_buffer_on_submit`); a later [`StatsRing::poll`]
//! collects every slot whose mapping completed. When every slot is still in flight the frame
//! records no statistics (counted in `skipped`) rather than wait.

use std::sync::atomic::{AtomicU8, Ordering};
use std::sync::Arc;

use crate::gpu::{readback, Gpu};

/// Slots in flight at once: three frames of latency before a frame goes without statistics.
pub const SLOTS: usize = 4;

const FREE: u8 = 0;
const PENDING: u8 = 1;
const MAPPED: u8 = 2;
const FAILED: u8 = 3;

struct Slot<T> {
    buffer: Option<wgpu::Buffer>,
    state: Arc<AtomicU8>,
    words: u64,
    tag: Option<T>,
}

/// A ring of staging buffers; `T` is what the frame recorded alongside (frame number, sizes).
pub struct StatsRing<T> {
    slots: Vec<Slot<T>>,
    next: usize,
    /// Frames that found no free slot and report no statistics.
    pub skipped: u64,
}

impl<T> Default for StatsRing<T> {
    fn default() -> Self {
        StatsRing {
            slots: (0..SLOTS)
                .map(|_| Slot {
                    buffer: None,
                    state: Arc::new(AtomicU8::new(FREE)),
                    words: 0,
                    tag: None,
                })
                .collect(),
            next: 0,
            skipped: 0,
        }
    }
}

impl<T> StatsRing<T> {
    /// Copies `sources` (buffer, byte offset, words) one after another into a free slot and
    /// schedules its mapping after the encoder's submission. Returns false (and counts the frame
    /// as skipped) when every slot is in flight.
    pub fn record(
        &mut self,
        gpu: &Gpu,
        encoder: &mut wgpu::CommandEncoder,
        sources: &[(wgpu::Buffer, u64, u64)],
        tag: T,
    ) -> bool {
        let Some(index) = (0..SLOTS)
            .map(|i| (self.next + i) % SLOTS)
            .find(|&i| self.slots[i].state.load(Ordering::Acquire) == FREE)
        else {
            self.skipped += 1;
            return false;
        };
        self.next = (index + 1) % SLOTS;
        let words: u64 = sources.iter().map(|s| s.2).sum::<u64>().max(1);
        let slot = &mut self.slots[index];
        if slot.buffer.as_ref().is_none_or(|b| b.size() < words * 4) {
            let size = (words * 4).next_multiple_of(wgpu::COPY_BUFFER_ALIGNMENT * 64);
            let staging = readback::staging_buffer(gpu, "strata.frame.stats_staging", size);
            slot.buffer = Some(staging);
        }
        let buffer = slot.buffer.as_ref().expect("created above");
        let mut at = 0;
        for (src, offset, n) in sources {
            encoder.copy_buffer_to_buffer(src, *offset, buffer, at * 4, n * 4);
            at += n;
        }
        slot.words = words;
        slot.tag = Some(tag);
        slot.state.store(PENDING, Ordering::Release);
        let state = slot.state.clone();
        encoder.map_buffer_on_submit(buffer, wgpu::MapMode::Read, ..words * 4, move |r| {
            state.store(if r.is_ok() { MAPPED } else { FAILED }, Ordering::Release);
        });
        true
    }

    /// Every completed slot's words and tag, oldest first, without waiting. `device.poll` is
    /// called without blocking so that finished mappings report.
    pub fn poll(&mut self, gpu: &Gpu) -> Vec<(T, Option<Vec<u32>>)> {
        let _ = gpu.device.poll(wgpu::PollType::Poll);
        self.collect()
    }

    /// True when some slot holds a frame not yet collected: waiting for its mapping, or mapped
    /// since the last [`StatsRing::poll`] looked. A mapping callback may run on any thread that
    /// polls the device, so a slot can turn MAPPED between `poll`'s look and this call; a waiter
    /// that counted only PENDING slots would give up on a frame that has just arrived.
    pub fn pending(&self) -> bool {
        self.slots
            .iter()
            .any(|s| s.state.load(Ordering::Acquire) != FREE)
    }

    fn collect(&mut self) -> Vec<(T, Option<Vec<u32>>)> {
        let mut done = Vec::new();
        // Oldest first: slots were filled in ring order starting after `next`.
        for i in 0..SLOTS {
            let slot = &mut self.slots[(self.next + i) % SLOTS];
            let state = slot.state.load(Ordering::Acquire);
            if state != MAPPED && state != FAILED {
                continue;
            }
            let buffer = slot.buffer.as_ref().expect("a recorded slot has a buffer");
            let words = (state == MAPPED).then(|| {
                buffer
                    .slice(..slot.words * 4)
                    .get_mapped_range()
                    .map(|m| bytemuck::pod_collect_to_vec::<u8, u32>(&m))
                    .ok()
            });
            if state == MAPPED {
                buffer.unmap();
            }
            let tag = slot.tag.take().expect("a recorded slot has a tag");
            slot.state.store(FREE, Ordering::Release);
            done.push((tag, words.flatten()));
        }
        done
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_slot_mapped_by_another_thread_is_still_pending_until_collected() {
        let ring = StatsRing::<u64>::default();
        assert!(!ring.pending());
        // Another thread's device poll ran the mapping callback after this thread's `poll`
        // looked: the frame has not been collected, so a waiter must look again.
        ring.slots[2].state.store(MAPPED, Ordering::Release);
        assert!(ring.pending());
        ring.slots[2].state.store(FAILED, Ordering::Release);
        assert!(ring.pending());
        ring.slots[2].state.store(FREE, Ordering::Release);
        assert!(!ring.pending());
    }
}
