//! GPU timing of passes with timestamp queries written at pass boundaries.
//!
//! Each pass asks for a begin/end pair under a name; passes with the same name (f2b's peel
//! passes, say) add up. Without TIMESTAMP_QUERY every time is `None`, reported as `null`.
//!
//! Why not wgpu-profiler (0.28 supports wgpu 30; looked at on 2026-11-27): its queries are read
//! back through buffers it maps itself, a second readback every frame beside the statistics',
//! while these timestamps are resolved into a range that the frame's one statistics readback
//! carries (a frame late, never stalling); and a span over many passes (convex's, past the
//! query set) would be an encoder scope there, which needs TIMESTAMP_QUERY_INSIDE_ENCODERS, where
//! this needs only pass timestamp writes. What it would add — trace export to Chrome, puffin or
//! Tracy — strata does not have.

use std::collections::BTreeMap;

use crate::gpu::Gpu;

/// WebGPU's largest query set.
const MAX_QUERIES: u32 = 4096;

/// A range of a buffer to read back: (buffer, byte offset, u32 words).
pub type ReadRange = (wgpu::Buffer, u64, u64);

/// Timestamp pairs of one frame's passes in a query set, resolved into a buffer read back with the frame's statistics.
pub struct Timer {
    set: Option<wgpu::QuerySet>,
    resolve: Option<wgpu::Buffer>,
    names: Vec<&'static str>,
    period_ns: f64,
    overflowed: bool,
}

impl Timer {
    /// A timer for `gpu`; without TIMESTAMP_QUERY it times nothing.
    pub fn new(gpu: &Gpu) -> Timer {
        let enabled = gpu.has(wgpu::Features::TIMESTAMP_QUERY);
        let set = enabled.then(|| {
            gpu.device.create_query_set(&wgpu::QuerySetDescriptor {
                label: Some("strata.timestamps"),
                ty: wgpu::QueryType::Timestamp,
                count: MAX_QUERIES,
            })
        });
        let resolve = enabled.then(|| {
            gpu.device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("strata.timestamps.resolve"),
                size: MAX_QUERIES as u64 * 8,
                usage: wgpu::BufferUsages::QUERY_RESOLVE | wgpu::BufferUsages::COPY_SRC,
                mapped_at_creation: false,
            })
        });
        Timer {
            set,
            resolve,
            names: Vec::new(),
            period_ns: gpu.queue.get_timestamp_period() as f64,
            overflowed: false,
        }
    }

    /// Starts a new frame's measurements.
    pub fn reset(&mut self) {
        self.names.clear();
        self.overflowed = false;
    }

    fn next_pair(&mut self, name: &'static str) -> Option<(&wgpu::QuerySet, u32)> {
        let set = self.set.as_ref()?;
        let index = self.names.len() as u32 * 2;
        if index + 2 > MAX_QUERIES {
            self.overflowed = true;
            return None;
        }
        self.names.push(name);
        Some((set, index))
    }

    /// The timestamp writes of a render pass named `name`; `None` when the adapter cannot time or the query set is full.
    pub fn render_pass(
        &mut self,
        name: &'static str,
    ) -> Option<wgpu::RenderPassTimestampWrites<'_>> {
        self.next_pair(name)
            .map(|(set, i)| PassWrites::whole(set, i).render())
    }

    /// As [`Timer::render_pass`], for a compute pass.
    pub fn compute_pass(
        &mut self,
        name: &'static str,
    ) -> Option<wgpu::ComputePassTimestampWrites<'_>> {
        self.next_pair(name)
            .map(|(set, i)| PassWrites::whole(set, i).compute())
    }

    /// A pair for a span of passes (see [`Timer::render_pass_in_span`]): its begin is written
    /// by the span's first pass and its end by its last, so a frame of more passes than the
    /// query set holds is still timed as a whole (idle gaps between its passes included).
    pub fn span(&mut self, name: &'static str) -> Option<u32> {
        self.next_pair(name).map(|(_, i)| i)
    }

    /// The writes of one render pass inside `span`: the begin when it is the span's first pass,
    /// the end when it is its last, nothing in between.
    pub fn render_pass_in_span(
        &self,
        span: Option<u32>,
        first: bool,
        last: bool,
    ) -> Option<wgpu::RenderPassTimestampWrites<'_>> {
        self.in_span(span, first, last).map(PassWrites::render)
    }

    /// As [`Timer::render_pass_in_span`], for a compute pass.
    pub fn compute_pass_in_span(
        &self,
        span: Option<u32>,
        first: bool,
        last: bool,
    ) -> Option<wgpu::ComputePassTimestampWrites<'_>> {
        self.in_span(span, first, last).map(PassWrites::compute)
    }

    fn in_span(&self, span: Option<u32>, first: bool, last: bool) -> Option<PassWrites<'_>> {
        let (query_set, i) = (self.set.as_ref()?, span?);
        (first || last).then_some(PassWrites {
            query_set,
            begin: first.then_some(i),
            end: last.then_some(i + 1),
        })
    }

    /// Resolves this frame's timestamps into the resolve buffer (inside `encoder`) and returns
    /// the range to read back with the frame's statistics and the pass names, or `None` when
    /// the adapter cannot time or more passes ran than the query set holds.
    pub fn resolve(
        &mut self,
        encoder: &mut wgpu::CommandEncoder,
    ) -> Option<(ReadRange, Vec<&'static str>)> {
        let (Some(set), Some(resolve)) = (&self.set, &self.resolve) else {
            return None;
        };
        if self.overflowed {
            return None;
        }
        let count = self.names.len() as u32 * 2;
        if count > 0 {
            encoder.resolve_query_set(set, 0..count, resolve, 0);
        }
        Some((
            (resolve.clone(), 0, count as u64 * 2),
            std::mem::take(&mut self.names),
        ))
    }

    /// Pass name → milliseconds from the resolved ticks (two u32 words per tick), same-named
    /// passes adding up.
    pub fn decode(&self, names: &[&'static str], words: &[u32]) -> BTreeMap<String, f64> {
        let tick = |i: usize| words[2 * i] as u64 | (words[2 * i + 1] as u64) << 32;
        let mut out = BTreeMap::new();
        for (i, name) in names.iter().enumerate() {
            let dt = tick(2 * i + 1).saturating_sub(tick(2 * i)) as f64 * self.period_ns / 1e6;
            *out.entry(name.to_string()).or_insert(0.0) += dt;
        }
        out
    }
}

/// The median of `values` (the mean of the middle two for an even count); NaN when empty.
pub fn median(mut values: Vec<f64>) -> f64 {
    values.sort_by(f64::total_cmp);
    let n = values.len();
    match n {
        0 => f64::NAN,
        _ if n % 2 == 1 => values[n / 2],
        _ => (values[n / 2 - 1] + values[n / 2]) * 0.5,
    }
}

/// Where one pass writes its timestamps, for a render or a compute pass alike.
struct PassWrites<'a> {
    query_set: &'a wgpu::QuerySet,
    begin: Option<u32>,
    end: Option<u32>,
}

impl<'a> PassWrites<'a> {
    /// Both timestamps of pair `i`: a pass timed on its own.
    fn whole(query_set: &'a wgpu::QuerySet, i: u32) -> Self {
        PassWrites {
            query_set,
            begin: Some(i),
            end: Some(i + 1),
        }
    }

    fn render(self) -> wgpu::RenderPassTimestampWrites<'a> {
        wgpu::RenderPassTimestampWrites {
            query_set: self.query_set,
            beginning_of_pass_write_index: self.begin,
            end_of_pass_write_index: self.end,
        }
    }

    fn compute(self) -> wgpu::ComputePassTimestampWrites<'a> {
        wgpu::ComputePassTimestampWrites {
            query_set: self.query_set,
            beginning_of_pass_write_index: self.begin,
            end_of_pass_write_index: self.end,
        }
    }
}
